"""Order where the force depends on the velocity (issue 12): leapfrog, Forest-Ruth and the Verlet
forms measure order 1 on the damped spring and the projectile. It is the schemes, not their code:
the reference code's measured one-step map is the matrix written from the update formulas
(each scheme's ``amplification``, beside its step), and that matrix's local error against the exact flow exp(h A) is
O(h^2) once zeta > 0 (a kick that takes the velocity-dependent force at the velocity before it,
without a solve), O(h^3) (leapfrog) and O(h^5) (Forest-Ruth) without damping. So the schemes
declare order 1 for velocity-dependent forces, and the order check judges them by it.

Tolerances: ORDER_TOL (0.15, the order tests' own); the map against the formulas 1e-13 (entries
of size 1, a dozen operations: measured 2.2e-16); local-error slopes within 0.1 of the integer
(fit over h = 1e-2 .. 1e-1, measured within 0.03).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.stats import linregress

from harness.measures import order

from harness.measures import stability
from reference import METHODS
from scenarios import make_scene

ORDER_TOL = 0.15
KICK_WITHOUT_SOLVE = ("leapfrog", "forest_ruth", "verlet", "velocity_verlet")


@pytest.mark.parametrize("sid", KICK_WITHOUT_SOLVE)
def test_the_schemes_declare_first_order_for_velocity_dependent_forces(sid):
    scheme = METHODS[sid]
    assert scheme.order >= 2 and scheme.order_for(False) == scheme.order and scheme.order_for(True) == 1
    assert scheme.describe()["order_velocity_dependent"] == 1


@pytest.mark.parametrize("scene_id", ["damped_spring", "projectile"])
@pytest.mark.parametrize("sid", KICK_WITHOUT_SOLVE)
def test_observed_order_is_the_declared_one_on_each_scene(sid, scene_id):
    res = order.observed_order(f"ref:{sid}", make_scene(scene_id))
    assert res["order_declared"] == 1
    assert res["order"] == pytest.approx(1.0, abs=ORDER_TOL)
    # Undamped (c = 0) the same scene is position-only again: the scheme's own order.
    undamped = order.observed_order(f"ref:{sid}", make_scene(scene_id, c=0.0))
    assert undamped["order_declared"] == METHODS[sid].order
    if scene_id == "damped_spring":  # the projectile without drag is exact for these schemes
        assert undamped["order"] == pytest.approx(METHODS[sid].order, abs=ORDER_TOL)


@pytest.mark.parametrize("sid", ["leapfrog", "forest_ruth"])
def test_the_code_is_the_formulas(sid):
    # The measured one-step map of the reference code on the damped spring (zeta = 0.3) is the
    # matrix written from the docstring's updates.
    y, zeta = 0.2, 0.3
    measured = stability.one_step_map(f"ref:{sid}", make_scene("damped_spring", c=2 * zeta), y)["matrix"]
    assert np.max(np.abs(measured - METHODS[sid].amplification(y, zeta))) <= 1e-13


@pytest.mark.parametrize("sid, undamped_local_order", [("leapfrog", 3), ("forest_ruth", 5)])
def test_the_formulas_lose_their_order_to_the_damping(sid, undamped_local_order):
    hs = np.geomspace(1e-2, 1e-1, 6)

    def local_slope(zeta):
        a = np.array([[0.0, 1.0], [-1.0, -2.0 * zeta]])
        err = [np.max(np.abs(METHODS[sid].amplification(h, zeta) - expm(h * a))) for h in hs]
        return linregress(np.log(hs), np.log(err)).slope

    assert local_slope(0.0) == pytest.approx(undamped_local_order, abs=0.1)
    assert local_slope(0.3) == pytest.approx(2.0, abs=0.1)
