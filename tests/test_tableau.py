"""Explicit Runge-Kutta schemes as tableaus (reference.tableau): a new one is one entry. The explicit midpoint rule is
declared and registered here, in this test alone, and runs interpreted and compiled like a shipped
scheme; each shipped tableau meets its declared order's conditions, and its generated step computes
what the hand-written step it replaced computed, bit for bit."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from scipy.stats import linregress

from reference import METHODS, carried_map, integrate, integrate_compiled, tableau_scheme
from reference.schemes.runge_kutta import TABLEAUS
from scenarios import make_scene

MIDPOINT_DOC = """The explicit midpoint rule (Runge's RK2), a test's tableau:

        k1 = f(t, y), k2 = f(t + h/2, y + h/2 k1), y_{n+1} = y_n + h k2

    Second order, two evaluations; on a spring |R(i y)|^2 = 1 + y^4/4: unstable for every h.
    """


@pytest.fixture
def midpoint(monkeypatch):
    """The explicit midpoint rule, registered in ``reference.METHODS`` for the test: the one entry a new scheme is."""
    scheme = tableau_scheme(
        "midpoint_test",
        A=[[0, 0], ["1/2", 0]],
        b=[0, 1],
        c=[0, "1/2"],
        order=2,
        energy_claim="grows",
        doc=MIDPOINT_DOC,
        module=__name__,
    )
    monkeypatch.setitem(METHODS, scheme.id, scheme)
    return scheme


@pytest.mark.parametrize("scene_id", ["spring", "pendulum", "kepler"])
def test_midpoint_runs_interpreted_and_compiled_with_the_same_bits(midpoint, scene_id):
    """The interpreted run and the compiled loop give one trajectory, bit for bit; the force
    evaluations counted interpreted are the tableau's two stages a step, as the compiled run
    declares them."""
    scene = make_scene(scene_id)
    dt, steps = 0.05 / scene.omega, 200
    interpreted = integrate(midpoint, scene, dt, steps, every=7)
    compiled = integrate_compiled(midpoint, scene, dt, steps, every=7, counted=True)
    np.testing.assert_array_equal(compiled.step, interpreted.step)
    assert compiled.q.tobytes() == interpreted.q.tobytes() and compiled.v.tobytes() == interpreted.v.tobytes()
    assert midpoint.force_evals == 2
    assert interpreted.force_evals == compiled.force_evals == 2 * steps


def test_midpoint_is_second_order_on_the_spring(midpoint):
    """Global error at t = 2 pi / omega against the closed form, dt halved four times: the log-log
    slope within 0.15 of 2 (the order tests' tolerance, tests/theory.py ORDER_TOL)."""
    spring = make_scene("spring")
    horizon = 2.0 * math.pi / spring.omega
    dts, errors = [], []
    for k in range(5):
        steps = 64 * 2**k
        traj = integrate(midpoint, spring, horizon / steps, steps, every=steps)
        x, v = spring.closed_form(traj.t[-1:])
        dts.append(horizon / steps)
        errors.append(math.hypot(traj.q[-1, 0, 0] - x[0, 0], (traj.v[-1, 0, 0] - v[0, 0]) / spring.omega))
    slope = linregress(np.log(dts), np.log(errors)).slope
    assert slope == pytest.approx(2.0, abs=0.15)
    assert midpoint.tableau.order_conditions(2) and not midpoint.tableau.order_conditions(3)


def test_midpoint_is_unstable_on_the_spring_at_every_step_as_theory_says(midpoint):
    """Theory, derived here: R(z) = 1 + z + z^2/2, so |R(i y)|^2 = (1 - y^2/2)^2 + y^2 = 1 + y^4/4 > 1
    for every y = h omega > 0: no stable step on the undamped spring. The tableau derives the same
    (``homega_max`` None), and the measured one-step map's spectral radius is sqrt(1 + y^4/4)
    (to roundoff: 1e-12 over four products of unit-size numbers)."""
    assert midpoint.homega_max is None
    spring = make_scene("spring")
    for y in (0.25, 0.5, 1.0, 2.0):
        M, c, _ = carried_map(midpoint, spring, y / spring.omega)
        rho = float(np.max(np.abs(np.linalg.eigvals(M))))
        assert rho == pytest.approx(math.sqrt(1.0 + y**4 / 4.0), abs=1e-12) and rho > 1.0
        assert not c.any()


def test_midpoint_has_a_floor_and_a_damping_matrix_without_another_file(midpoint):
    """The floor (``harness bench``) is generated from the tableau and computes the compiled kernel's
    bits; the damped spring's recurrence (``Scheme.amplification``) is the measured one-step
    map on the damped spring (1e-14: a few roundoffs of unit-size entries); its theory limit is the
    damping search's on that matrix."""
    from harness.measures.stability_damping import theory_limit
    from reference._compiled import run_compiled
    from reference._floors import run_floor

    assert midpoint.floor is not None and midpoint.amplification is not None and midpoint.damping_limit is None
    q, v = run_compiled(midpoint, make_scene("spring"), 0.01, 1000)
    assert (q[0, 0], v[0, 0]) == run_floor(midpoint.floor, 1.0, 0.0, 0.01, 1.0, 1.0, 1000)
    for zeta, y in ((0.0, 0.5), (0.3, 1.2)):
        M, _, _ = carried_map(midpoint, make_scene("damped_spring", c=2.0 * zeta), y)
        np.testing.assert_allclose(M, midpoint.amplification(y, zeta), rtol=0, atol=1e-14)
    # The damping theory searches for rho > 1 + RHO_TOL, as the stability measure does, by its rule:
    # on the spring 1 + y^4/4 grows at every y, below RHO_TOL up to y = 0.00168: no stable step
    # resolved (None, as the scheme declares), where the bare search would report 0.00168.
    assert theory_limit(midpoint.id, 0.0)["homega_max"] is None


@pytest.mark.parametrize("scheme", TABLEAUS, ids=lambda s: s.id)
def test_each_tableau_meets_its_declared_order_and_no_more(scheme):
    # The conditions are written out to order 4; Dormand-Prince's fifth order is held by its observed
    # order (tests/test_drake.py measures it against the closed form) and its stability polynomial.
    tab = scheme.tableau
    assert tab.order_conditions(min(scheme.order, 4))
    if scheme.order < 4:
        assert not tab.order_conditions(scheme.order + 1)
    assert scheme.force_evals == tab.stages and not scheme.symplectic and METHODS[scheme.id] is scheme


def test_stability_limits_derived_from_the_tableau_are_the_textbook_ones():
    """Explicit Euler: |1 + i y| > 1 for every y > 0 (None); RK4: |R(i y)|^2 = 1 - y^6/72 + y^8/576,
    limit sqrt(8) (the value the scheme declared before it was a tableau, to the last bit); Kutta's
    RK3: |R(i y)|^2 = 1 - y^4/12 + y^6/36, limit sqrt(3)."""
    assert METHODS["explicit_euler"].homega_max is None
    assert METHODS["rk4"].homega_max == 2.8284271247461903 == math.sqrt(8.0)
    rk3 = tableau_scheme(
        "kutta_rk3_test",
        A=[[0, 0, 0], ["1/2", 0, 0], [-1, 2, 0]],
        b=["1/6", "2/3", "1/6"],
        c=[0, "1/2", 1],
        order=3,
        energy_claim="decays",
        doc="Kutta's RK3.",
        module=__name__,
    )
    assert rk3.homega_max == math.sqrt(3.0) and rk3.tableau.order_conditions(3)
    # The shipped entries: Heun none (1 + y^4/4), Kutta and Bogacki-Shampine sqrt(3) (one stability
    # polynomial for every three-stage third-order scheme), Dormand-Prince's fifth-order solution
    # R(z) = sum_{k<=5} z^k/k! + z^6/600: |R(i y)|^2 - 1 = -y^6/1800 + y^8/1600 - ..., whose first root
    # is y = 0.99719 (beyond it |R(i y)| > 1 all the way: 1.07 at y = 3.5).
    assert METHODS["heun"].homega_max is None
    assert METHODS["kutta_rk3"].homega_max == METHODS["bogacki_shampine3"].homega_max == math.sqrt(3.0)
    assert METHODS["dormand_prince5"].homega_max == pytest.approx(0.99719, abs=1e-5)
    assert METHODS["dormand_prince5"].tableau.stability_coefficients()[-1] == Fraction(1, 600)


def _rk4_written_out(accel, state, t, h, p):
    # RK4 as reference/schemes/rk4.py wrote it by hand before it became a tableau entry.
    q, v = state
    half = 0.5 * h
    a1 = accel(q, v, t, p)
    q2, v2 = q + half * v, v + half * a1
    a2 = accel(q2, v2, t + half, p)
    q3, v3 = q + half * v2, v + half * a2
    a3 = accel(q3, v3, t + half, p)
    q4, v4 = q + h * v3, v + h * a3
    a4 = accel(q4, v4, t + h, p)
    sixth = h / 6.0
    return (q + sixth * (v + 2.0 * v2 + 2.0 * v3 + v4), v + sixth * (a1 + 2.0 * a2 + 2.0 * a3 + a4))


def _euler_written_out(accel, state, t, h, p):
    q, v = state
    a = accel(q, v, t, p)
    return (q + h * v, v + h * a)


@pytest.mark.parametrize("sid, written", [("rk4", _rk4_written_out), ("explicit_euler", _euler_written_out)])
def test_a_generated_step_computes_the_hand_written_steps_bits(sid, written):
    """The tableau's one written form keeps each shipped scheme's order of operations: on random
    states, times and steps under a nonlinear, time-dependent force the two agree bit for bit."""
    rng = np.random.default_rng(7)

    def accel(q, v, t, p):
        return -p[0] * np.sin(q) - p[1] * v * v + np.cos(t)

    for _ in range(20):
        q, v = rng.normal(size=(3, 4)), rng.normal(size=(3, 4))
        t, h, p = rng.uniform(0, 10), rng.uniform(1e-4, 0.5), rng.uniform(0.1, 2.0, size=2)
        got = METHODS[sid].step(accel, (q, v), t, h, p)
        want = written(accel, (q, v), t, h, p)
        for a, b in zip(got, want):
            assert np.array_equal(a, b)
