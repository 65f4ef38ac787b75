"""Engine modes run through the engines' own loops (issue 11): the same trajectories, bitwise,
as the per-step path the harness always took, and force evaluations counted by the engines.

Tolerances: ``0`` everywhere. The two loops make the same engine calls in the same order on
the same model (MuJoCo: ``mujoco.rollout`` steps with ``mj_step`` from the full physics state
and warm start; REBOUND: ``sim.steps(n)`` is n calls of its step; pybullet and pymunk: the
same calls, only the reads between output points left out), so any difference is a bug.
Counted evaluations are integers and compared exactly.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import adapters
from adapters import output_marks
from scenarios import make_scene

#: (h * omega, steps, every): a stable run, and one past every explicit scheme's stability
#: limit (h omega = 3 > 2 sqrt 2), which ends ``unstable`` for the modes that integrate one.
RUNS = {"stable": (0.2, 240, 7), "unstable": (3.0, 240, 7)}

CASES = [(mid, sid) for mid, mode in sorted(adapters.ENGINE_METHODS.items()) for sid in mode.scenes]
#: A scene a mode poses only in other parameters than its defaults, in those (the triangulated cloth).
POSED = {("pybullet:semi_implicit", "cloth"): {"shear": 1, "k_shear": 500.0, "k_bend": 0.0}}


def _both(method_id: str, scene_id: str, homega: float, steps: int, every: int):
    mode = adapters.ENGINE_METHODS[method_id]
    scene = make_scene(scene_id, **POSED.get((method_id, scene_id), {}))
    dt = homega / scene.omega
    return (
        mode.simulate(scene, dt, steps, every, loop="engine"),
        mode.simulate(scene, dt, steps, every, loop="harness"),
    )


def _assert_bitwise(a, b) -> None:
    assert (a.status, a.failed_step, a.detail) == (b.status, b.failed_step, b.detail)
    for name in ("step", "q", "v", "energy"):
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name


#: Newton's VBD solver builds Warp kernels of its own for seconds, and Drake's plant of the
#: 32-link chain steps at a second a run: their loops are checked by ``make test-slow``, but for the
#: two Drake modes the standard suite runs on the chain.
SLOW_TO_BUILD = ("newton:vbd",)
DRAKE_CHAIN_KEPT = ("drake:semi_explicit_euler", "drake:radau1")


def _slow(m: str, s: str) -> bool:
    return m in SLOW_TO_BUILD or (m.startswith("drake:") and s == "chain" and m not in DRAKE_CHAIN_KEPT)


@pytest.mark.parametrize("run", sorted(RUNS))
@pytest.mark.parametrize(
    "method_id,scene_id",
    [pytest.param(m, s, id=f"{m}-{s}", marks=[pytest.mark.slow] if _slow(m, s) else []) for m, s in CASES],
)
def test_engine_loop_is_the_per_step_path_bitwise(method_id, scene_id, run):
    homega, steps, every = RUNS[run]
    engine_loop, per_step = _both(method_id, scene_id, homega, steps, every)
    _assert_bitwise(engine_loop, per_step)
    assert engine_loop.meta.loop.startswith("engine")
    assert per_step.meta.loop.startswith("harness")


def test_the_runs_cover_unstable_runs_of_every_engine_that_has_one():
    """The unstable runs above are unstable (else the bitwise test would not test the replay):
    an explicit scheme at h omega = 3 on the spring, and the stiff chain."""
    for method_id, scene_id in [
        ("mujoco:euler", "spring"),
        ("mujoco:rk4", "spring"),
        ("pybullet:semi_implicit", "spring"),
        ("pymunk:spring_force", "spring"),
        ("pymunk:applied_force", "chain"),
        ("pymunk:damped_spring", "chain"),
    ]:
        a, b = _both(method_id, scene_id, *RUNS["unstable"])
        assert a.status == "unstable" and a.failed_step is not None, (method_id, scene_id)
        assert "replayed" in a.meta.loop


def test_a_run_whose_output_interval_is_longer_than_one_rollout_span(monkeypatch):
    """MuJoCo's rollout spans: an output interval longer than a span is rolled out in several
    calls, marks falling inside a span are rows of its state array; still bitwise."""
    from adapters import mujoco as mujoco_adapter

    monkeypatch.setattr(mujoco_adapter, "ROLLOUT_SPAN_VALUES", 3 * 5)  # nstate 3 (time, x, v): 5 steps
    for every in (1, 3, 12):
        a, b = _both("mujoco:rk4", "spring", 0.2, 61, every)
        _assert_bitwise(a, b)


def test_output_marks_are_the_reference_drivers():
    assert output_marks(10, 3).tolist() == [0, 3, 6, 9, 10]
    assert output_marks(0, 1).tolist() == [0]
    assert output_marks(5, 7).tolist() == [0, 5]


def test_an_unknown_loop_is_a_one_line_error():
    with pytest.raises(ValueError, match="loop: 'python' is not one of engine, harness"):
        adapters.ENGINE_METHODS["mujoco:euler"].simulate(make_scene("spring"), 0.1, 10, loop="python")


# ---------------------------------------------------------------- counted evaluations

#: Force evaluations per step each engine's own counter should show, from what the engines
#: document: MuJoCo runs one forward pass a step, RK4 four (its stages); REBOUND's leapfrog
#: and WHFast evaluate gravity once a step; pymunk calls a body's velocity_func once a step.
EXPECTED = [
    ("mujoco:euler", "spring", 1),
    ("mujoco:implicit", "spring", 1),
    ("mujoco:implicitfast", "spring", 1),
    ("mujoco:discrete", "spring", 1),
    ("mujoco:rk4", "spring", 4),
    ("mujoco:rk4", "chain", 4),
    ("rebound:leapfrog", "kepler", 1),
    ("rebound:whfast", "kepler", 1),
    ("rebound:leapfrog", "solar_system", 1),
    ("pymunk:spring_force", "spring", 1),
    ("pymunk:spring_force", "chain", 1),
    ("pymunk:applied_force", "spring", 1),
]


@pytest.mark.parametrize("method_id,scene_id,per_step", EXPECTED)
def test_counted_force_evaluations_are_the_documented_ones(method_id, scene_id, per_step):
    mode = adapters.ENGINE_METHODS[method_id]
    scene = make_scene(scene_id)
    dt, steps = 0.1 / scene.omega, 50
    for loop in mode.LOOPS:
        counted = mode.simulate(scene, dt, steps, 10, loop=loop, count=True)
        assert counted.ok
        assert counted.force_evals == per_step * steps, (loop, counted.meta.force_evals_counted)
        # The counter changes nothing that is integrated.
        plain = mode.simulate(scene, dt, steps, 10, loop=loop)
        _assert_bitwise(counted, plain)


def test_modes_that_cannot_count_say_why():
    spring, kepler = make_scene("spring"), make_scene("kepler")
    bullet = adapters.ENGINE_METHODS["pybullet:semi_implicit"].simulate(spring, 0.1, 10, count=True)
    assert bullet.force_evals is None and "stepSimulation" in bullet.meta.force_evals_reason
    chipmunk = adapters.ENGINE_METHODS["pymunk:pin_joint"].simulate(make_scene("pendulum"), 0.01, 10, count=True)
    assert chipmunk.force_evals is None and "constraints" in chipmunk.meta.force_evals_reason
    uncounted = adapters.ENGINE_METHODS["rebound:leapfrog"].simulate(kepler, 0.01, 10)
    assert uncounted.force_evals is None and "counting run" in uncounted.meta.force_evals_reason
    # MuJoCo's timers count in every run, the timed ones included.
    assert adapters.ENGINE_METHODS["mujoco:rk4"].simulate(spring, 0.1, 10).force_evals == 40
    assert math.isfinite(bullet.q[-1, 0, 0])


# ---------------------------------------------------------------- the two cost figures


def test_cost_of_an_engine_mode_has_two_figures_and_ratios_use_the_engines_own():
    from harness.measures import cost

    spring = make_scene("spring")
    res = cost.cost_per_step("mujoco:euler", spring, 0.01, time_steps=500, repeats=2)
    assert res.loop == "engine" and res.timing.startswith("engine s/step")
    stepped = res.as_stepped
    assert stepped["loop"] == "harness" and stepped["timing"].startswith("as stepped by the harness")
    assert res.as_stepped_s_per_step == stepped["s_per_step"] == min(stepped["repeats_s_per_step"]) > 0
    assert len(stepped["repeats_s_per_step"]) == 2
    # The ratio to explicit Euler is the engine's own figure's, repeat by repeat.
    ratios = np.array(res.repeats_s_per_step) / np.array(res.baseline["repeats_s_per_step"])
    assert res.ratio_to_explicit_euler == pytest.approx(float(np.median(ratios)), rel=1e-12)
    assert res.force_evals_per_step == 1.0


def test_a_force_applied_from_python_every_step_is_said_in_the_cost():
    from harness.measures import cost

    res = cost.wall_time_per_step("pybullet:semi_implicit", make_scene("spring"), 0.01, steps=300, repeats=1)
    assert res["loop"] == "engine" and "from Python every step" in res["engine_loop"]
    chipmunk = cost.wall_time_per_step("pymunk:spring_force", make_scene("spring"), 0.01, steps=300, repeats=1)
    assert chipmunk["engine_loop"].startswith("space.step only")


# ---------------------------------------------------------------- the engine bench and the chart


def test_bench_engines_json_puts_each_mode_beside_its_bare_loops(capsys):
    import json

    from harness.cli import main

    assert (
        main(["bench", "--engines", "--json", "--methods", "mujoco:rk4", "rebound:leapfrog", "pymunk:applied_force"])
        == 0
    )
    rows = {r["method"]: r for r in json.loads(capsys.readouterr().out)}
    assert list(rows) == ["mujoco:rk4", "rebound:leapfrog", "pymunk:applied_force"]
    mj, rb, pm = rows["mujoco:rk4"], rows["rebound:leapfrog"], rows["pymunk:applied_force"]
    assert (mj["scene"], rb["scene"], pm["scene"]) == ("spring", "kepler", "spring")
    assert list(mj["bare_ns_per_step"]) == ["mujoco.rollout", "mj_step loop"] and mj["target_loop"] == "mujoco.rollout"
    assert list(rb["bare_ns_per_step"]) == ["sim.steps(N)"]
    assert list(pm["bare_ns_per_step"]) == ["space.step loop", "bare loop + force"]
    # A mode whose force is set from Python is judged against the least loop that simulates the
    # scene (a step-only loop would step a body with no spring); the step-only ratio rides beside.
    assert pm["target_loop"] == "bare loop + force"
    assert pm["ratio_to_step_loop"] == pytest.approx(
        pm["engine_ns_per_step"] / pm["bare_ns_per_step"]["space.step loop"]
    )
    assert "ratio_to_step_loop" not in mj and "ratio_to_step_loop" not in rb
    for r in rows.values():
        assert r["ratio_to_bare"] == pytest.approx(r["engine_ns_per_step"] / r["bare_ns_per_step"][r["target_loop"]])
        assert r["meets_target"] == (r["ratio_to_bare"] <= r["target_ratio"] == 1.3)
        assert r["as_stepped_ns_per_step"] > 0 and r["clock"] == "cpu"
    assert "from Python every step" in pm["engine_loop"]


def test_bench_engines_refuses_an_unknown_mode_in_one_line(capsys):
    from harness.cli import main

    assert main(["bench", "--engines", "--methods", "mujoco:verlet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "mujoco:verlet" in err and "mujoco:euler" in err


def test_the_work_precision_chart_says_which_loop_and_clock(tmp_path, monkeypatch):
    from records.cell import Cell, CostFigures, OrderFigures
    from reports import charts

    said = {}
    real = charts._save

    def keep(fig, path):
        ax = fig.axes[0]
        said["xlabel"] = ax.get_xlabel()
        said["legend"] = [t.get_text() for t in ax.get_legend().get_texts()]
        return real(fig, path)

    monkeypatch.setattr(charts, "_save", keep)
    points = OrderFigures(points=[{"dt": 0.1, "error": 1e-3}, {"dt": 0.05, "error": 2.5e-4}])
    methods = ("ref:leapfrog", "mujoco:euler")
    cells = [Cell("spring", m, m.split(":")[0], "order", value=2.0, figures=points) for m in methods] + [
        Cell("spring", m, m.split(":")[0], "cost", value=1e-6, figures=CostFigures(clock="cpu")) for m in methods
    ]
    assert charts.workprecision_chart(cells, "spring", tmp_path / "wp.png")
    # the two identical curves: one holds the Pareto front, the other is named beside it
    assert sorted(said["legend"]) == ["Pareto front", "mujoco:euler (engine's own loop)", "ref:leapfrog (compiled)"]
    assert said["xlabel"].startswith("cost: CPU seconds") and "engines: their own loop" in said["xlabel"]


def test_pin_jointed_pendulum_follows_whole_turns_in_chunks():
    """A bob thrown over the top (omega0 = 20 rad/s, well above the 2 sqrt(g/L) = 6.3 it needs)
    turns many times: the angle followed in chunks (``steps(n)``) is the angle followed after
    every step, bit for bit, and it has gained the whole turns (> 10 turns in 4 s)."""
    import pymunk

    from adapters.pymunk import build

    scene = make_scene("pendulum")
    chunked, stepwise = (build(pymunk, "pin_joint", scene, 1e-3) for _ in range(2))
    for model in (chunked, stepwise):
        model.set_state(np.array([0.0]), np.array([20.0]))
    chunked.steps(4000)
    for _ in range(4000):
        stepwise.steps(1)
    (qa, va), (qb, vb) = chunked.state(), stepwise.state()
    assert qa[0] == qb[0] and va[0] == vb[0]
    assert qa[0] > 10 * 2 * math.pi


def test_every_engine_mode_has_a_bench_scene():
    """``harness bench --engines`` benches every mode: each has a scene it poses."""
    from harness.bench.engines import bench_scene, engine_modes

    for mode in engine_modes():
        assert bench_scene(mode).id in mode.scenes, mode.id
    assert bench_scene(adapters.ENGINE_METHODS["pymunk:space_damping"]).id == "damped_spring"


def _one_mode_per_engine() -> list[str]:
    """The first available mode of each engine, and each mode whose bare loops differ from its
    engine's first (REBOUND's adaptive IAS15; pymunk's force applied from Python)."""
    from harness.bench.engines import engine_modes

    firsts = {}
    for mode in engine_modes():
        firsts.setdefault(mode.engine, mode.id)
    return sorted(set(firsts.values()) | ({"rebound:ias15", "pymunk:applied_force"} & {m.id for m in engine_modes()}))


@pytest.mark.parametrize("mode_id", _one_mode_per_engine())
def test_every_engine_has_a_bare_loop_that_steps_its_model(mode_id):
    """``harness bench --engines`` (every mode by default) reaches each engine's bare loops: each
    runs a few steps on the model the adapter built, and closes (Drake and Newton had none: the
    command raised there, after the modes before them had been timed)."""
    from harness.bench.engines import _bare_loops, bench_scene

    mode = adapters.ENGINE_METHODS[mode_id]
    scene = bench_scene(mode)
    loops, said = _bare_loops(mode, scene)
    assert loops and said
    try:
        for loop in loops:
            loop.repeat(3)
            assert loop.times[-1] > 0.0, loop.name
    finally:
        for loop in loops:
            loop.close()


@pytest.mark.parametrize(
    "scene_id, params, mode",
    [
        ("rope", {"N": 5}, "pin_joint"),
        ("chain", {"N": 8}, "spring_force"),
        ("chain", {"N": 8}, "damped_spring"),
        ("net", {"n": 3, "m": 4}, "damped_spring"),
    ],
)
def test_pymunk_reads_every_body_in_one_call_the_same_doubles(scene_id, params, mode):
    """A multi-body pose reads its bodies through pymunk.batch (one Chipmunk call a state, where the
    per-step reads were most of a stability search's time): the doubles the properties give."""
    import pymunk

    from adapters.pymunk import POSES
    from scenarios import make_scene

    model = POSES[scene_id](pymunk, mode, make_scene(scene_id, **params), 0.01)
    model.steps(7)
    x, u = model._bodies_state()
    assert model._batch.batched  # the batch path, not the fallback
    assert x.tobytes() == np.array([tuple(b.position) for b in model.bodies]).tobytes()
    assert u.tobytes() == np.array([tuple(b.velocity) for b in model.bodies]).tobytes()
