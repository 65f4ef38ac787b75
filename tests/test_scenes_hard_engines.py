"""The chain and the rope on the engines (issue 6): which scheme each engine mode integrates on
the chain, the stability limits and the damping far beyond them, the rope's constraint drift
and energy change against ref:verlet_constrained, and the nightly cells and findings that
carry them. Every tolerance says where it comes from; measured with mujoco 4.0.0, pybullet
3.2.7, pymunk 7.3.1.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import adapters
import reference
from harness.measures import damping
from harness.measures import stability
from harness.measures.common import started_at
from harness.measures.constraint import constraint_drift
from harness.methods import get_method
from scenarios import make_scene


def engine(method_id, scene, dt, steps, every=1):
    """Stepped in this process: the numbers are the adapter's (test_adapters checks that the
    worker process only wraps them)."""
    return adapters.ENGINE_METHODS[method_id].simulate(scene, dt, steps, every)


def ref(scheme_id, scene, dt, steps, every=1, **kw):
    return reference.integrate(reference.METHODS[scheme_id], scene, dt, steps, every, **kw)


def relative_deviation(a, b) -> float:
    """max |difference| in (q, v) over every step, relative to the largest |q|, |v| seen; the
    two runs must end the same way at the same step."""
    assert (a.status, a.failed_step) == (b.status, b.failed_step), (a.detail, b.detail)
    np.testing.assert_array_equal(a.step, b.step)
    scale = max(1.0, float(np.max(np.abs(b.q))), float(np.max(np.abs(b.v))))
    return float(max(np.max(np.abs(a.q - b.q)), np.max(np.abs(a.v - b.v)))) / scale


@pytest.fixture(scope="module")
def chain():
    return make_scene("chain")  # N = 32, k = 1e4, m = 1: omega_max = 199.9


# ------------------------------------------------------------------ chain: identities
#: (mode, the scheme it integrates, tolerance relative to the state's size). 0: bitwise (the
#: force is the scene's, summed in the scene's order, and the update the scheme's). 1e-13:
#: MuJoCo sums the springs through tendons and joints in its own order: measured 2.5e-15
#: (Euler family) and 3.2e-15 (RK4) in this test. 1e-11: Chipmunk's DampedSprings act
#: between bodies spaced 10 apart, up to 330 from the origin, so each position carries
#: 330 eps of roundoff: measured 6.7e-13.
CHAIN_IDENTITIES = [
    ("mujoco:euler", "semi_implicit_euler", 1e-13),
    ("mujoco:implicit", "semi_implicit_euler", 1e-13),
    ("mujoco:implicitfast", "semi_implicit_euler", 1e-13),
    ("mujoco:rk4", "rk4", 1e-13),
    ("pybullet:semi_implicit", "semi_implicit_euler", 0.0),
    ("pymunk:spring_force", "semi_implicit_euler_position_first", 0.0),
    ("pymunk:applied_force", "explicit_euler", 0.0),
    ("pymunk:damped_spring", "semi_implicit_euler_position_first", 1e-11),
]


@pytest.mark.parametrize("method_id, scheme_id, tol", CHAIN_IDENTITIES, ids=[m for m, _, _ in CHAIN_IDENTITIES])
@pytest.mark.filterwarnings("ignore:overflow encountered")  # the scheme's energy of a blown-up state
def test_chain_engine_mode_is_the_reference_scheme(chain, method_id, scheme_id, tol):
    # h w_max = 1.5: below every limit but explicit Euler's (which has none: it blows up at
    # the same step in both); 500 steps, 8 periods of the highest mode.
    dt = 1.5 / chain.omega
    dev = relative_deviation(engine(method_id, chain, dt, 500), ref(scheme_id, chain, dt, 500))
    assert dev <= tol if tol else dev == 0.0


def generic(scene, seed=0):
    """The scene started from a generic state: every spring stretched (no q_i equal)."""
    y = damping.generic_state(scene, seed)
    return started_at(scene, y[: scene.ndof], y[scene.ndof :])


def test_mujoco_discrete_is_backward_euler_only_where_every_tendon_is_stretched(chain, monkeypatch):
    dt = 1.0 / chain.omega
    # From a generic state: backward Euler. Measured 5.2e-15 of the state over 1000 steps (its
    # iterative solve at opt.tolerance 1e-14); 1e-12 is roundoff with margin.
    moved = generic(chain)
    assert (
        relative_deviation(engine("mujoco:discrete", moved, dt, 1000), ref("implicit_euler", moved, dt, 1000)) <= 1e-12
    )
    # From the scene's state every spring but the two beside the displaced mass sits exactly at
    # its rest length, and MuJoCo leaves those tendons out of the implicit step: far from
    # backward Euler (measured 7.4e-2 of the state) after the first step alone...
    first = relative_deviation(engine("mujoco:discrete", chain, dt, 1), ref("implicit_euler", chain, dt, 1))
    assert first > 1e-3
    # ... and that is the cause: moved off their rest length by 1e-300, the same step is
    # backward Euler's to roundoff (measured 4.2e-15; 1e-13 is roundoff of the solve with margin).
    q0, v0 = chain.initial_state()
    nudged = started_at(chain, q0 + 1e-300 * np.arange(chain.ndof), v0)
    assert relative_deviation(engine("mujoco:discrete", nudged, dt, 1), ref("implicit_euler", nudged, dt, 1)) <= 1e-13
    # The adapter's tolerance matters: at MuJoCo's default (1e-8) the same generic run is off
    # by 1e-8 of the state (measured 2.6e-8 at h w = 0.1), four decades above 1e-12.
    assert adapters.ENGINE_METHODS["mujoco:discrete"].simulate(chain, dt, 1, 1).meta.settings["tolerance"] == 1e-14
    monkeypatch.setitem(
        adapters.mujoco.POSES, "chain", dataclasses.replace(adapters.mujoco.POSES["chain"], tolerance=1e-8)
    )
    loose = relative_deviation(
        engine("mujoco:discrete", moved, 0.1 / chain.omega, 1000), ref("implicit_euler", moved, 0.1 / chain.omega, 1000)
    )
    assert loose > 1e-9


# ------------------------------------------------------------------ chain: stability
#: Theory on the stiffest mode (y = h w_max): semi-implicit Euler (either order) has a double
#: root crossing -1 at y = 2; RK4 |R(iy)| = 1 at y = 2 sqrt(2); explicit Euler sqrt(1 + y^2).
ENGINE_LIMITS = {
    "mujoco:euler": 2.0,
    "mujoco:implicit": 2.0,
    "mujoco:implicitfast": 2.0,
    "pybullet:semi_implicit": 2.0,
    "pymunk:spring_force": 2.0,
    "pymunk:damped_spring": 2.0,
    "mujoco:rk4": 2.0 * math.sqrt(2.0),
}


@pytest.mark.parametrize("method_id", list(ENGINE_LIMITS))
@pytest.mark.filterwarnings("ignore:overflow encountered")
def test_chain_engine_limit_and_blow_up(chain, method_id):
    """The one-step map (measured through a worker, 2N + 2 states on one model) has spectral
    radius 1 just below the limit and the mode theory's growth just above; a run just above
    blows up."""
    limit = ENGINE_LIMITS[method_id]
    method = get_method(method_id)
    below = stability.one_step_map(method, chain, 0.99 * limit / chain.omega)
    above = stability.one_step_map(method, chain, 1.01 * limit / chain.omega)
    # Roundoff in the 64 x 64 map's eigenvalues: measured |rho - 1| <= 4e-15 (test_scenes_hard).
    assert below["rho"] <= 1.0 + stability.RHO_TOL
    y = 1.01 * limit
    if limit == 2.0:
        half_trace = 1.0 - 0.5 * y * y
        growth = abs(half_trace) + math.sqrt(half_trace * half_trace - 1.0)
    else:
        growth = math.sqrt(1.0 - y**6 / 72.0 + y**8 / 576.0)
    assert above["rho"] == pytest.approx(growth, abs=1e-10)  # 1.327 (limit 2) and 1.073 (RK4)
    # A run just above: the highest mode grows by rho a step until the state passes 1e100
    # (1e10 for MuJoCo, which warns there): a few hundred to a few thousand steps.
    run = engine(method_id, chain, 1.01 * limit / chain.omega, 4000, every=4000)
    assert run.status == "unstable"


def test_chain_largest_stable_dt_through_the_harness():
    """End to end on a small chain: the bisection on the measured map finds h w_max = 2 for
    MuJoCo's Euler. The discrete integrator is stable at every h searched, but its map from
    rest is not affine (the tendon rule above): at h*omega = 1e4 the probe misses the affine
    fit by 2% (measured 0.0187), and the verdict carries that note."""
    small = make_scene("chain", N=4)
    res = stability.largest_stable_dt(get_method("mujoco:euler"), small)
    assert res.criterion == "spectral_radius" and res.verdict == "limited"
    assert res.omega_dt_max == pytest.approx(2.0, rel=2 * stability.BISECT_RTOL)
    res = stability.largest_stable_dt(get_method("mujoco:discrete"), small)
    assert res.verdict == "unbounded" and "not affine" in res.note


# ------------------------------------------------------------------ chain: damping at 100x
def test_damping_far_beyond_the_limit(chain):
    """At 100x the explicit limit (h w_max = 200): backward Euler and MuJoCo's discrete step keep
    each mode's energy by 1/(1 + (h w_j)^2) a step; every explicit engine mode grows."""
    y = 200.0
    be = damping.damping_far_beyond_the_limit("ref:implicit_euler", chain)
    disc = damping.damping_far_beyond_the_limit("mujoco:discrete", chain)
    for res in (be, disc):
        assert res["stable"] and res["omega_dt"] == pytest.approx(y, rel=1e-15)
        # The modal transform separates the modes to roundoff: measured 1e-11 of the largest
        # entry (the map's entries reach (h w)^2 = 4e4 before the solve divides them back).
        assert res["modal_leak"] <= 1e-9
        hi = res["highest"]
        # Theory |lambda| = 1/sqrt(1 + y^2) = 5.0e-3; the map is measured through an O(N) solve
        # of condition ~4e4: measured 1e-11 relative (ref) and 1e-8 (MuJoCo's iterative solve).
        assert hi["rho"] == pytest.approx(1.0 / math.sqrt(1.0 + y * y), rel=1e-7)
        # zeta = ln(1 + y^2) / sqrt(ln^2(1 + y^2) + 4 atan^2 y) = 0.95900 for the highest mode.
        assert hi["zeta"] == pytest.approx(
            math.log(1 + y * y) / math.hypot(math.log(1 + y * y), 2 * math.atan(y)), rel=1e-6
        )
        w1 = chain.mode_frequencies()[0] * res["dt"]
        assert res["lowest"]["energy_factor"] == pytest.approx(1.0 / (1.0 + w1 * w1), rel=1e-7)
    # Energy kept after one step from the scene's state: backward Euler 4.985e-5 (each mode by
    # its factor, test_scenes_hard); MuJoCo 0.111 (measured), its first step leaving 29 of the
    # 31 tendons explicit. Both runs are deterministic; 1e-3 allows for the last digits.
    assert be["energy_kept_one_step"] == pytest.approx(4.985e-5, rel=1e-3)
    assert disc["energy_kept_one_step"] == pytest.approx(0.1111, rel=1e-3)
    # The explicit engine modes there: their theory growth per step on the stiffest mode.
    sie = (y * y - 2.0 + math.sqrt((y * y - 2.0) ** 2 - 4.0)) / 2.0  # 39998.0
    for method_id, growth in (
        ("mujoco:euler", sie),
        ("pybullet:semi_implicit", sie),
        ("pymunk:spring_force", sie),
        ("pymunk:applied_force", math.sqrt(1 + y * y)),
    ):
        res = damping.damping_far_beyond_the_limit(method_id, chain)
        assert res["stable"] is False and res["rho"] == pytest.approx(growth, rel=1e-9)


# ------------------------------------------------------------------ rope
@pytest.fixture(scope="module")
def rope():
    return make_scene("rope")  # N = 10 links of 0.1 m, 0.1 kg each


def test_mujoco_hinge_chain_is_the_rope(rope):
    """Same geometry and masses: MuJoCo's RK4 at dt = 1e-4 follows the reduced-coordinate
    reference (DOP853, 5e-13) to 1.3e-9 in position over 2 s (measured; RK4's own error at
    this dt); 1e-8 leaves margin and is far below any modelling difference (a link 1% longer
    moves the free end by 1e-3)."""
    run = engine("mujoco:rk4", rope, 1e-4, 20_000, every=1000)
    q_ref, v_ref = rope.reference_solution(run.t)
    assert np.max(np.abs(run.q[:, 0] - q_ref)) <= 1e-8
    assert np.max(np.abs(run.v[:, 0] - v_ref)) <= 1e-7  # measured 1.6e-8
    # No spring, no damping: nothing for implicitfast or discrete to treat implicitly, so they
    # are Euler, bitwise (the standard suite runs only mujoco:euler of the three on the rope).
    euler = engine("mujoco:euler", rope, 1e-3, 1000)
    for mode in ("implicitfast", "discrete"):
        other = engine(f"mujoco:{mode}", rope, 1e-3, 1000)
        assert np.array_equal(other.q, euler.q) and np.array_equal(other.v, euler.v)


#: Over 1 s at dt = 1e-3 from the horizontal release (the first whip included), measured:
#: (largest relative stretch, energy change at the end). MuJoCo's hinges keep every link at
#: length l to roundoff (10 links: a few eps); pymunk's pin joints let them stretch 3.7% and
#: bleed 1.2% of the energy through their error correction; ref:verlet_constrained at K
#: projection passes stretches less (1/K-like) but loses 5.8% (first order: its projection
#: acts along the predicted links). Deterministic runs: 1% relative on the measured numbers
#: allows for libm differences in the last digits, which the chaotic rope amplifies about
#: 1000-fold a second (from 1e-16).
ROPE = {
    ("mujoco:euler", None): (None, +0.02835),
    ("mujoco:implicit", None): (None, -0.02680),
    ("pymunk:pin_joint", None): (3.705e-2, -0.01243),
    ("ref:verlet_constrained", 1): (3.536e-3, -0.05850),
    ("ref:verlet_constrained", 4): (8.219e-4, -0.05822),
    ("ref:verlet_constrained", 16): (1.864e-4, -0.05823),
}


def test_rope_constraint_drift_and_energy_change(rope):
    got = {}
    for (method_id, passes), (stretch, energy) in ROPE.items():
        method = get_method(method_id, {"iterations": passes} if passes else None)
        res = constraint_drift(method, rope, 1e-3, 1000, every=10)
        assert res["status"] == "ok"
        got[(method_id, passes)] = res
        if stretch is None:
            assert res["max_stretch"] <= 1e-14  # reduced coordinates: measured 1.8e-15
        else:
            assert res["max_stretch"] == pytest.approx(stretch, rel=0.01)
        assert res["energy_change"] == pytest.approx(energy, rel=0.01)
    # The comparison the issue asks for: pymunk's impulses hold the links 10x (K = 1) to 200x
    # (K = 16) worse than the position projection, but lose a fifth of its energy.
    pin = got[("pymunk:pin_joint", None)]
    for k in (1, 4, 16):
        assert pin["max_stretch"] > 10 * got[("ref:verlet_constrained", k)]["max_stretch"]
        assert abs(pin["energy_change"]) < abs(got[("ref:verlet_constrained", k)]["energy_change"]) / 4


# ------------------------------------------------------------------ the nightly's cells
@pytest.fixture
def tiny_suite(monkeypatch):
    """A suite of a 4-mass chain and a 3-link rope, run in this process (engines too)."""
    from harness.execution import isolation
    from harness.nightly.suites import SUITES, SceneExtras, SceneSpec, Suite

    suite = Suite(
        "tiny",
        scenes={
            "chain": SceneSpec(
                params={"N": 4},
                periods=10,
                order_points=6,
                order_span=4.0,
                extras=SceneExtras(
                    damping_factor=100.0,
                    scaling={"sizes": ({"N": 10}, {"N": 100}), "repeats": 1, "work_per_call": 20_000},
                ),
            ),
            "rope": SceneSpec(
                params={"N": 3},
                periods=5,
                order_points=6,
                order_span=4.0,
                stability=False,
                extras=SceneExtras(constraint_iterations=(1, 4)),
            ),
        },
        cost_repeats=1,
        cost_steps=500,
        series_points=100,
        stability_steps=200,
        bounds=False,
    )
    monkeypatch.setitem(SUITES, "tiny", suite)
    monkeypatch.setattr(isolation, "IN_WORKER", True)
    return suite


def test_nightly_cells_of_the_chain_and_the_rope(tiny_suite, tmp_path):
    """Engine tasks run whole; the reference schemes' own scene cells run alone (their cost
    cells would each compile a (scheme, scene) pair, which the cost tests already cover; the
    scaling cell reuses the implicit-Euler chain pair test_scenes_hard compiles)."""
    from harness.nightly.cells import measures_for, run_task
    from harness.nightly.run import Task, build_tasks
    from harness.nightly.measures.scene_cells import scene_cells
    from harness.history.storage import History
    from harness.judge import judge
    from reports.markdown import render

    tasks, skipped = build_tasks(tiny_suite)
    pairs = {(t.scene, t.method) for t in tasks}
    assert ("rope", "ref:verlet_constrained") in pairs and ("rope", "ref:leapfrog") not in pairs
    assert ("chain", "pymunk:damped_spring") in pairs and ("chain", "pymunk:pin_joint") not in pairs
    reasons = {(s["scene"], s["method"]): s["reason"] for s in skipped}
    assert "fall freely" in reasons[("rope", "ref:leapfrog")] and "pin joints" in reasons[("chain", "pymunk:pin_joint")]

    history = History(tmp_path / "h.sqlite")
    run_id = history.start_run(started="now", suite="tiny", git_commit=None, versions={}, machine={}, settings={})
    for task in (
        Task("cell", "chain", "mujoco:discrete", "mujoco", {"N": 4}, "tiny"),
        Task("cell", "rope", "pymunk:pin_joint", "pymunk", {"N": 3}, "tiny"),
    ):
        cells = run_task(task)
        assert [c.measure for c in cells] == [
            m
            for m in ["identity", "energy", "error", "order", "cost", "stability", "constraint", "damping"]
            if m in measures_for(task)
        ]
        assert all(c.status == "ok" for c in cells), [(c.measure, c.detail) for c in cells]
        for c in cells:
            history.add_cell(run_id, c)
    for task in (
        Task("cell", "chain", "ref:implicit_euler", "ref", {"N": 4}, "tiny"),
        Task("cell", "rope", "ref:verlet_constrained", "ref", {"N": 3}, "tiny"),
    ):
        scene, method, spec = (
            make_scene(task.scene, **task.params),
            get_method(task.method),
            tiny_suite.scenes[task.scene],
        )
        cells = scene_cells(task, method, scene, spec.homega / scene.omega, spec, tiny_suite)
        assert [c.measure for c in cells] == (
            ["constraint", "damping", "scaling"] if task.scene == "chain" else ["constraint"]
        )
        assert all(c.status == "ok" for c in cells), [(c.measure, c.detail) for c in cells]
        for c in cells:
            history.add_cell(run_id, c)
    by = {(r.method, r.measure): r for _, r in history.cells(run_id).iterrows()}
    assert "identity" not in measures_for(Task("cell", "rope", "pymunk:pin_joint", "pymunk", {"N": 3}, "tiny"))
    # The scaling cell's slope is read off the clock: its sign and size are the slow scaling study's
    # to judge (a busy machine can flatten four timings of a tiny chain); here it is measured, and finite.
    assert by[("mujoco:discrete", "damping")].data["stable"] and math.isfinite(
        by[("ref:implicit_euler", "scaling")].value
    )
    # The rope's error is measured against its reduced-coordinate reference, within its horizon.
    assert by[("pymunk:pin_joint", "error")].data["source"] == "rope reference_solution"
    assert [b["iterations"] for b in by[("ref:verlet_constrained", "constraint")].data["by_iterations"]] == [1, 4]
    assert by[("mujoco:discrete", "stability")].data["unbounded"]

    cells = history.cell_records(run_id)
    text, _ = render(history.run(run_id), cells, judge(cells), tmp_path / "out", {})
    findings = text.split("## Findings")[1]
    assert "`ref:implicit_euler` on `chain` at 100x the explicit limit (h·ω_max = 200)" in findings
    assert "`mujoco:discrete` on `chain` is `ref:implicit_euler` only from a generic state" in findings
    assert "cost per step grows as N^" in findings
    assert (
        "`pymunk:pin_joint`:" in findings and "`ref:verlet_constrained` on `rope` against projection passes" in findings
    )


# ----------------------------------------------------------------------------- the rope's limits
@pytest.mark.slow
def test_mujoco_implicit_blows_up_on_the_rope_where_its_companions_run_on():
    """At the standard suite's nominal timestep (h*omega = 0.1, N = 5), MuJoCo's implicit mode
    gains energy and blows up at step 2434, past the 1,257-step energy run; euler, implicitfast
    (implicit less the Coriolis and centripetal derivatives) and rk4, on the same model, run on.
    The rope's stability search runs 10,000 steps, so it sees it: the limit lies below the
    nominal timestep."""
    from harness.execution.simulate import simulate
    from harness.measures.stability import largest_stable_dt
    from harness.nightly.suites import SUITES

    spec = SUITES["standard"].scenes["rope"]
    assert spec.stability and spec.stability_steps == 10_000 and "mujoco:implicitfast" not in spec.skip
    scene = make_scene("rope", **spec.params)
    dt = spec.homega / scene.omega
    implicit = simulate(get_method("mujoco:implicit"), scene, dt, 10_000, 100)
    assert implicit.status == "unstable" and implicit.failed_step == 2434
    for mode in ("mujoco:euler", "mujoco:implicitfast", "mujoco:rk4"):
        assert simulate(get_method(mode), scene, dt, 10_000, 100).status == "ok", mode
    limit = largest_stable_dt(get_method("mujoco:implicit"), scene, steps=spec.stability_steps).omega_dt_max
    assert limit == pytest.approx(0.0342, rel=1e-2)


def _stability_cell(method, failed=None, energy=(1.47, 1.4, 1.3)):
    from records.cell import Cell

    nominal = {
        "dt": 0.00284,
        "homega": 0.1,
        "steps": 10000,
        "status": "unstable" if failed else "ok",
        "failed_step": failed,
        "detail": "diverged" if failed else "",
        "series": {"t": [0.0, 3.0, 6.9 if failed else 28.0], "energy": list(energy), "e0": 1.47},
    }
    return Cell.from_row(
        {
            "scene": "rope",
            "method": method,
            "family": method.split(":")[0],
            "measure": "stability",
            "dt": None,
            "steps": None,
            "status": "ok",
            "value": 0.0342 if failed else 0.19,
            "data": {"criterion": "finite_horizon", "verdict": "limited", "nominal": nominal},
        }
    )


def test_a_blow_up_at_the_nominal_timestep_is_a_finding_with_its_companions():
    from harness.engine_findings import blowups_at_nominal
    from records.cell import pivot

    cells = [
        _stability_cell("mujoco:implicit", failed=2434, energy=(1.47, 2.9, 105.0)),
        _stability_cell("mujoco:implicitfast"),
        _stability_cell("pymunk:pin_joint"),
    ]
    (finding,) = blowups_at_nominal(pivot(cells))
    text = finding.text
    assert text.startswith(
        "`mujoco:implicit` on `rope` blows up at the nominal h·ω = 0.1 (dt = 0.00284) at "
        "step 2434 of 10000, its energy 1.47 -> 105 before it"
    )
    assert "`mujoco:implicitfast` runs on, energy 1.38 (started at 1.47)" in text and "pymunk" not in text
    assert "Cause: the mode's integrator, not the scene's model" in text and "h·ω <= 0.0342" in text
    everyone = [_stability_cell("mujoco:implicit", failed=2434), _stability_cell("mujoco:euler", failed=100)]
    texts = [f.text for f in blowups_at_nominal(pivot(everyone))]
    assert any("Cause: the scene's model at this timestep" in t for t in texts)


def test_the_findings_show_the_blow_up_chart_beside_every_other_chart_name():
    from reports.markdown import findings

    names = {
        "damping": "charts/run1-damping-stability.png",
        ("rope", "nominal"): "charts/run1-rope-nominal.png",
        ("rope", "energy"): "charts/run1-rope-energy.png",
    }
    lines = findings([], names)
    assert "![Energy at the nominal timestep over the stability horizon on rope](charts/run1-rope-nominal.png)" in lines
    assert not any("damping" in line or "rope-energy" in line for line in lines)
