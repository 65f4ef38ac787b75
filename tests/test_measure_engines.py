"""The measurements on engine modes: the same measures, through the same generic method
interface (``harness.execution.simulate.simulate``, isolated workers) as the reference schemes.

Expected values and tolerances: tests/theory.py (issue 4; docs/engines.md for what each mode
integrates). These need the engine adapters; an unknown method id is a failure here,
never a skip, so a missing adapter cannot pass unnoticed.
"""

from __future__ import annotations

import pytest

from harness.measures import cost

from harness.measures import energy

from harness.measures import order

from harness.measures import stability
from harness.methods import get_method
from scenarios import make_scene
from theory import ENGINE_ORDER, ENGINE_STABILITY, ORDER_TOL, STABILITY_RTOL, UNBOUNDED


@pytest.mark.slow
@pytest.mark.parametrize("method_id", list(ENGINE_STABILITY))
def test_engine_largest_stable_dt_on_spring(method_id):
    spring = make_scene("spring")
    res = stability.largest_stable_dt(get_method(method_id), spring)
    # The spring's initial state is two parameters, so the one-step map is measurable
    # through a worker: the spectral criterion must be the one used.
    assert res.criterion == "spectral_radius", res.note
    expected = ENGINE_STABILITY[method_id]
    if expected == UNBOUNDED:
        assert res.verdict == "unbounded"
    else:
        assert res.verdict == "limited"
        assert res.omega_dt_max == pytest.approx(expected, rel=STABILITY_RTOL)


@pytest.mark.parametrize("method_id, scene_id", list(ENGINE_ORDER))
def test_engine_observed_order(method_id, scene_id):
    # The theory order steers only the dt range (what a declared order would do); the
    # slope is measured.
    theory = ENGINE_ORDER[(method_id, scene_id)]
    res = order.observed_order(get_method(method_id), make_scene(scene_id), order=theory)
    assert len(res["points"]) >= order.MIN_POINTS
    assert res["order"] == pytest.approx(theory, abs=ORDER_TOL)


@pytest.mark.parametrize(
    "method_id, expected",
    [
        ("mujoco:euler", "bounded"),  # semi-implicit Euler, bitwise (docs/engines.md)
        ("mujoco:rk4", "decays"),  # classical RK4
        ("mujoco:discrete", "decays"),  # backward Euler
    ],
)
def test_engine_energy_classification_on_spring(method_id, expected):
    res = energy.energy_behaviour(get_method(method_id), make_scene("spring"), 0.1, 10_000)
    assert res["classification"] == expected, res["rule"]


def test_engine_cost_is_measured_the_same_way():
    spring = make_scene("spring")
    res = cost.cost_per_step(get_method("mujoco:euler"), spring, 0.01, time_steps=500, repeats=2)
    assert "in-process simulate through the engine's own loop" in res.timing and res.s_per_step > 0
    assert res.force_evals_per_step is not None or res.force_evals_reason
    assert res.ratio_to_explicit_euler > 0


@pytest.mark.parametrize("loop", ["engine", "harness"])
def test_engine_cost_is_timed_over_the_steps_before_a_blow_up(loop):
    # Semi-implicit Euler past h*omega = 2 blows up: the run is replayed step by step to find where,
    # which is no cost of a step; the timing covers the steps before the blow-up and says so.
    spring, method = make_scene("spring"), get_method("mujoco:euler")
    failed = method.simulate(spring, 2.2, 5_000, 5_000).failed_step
    assert failed is not None and 1 < failed < 5_000
    res = cost.wall_time_per_step(method, spring, 2.2, steps=5_000, repeats=2, loop=loop)
    assert res["time_steps"] == failed - 1
    assert f"timed over the {failed - 1} steps before the run diverged at step {failed}" in res["timing"]
    assert res["s_per_step"] > 0


def _scripted_timing(monkeypatch, empties: list[float], timed: float):
    """A ``_Timing`` of an engine mode whose runs take the given seconds: 0-step runs ``empties`` in
    turn (the last one repeated), every n-step run ``timed``; nothing is run or read off a clock."""
    from types import SimpleNamespace

    left = list(empties)

    def run_s(self, n):
        if n:
            return timed
        return left.pop(0) if len(left) > 1 else left[0]

    monkeypatch.setattr(cost._Timing, "_run_s", run_s)
    monkeypatch.setattr(
        cost._Timing, "_simulate", lambda self, n: SimpleNamespace(meta=SimpleNamespace(settings={}), failed_step=None)
    )
    return cost._Timing(get_method("mujoco:euler"), make_scene("spring"), 0.01, 26, "wall", "harness", injected=None)


def test_a_setup_slowed_in_every_repeat_is_timed_again_and_never_makes_a_step_cost_negative(monkeypatch):
    # The pilot's 0-step run, then one per repeat: all slowed by 4 ms (a loaded machine), beside
    # timed runs of 26 steps at 0.2 ms; the setup's 0.04 ms shows on a later 0-step run.
    timing = _scripted_timing(monkeypatch, [4e-3, 4e-3, 4e-3, 4e-3, 4e-5], 2e-4)
    for _ in range(3):
        timing.repeat()
    res = timing.result("wall")
    assert res["s_per_step"] == pytest.approx((2e-4 - 4e-5) / 26) and not timing.setup_unresolved
    assert "upper bound" not in res["timing"]
    # Where no 0-step run comes out faster, the runs are taken whole, said so: an upper bound.
    timing = _scripted_timing(monkeypatch, [4e-3], 2e-4)
    for _ in range(3):
        timing.repeat()
    res = timing.result("wall")
    assert timing.setup_unresolved and res["s_per_step"] == pytest.approx(2e-4 / 26)
    assert "an upper bound" in res["timing"] and len(timing.empty) == 3 + cost.SETUP_RETRIES
