"""The measurements on the reference schemes: stability limits, observed orders, energy
classification, counted evaluations and timing, the global error's reference solve, the
CLI's JSON shapes and its bad-input exits.

Numbers and tolerances come from tests/theory.py (issue 4 and docs/engines.md) unless a test
says otherwise. Engine modes are checked in test_measure_engines.py.
"""

from __future__ import annotations

import io
import json
import math
from contextlib import redirect_stderr, redirect_stdout

import numpy as np
import pytest

import reference
from harness.measures import cost
from harness.measures import energy
from harness.measures import error
from harness.measures import order
from harness.measures import stability
from harness.measures import workprecision
from harness.measures.common import started_at
from harness.measures.frames import frame, order_points_frame
from harness.cli import main
from reference import RefMethod
from records import InvalidInput, Trajectory
from scenarios import make_scene
from scenarios.pendulum import Pendulum
from records.trajectory import UNSTABLE
from theory import (
    ENERGY_DT,
    ENERGY_STEPS,
    ORDER_SCENES,
    ORDER_TOL,
    ORDER_TOL_FOR,
    REF_ENERGY,
    REF_EVALS,
    REF_ORDER,
    REF_STABILITY,
    STABILITY_RTOL,
    UNBOUNDED,
    UNRESOLVED,
    UNSTABLE as NEVER_STABLE,
)


class Delegate:
    """A method that answers the engine-mode interface (no ``scheme`` behind it, counts
    nothing) by delegating to a reference scheme: the measures must treat it exactly as
    they will treat an engine adapter. ``fail_above`` makes runs with a larger dt fail."""

    family = "test"

    def __init__(self, scheme_id: str, isolated: bool = False, fail_above: float = math.inf):
        self.inner = RefMethod(reference.METHODS[scheme_id])
        self.id = f"test:{scheme_id}"
        self.isolated = isolated
        self.fail_above = fail_above

    def available(self):
        return True, ""

    def supports(self, scene):
        return self.inner.supports(scene)

    def simulate(self, scene, dt, steps, every=1):
        if dt > self.fail_above:
            return Trajectory.failed(scene.id, self.id, dt, steps, UNSTABLE, "told to fail", every, scene.ndof)
        traj = self.inner.simulate(scene, dt, steps, every)
        traj.method, traj.force_evals, traj.solves = self.id, None, None
        traj.meta.force_evals_reason = "a delegate counts nothing"
        return traj

    def describe(self):
        return {"id": self.id, "family": self.family}


@pytest.fixture(scope="module")
def spring():
    return make_scene("spring")


# --------------------------------------------------------------------------- stability
@pytest.mark.parametrize("sid", list(REF_STABILITY))
def test_largest_stable_dt_on_spring(spring, sid):
    res = stability.largest_stable_dt(f"ref:{sid}", spring)
    expected = REF_STABILITY[sid]
    assert res.criterion == "spectral_radius"
    if expected == NEVER_STABLE:
        assert res.verdict == "unstable" and res.dt_max is None
        assert res.spectral["rho"] > 1.0
    elif expected == UNBOUNDED:
        assert res.verdict == "unbounded" and res.dt_max is None
        assert res.dt_searched_max == pytest.approx(stability.HOMEGA_HI)
    elif expected == UNRESOLVED:
        assert res.verdict == "unresolved" and res.dt_max is None and res.omega_dt_max is None
        assert res.detail.startswith("no stable step resolved")
    else:
        assert res.verdict == "limited"
        assert res.omega_dt_max == pytest.approx(expected, rel=STABILITY_RTOL)
        assert res.dt_max == res.omega_dt_max / spring.omega
        assert res.spectral["rho"] <= 1.0 + stability.RHO_TOL < res.rho_above_dt_max


def test_a_growth_below_the_search_resolution_is_no_limit(spring):
    """Heun on the spring grows at every step, rho - 1 = y^4/8 + O(y^6) (|R(iy)|^2 = 1 + y^4/4):
    below RHO_TOL up to y = 0.00168, where the bisection ends. The search says so instead of
    reporting 0.00168: rho - 1 at the last step called stable is RHO_TOL (the bisection's end, to
    its 1e-6 relative width times the power 4), and 1/16 of it at half that step (y^4), both > 0;
    rho - 1 of 1e-12 read from the eigenvalues of a map whose entries carry eps (1e-16) is good to
    about 1e-4 relative, the step where it crosses to a quarter of that: the tolerances below.
    Semi-implicit Euler (rho = 1 to roundoff below 2) and RK4 (rho < 1 below 2 sqrt 2) keep their
    limits: the rule reads their growth at the limit as none."""
    res = stability.largest_stable_dt("ref:heun", spring)
    y = (8.0 * stability.RHO_TOL) ** 0.25
    assert res.verdict == "unresolved" and res.first_unstable_omega_dt == pytest.approx(y, rel=1e-4)
    rho = lambda h: stability.recurrence_map("ref:heun", spring, h)["rho"]  # noqa: E731
    unresolved, at, half = stability.growth_unresolved(rho, res.spectral["omega_dt"])
    assert unresolved and at == pytest.approx(stability.RHO_TOL, rel=1e-3) and half == pytest.approx(at / 16, rel=1e-2)
    for sid, limit in (("semi_implicit_euler", 2.0), ("rk4", 2.0 * math.sqrt(2.0))):
        rho = lambda h, sid=sid: stability.recurrence_map(f"ref:{sid}", spring, h)["rho"]  # noqa: E731
        assert not stability.growth_unresolved(rho, limit * (1 - 1e-6))[0]


def test_explicit_euler_is_unstable_at_every_dt_searched(spring):
    # Theory (docs/engines.md): |eigenvalue| = sqrt(1 + h^2) > 1 for every h > 0. At the smallest
    # h*omega searched, rho - 1 = h^2/2 = 5e-9; the entries of the map are exact to eps,
    # so rho - 1 is good to ~1e-16/5e-9 = 2e-8 relative: 1e-6 leaves room.
    res = stability.largest_stable_dt("ref:explicit_euler", spring)
    lo = stability.HOMEGA_LO
    assert res.spectral["omega_dt"] == pytest.approx(lo)
    assert res.spectral["rho"] - 1.0 == pytest.approx(math.sqrt(1.0 + lo * lo) - 1.0, rel=1e-6)
    assert res.spectral["rho"] - 1.0 > 1e3 * stability.RHO_TOL


@pytest.mark.parametrize(
    "sid, rho",
    [
        ("explicit_euler", math.sqrt(2.0)),  # |1 + i h|, h = 1
        ("implicit_euler", 1.0 / math.sqrt(2.0)),  # 1/|1 - i h|
        ("rk4", math.sqrt(1.0 - 1.0 / 72.0 + 1.0 / 576.0)),  # docs/engines.md: |R|^2
        ("semi_implicit_euler", 1.0),  # det 1, complex pair
        ("implicit_midpoint", 1.0),  # Cayley transform
    ],
)
def test_one_step_map_spectral_radius_matches_theory(spring, sid, rho):
    # At h = 1 the map's entries are formed in a handful of flops from O(1) numbers: a few
    # eps each, so 1e-14 absolute.
    res = stability.one_step_map(f"ref:{sid}", spring, 1.0)
    assert res["rho"] == pytest.approx(rho, abs=1e-14)
    assert res["linearity_residual"] <= 1e-14
    assert np.asarray(res["matrix"]).shape == (2, 2) and np.allclose(res["offset"], 0.0)


def test_one_step_map_refuses_a_nonlinear_map():
    # sin(theta) over unit states: the affine fit misses the probe by far more than roundoff.
    res = stability.one_step_map("ref:leapfrog", make_scene("pendulum"), 0.1)
    assert res["rho"] is None and "not affine" in res["reason"]
    with pytest.raises(InvalidInput, match="linear scene"):
        stability.largest_stable_dt("ref:leapfrog", make_scene("kepler"), criterion="spectral_radius")


def test_finite_horizon_understates_explicit_euler(spring):
    # Explicit Euler's amplitude is exactly (1 + h^2)^(n/2) (its map is a scaled rotation),
    # so 10^4 steps stay within GROWTH = 10 up to h = sqrt(10^(2/N) - 1) = 0.02146: "stable"
    # there by a finite horizon, though rho > 1. Bisection stops at 1e-6 relative; 1e-5 here.
    n = 10_000
    res = stability.largest_stable_dt("ref:explicit_euler", spring, criterion="finite_horizon", steps=n, lo=1e-2)
    assert res.verdict == "limited" and res.criterion == "finite_horizon"
    assert res.omega_dt_max == pytest.approx(math.sqrt(stability.GROWTH ** (2.0 / n) - 1.0), rel=1e-5)
    # The map at that dt, attached for a linear scene, shows what the horizon missed.
    assert res.spectral["rho"] > 1.0 + stability.RHO_TOL


def test_nonlinear_scene_uses_the_finite_horizon():
    pendulum = make_scene("pendulum")
    res = stability.largest_stable_dt("ref:leapfrog", pendulum, steps=500)
    assert res.criterion == "finite_horizon" and res.verdict == "limited"
    # The pendulum is at most as stiff as its linearisation (|d a/d theta| <= g/L), whose
    # limit is h*omega = 2; at theta0 = 2 it loses boundedness well before.
    assert 0.5 < res.omega_dt_max <= 2.0


def test_stability_through_the_engine_interface(spring):
    # The delegate has no scheme: the map comes from stepping unit states via simulate,
    # the initial state set through the spring's x0/v0 parameters.
    res = stability.largest_stable_dt(Delegate("semi_implicit_euler"), spring)
    assert res.criterion == "spectral_radius"
    assert res.omega_dt_max == pytest.approx(2.0, rel=STABILITY_RTOL)


def test_started_at_uses_parameters_where_it_can(spring):
    moved = started_at(spring, [0.0], [1.0])
    assert moved.state_in_params and moved.values["x0"] == 0.0 and moved.values["v0"] == 1.0
    assert spring.values["x0"] == 1.0
    projectile = make_scene("projectile")
    moved = started_at(projectile, [1.0, 2.0], [3.0, 4.0])
    assert not moved.state_in_params
    assert moved.initial_state()[0].tolist() == [1.0, 2.0]
    assert projectile.initial_state()[0].tolist() == [0.0, 0.0]
    # An isolated (worker-process) method would not see the override: refused, not wrong.
    res = stability.one_step_map(Delegate("leapfrog", isolated=True), projectile, 0.1)
    assert res["rho"] is None and "worker process" in res["reason"]


# ------------------------------------------------------------------------------ order
def test_the_theory_tables_cover_every_unconstrained_scheme():
    # A scheme added to the registry must be added to the tables, or it goes unmeasured.
    # (ref:verlet_constrained runs only on the rope; see tests/test_scenes_hard.py.)
    free = {sid for sid, s in reference.METHODS.items() if not s.constrained}
    assert set(REF_ORDER) == set(REF_STABILITY) == free


def _order_cases():
    """(scene, scheme) for each scheme on each order scene it runs on (a position-based scheme
    projects springs, so of these only the spring)."""
    from harness.methods import get_method

    return [
        (scene_id, sid)
        for sid in REF_ORDER
        for scene_id in ORDER_SCENES
        if get_method(f"ref:{sid}").supports(make_scene(scene_id))[0]
    ]


#: First-order implicit schemes on Kepler: their Newton passes vary, so each order run is
#: interpreted, over many steps; marked slow (the pendulum and the spring ask the same of them).
ORDER_SLOW = {("kepler", "implicit_euler"), ("kepler", "implicit_euler_doubled"), ("kepler", "linearly_implicit_euler")}


@pytest.mark.parametrize(
    "scene_id, sid", [c if c not in ORDER_SLOW else pytest.param(*c, marks=pytest.mark.slow) for c in _order_cases()]
)
def test_observed_order(scene_id, sid):
    scene = make_scene(scene_id)
    res = order.observed_order(f"ref:{sid}", scene)
    assert len(res["points"]) >= order.MIN_POINTS
    assert res["order"] == pytest.approx(REF_ORDER[sid], abs=ORDER_TOL_FOR.get((sid, scene_id), ORDER_TOL))
    assert res["range"]["order_source"] == "declared"


def test_order_leaves_out_points_by_rule(spring):
    # Horizon pi (half a period). dt = pi is one RK4 step with |R(i pi) - e^(i pi)| = 2.3:
    # lost. dt = pi/40000 has error ~1e-17, under the roundoff floor 1e3 eps N = 9e-9.
    # A delegate told to fail above dt = 2.5 supplies the unstable point.
    horizon = 0.5 * spring.period
    good = [horizon / n for n in (8, 11, 16, 22, 32, 45)]
    dts = [horizon, horizon / 40_000] + good
    res = order.observed_order("ref:rk4", spring, dts=dts)
    reasons = {round(p["steps"]): p["reason"] for p in res["excluded"]}
    assert reasons[1].startswith("past stability") and reasons[40_000].startswith("roundoff floor")
    assert res["order"] == pytest.approx(4, abs=ORDER_TOL)
    table = order_points_frame(res)
    assert len(table) == len(dts) and table["used"].sum() == len(good) and table["dt"].is_monotonic_increasing
    res = order.observed_order(Delegate("rk4", fail_above=2.5), spring, dts=[3.0] + good)
    assert [p["reason"] for p in res["excluded"]] == ["unstable (unstable)"]
    assert len(res["points"]) == len(good)


def test_order_needs_six_points(spring):
    with pytest.raises(InvalidInput, match="points"):
        order.observed_order("ref:rk4", spring, points=5)


def test_order_through_the_engine_interface(spring):
    # No declared order: the range is chosen for order 2, and the slope still comes out 1.
    res = order.observed_order(Delegate("semi_implicit_euler"), spring)
    assert res["range"]["order_source"].startswith("none declared")
    assert res["order"] == pytest.approx(1, abs=ORDER_TOL)


# ----------------------------------------------------------------------------- energy
@pytest.fixture(scope="module")
def energy_table(spring):
    return {sid: energy.energy_behaviour(f"ref:{sid}", spring, ENERGY_DT, ENERGY_STEPS) for sid in REF_ENERGY}


@pytest.mark.parametrize("sid", list(REF_ENERGY))
def test_energy_classification_on_spring(energy_table, sid):
    res = energy_table[sid]
    assert res["classification"] == REF_ENERGY[sid], res["rule"]
    assert not res["short_horizon"]


def test_energy_numbers_match_theory(energy_table):
    h, n = ENERGY_DT, ENERGY_STEPS
    # Explicit Euler and implicit Euler scale the energy by exactly (1 + h^2)^(+-1) a step
    # (their maps are scaled rotations); RK4 by |R|^2 = 1 - h^6/72 + h^8/576 (docs/engines.md).
    # 10^4 steps of rounding move ln E by ~1e-12: 1e-9 relative leaves room.
    assert energy_table["explicit_euler"]["final_rel_error"] == pytest.approx((1 + h * h) ** n - 1, rel=1e-9)
    assert energy_table["implicit_euler"]["final_rel_error"] == pytest.approx(1 - (1 + h * h) ** -n, rel=1e-9)
    rk4 = 1.0 - (1.0 - h**6 / 72 + h**8 / 576) ** n
    assert energy_table["rk4"]["final_rel_error"] == pytest.approx(rk4, rel=1e-6)
    # "Slowly": RK4 loses 1.4e-4 over 159 periods against implicit Euler's everything.
    assert energy_table["rk4"]["final_rel_error"] < 1e-3
    # Semi-implicit Euler conserves x^2 + v^2 - h x v, so E/E0 - 1 = h x v stays within
    # h/(2 - h); the maximum is sampled within a fraction of a degree of phase over 1590
    # oscillations of the error: 1e-4 relative.
    assert energy_table["semi_implicit_euler"]["max_rel_error"] == pytest.approx(h / (2 - h), rel=1e-4)


def test_damped_energy_is_judged_against_the_decaying_energy():
    # Against E0 the damped spring's energy error would be 1 - e^(-c T) ~ 0.86 at T = 20;
    # against the exact decaying energy RK4 at h = 0.01 is at its truncation level.
    res = energy.energy_behaviour("ref:rk4", make_scene("damped_spring"), 0.01, 2000)
    assert res["max_rel_error"] < 1e-8


def test_classification_rule_on_constructed_series():
    t = np.linspace(0.0, 100.0, 1001)
    one = np.ones_like(t)
    assert energy.classify(1 + 1e-3 * np.sin(t), one, t)["classification"] == "bounded"
    assert energy.classify(np.exp(1e-3 * t), one, t)["classification"] == "grows"
    # A bound orbit's energy is negative: rising towards zero is gaining energy.
    assert energy.classify(-0.5 * (1 - 1e-4 * t), -0.5 * one, t)["classification"] == "grows"
    assert energy.classify(1 - 0.02 * t, one, t)["classification"] == "decays"  # crosses zero
    walk = 1 + 1e-6 * np.cumsum(np.random.default_rng(3).choice([-1.0, 1.0], size=len(t)))
    assert energy.classify(walk, one, t)["classification"] == "drifts"
    assert energy.classify(one, 1 - 0.02 * t, t)["classification"] is None  # exact energy changes sign
    assert energy.classify(one[:50], one[:50], t[:50])["classification"] is None  # too few states


# ------------------------------------------------------------------------------- cost
@pytest.mark.parametrize("sid", list(REF_EVALS))
def test_counted_evaluations_per_step(spring, sid):
    res = cost.counted_evaluations(f"ref:{sid}", spring, 0.01)
    assert (res["force_evals_per_step"], res["solves_per_step"]) == REF_EVALS[sid]


@pytest.mark.parametrize("sid", list(reference.METHODS))
def test_counted_evaluations_agree_with_declarations(sid):
    from harness.methods import get_method

    scheme = reference.METHODS[sid]
    # A constrained scheme runs only on a scene with constraints to project, a position-based one
    # on the springs and links it projects: each on those of these it runs on, at least one.
    scenes = [s for s in ("spring", "pendulum", "rope") if get_method(f"ref:{sid}").supports(make_scene(s))[0]]
    assert scenes
    for scene_id in scenes if scheme.constrained or scheme.kind.name == "position_based" else ["spring", "pendulum"]:
        res = cost.counted_evaluations(f"ref:{sid}", make_scene(scene_id), 0.01)
        if scheme.implicit and (scene_id == "pendulum" or not scheme.one_pass_on_linear):
            # Newton: one evaluation and one solve per iteration, at least one iteration (coupled
            # stages iterate on the linear spring too: Scheme.one_pass_on_linear).
            assert res["force_evals_per_step"] == res["solves_per_step"] >= 1
        else:
            assert res["force_evals_per_step"] == scheme.force_evals
    assert cost.counted_evaluations("ref:verlet", make_scene("spring"), 0.01)["start_force_evals"] == 1


def test_wall_time_per_step_and_ratio(spring):
    res = cost.cost_per_step("ref:rk4", spring, 0.01, time_steps=20_000, repeats=3)
    assert len(res.repeats_s_per_step) == 3
    assert 0 < res.s_per_step == min(res.repeats_s_per_step) <= res.median_s_per_step
    assert res.rel_spread >= 0 and res.baseline["method"] == "ref:explicit_euler"
    # The ratio is the median of the interleaved pairs' ratios; its size is the machine's, so no
    # test asserts on it (test_injected_timings_make_the_ratio_and_its_spread below does).
    ratios = np.array(res.repeats_s_per_step) / np.array(res.baseline["repeats_s_per_step"])
    assert res.ratio_to_explicit_euler == pytest.approx(float(np.median(ratios)), rel=1e-12)
    assert res.calibration > 0 and res.calibration_spread >= 0


def test_injected_timings_make_the_ratio_and_its_spread(spring, tmp_path, monkeypatch):
    """Timings injected (``HARNESS_INJECT_TIMINGS``) are what the cost figures read: the runs are
    still timed, the clock's figures replaced, and the clock recorded as ``injected``."""
    injected = {
        "s_per_step": {"ref:explicit_euler": 1e-8, "*": 4e-8},
        "jitter": [1.0, 1.1, 0.9],
        "calibration": {"python": 6e-8, "compiled": 5e-9},
    }
    path = tmp_path / "timings.json"
    path.write_text(json.dumps(injected))
    monkeypatch.setenv("HARNESS_INJECT_TIMINGS", str(path))
    res = cost.cost_per_step("ref:rk4", spring, 0.01, time_steps=20_000, repeats=3)
    assert res.repeats_s_per_step == pytest.approx([4e-8, 4.4e-8, 3.6e-8], rel=1e-15)
    assert res.s_per_step == pytest.approx(3.6e-8, rel=1e-15) and res.clock == "injected"
    assert "injected from $HARNESS_INJECT_TIMINGS, not measured" in res.timing
    assert res.ratio_to_explicit_euler == pytest.approx(4.0, rel=1e-15) and res.ratio_spread == 0.0
    assert res.calibration == pytest.approx(12.0, rel=1e-15)
    assert res.calibration_spread == pytest.approx(1.1 / 0.9 - 1.0, rel=1e-12)
    path.write_text("{}")
    with pytest.raises(InvalidInput, match=r"^HARNESS_INJECT_TIMINGS=.*not an injected-timings file"):
        cost.cost_per_step("ref:rk4", spring, 0.01, time_steps=20_000, repeats=3)


def test_a_slow_compiled_loop_is_timed_over_fewer_steps(spring, monkeypatch):
    # Past the budget a repeat runs fewer steps, never under REF_MIN_STEPS, and the explicit-Euler
    # baseline timed beside it runs the same loop length. (A clock read to 1e-12 s: the policy's
    # budget is the one in effect.)
    monkeypatch.setattr(cost, "clock_resolution", lambda clock: 1e-12)
    monkeypatch.setattr(cost, "REF_RUN_BUDGET_S", 1e-9)
    res = cost.cost_per_step("ref:rk4", spring, 0.01, repeats=2)
    assert res.time_steps == cost.REF_MIN_STEPS == res.baseline["time_steps"]
    monkeypatch.setattr(cost, "REF_RUN_BUDGET_S", 10.0)
    res = cost.cost_per_step("ref:rk4", spring, 0.01, repeats=1)
    assert res.time_steps == cost.REF_TIME_STEPS == res.baseline["time_steps"]


def test_the_run_budget_is_the_policy_unless_the_clocks_measured_resolution_needs_longer(spring, monkeypatch):
    """Issue 52: the budget is a policy (REF_RUN_BUDGET_S), lengthened to the run whose share the
    clock's measured resolution is at most MAX_CLOCK_SHARE; the resolution is recorded."""
    for clock in ("wall", "cpu"):
        r = cost.clock_resolution(clock)
        assert 0 < r < cost.REF_RUN_BUDGET_S * cost.MAX_CLOCK_SHARE  # a clock read to the microsecond or finer
        assert cost.run_budget(cost.REF_RUN_BUDGET_S, clock) == cost.REF_RUN_BUDGET_S
    with pytest.raises(InvalidInput, match=r"^clock 'sundial' is not one of \['cpu', 'wall'\]$"):
        cost.clock_resolution("sundial")
    # A coarse clock (a tick of 1e-3 s) needs runs of 1 s: a tiny policy budget no longer cuts the loop.
    monkeypatch.setattr(cost, "clock_resolution", lambda clock: 1e-3)
    assert cost.run_budget(1e-9, "wall") == pytest.approx(1e-3 / cost.MAX_CLOCK_SHARE)
    monkeypatch.setattr(cost, "REF_RUN_BUDGET_S", 1e-9)
    res = cost.cost_per_step("ref:rk4", spring, 0.01, repeats=1)
    assert res.time_steps == cost.REF_TIME_STEPS and res.clock_resolution_s == 1e-3
    assert res.baseline["clock_resolution_s"] == 1e-3


def test_the_measured_clock_resolution_is_recorded_and_not_with_injected_timings(spring, tmp_path, monkeypatch):
    res = cost.cost_per_step("ref:rk4", spring, 0.01, time_steps=20_000, repeats=1, clock="cpu")
    assert res.clock_resolution_s == cost.clock_resolution("cpu") > 0
    path = tmp_path / "timings.json"
    path.write_text(json.dumps({"s_per_step": {"*": 4e-8}}))
    monkeypatch.setenv("HARNESS_INJECT_TIMINGS", str(path))
    assert cost.cost_per_step("ref:rk4", spring, 0.01, time_steps=20_000, repeats=1).clock_resolution_s is None


def test_cost_through_the_engine_interface(spring):
    method = Delegate("semi_implicit_euler")
    res = cost.counted_evaluations(method, spring, 0.01)
    assert res["force_evals_per_step"] is None and "counts nothing" in res["force_evals_reason"]
    timing = cost.wall_time_per_step(method, spring, 0.01, steps=200, repeats=2)
    assert "in-process simulate" in timing["timing"] and timing["s_per_step"] > 0
    # A plugin's simulate has no per-step path to time beside it: one figure.
    assert cost.cost_per_step(method, spring, 0.01, time_steps=200, repeats=1).as_stepped is None


# ------------------------------------------------------------------------------ error
class PendulumWithoutClosedForm(Pendulum):
    id = "pendulum_without_closed_form"

    def closed_form(self, t):
        return None


def test_reference_solve_matches_the_closed_forms():
    # The order rule trusts a reference solve down to REFERENCE_FLOOR: check it against the
    # closed forms it stands in for, in the error's own norm.
    for scene_id in ("pendulum", "kepler", "damped_spring"):
        scene = make_scene(scene_id)
        t = np.linspace(0.0, scene.period, 201)
        q, v = error.reference_solution(scene, t)
        qe, ve = scene.closed_form(t)
        y, ye = np.hstack([q, v / scene.omega]), np.hstack([qe, ve / scene.omega])
        assert np.max(np.linalg.norm(y - ye, axis=1)) / np.max(np.linalg.norm(ye, axis=1)) < error.REFERENCE_FLOOR


def test_reference_solve_is_cached(monkeypatch):
    scene = make_scene("pendulum", theta0=1.0)
    t = np.linspace(0.0, 1.0, 11)
    first = error.reference_solution(scene, t)
    import scipy.integrate

    monkeypatch.setattr(scipy.integrate, "solve_ivp", lambda *a, **k: pytest.fail("solved twice"))
    again = error.reference_solution(scene, t)
    assert np.array_equal(first[0], again[0]) and np.array_equal(first[1], again[1])


def test_order_against_a_reference_solve():
    scene = PendulumWithoutClosedForm()
    res = error.global_error("ref:leapfrog", scene, 0.01, 100)
    assert res["source"].startswith("reference DOP853")
    assert order.observed_order("ref:leapfrog", scene)["order"] == pytest.approx(2, abs=ORDER_TOL)


# ----------------------------------------------------------------------- workprecision
def test_work_precision_rows(spring):
    rows = workprecision.work_precision(
        ["ref:explicit_euler", Delegate("leapfrog")], spring, points=3, periods=1.0, repeats=1, time_steps=500
    )
    assert len(rows) == 6 and len(frame(rows)) == 6
    for r in rows:
        assert r["status"] == "ok" and r["error"] > 0 and r["s_per_unit_time"] > 0
    assert rows[0]["evals_per_unit_time"] == pytest.approx(1.0 / rows[0]["dt"])
    assert rows[3]["evals_per_unit_time"] is None  # the delegate counts nothing
    chart = workprecision.chart_ready(rows)
    assert set(chart) == {"ref:explicit_euler", "test:leapfrog"}
    assert chart["test:leapfrog"]["s_per_unit_time"] == sorted(chart["test:leapfrog"]["s_per_unit_time"])


# -------------------------------------------------------------------------------- CLI
def run_cli(*argv):
    # Plain StringIO redirection, not capsys's streams: a module imported during the call
    # may keep a reference to sys.stderr, and capsys closes its stream after the test.
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        rc = main(list(argv))
    return rc, out.getvalue(), err.getvalue()


def test_cli_order_json():
    rc, out, _ = run_cli("order", "spring", "--method", "ref:leapfrog", "--json")
    res = json.loads(out)
    assert rc == 0 and res["order"] == pytest.approx(2, abs=ORDER_TOL)
    assert all({"dt", "error"} <= set(p) for p in res["points"]) and isinstance(res["excluded"], list)


def test_cli_stability_json():
    rc, out, _ = run_cli("stability", "spring", "--method", "ref:rk4", "--set", "k=4", "--json")
    res = json.loads(out)
    assert rc == 0 and res["criterion"] == "spectral_radius" and res["verdict"] == "limited"
    # k = 4 doubles omega: the same h*omega limit at half the dt.
    assert res["omega_dt_max"] == pytest.approx(2 * math.sqrt(2), rel=STABILITY_RTOL)
    assert res["dt_max"] == pytest.approx(res["omega_dt_max"] / 2)
    eig = res["spectral"]["eigenvalues"]
    assert len(eig) == 2 and set(eig[0]) == {"re", "im"} and res["spectral"]["rho"] <= 1 + stability.RHO_TOL


def test_cli_energy_json():
    rc, out, _ = run_cli(
        "energy", "spring", "--method", "ref:leapfrog", "--dt", "0.1", "--steps", "2000", "--series", "--json"
    )
    res = json.loads(out)
    assert rc == 0 and res["classification"] == "bounded"
    assert len(res["rel_error"]) == len(res["t"]) == 2001
    assert res["max_rel_error"] == pytest.approx(max(abs(x) for x in res["rel_error"]))


def test_cli_cost_and_workprecision_json():
    rc, out, _ = run_cli(
        "cost",
        "spring",
        "--method",
        "ref:explicit_euler",
        "--dt",
        "0.01",
        "--time-steps",
        "1000",
        "--repeats",
        "2",
        "--json",
    )
    res = json.loads(out)
    assert rc == 0 and res["force_evals_per_step"] == 1.0 and len(res["repeats_s_per_step"]) == 2
    assert res["ratio_to_explicit_euler"] > 0
    rc, out, _ = run_cli(
        "workprecision",
        "spring",
        "--method",
        "ref:explicit_euler",
        "--points",
        "2",
        "--periods",
        "1",
        "--repeats",
        "1",
        "--json",
    )
    res = json.loads(out)
    assert rc == 0 and len(res["rows"]) == 2 and set(res["chart"]) == {"ref:explicit_euler"}


def test_cli_cost_on_a_scene_explicit_euler_cannot_pose_says_why_there_is_no_ratio(monkeypatch):
    """The rope is held by constraints: no explicit-Euler run to divide by. The text says why
    (it raised KeyError on the missing baseline figure before)."""
    monkeypatch.setenv("HARNESS_PROGRESS_AFTER", "inf")  # stderr is read whole: no progress lines (a cold compile)
    rc, out, err = run_cli(
        "cost",
        "rope",
        "--method",
        "ref:verlet_constrained",
        "--set",
        "N=3",
        "--dt",
        "0.001",
        "--time-steps",
        "200",
        "--repeats",
        "1",
    )
    assert rc == 0 and not err.strip(), err
    assert "no ratio to ref:explicit_euler: scene rope is held together by constraints" in out


def test_cli_text_output():
    rc, out, _ = run_cli("stability", "spring", "--method", "ref:explicit_euler")
    assert rc == 0 and "unstable for every dt" in out


@pytest.mark.parametrize(
    "argv, field",
    [
        (["energy", "spring", "--method", "ref:rk4", "--dt", "-1", "--steps", "10"], "--dt"),
        (["energy", "spring", "--method", "ref:rk4", "--dt", "abc", "--steps", "10"], "--dt"),
        (["energy", "spring", "--method", "ref:rk4", "--dt", "0.1", "--steps", "0"], "--steps"),
        (["energy", "spring", "--method", "ref:rk4", "--dt", "0.1", "--steps", "1.5"], "--steps"),
        (["energy", "spring", "--method", "ref:rk4", "--dt", "0.1", "--steps", "10", "--every", "0"], "--every"),
        (["energy", "nowhere", "--method", "ref:rk4", "--dt", "0.1", "--steps", "10"], "scene"),
        (["energy", "spring", "--method", "nope:x", "--dt", "0.1", "--steps", "10"], "method"),
        (["energy", "spring", "--method", "ref:rk4", "--dt", "0.1", "--steps", "10", "--set", "k=-1"], "k="),
        (["energy", "spring", "--method", "ref:rk4", "--dt", "0.1", "--steps", "10", "--set", "q=1"], "'q'"),
        (["order", "spring", "--method", "ref:rk4", "--points", "3"], "--points"),
        (["order", "spring", "--method", "ref:rk4", "--span", "1"], "--span"),
        (["order", "spring", "--method", "ref:rk4", "--periods", "0"], "--periods"),
        (["order", "spring", "--method", "ref:rk4", "--order-hint", "0"], "--order-hint"),
        (["order", "spring", "--method", "ref:rk4", "--dt", "0.1", "--dt", "0.2"], "--dt"),
        (["stability", "spring", "--method", "ref:rk4", "--criterion", "eyeball"], "--criterion"),
        (["stability", "spring", "--method", "ref:rk4", "--steps", "0"], "--steps"),
        (["stability", "spring", "--method", "ref:rk4", "--lo", "0"], "--lo"),
        (["stability", "spring", "--method", "ref:rk4", "--lo", "1", "--hi", "0.5"], "--hi"),
        (["stability", "spring", "--method", "ref:rk4", "--timeout", "-5"], "--timeout"),
        (["cost", "spring", "--method", "ref:rk4", "--dt", "nan"], "--dt"),
        (["cost", "spring", "--method", "ref:rk4", "--dt", "0.1", "--repeats", "0"], "--repeats"),
        (["cost", "spring", "--method", "ref:implicit_euler", "--dt", "0.1", "--set", "m=0"], "m="),
        (["workprecision", "spring", "--points", "0"], "--points"),
        (["workprecision", "spring", "--homega-max", "inf"], "--homega-max"),
        (["workprecision", "spring", "--method", "ref:nope"], "method"),
        # IAS15 takes dt as its output interval: refused before it is stepped (its stability scan on
        # kepler ran for over 5 minutes before this check).
        (["order", "kepler", "--method", "rebound:ias15"], "rebound:ias15 chooses its own steps"),
        (["stability", "kepler", "--method", "rebound:ias15"], "rebound:ias15 chooses its own steps"),
    ],
)
def test_cli_bad_input_exits_2_with_one_line(argv, field):
    rc, out, err = run_cli(*argv)
    assert rc == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("harness: error:") and field in err


def test_cli_missing_argument_exits_2():
    err = io.StringIO()
    with redirect_stderr(err), pytest.raises(SystemExit) as exc:
        main(["cost", "spring", "--method", "ref:rk4"])
    assert exc.value.code == 2
    assert err.getvalue().count("\n") == 1 and "--dt" in err.getvalue()


class RoundingDelegate(Delegate):
    """A delegate whose states come back rounded, as a float32 engine's (Newton's) do, here to
    half precision so that no step size hides it: its one-step map is not affine to the check's
    tolerance."""

    def simulate(self, scene, dt, steps, every=1):
        traj = super().simulate(scene, dt, steps, every)
        with np.errstate(over="ignore"):  # a run that blows up rounds to inf, as it would overflow
            traj.q = traj.q.astype(np.float16).astype(float)
            traj.v = traj.v.astype(np.float16).astype(float)
        return traj


def test_a_map_that_cannot_be_measured_is_said_in_the_commands_lines_not_a_traceback(spring):
    """A rounding method on a linear scene (a float32 engine): the spectral radius does not apply, the finite horizon
    judges, and the one-step map attached at the limit says why it has no eigenvalues (the
    command's lines read them, and raised a KeyError for Newton's modes)."""
    from harness.cli.stability import _lines

    res = stability.largest_stable_dt(RoundingDelegate("semi_implicit_euler"), spring, steps=200, lo=0.3, hi=4.0)
    assert res.criterion == "finite_horizon" and res.verdict == "limited"
    assert res.spectral["rho"] is None and res.spectral["reason"]
    lines = list(_lines(res))
    assert lines[-1].startswith("  one-step map at dt ") and "not measured (" in lines[-1]
