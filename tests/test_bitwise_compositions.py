"""Splittings and substepped schemes as data (reference.splitting, reference.substepped): the
schemes declared so compute what their hand-written steps computed, bit for bit.

The oracle is the code they replaced, kept here as it was written (each scheme's step, start,
floor and recurrence on the damped oscillator): on random states under a nonlinear, time- and
velocity-dependent force the generated step gives the old step's bits; on the scenes, interpreted
and compiled, the old and the new give one trajectory; their floors and their recurrences agree
bit for bit, and every claim the records hold of them is the one they declared."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from reference import EVERY_SCENE, METHODS, Floor, bitwise_why, integrate, integrate_compiled
from reference._floors import run_floor
from reference._scheme import largest_magnitude, observe_qv, start_qv
from reference.oscillator import drift, kick, unbounded
from reference.splitting import DRIFT, KICK, Splitting, splitting_scheme
from reference.substepped import substepped
from scenarios import make_scene

NEWTON_RTOL = 1e-13
THETA = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))


# ------------------------------------------------------------------ the hand-written code replaced
def old_leapfrog(accel, state, t, h, p):
    q, v = state
    half = 0.5 * h
    q = q + half * v
    v = v + h * accel(q, v, t + half, p)
    return (q + half * v, v)


def old_leapfrog_floor(s, h, k, m):
    x, v = s
    x = x + 0.5 * h * v
    v = v + h * (-k * x / m)
    return (x + 0.5 * h * v, v)


def old_leapfrog_amplification(y, z):
    return drift(0.5 * y) @ kick(y, z) @ drift(0.5 * y)


def old_velocity_verlet_start(accel, q, v, t, h, p):
    return (q, v, accel(q, v, t, p))


def old_velocity_verlet(accel, state, t, h, p):
    q, v, a = state
    v_half = v + (0.5 * h) * a
    q = q + h * v_half
    a = accel(q, v_half, t + h, p)
    return (q, v_half + (0.5 * h) * a, a)


def old_velocity_verlet_floor(s, h, k, m):
    x, v, a = s
    v = v + 0.5 * h * a
    x = x + h * v
    a = -k * x / m
    return (x, v + 0.5 * h * a, a)


def old_velocity_verlet_floor_start(x, v, h, k, m):
    return (x, v, -k * x / m)


def old_velocity_verlet_amplification(y, z):
    vh = np.array([0.0, 1.0, 0.5 * y])
    x1 = np.array([1.0, 0.0, 0.0]) + y * vh
    a1 = -x1 - 2.0 * z * vh
    return np.vstack([x1, vh + 0.5 * y * a1, a1])


def old_semi_implicit_euler(accel, state, t, h, p):
    q, v = state
    a = accel(q, v, t, p)
    v = v + h * a
    return (q + h * v, v)


def old_semi_implicit_euler_floor(s, h, k, m):
    x, v = s
    v = v + h * (-k * x / m)
    return (x + h * v, v)


def old_semi_implicit_euler_amplification(y, z):
    return drift(y) @ kick(y, z)


def old_semi_implicit_euler_position_first(accel, state, t, h, p):
    q, v = state
    q = q + h * v
    return (q, v + h * accel(q, v, t + h, p))


def old_semi_implicit_euler_position_first_floor(s, h, k, m):
    x, v = s
    x = x + h * v
    return (x, v + h * (-k * x / m))


def old_semi_implicit_euler_position_first_amplification(y, z):
    return kick(y, z) @ drift(y)


def old_forest_ruth(accel, state, t, h, p):
    q, v = state
    c1 = 0.5 * THETA * h
    c2 = 0.5 * (1.0 - THETA) * h
    d1 = THETA * h
    d2 = (1.0 - 2.0 * THETA) * h
    q = q + c1 * v
    v = v + d1 * accel(q, v, t + c1, p)
    q = q + c2 * v
    v = v + d2 * accel(q, v, t + 0.5 * h, p)
    q = q + c2 * v
    v = v + d1 * accel(q, v, t + h - c1, p)
    return (q + c1 * v, v)


def old_forest_ruth_floor(s, h, k, m):
    x, v = s
    x = x + 0.5 * THETA * h * v
    v = v + THETA * h * (-k * x / m)
    x = x + 0.5 * (1.0 - THETA) * h * v
    v = v + (1.0 - 2.0 * THETA) * h * (-k * x / m)
    x = x + 0.5 * (1.0 - THETA) * h * v
    v = v + THETA * h * (-k * x / m)
    return (x + 0.5 * THETA * h * v, v)


def old_forest_ruth_amplification(y, z):
    c1, c2 = 0.5 * THETA * y, 0.5 * (1.0 - THETA) * y
    d1, d2 = THETA * y, (1.0 - 2.0 * THETA) * y
    return drift(c1) @ kick(d1, z) @ drift(c2) @ kick(d2, z) @ drift(c2) @ kick(d1, z) @ drift(c1)


def old_implicit_euler_doubled(accel, solve, newton_max, state, t, h, p):
    q, v = state
    half = 0.5 * h
    for k in range(2):
        t_end = t + half if k == 0 else t + h
        w = v
        for _ in range(newton_max):
            q_new = q + half * w
            r = v + half * accel(q_new, w, t_end, p) - w
            dw = solve(q_new, w, t_end, p, half, half * half, r)
            w = w + dw
            if largest_magnitude(dw) <= NEWTON_RTOL * (1.0 + largest_magnitude(w)):
                break
        q, v = q + half * w, w
    return (q, v)


def old_implicit_euler_doubled_floor(s, h, k, m):
    x, v = s
    half = 0.5 * h
    for _ in range(2):
        dw = (half * (-k * (x + half * v) / m)) / (1.0 + half * half * (k / m))
        w = v + dw
        x, v = x + half * w, w
    return (x, v)


def old_implicit_euler_doubled_amplification(y, z):
    half = np.linalg.inv(np.eye(2) - 0.5 * y * np.array([[0.0, 1.0], [-1.0, -2.0 * z]]))
    return half @ half


#: scheme id -> (step, start, floor, amplification) as they were written by hand.
OLD = {
    "leapfrog": (old_leapfrog, start_qv, Floor(old_leapfrog_floor), old_leapfrog_amplification),
    "velocity_verlet": (
        old_velocity_verlet,
        old_velocity_verlet_start,
        Floor(old_velocity_verlet_floor, old_velocity_verlet_floor_start),
        old_velocity_verlet_amplification,
    ),
    "semi_implicit_euler": (
        old_semi_implicit_euler,
        start_qv,
        Floor(old_semi_implicit_euler_floor),
        old_semi_implicit_euler_amplification,
    ),
    "semi_implicit_euler_position_first": (
        old_semi_implicit_euler_position_first,
        start_qv,
        Floor(old_semi_implicit_euler_position_first_floor),
        old_semi_implicit_euler_position_first_amplification,
    ),
    "forest_ruth": (old_forest_ruth, start_qv, Floor(old_forest_ruth_floor), old_forest_ruth_amplification),
    "implicit_euler_doubled": (
        old_implicit_euler_doubled,
        start_qv,
        Floor(old_implicit_euler_doubled_floor),
        old_implicit_euler_doubled_amplification,
    ),
}

#: What each declared before (order, force_evals, symplectic, energy, homega_max, order with a
#: velocity-dependent force, carried state, the standard suite's scenes).
OLD_CLAIMS = {
    "leapfrog": (2, 1, True, "bounded", 2.0, 1, ("q", "v")),
    "velocity_verlet": (2, 1, True, "bounded", 2.0, 1, ("q", "v", "a")),
    "semi_implicit_euler": (1, 1, True, "bounded", 2.0, 1, ("q", "v")),
    "semi_implicit_euler_position_first": (1, 1, True, "bounded", 2.0, 1, ("q", "v")),
    "forest_ruth": (4, 3, True, "bounded", 1.5734, 1, ("q", "v")),
    "implicit_euler_doubled": (1, 2, False, "decays", math.inf, 1, ("q", "v")),
}


#: The standard suite's scenes each declared before.
OLD_SUITES = {
    "leapfrog": EVERY_SCENE,
    "semi_implicit_euler": EVERY_SCENE,
    "velocity_verlet": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "solar_system"),
    "semi_implicit_euler_position_first": ("spring", "damped_spring", "pendulum", "kepler", "projectile"),
    "forest_ruth": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "solar_system"),
    "implicit_euler_doubled": ("spring", "damped_spring", "pendulum"),
}


def _old_scheme(sid):
    step, start, floor, amplification = OLD[sid]
    return dataclasses.replace(
        METHODS[sid], id=f"{sid}_old", step=step, start=start, floor=floor, amplification=amplification
    )


def _force(q, v, t, p):
    # Nonlinear, time- and velocity-dependent: every argument of a kick's force shows in its bits.
    return -p[0] * np.sin(q) - p[1] * v * np.abs(v) + np.cos(3.0 * t)


def _solve(q, v, t, p, alpha, beta, r):
    return r / (1.0 + beta * p[0] * np.cos(q) + alpha * p[1])


# ------------------------------------------------------------------ bit for bit
@pytest.mark.parametrize("sid", list(OLD))
def test_the_declared_step_computes_the_hand_written_steps_bits(sid):
    """On random states, times and steps (a batch of 3 x 4), the generated step and the old one
    agree bit for bit, the start too; the implicit one with 1 and with 3 Newton passes."""
    new, old = METHODS[sid], _old_scheme(sid)
    rng = np.random.default_rng(11)
    for _ in range(25):
        q, v = rng.normal(size=(3, 4)), rng.normal(size=(3, 4))
        t, h, p = rng.uniform(0, 10), rng.uniform(1e-4, 0.5), rng.uniform(0.1, 2.0, size=2)
        s_new, s_old = new.start(_force, q, v, t, h, p), old.start(_force, q, v, t, h, p)
        if new.implicit:
            for passes in (1, 3):
                got = new.step(_force, _solve, passes, s_new, t, h, p)
                want = old.step(_force, _solve, passes, s_old, t, h, p)
                assert all(np.array_equal(a, b) for a, b in zip(got, want))
            continue
        assert all(np.array_equal(a, b) for a, b in zip(s_new, s_old))
        got, want = new.step(_force, s_new, t, h, p), old.step(_force, s_old, t, h, p)
        assert len(got) == len(want) and all(np.array_equal(a, b) for a, b in zip(got, want))


#: The scenes the trajectories are compared on: the pointwise spring and damped spring (a
#: velocity-dependent force), and Kepler's orbit (the array loop, a nonlinear force).
SCENES = ("spring", "damped_spring", "kepler")
#: The pairs ``make test`` compiles (each compiles two kernels); the rest are marked slow.
COMPILED_FAST = {("forest_ruth", "kepler"), ("implicit_euler_doubled", "spring")}


def _compare(sid, scene_id, compiled):
    scene = make_scene(scene_id)
    new, old = METHODS[sid], _old_scheme(sid)
    dt, steps = 0.07 / scene.omega, 400
    # The accuracy runs take the compiled loop where it computes the interpreted bits: as before.
    assert (bitwise_why(new, scene) == "") == (bitwise_why(old, scene) == "")
    run = integrate_compiled if compiled else integrate
    a, b = run(new, scene, dt, steps, every=9), run(old, scene, dt, steps, every=9)
    assert np.array_equal(a.step, b.step) and a.status == b.status == "ok"
    assert np.array_equal(a.q, b.q) and np.array_equal(a.v, b.v) and np.array_equal(a.energy, b.energy)
    if not compiled:  # counted as they ran: the same evaluations and solves
        assert (a.force_evals, a.solves) == (b.force_evals, b.solves)
        assert new.implicit and not scene.linear or a.force_evals == steps * new.force_evals


@pytest.mark.parametrize("scene_id", SCENES)
@pytest.mark.parametrize("sid", list(OLD))
def test_the_declared_scheme_runs_the_hand_written_trajectory_interpreted(sid, scene_id):
    _compare(sid, scene_id, compiled=False)


@pytest.mark.parametrize(
    "sid, scene_id",
    [(s, c) if (s, c) in COMPILED_FAST else pytest.param(s, c, marks=pytest.mark.slow) for s in OLD for c in SCENES],
)
def test_the_declared_scheme_runs_the_hand_written_trajectory_compiled(sid, scene_id):
    """The compiled loops, generated from the new and the old source, give one trajectory."""
    _compare(sid, scene_id, compiled=True)


@pytest.mark.parametrize("sid", list(OLD))
def test_the_generated_floor_computes_the_hand_written_floors_bits(sid):
    """Interpreted on random floats (k, m read from the arguments) and compiled over 1000 steps."""
    new, old = METHODS[sid].floor, OLD[sid][2]
    rng = np.random.default_rng(5)
    for _ in range(50):
        x, v, h, k, m = rng.normal(), rng.normal(), rng.uniform(1e-3, 1.0), rng.uniform(0.1, 5), rng.uniform(0.1, 5)
        s_new, s_old = new.start(x, v, h, k, m), old.start(x, v, h, k, m)
        assert s_new == s_old and new.step(s_new, h, k, m) == old.step(s_old, h, k, m)
    if sid in ("forest_ruth", "implicit_euler_doubled"):  # one explicit and one implicit compiled (each compiles two)
        assert run_floor(new, 1.0, 0.0, 0.01, 2.0, 0.5, 1000) == run_floor(old, 1.0, 0.0, 0.01, 2.0, 0.5, 1000)


@pytest.mark.parametrize("sid", list(OLD))
def test_the_derived_recurrence_is_the_hand_written_one_bit_for_bit(sid):
    new, old = METHODS[sid].amplification, OLD[sid][3]
    for y in (0.01, 0.3, 1.0, 1.9, 2.5):
        for zeta in (0.0, 0.1, 0.7, 2.0):
            assert np.array_equal(new(y, zeta), old(y, zeta))


@pytest.mark.parametrize("sid", list(OLD))
def test_the_derived_claims_are_the_declared_ones(sid):
    s = METHODS[sid]
    order, evals, symplectic, energy, limit, order_v, carries = OLD_CLAIMS[sid]
    assert (s.order, s.force_evals, s.symplectic, s.energy_claim, s.homega_max, s.order_for(True), s.carries) == (
        order,
        evals,
        symplectic,
        energy,
        limit,
        order_v,
        carries,
    )
    assert s.floor is not None and s.amplification is not None and s.kind is _old_scheme(sid).kind
    assert s.suites == {"standard": OLD_SUITES[sid]}
    assert (s.damping_limit is not None) == (
        sid in ("semi_implicit_euler", "semi_implicit_euler_position_first", "implicit_euler_doubled")
    )


def test_the_composed_schemes_say_what_they_are_composed_of():
    assert METHODS["forest_ruth"].splitting.force_evals == 3
    assert METHODS["velocity_verlet"].splitting.fsal and METHODS["velocity_verlet"].start is not start_qv
    inner, n = METHODS["implicit_euler_doubled"].substepped_from
    assert inner is METHODS["implicit_euler"] and n == 2
    assert METHODS["implicit_euler_doubled"].damping_limit(0.3) == unbounded(0.3) == math.inf
    assert METHODS["implicit_euler_doubled"].describe()["force_evals"] == "2 + solve"
    assert METHODS["implicit_euler_doubled"].observe is observe_qv


# ------------------------------------------------------------------ what a splitting derives
def test_the_stability_limit_is_derived_exactly_where_the_coefficients_are_rational():
    """|tr M(y)| <= 2 on the spring: 2 - y^2 for the one-kick splittings (limit 2, to the bit);
    Forest-Ruth's 1.57340 from its float coefficients (the declared 1.5734 is its rounding); the
    spectral radius of the recurrence is 1 just below the limit and above 1 past it."""
    for sid in ("leapfrog", "velocity_verlet", "semi_implicit_euler", "semi_implicit_euler_position_first"):
        assert METHODS[sid].splitting.homega_max() == 2.0
    fr = METHODS["forest_ruth"].splitting.homega_max()
    assert fr == pytest.approx(1.5734019474, rel=1e-9)
    for sid, y in (("leapfrog", 2.0), ("forest_ruth", fr)):
        amp = METHODS[sid].amplification
        assert max(abs(np.linalg.eigvals(amp(y * (1 - 1e-6), 0.0)))) == pytest.approx(1.0, abs=1e-6)
        assert max(abs(np.linalg.eigvals(amp(y * (1 + 1e-3), 0.0)))) > 1.0 + 1e-6


def test_a_splitting_says_what_is_wrong_with_it():
    with pytest.raises(ValueError, match="kicks of a splitting must sum to 1"):
        Splitting((DRIFT, 1), (KICK, "1/2"))
    with pytest.raises(ValueError, match="drifts of a splitting must sum to 1"):
        Splitting((DRIFT, "1/2"), (KICK, 1))
    with pytest.raises(ValueError, match="first-same-as-last"):
        Splitting((DRIFT, "1/2"), (KICK, 1), (DRIFT, "1/2"), fsal=True)
    with pytest.raises(ValueError, match="not among the declared constants"):
        Splitting((DRIFT, "A"), (KICK, 1), (DRIFT, "1 - A"))
    with pytest.raises(ValueError, match="not linear"):
        Splitting((DRIFT, "A*A"), (KICK, 1), (DRIFT, "1 - A*A"), constants={"A": 0.3})
    with pytest.raises(ValueError, match="no update"):
        Splitting((DRIFT, 0), (DRIFT, 1), (KICK, 1))
    with pytest.raises(ValueError, match="declared stability limit"):
        splitting_scheme(
            "leapfrog_test",
            Splitting((DRIFT, "1/2"), (KICK, 1), (DRIFT, "1/2")),
            order=2,
            doc="Leapfrog.",
            homega_max=2.1,
        )


def test_a_kicks_time_is_written_from_the_drifts_before_it():
    """t + tau h: t, t + h, a coefficient, h less a coefficient (a symmetric splitting's mirror),
    else the rational as a tableau writes it."""
    ruth3 = Splitting((KICK, "7/24"), (DRIFT, "2/3"), (KICK, "3/4"), (DRIFT, "-2/3"), (KICK, "-1/24"), (DRIFT, 1))
    src = ruth3.step_source("s", lambda x, v, t: f"f({x}, {v}, {t})", "f, state, t, h, p", "q, v = state")
    assert "f(q, v, t)" in src and src.count("f(q, v, t + c2)") == 1 and "f(q, v, t)" in src
    assert src.count("f(q, v, t)") == 2  # the third kick's tau is 2/3 - 2/3 = 0
    lf = Splitting((DRIFT, "1/3"), (KICK, "1/2"), (DRIFT, "1/3"), (KICK, "1/2"), (DRIFT, "1/3"))
    src = lf.step_source("s", lambda x, v, t: f"f({x}, {v}, {t})", "f, state, t, h, p", "q, v = state")
    assert "c1 = h / 3.0" in src and "f(q, v, t + c1)" in src and "f(q, v, t + h - c1)" in src


def test_substepped_takes_n_steps_of_h_over_n():
    """Leapfrog substepped three times: its step is three leapfrog steps of h/3 (bitwise, the
    substep times from t alike), its floor three of its floor's, its recurrence the cube at y/3,
    three evaluations, the limit 6, the order and the energy claim leapfrog's."""
    lf = METHODS["leapfrog"]
    tri = substepped(lf, 3, id="leapfrog_x3_test", doc="Leapfrog, thrice at h/3.", module=__name__)
    rng = np.random.default_rng(3)
    for _ in range(10):
        q, v = rng.normal(size=(2, 3)), rng.normal(size=(2, 3))
        t, h, p = rng.uniform(0, 10), rng.uniform(1e-3, 0.5), rng.uniform(0.1, 2.0, size=2)
        want, hs = (q, v), h / 3.0
        for j in range(3):
            want = lf.step(_force, want, t + j * hs, hs, p)
        got = tri.step(_force, (q, v), t, h, p)
        assert all(np.array_equal(a, b) for a, b in zip(got, want))
    s = (0.3, -1.2)
    want = s
    for _ in range(3):
        want = lf.floor.step(want, 0.3 / 3.0, 2.0, 0.5)
    assert tri.floor.step(s, 0.3, 2.0, 0.5) == want
    m = lf.amplification(0.9 / 3.0, 0.2)
    assert np.array_equal(tri.amplification(0.9, 0.2), m @ m @ m)
    assert (tri.force_evals, tri.homega_max, tri.order, tri.energy_claim, tri.symplectic) == (
        3,
        6.0,
        2,
        "bounded",
        True,
    )
    with pytest.raises(ValueError, match="n >= 2"):
        substepped(lf, 1, id="x", doc="x")
