"""A tableau's embedded row and the step-size controller it drives (reference.tableau:
``Tableau.b_hat``, ``error_step``, ``error_controlled``): Bogacki-Shampine 3(2) and Dormand-Prince
5(4) declare theirs; the estimate is the difference of the two solutions at the embedded order's
rate, the step it comes with is the fixed step's bits, and the controlled run meets its tolerance."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import linregress

from reference import METHODS, Tableau
from reference.tableau import error_controlled, error_step
from scenarios import make_scene


def _force(q, v, t, p):
    return -p[0] * np.sin(q) - p[1] * v * np.abs(v) + np.cos(3.0 * t)


def test_the_embedded_rows_have_their_textbook_orders():
    """Bogacki-Shampine's row (over the first-same-as-last stage) is second order, not third;
    Dormand-Prince's fourth (its conditions are written out to 4); a tableau without one has none."""
    bs, dp = METHODS["bogacki_shampine3"].tableau, METHODS["dormand_prince5"].tableau
    assert bs.embedded_order() == 2 and dp.embedded_order() == 4
    assert (bs.error_evals, dp.error_evals) == (4, 7)
    with pytest.raises(ValueError, match="no embedded row"):
        METHODS["rk4"].tableau.embedded_order()
    with pytest.raises(ValueError, match="embedded row"):
        Tableau([[0, 0], ["1/2", 0]], [0, 1], [0, "1/2"], b_hat=[1])


@pytest.mark.parametrize("sid", ["bogacki_shampine3", "dormand_prince5"])
def test_the_step_with_the_estimate_is_the_fixed_steps_bits(sid):
    scheme = METHODS[sid]
    step = error_step(scheme.tableau, f"error_step_{sid}")
    rng = np.random.default_rng(2)
    for _ in range(10):
        q, v = rng.normal(size=(2, 3)), rng.normal(size=(2, 3))
        t, h, p = rng.uniform(0, 10), rng.uniform(1e-3, 0.5), rng.uniform(0.1, 2.0, size=2)
        q1, v1, eq, ev = step(_force, (q, v), t, h, p)
        want = scheme.step(_force, (q, v), t, h, p)
        assert np.array_equal(q1, want[0]) and np.array_equal(v1, want[1])
        assert eq.shape == q.shape and ev.shape == v.shape


@pytest.mark.parametrize("sid, rate", [("bogacki_shampine3", 3), ("dormand_prince5", 5)])
def test_the_estimate_shrinks_at_the_embedded_orders_rate(sid, rate):
    """On the spring from (1, 0): |estimate| ~ h^(q+1), q the embedded order (log-log slope within 0.15)."""
    step = error_step(METHODS[sid].tableau, f"error_step_{sid}")
    spring = make_scene("spring")
    hs = [0.2 / 2**k for k in range(5)]
    sizes = []
    for h in hs:
        _, _, eq, ev = step(spring.accel, (np.array([[1.0]]), np.array([[0.0]])), 0.0, h, spring.pvec)
        sizes.append(math.hypot(eq[0, 0], ev[0, 0]))
    assert linregress(np.log(hs), np.log(sizes)).slope == pytest.approx(rate, abs=0.15)


@pytest.mark.parametrize("sid", ["bogacki_shampine3", "dormand_prince5"])
def test_the_controlled_run_meets_its_tolerance(sid):
    """One period of the spring against its closed form: the error within 100 tolerances, at rtol
    1e-5 and 1e-8; the tighter tolerance takes more steps, about (1000)^(1/(q+1)) times as many."""
    spring = make_scene("spring")
    horizon = 2.0 * math.pi / spring.omega
    x, v = spring.closed_form(np.array([horizon]))
    runs = {}
    for rtol in (1e-5, 1e-8):
        res = error_controlled(METHODS[sid], spring, horizon, rtol=rtol)
        assert res["t"] == horizon
        err = math.hypot(res["q"][0, 0] - x[0, 0], res["v"][0, 0] - v[0, 0])
        assert err <= 100 * rtol, (rtol, err)
        runs[rtol] = res
    q = METHODS[sid].tableau.embedded_order()
    ratio = runs[1e-8]["accepted"] / runs[1e-5]["accepted"]
    assert ratio == pytest.approx(1000 ** (1 / (q + 1)), rel=0.5)
    assert (
        runs[1e-8]["force_evals"]
        == (runs[1e-8]["accepted"] + runs[1e-8]["rejected"]) * METHODS[sid].tableau.error_evals
    )


def test_a_scheme_without_an_embedded_row_is_not_controlled():
    with pytest.raises(ValueError, match="no embedded row"):
        error_controlled(METHODS["rk4"], make_scene("spring"), 1.0, rtol=1e-6)
