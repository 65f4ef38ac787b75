"""Reference schemes: the seed's worked examples, energy factors, counting, batching, long-run behaviour."""

import numpy as np
import pytest

from reference import METHODS, integrate, integrate_compiled
from reference._compiled import run_compiled
from scenarios import SCENES, make_scene

SPRING = make_scene("spring")


# Constrained schemes (ref:verlet_constrained) run only on constrained scenes (the rope,
# tested in test_scenes_hard.py), the position-based ones (PBD, XPBD) only on scenes whose springs
# and links they take as constraints (tests/test_position_based.py); everything here is about the
# schemes that run on every unconstrained scene.
FREE = {sid: m for sid, m in METHODS.items() if not m.constrained and m.kind.name != "position_based"}


def run(scheme_id, scene=SPRING, dt=0.5, steps=4, **kw):
    return integrate(METHODS[scheme_id], scene, dt, steps, **kw)


# The seed's worked example, dt = 0.5, steps 0-4, printed to 3 decimals.
WORKED = {
    "explicit_euler": {
        "x": [1, 1, 0.75, 0.25, -0.438],
        "v": [0, -0.5, -1, -1.375, -1.5],
        "energy": [0.5, 0.625, 0.781, 0.977, 1.221],
    },
    "semi_implicit_euler": {
        "x": [1, 0.75, 0.313, -0.203, -0.668],
        "v": [0, -0.5, -0.875, -1.031, -0.930],
        "energy": [0.5, 0.406, 0.432, 0.552, 0.655],
    },
}


@pytest.mark.parametrize("scheme_id", WORKED)
def test_worked_example_to_printed_decimals(scheme_id):
    tr = run(scheme_id)
    want = WORKED[scheme_id]
    # "To the printed 3 decimals": rounding half away from zero, as the seed prints.
    for got, key in ((tr.q[:, 0, 0], "x"), (tr.v[:, 0, 0], "v"), (tr.energy[:, 0], "energy")):
        assert np.all(np.abs(got - np.array(want[key])) <= 0.0005 + 1e-12), (key, got)


@pytest.mark.parametrize("h", [0.5, 0.1, 0.01])
def test_explicit_euler_energy_grows_by_one_plus_h2_per_step(h):
    tr = run("explicit_euler", dt=h, steps=50)
    ratio = tr.energy[1:, 0] / tr.energy[:-1, 0]
    # Exact in real arithmetic; 1e-12 leaves room for 50 steps of roundoff.
    np.testing.assert_allclose(ratio, 1 + h * h, rtol=1e-12)


@pytest.mark.parametrize("h", [0.5, 0.1, 0.01])
def test_implicit_euler_energy_shrinks_by_one_over_one_plus_h2(h):
    tr = run("implicit_euler", dt=h, steps=50)
    ratio = tr.energy[1:, 0] / tr.energy[:-1, 0]
    np.testing.assert_allclose(ratio, 1 / (1 + h * h), rtol=1e-12)


@pytest.mark.parametrize("scheme_id", FREE)
@pytest.mark.parametrize("scene_id", ["spring", "damped_spring", "projectile"])
def test_counted_force_evaluations_equal_declared_on_linear_scenes(scheme_id, scene_id):
    steps = 37
    tr = run(scheme_id, scene=make_scene(scene_id), dt=0.01, steps=steps)
    scheme = METHODS[scheme_id]
    if not scheme.one_pass_on_linear:
        # Coupled stages (two-stage Radau IIA) iterate on a linear scene too: whole passes of the
        # declared evaluations, each with its solves, more than one a step and within NEWTON_MAX.
        assert tr.force_evals == tr.solves and tr.force_evals % scheme.force_evals == 0
        assert scheme.force_evals * steps < tr.force_evals <= 50 * scheme.force_evals * steps
        return
    assert tr.force_evals == scheme.force_evals * steps
    # Implicit schemes: one solve per force evaluation (one Newton iteration is exact for linear
    # forces; implicit Euler by step doubling solves once in each half step).
    assert tr.solves == (scheme.force_evals * steps if scheme.implicit else 0)


@pytest.mark.parametrize("scheme_id", [s for s, m in FREE.items() if m.implicit])
@pytest.mark.parametrize("scene_id", ["pendulum", "kepler"])
def test_implicit_schemes_on_nonlinear_scenes_count_one_evaluation_per_newton_iteration(scheme_id, scene_id):
    steps = 50
    tr = run(scheme_id, scene=make_scene(scene_id), dt=0.01, steps=steps)
    # Each Newton iteration is one evaluation and one solve; Newton needs more than one here,
    # except in the linearly implicit step, which is one solve by construction.
    assert tr.force_evals == tr.solves
    if scheme_id == "linearly_implicit_euler":
        assert tr.force_evals == steps
    else:
        declared = METHODS[scheme_id].force_evals  # the Newton solves a step makes (two half steps: 2)
        assert declared * steps < tr.force_evals <= 50 * declared * steps


def test_every_scheme_declares_its_metadata_and_formulas():
    for sid, s in METHODS.items():
        assert s.id == sid
        assert s.order in (1, 2, 3, 4, 5)
        assert s.force_evals >= (0 if s.kind.name == "position_based" else 1)  # PBD/XPBD: the forces are constraints
        assert s.energy_claim in ("grows", "bounded", "decays")
        assert "=" in s.doc and "order" in s.doc.lower(), f"{sid}: docstring carries the update formulas and order"


LONG_STEPS = 100_000


class _LongRuns(dict):
    """10^5 steps at h = 0.1 on the unit spring, energy recorded every 100 steps: each scheme's
    run made the first time a test asks for it (the tests ask for eleven of the schemes), on the
    compiled path: the interpreted run's operations in the same order (tests/test_kernels.py holds
    the spring's pointwise loop to the interpreted run bit for bit), a fraction of its time."""

    def __missing__(self, scheme_id):
        self[scheme_id] = integrate_compiled(METHODS[scheme_id], SPRING, 0.1, LONG_STEPS, every=100)
        return self[scheme_id]


@pytest.fixture(scope="module")
def long_runs():
    return _LongRuns()


def tenth_envelopes(energy):
    e = energy[:, 0]
    n = len(e) // 10
    return np.ptp(e[:n]), np.ptp(e[-n:]), e[:n].mean(), e[-n:].mean()


@pytest.mark.parametrize("scheme_id", [s for s, m in FREE.items() if m.symplectic])
def test_symplectic_energy_stays_in_a_band(long_runs, scheme_id):
    tr = long_runs[scheme_id]
    assert tr.ok
    w_first, w_last, m_first, m_last = tenth_envelopes(tr.energy)
    e0 = tr.energy[0, 0]
    # The band of the first tenth and the last tenth agree: width and centre within 1% of E0.
    assert abs(w_last - w_first) <= 0.01 * e0
    assert abs(m_last - m_first) <= 0.01 * e0


def test_explicit_euler_energy_grows_without_bound(long_runs):
    tr = long_runs["explicit_euler"]
    # (1 + h^2)^(n/2) passes the divergence threshold (1e100) near step 46,000: a recorded
    # blow-up, not a calm run; before that the energy has grown by more than 1e100.
    assert tr.status == "unstable" and tr.failed_step is not None
    assert tr.failed_step == pytest.approx(2 * np.log(1e100) / np.log(1.01), rel=1e-3)
    assert tr.energy[-1, 0] > 1e100 * tr.energy[0, 0]


@pytest.mark.parametrize("scheme_id", ["implicit_euler", "rk4"])
def test_implicit_euler_and_rk4_lose_energy(long_runs, scheme_id):
    tr = long_runs[scheme_id]
    e = tr.energy[:, 0]
    assert tr.ok
    assert e[-1] < e[0]
    assert np.all(np.diff(e) <= 1e-15 * e[0]), "monotone loss"
    if scheme_id == "rk4":
        # |R|^2 = 1 - h^6/72 + h^8/576 per step at h = 0.1: the predicted loss over 10^5 steps.
        factor = (1 - 0.1**6 / 72 + 0.1**8 / 576) ** LONG_STEPS
        assert e[-1] / e[0] == pytest.approx(factor, rel=1e-6)


@pytest.mark.parametrize("scheme_id", FREE)
def test_a_batch_of_initial_states_runs_as_one_array(scheme_id):
    scene = make_scene("pendulum")
    q0 = np.array([[0.5], [1.0], [2.0], [3.0]])
    v0 = np.array([[0.0], [0.3], [-0.2], [0.0]])
    batched = integrate(METHODS[scheme_id], scene, 0.01, 20, q0=q0, v0=v0)
    assert batched.q.shape == (21, 4, 1)
    for b in range(4):
        single = integrate(METHODS[scheme_id], scene, 0.01, 20, q0=q0[b : b + 1], v0=v0[b : b + 1])
        # Newton's stopping test looks at the whole batch, so members may take one more
        # iteration than alone: agreement to roundoff, not bitwise.
        np.testing.assert_allclose(batched.q[:, b], single.q[:, 0], rtol=0, atol=1e-12)


# Each pair compiles for ~2 s, so not the full matrix: every scheme on kepler (2 DOF, nonlinear,
# a 2x2 solve), and implicit midpoint (which calls both the force and the solve kernel) on every scene.
# The solar system runs leapfrog (its scheme in the nightly) instead: implicit midpoint's dense
# 18x18 solve alone takes ~20 s to compile.
COMPILED_CASES = (
    [(s, "kepler") for s in FREE]
    + [("verlet_constrained", "rope"), ("leapfrog", "solar_system")]
    + [
        ("implicit_midpoint", s)
        for s in sorted(SCENES)
        if s not in ("kepler", "solar_system") and not make_scene(s).constrained
    ]
)


#: The pairs ``make test`` runs (one explicit tableau, one symplectic and one implicit scheme on
#: kepler, the constrained projection, implicit midpoint on the small scenes); the rest of the
#: matrix compiles a kernel each for seconds and is marked slow (``make test-slow``).
COMPILED_FAST = {
    ("rk4", "kepler"),
    ("leapfrog", "kepler"),
    ("implicit_euler", "kepler"),
    ("verlet_constrained", "rope"),
    *(("implicit_midpoint", s) for s in ("spring", "damped_spring", "pendulum", "chain", "projectile", "penalty_ball")),
}


@pytest.mark.parametrize(
    "scheme_id,scene_id",
    [c if c in COMPILED_FAST else pytest.param(*c, marks=pytest.mark.slow) for c in COMPILED_CASES],
)
def test_compiled_path_matches_interpreted_path(scheme_id, scene_id):
    # The cloth and the net at 3 x 3: an interpreted banded solve of the default 8 x 8 takes ~0.1 s,
    # and 200 interpreted implicit-midpoint steps of the 8 x 8 net 18 CPU-s.
    scene = make_scene(scene_id, **({"n": 3, "m": 3} if scene_id in ("cloth", "net") else {}))
    scheme = METHODS[scheme_id]
    ref = integrate(scheme, scene, 0.01, 200, every=200)
    q, v = run_compiled(scheme, scene, 0.01, 200)
    # Same operations; numba may use libm's sin/sqrt where numpy uses its own: ulp-level differences.
    np.testing.assert_allclose(q, ref.q[-1], rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(v, ref.v[-1], rtol=1e-11, atol=1e-12)


@pytest.mark.parametrize(
    "scheme_id, dt, steps, every",
    [
        ("explicit_euler", 1.0, 1000, 10),  # blows up at step 666
        ("rk4", 3.0, 1000, 1),  # h w = 3 > 2 sqrt(2): blows up at step 564
        ("rk4", 0.1, 1000, 7),  # stable, the last step off the recording grid
    ],
)
def test_compiled_run_is_the_interpreted_run(scheme_id, dt, steps, every):
    """integrate_compiled records and stops exactly as integrate does: same steps, same states
    (bitwise, measured), the same failing step. Pairs the cost tests compile anyway."""
    from reference import integrate_compiled

    a = integrate(METHODS[scheme_id], SPRING, dt, steps, every)
    b = integrate_compiled(METHODS[scheme_id], SPRING, dt, steps, every)
    assert (b.status, b.failed_step, b.detail) == (a.status, a.failed_step, a.detail)
    np.testing.assert_array_equal(b.step, a.step)
    np.testing.assert_array_equal(b.q, a.q)
    np.testing.assert_array_equal(b.v, a.v)
    assert b.force_evals is None and b.meta.backend == "compiled"


def test_blow_up_is_recorded_as_unstable_with_the_step():
    tr = run("explicit_euler", scene=make_scene("spring", k=1e6), dt=0.5, steps=10_000)
    assert tr.status == "unstable"
    assert 1 < tr.failed_step < 10_000
    assert np.isfinite(tr.q).all() and tr.step[-1] < tr.failed_step


def test_velocity_verlet_and_position_verlet_agree():
    # Stormer-Verlet with the documented start-up and velocity estimate is velocity Verlet
    # in exact arithmetic; in floating point they agree to roundoff.
    scene = make_scene("kepler")
    a = run("verlet", scene=scene, dt=0.01, steps=2000, every=100)
    b = run("velocity_verlet", scene=scene, dt=0.01, steps=2000, every=100)
    np.testing.assert_allclose(a.q, b.q, atol=1e-10)
    np.testing.assert_allclose(a.v, b.v, atol=1e-9)


def test_leapfrog_is_drift_kick_drift():
    # One step on the unit spring, by hand: x_half = 1 + h/2 * 0, v1 = -h * x_half, x1 = x_half + h/2 v1.
    h = 0.5
    tr = run("leapfrog", dt=h, steps=1)
    assert tr.q[1, 0, 0] == 1 + h / 2 * (-h * 1.0)
    assert tr.v[1, 0, 0] == -h


def test_implicit_midpoint_conserves_spring_energy():
    tr = run("implicit_midpoint", dt=0.5, steps=1000, every=10)
    np.testing.assert_allclose(tr.energy[:, 0], 0.5, rtol=1e-12)


def test_forest_ruth_coefficient():
    from reference.schemes.forest_ruth import THETA

    assert THETA == pytest.approx(1.3512071919596578, rel=1e-15)
    # Yoshida's condition for the triple jump theta, 1 - 2 theta, theta to cancel the third-order
    # error of its leapfrogs: 2 theta^3 + (1 - 2 theta)^3 = 0 (its real root is 1/(2 - 2^(1/3))).
    assert 2 * THETA**3 + (1 - 2 * THETA) ** 3 == pytest.approx(0.0, abs=1e-14)
    # A wrong theta fails it: the nearby 1.35 leaves 2.7e-2.
    assert abs(2 * 1.35**3 + (1 - 2 * 1.35) ** 3) > 1e-3


# ------------------------------------------------------------------ two-stage Radau IIA
def test_radau_iia2_is_third_order_on_the_spring_and_the_pendulum():
    """The harness's order measure (log-log slope of the global error against the closed form, the
    pendulum's elliptic-function solution); within 0.1 of 3 (the Drake order tests' tolerance)."""
    from harness.measures import order

    for scene_id in ("spring", "pendulum"):
        assert order.observed_order("ref:radau_iia2", make_scene(scene_id))["order"] == pytest.approx(3.0, abs=0.1)


@pytest.mark.parametrize("h, steps", [(0.5, 50), (3.0, 8), (100.0, 2)])
def test_radau_iia2_damps_the_spring_by_its_stability_function_at_any_step(h, steps):
    """A-stable: |R(i z)|^2 = (1 + z^2/9)/(1 + z^2/9 + z^4/36) < 1 for every z = h omega, so the
    energy falls by that factor each step, up to h omega = 100 (L-stable: ~36/z^2 there). Steps
    while the energy stays above 1e-7: the iteration's stop is absolute below a unit state
    (NEWTON_RTOL (1 + |w|)), so over a state decayed to 1e-2 it is ~1e-11 relative. Relative 1e-10:
    measured 2.8e-11 at h = 100, 1e-15 at h = 0.5 and 3."""
    tr = run("radau_iia2", dt=h, steps=steps)
    assert tr.ok
    ratio = tr.energy[1:, 0] / tr.energy[:-1, 0]
    z2 = h * h
    np.testing.assert_allclose(ratio, (1 + z2 / 9) / (1 + z2 / 9 + z2 * z2 / 36), rtol=1e-10)
    assert np.all(ratio < 1.0)


@pytest.mark.parametrize(
    "scene_id", ["spring", "damped_spring", "pendulum", "chain", pytest.param("cloth", marks=pytest.mark.slow)]
)
def test_radau_iia2_compiled_is_the_interpreted_run_bit_for_bit(scene_id):
    """The compiled loop steps the interpreted run's states, bit for bit (its kernels are copied
    from the step's source): the same passes, the same stop, on a linear scene (iterated to
    roundoff too) and a nonlinear one. The cloth at 3 x 3 and the chain of 8 masses, at h omega =
    0.1 on the spring's scale, to keep the interpreted runs short."""
    from reference import bitwise_why, integrate_compiled

    scene = make_scene(
        scene_id, **({"n": 3, "m": 3} if scene_id == "cloth" else {"N": 8} if scene_id == "chain" else {})
    )
    scheme = METHODS["radau_iia2"]
    dt = 0.1 / scene.omega
    a = integrate(scheme, scene, dt, 60, 7)
    assert bitwise_why(scheme, scene) == ""
    b = integrate_compiled(scheme, scene, dt, 60, 7)
    assert b.status == a.status and np.array_equal(b.step, a.step)
    assert b.q.tobytes() == a.q.tobytes() and b.v.tobytes() == a.v.tobytes()
    assert a.force_evals == a.solves and a.force_evals % 2 == 0  # whole passes: two stages, two solves
