"""Contact: the scenes and their truth, the figures a run is measured by (on runs whose answer is
known), MuJoCo's poses and its traps, the nightly's contact and penalty cells, their regression
rule, the report's section and ``harness contact``'s refusals (the penalty ground and its table:
``tests/test_penalty.py``)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from records import InvalidInput
from records.cell import Cell
from records.contact import ContactCellFigures, ContactTrajectory
from records.measures import Comparison
from scenarios import make_scene
from scenarios.contact import PROFILES, TOLERANCES, make_contact_scene

from harness.contact.figures import apexes, contact_figures


# ----------------------------------------------------------------------------- scenes
@pytest.mark.parametrize(
    "scene_id, params, field",
    [
        ("ball", {"e": 1.5}, "e=1.5"),
        ("ball", {"e": -0.1}, "e=-0.1"),
        ("ball", {"e": float("nan")}, "e=nan"),
        ("slide", {"mu": -0.5}, "mu=-0.5"),
        ("slide", {"mu": 0}, "mu=0"),
        ("slide", {"v0": float("inf")}, "v0=inf"),
        ("rest", {"bogus": 1}, "'bogus'"),
        ("floor", {}, "'floor'"),
    ],
)
def test_bad_contact_input_is_one_line_naming_the_field(scene_id, params, field):
    with pytest.raises(InvalidInput) as err:
        make_contact_scene(scene_id, **params)
    line = str(err.value)
    assert field in line and "\n" not in line and ("allowed" in line or "valid" in line)


def test_the_scenes_state_their_truth():
    ball = make_contact_scene("ball", e=0.8)
    t = ball.truth()
    assert t["apexes"][3] == pytest.approx(0.8**6) and t["apex_ratio"] == pytest.approx(0.8**10)
    assert ball.flight(1) == pytest.approx(2 * 0.8 * math.sqrt(2 * 9.81) / 9.81)
    assert ball.duration > ball.impacts()[-2] + ball.flight(5) / 2  # the last apex is recorded
    slide = make_contact_scene("slide")
    assert slide.truth()["stop"] == pytest.approx(2.0**2 / (2 * 0.5 * 9.81))
    assert [c[2] for c in make_contact_scene("stack").initial_centres()] == pytest.approx([0.1, 0.3, 0.5])


def test_a_contact_scene_is_a_scene_its_state_the_bodies_centres_and_velocities():
    """One registry of scenes: the contact scenes are engine scenes (only engines pose them), their
    parameters checked by ``Scene``'s machinery, their state each body's centre and velocity."""
    from scenarios import ENGINE_SCENES, Scene, contact_scenes

    assert list(contact_scenes()) == ["ball", "slide", "rest", "stack", "edge", "corner", "tip", "roll"]
    for sid, cls in contact_scenes().items():
        scene = make_scene(sid)
        assert isinstance(scene, Scene) and ENGINE_SCENES[sid] is cls and not scene.has_kernels
        q, v = scene.initial_state()
        assert q.tolist() == [x for c in scene.initial_centres() for x in c] and len(v) == len(q) == 3 * scene.bodies
        assert scene.ndof == 3 * scene.bodies and scene.duration > 0 and scene.FIGURES
        assert {f.truth for f in scene.FIGURES if f.truth} <= set(scene.truth())
        assert sum(1 for f in scene.FIGURES if f.chart) == 1  # one figure a scene is charted
    slide = make_scene("slide")
    assert slide.initial_state()[1].tolist() == [slide.v0, 0.0, 0.0]
    assert float(slide.energy(*slide.initial_state())) == pytest.approx(0.5 * slide.v0**2 + slide.g * slide.half)


def test_a_contact_run_is_a_trajectory_with_its_settings_as_metadata():
    from records.trajectory import Trajectory

    scene, run = ideal_ball(0.8, 1e-3)
    assert isinstance(run, Trajectory) and run.q.shape == (len(run.t), 1, 3) and run.centres.shape == (len(run.t), 1, 3)
    assert run.energy.shape == (len(run.t), 1) and run.meta.params == scene.values
    in_flight = run.t < scene.impacts()[0]
    assert np.ptp(run.energy[in_flight]) < 1e-9  # the scene's energy, computed from the state
    failed = ContactTrajectory.failed("ball", "m", 0.01, "crashed", "why")
    assert failed.status == "crashed" and failed.centres.shape == (0, 1, 3) and failed.settings == {}


def test_harness_contact_lists_a_mode_asked_for_that_does_not_pose_the_scene(capsys):
    from harness.cli import main

    assert main(["contact", "slide", "--modes", "rebound:hardsphere", "--dt", "1/60"]) == 0
    out = capsys.readouterr().out
    assert "rebound:hardsphere" in out and "unsupported: REBOUND's particles are spheres" in out


# ----------------------------------------------------------------------------- figures
def ideal_ball(e: float, dt: float, sink: float = 0.0) -> tuple:
    """The exact motion of a point ball bouncing with restitution e off z = 0 (each rebound an
    instant speed reversal), sampled every dt: the ball scene's centres and velocities."""
    scene = make_contact_scene("ball", e=e)
    g, r = scene.g, scene.radius
    t = np.arange(0.0, scene.duration, dt)
    z, v = np.empty_like(t), np.empty_like(t)
    u = 0.0
    impacts = scene.impacts()
    while impacts[-1] < scene.duration:  # bounces past the measured ones, to the end of the run
        impacts.append(impacts[-1] + scene.flight(len(impacts)))
    starts = [0.0] + impacts
    for i, ti in enumerate(t):
        k = np.searchsorted(impacts, ti, side="right")
        s = ti - starts[k]
        u = 0.0 if k == 0 else e**k * math.sqrt(2 * g * scene.h0)
        z[i] = (scene.h0 if k == 0 else 0.0) + u * s - 0.5 * g * s * s
        v[i] = u - g * s
    centres = np.zeros((len(t), 1, 3))
    vel = np.zeros((len(t), 1, 3))
    centres[:, 0, 2], vel[:, 0, 2] = z + r - sink, v
    return scene, ContactTrajectory.of(scene, "test", dt, t, centres, vel)


@pytest.mark.parametrize("e", [0.8, 1.0])
def test_the_ball_figures_read_the_true_restitution_from_an_exact_motion(e):
    scene, run = ideal_ball(e, 1e-4)
    f = contact_figures(scene, run)
    assert f.restitution == pytest.approx([e] * 5, abs=1e-3)
    assert f.apex_ratio == pytest.approx(e**10, rel=1e-2) and f.gained == []
    assert all(f.passes.values())
    assert f.intervals == pytest.approx([scene.flight(n) for n in range(1, 6)], abs=2e-4)


def test_a_gain_at_a_bounce_is_a_cross_and_a_dead_ball_bounces_zero():
    scene, run = ideal_ball(0.8, 1e-3)
    z = run.centres[:, 0, 2]
    i = np.argmax(run.t > scene.impacts()[2])  # after the third impact the ball rises twice as high: above apex 2
    run.centres[i:, 0, 2] = scene.radius + (z[i:] - scene.radius) * 2.0
    f = contact_figures(scene, run)
    assert 3 in f.gained and f.passes["gain"] is False
    scene, run = ideal_ball(0.8, 1e-3)
    after = run.t > scene.impacts()[1]
    run.centres[after, 0, 2], run.velocities[after, 0, 2] = scene.radius, 0.0  # dead after the second impact
    f = contact_figures(scene, run)
    assert f.restitution[2:] == [0.0, 0.0, 0.0] and f.passes["restitution"] is False


def test_apexes_count_an_impact_far_from_the_plane_and_not_a_contact_s_chatter():
    """A long step may turn the velocity with no sample near the plane (a launch from 6.7 mm): it
    is an impact. A soft contact's chatter (down and up again, never lifted) is not."""
    z = np.array([1.0, 0.5, 0.0067, 0.3, 0.5, 0.3, 0.01])
    v = np.array([0.0, -3.0, -4.0, 3.0, 1.0, -1.0, -3.0])
    heights, impacts = apexes(z, v, lift=0.0065)
    assert impacts == [3] and heights == [1.0, 0.5]
    z = np.array([1.0, 0.5, 0.0, -0.001, 0.0005, -0.0002, 0.2, 0.4, 0.2])
    v = np.array([0.0, -3.0, -4.0, 0.5, -0.2, 2.0, 2.5, 0.5, -2.0])
    heights, impacts = apexes(z, v, lift=0.0065)
    assert impacts == [3] and heights == [1.0, 0.4]


def test_slide_and_rest_figures_on_known_runs():
    scene = make_contact_scene("slide")
    dt = 1e-3
    t = np.arange(0.0, scene.duration, dt)
    a = scene.mu * scene.g
    v = np.maximum(scene.v0 - a * t, 0.0)
    x = np.where(t < scene.stop_time, scene.v0 * t - 0.5 * a * t * t, scene.truth()["stop"])
    c = np.zeros((len(t), 1, 3))
    vel = np.zeros((len(t), 1, 3))
    c[:, 0, 0], c[:, 0, 2], vel[:, 0, 0] = x, scene.half, v
    f = contact_figures(scene, ContactTrajectory.of(scene, "t", dt, t, c, vel))
    assert f.stop == pytest.approx(scene.truth()["stop"], rel=1e-3) and f.creep == 0.0 and all(f.passes.values())
    stack = make_contact_scene("stack", settle=0.02)
    c = np.repeat(np.array(stack.initial_centres())[None], 5, axis=0)
    c[1, 0, 2] -= 3e-3  # the start's transient: the bottom box 3 mm into the plane before it settles
    c[3, 0, 2] -= 2e-3  # settled, the bottom box 2 mm into the plane at one step
    c[4, 2, 1] += 4e-3  # the top box 4 mm sideways
    vel = np.zeros_like(c)
    vel[-1, 2, 0] = 0.01
    f = contact_figures(stack, ContactTrajectory.of(stack, "t", 0.01, np.arange(5) * 0.01, c, vel))
    assert f.penetration == pytest.approx(2e-3) and f.transient == pytest.approx(3e-3)
    assert f.sink == pytest.approx(2e-3) and f.creep == pytest.approx(4e-3)
    assert f.kinetic == pytest.approx(0.5 * 1e-4) and f.passes == {
        "penetration": False,
        "creep": False,
        "sink": False,
        "kinetic": False,
    }
    game = contact_figures(stack, ContactTrajectory.of(stack, "t", 0.01, np.arange(5) * 0.01, c, vel), PROFILES["game"])
    assert game.passes == {"penetration": True, "creep": True, "sink": True, "kinetic": False}


# ----------------------------------------------------------------------------- MuJoCo
def test_mujoco_poses_every_scene_and_its_default_solref_does_not_bounce():
    """Every scene at 1 ms; the ball at e = 0.8 keeps each bounce within tolerance with RK4. With
    MuJoCo's default contact (solref 0.02 1: critically damped) the same ball does not bounce."""
    from harness.contact.run import run_contact

    for scene_id in ("ball", "slide", "rest", "stack"):
        run = run_contact("mujoco:rk4", scene_id, {}, 1e-3, isolated=False)
        assert run.status == "ok" and run.loop_cpu_s > 0 and run.settings["solver converged"]
    f = contact_figures(make_contact_scene("ball"), run_contact("mujoco:rk4", "ball", {"e": 0.8}, 1e-3, isolated=False))
    assert f.passes["restitution"] and f.passes["gain"]
    import mujoco

    from adapters.mujoco.contact import _xml

    scene = make_contact_scene("ball", e=0.8)
    xml = _xml("Euler", "pyramidal", scene, 1e-3)
    default = xml.replace(xml[xml.index(' solref="') : xml.index(" margin=")], "")  # MuJoCo's own solref, solimp
    m = mujoco.MjModel.from_xml_string(default)
    assert list(m.geom_solref[0]) == [0.02, 1.0]
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    z = []
    for _ in range(int(1.5 / 1e-3)):
        mujoco.mj_step(m, d)
        z.append(d.qpos[0] - scene.radius)
    after = np.array(z)[int(0.6 / 1e-3) :]  # past the first impact (0.45 s)
    assert after.max() < 0.01 * scene.h0  # no rebound worth the name: not a centimetre of a metre's drop


# ----------------------------------------------------------------------------- the nightly's cells
def _suite(**contact):
    from harness.nightly.suites import SUITES

    return dataclasses.replace(
        SUITES["smoke"],
        contact={
            "scenes": (("ball", {"e": 1.0}),),
            "modes": ("mujoco:rk4",),
            "ladder": (1 / 1000, 1 / 240),
            "penalty": (),
            "penalty_scene": "penalty_ball",
            **contact,
        },
    )


def test_the_nightly_contact_and_penalty_cells():
    from harness.judge import judge
    from harness.nightly.cells import run_task
    from harness.nightly.run import build_tasks

    suite = _suite(penalty=("ref:semi_implicit_euler", "ref:implicit_euler"), grid=(1.0,))
    tasks, _ = build_tasks(dataclasses.replace(suite, bounds=False, scenes={}))
    # cell tasks that name their one measure and carry their scene's id and parameters (no kind of their own)
    assert [(t.kind, t.only, t.scene, t.scene_id, t.params, t.method) for t in tasks] == [
        ("cell", ("contact",), "ball_e1", "ball", {"e": 1.0}, "mujoco:rk4"),
        ("cell", ("penalty",), "penalty_ball", None, {}, "ref:semi_implicit_euler"),
        ("cell", ("penalty",), "penalty_ball", None, {}, "ref:implicit_euler"),
    ]
    assert [t.measures() for t in tasks] == [["contact"], ["penalty"], ["penalty"]]
    assert tasks[0].label == "contact ball_e1 mujoco:rk4"
    cells = [c for t in tasks for c in run_task(t)]
    contact = cells[0]
    assert contact.measure == "contact" and contact.status == "ok" and len(contact.figures.runs) == 2
    assert contact.figures.largest["gain"] == 1 / 1000  # RK4 gains at 1/240
    # MuJoCo's stiff pose (omega_c = 200 rad/s) takes a 4.4 m/s ball 22 mm deep: never within 1 mm
    assert contact.figures.largest["impact_depth"] is None and contact.value is None
    assert [c.value for c in cells[1:]] == [1.0, None]
    found = judge(cells).findings
    seed = [f for f in found if "lively bounces go dead" in f.text]
    assert len(seed) == 1 and seed[0].ok is True and "h·ω_c = 1" in seed[0].text
    assert any("gains energy at a bounce" in f.text and f.ok is False for f in found)
    # the report shows both sections and draws both charts
    import pathlib
    import tempfile

    from reports.markdown import render

    with tempfile.TemporaryDirectory() as out:
        text, written = render(
            {
                "run_id": 1,
                "suite": "smoke",
                "started": "",
                "finished": "",
                "status": "complete",
                "measurement_version": 1,
            },
            cells,
            judge(cells),
            pathlib.Path(out),
        )
    assert "**Contact: `ball`** (e = 1" in text and "The reference schemes on a penalty ground" in text
    assert "| `mujoco:rk4` | 1/1000 s |" in text and "| `ref:implicit_euler` | 0.250− |" in text
    assert {"charts/run1-ball_e1-contact.png", "charts/run1-penalty_ball-penalty.png"} <= set(written)


def _contact_cell(runs, value):
    return Cell(
        "ball", "mujoco:euler", "mujoco", "contact", value=value, figures=ContactCellFigures(scene="ball", runs=runs)
    )


def test_a_contact_regression_is_a_figure_that_held_and_fails_or_a_shorter_largest_step():
    from records.measures import measures

    rule = next(m for m in measures() if m.name == "contact").regression
    ok = {"dt": 1e-3, "passes": {"gain": True, "restitution": True}}
    gains = {"dt": 1e-3, "passes": {"gain": False, "restitution": True}}
    worse = rule(_contact_cell([ok], 1e-3), _contact_cell([gains], 1e-3), Comparison())
    assert worse is not None and "gain held and now fails" in worse.detail
    assert rule(_contact_cell([ok], 1e-3), _contact_cell([ok], 1e-3), Comparison()) is None
    shorter = rule(_contact_cell([ok], 1 / 240), _contact_cell([ok], 1e-3), Comparison())
    assert shorter is not None and "largest step" in shorter.detail


@pytest.mark.parametrize(
    "argv, field",
    [
        (["contact", "ball", "--set", "e=2"], "e=2"),
        (["contact", "slide", "--set", "mu=-1"], "mu=-1"),
        (["contact", "ball", "--dt", "nan"], "--dt"),
        (["contact", "ball", "--modes", "mujoco:nope"], "--modes"),
        (["contact", "--penalty", "--grid", "-1"], "--grid"),
        (["contact", "--penalty", "--set", "zeta=0.1"], "zeta"),
        (["contact", "--advise", "--hz", "0"], "--hz"),
    ],
)
def test_harness_contact_refuses_bad_input_in_one_line(argv, field, capsys):
    from harness.cli import main

    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and field in err[0]


def test_tolerances_are_stated():
    assert TOLERANCES.restitution == 0.05 and TOLERANCES.penetration == 1e-3


def test_a_run_that_needs_a_process_of_its_own_gets_one_from_a_pool_worker():
    """A nightly pool's worker is daemonic: a mode whose settings are process-wide (pybullet) is
    stepped in a child forked for the run, with the same bits as in a fresh worker; the child's
    exception is a crashed run, and one past its limit is killed and timed out."""
    pytest.importorskip("pybullet")
    from harness.contact.run import _in_fork, run_contact

    mode = "pybullet:sequential_impulse"
    args = (mode, "ball", dict(make_contact_scene("ball").values), 1 / 240)
    forked = _in_fork(args, 60.0)
    fresh = run_contact(mode, "ball", {}, 1 / 240, isolated=True)
    assert forked.status == "ok" and np.array_equal(forked.centres, fresh.centres)
    crashed = _in_fork((mode, "ball", {"e": 7.0}, 1 / 240), 60.0)
    assert crashed.status == "crashed" and "e=7" in crashed.detail
    late = _in_fork(args, 1e-3)
    assert late.status == "timed_out"


def test_harness_list_names_the_contact_scenes_and_modes():
    from harness.cli.list import contact_catalogue

    cat = contact_catalogue()
    assert set(cat["contact_scenes"]) == {"ball", "slide", "rest", "stack", "edge", "corner", "tip", "roll"}
    assert cat["contact_scenes"]["ball"]["params"]["e"]["allowed"] == "[0, 1]"
    modes = cat["contact_modes"]
    assert {
        "mujoco:discrete",
        "pybullet:sequential_impulse",
        "pymunk:sequential_impulse",
        "drake:sap",
        "newton:xpbd",
        "rebound:hardsphere",
    } <= set(modes)
    assert "slide" in modes["rebound:hardsphere"]["unsupported"] and modes["mujoco:rk4"]["doc"]


def test_the_advice_ranks_modes_within_every_tolerance_by_their_summed_cost():
    from harness.contact.study import rank

    ok = {"passes": {"restitution": True}, "status": "ok"}
    by_mode = {
        "a": {"ball": {**ok, "cpu_per_s": 3.0}, "stack": {**ok, "cpu_per_s": 1.0}},
        "b": {"ball": {**ok, "cpu_per_s": 1.0}, "stack": {**ok, "cpu_per_s": 1.0}},
        "c": {
            "ball": {"passes": {"restitution": False, "gain": True}, "status": "ok", "cpu_per_s": 0.1},
            "stack": {"passes": {}, "status": "unstable", "cpu_per_s": None},
        },
        "d": {"ball": {**ok, "cpu_per_s": 0.1}},
    }  # does not pose the stack: not advised either way
    fine, failing = rank(by_mode, ("ball", "stack"))
    assert fine == [(2.0, "b"), (4.0, "a")]
    assert failing == {"c": {"ball": ["restitution"], "stack": ["unstable"]}}


def test_a_frames_advice_takes_each_modes_fewest_substeps_within_and_its_cost_there():
    """A game steps physics more than once a frame where one step cannot hold the contact: the
    frame's advice takes each mode at its fewest substeps within every tolerance, costed there."""
    from harness.contact.study import frame_pick

    def run(ok, cpu):
        return {"passes": {"impact_depth": ok}, "status": "ok", "cpu_per_s": cpu}

    by_n = {
        1: {"a": {"ball": run(False, 1.0)}, "b": {"ball": run(True, 3.0)}},
        4: {"a": {"ball": run(True, 2.0)}, "b": {"ball": run(True, 9.0)}, "c": {"ball": run(False, 0.5)}},
    }
    fine, failing = frame_pick(by_n, ("ball",))
    assert fine == [(2.0, "a", 4), (3.0, "b", 1)] and failing == {"c": {"ball": ["impact_depth"]}}


def test_the_ball_judges_the_engines_depth_beyond_the_steps_overshoot():
    """A ball first found 30 mm under the plane by the step that crossed it (the step's lottery, up
    to u h) and pushed out at once has no depth of the engine's own; one that goes 22 mm deeper
    after it was found has 22 mm."""
    from scenarios.contact import impact_depths

    z = np.array([0.1, 0.02, -0.03, 0.01, 0.2, -0.001, -0.023, -0.01, 0.05])
    depth, overshoot = impact_depths(z)
    assert overshoot == pytest.approx(0.03) and depth == pytest.approx(0.022)
