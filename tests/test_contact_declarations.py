"""What a contact scene declares is held where it is written and where it is run: a pose that cannot
start the scene's state says so instead of running it, an engine poses the scene's own gravity, a
scene's judge and its figures agree, the full suite takes every registered contact scene, and a
cell's name tells two parameter values apart."""

from __future__ import annotations

import pytest

from scenarios.contact import Ball, Figure, Slide


class _Thrown(Ball):
    """The ball thrown along x: a state a ball held to z cannot start."""

    id = "thrown_test"

    def initial_velocities(self):
        return [(1.0, 0.0, 0.0)]


class _Tilted(Slide):
    """The slide in a field tilted along x: a field REBOUND's planet cannot pose."""

    id = "tilted_test"

    @property
    def gravity(self):
        return (0.5, 0.0, -self.g)


def test_a_pose_that_cannot_start_the_scene_says_why(monkeypatch):
    from adapters import CONTACT_MODES, SPHERE
    from adapters.drake import contact as drake_contact
    from adapters.mujoco import contact as mujoco_contact
    from adapters.pybullet import contact as pybullet_contact
    from adapters.rebound import contact as rebound_contact

    for poses in (mujoco_contact.POSES, drake_contact.POSES, pybullet_contact.POSES):
        monkeypatch.setitem(poses, _Thrown.id, SPHERE)
    monkeypatch.setitem(rebound_contact.POSES, _Tilted.id, SPHERE)
    thrown = _Thrown()
    for mode_id in ("mujoco:rk4", "drake:sap"):  # the ball on a joint along z
        ok, why = CONTACT_MODES[mode_id].supports(thrown)
        assert not ok and "holds the ball to z" in why
    assert CONTACT_MODES["pybullet:sequential_impulse"].supports(thrown) == (True, "")
    ok, why = CONTACT_MODES["rebound:hardsphere"].supports(_Tilted())
    assert not ok and "gravity along -z only" in why
    assert CONTACT_MODES["mujoco:rk4"].supports(Ball()) == (True, "")


#: One pose's run of the tilted slide in a process of its own (pybullet's settings are process-wide).
TILTED_RUN = """
import json, sys
from scenarios.contact import Slide
from adapters import CONTACT_MODES
import adapters.{engine}.contact as pose

class Tilted(Slide):
    id = "tilted_test"
    @property
    def gravity(self):
        return (0.5, 0.0, -self.g)

pose.POSES[Tilted.id] = pose.POSES["slide"]
mode = CONTACT_MODES[sys.argv[1]]
out = []
for scene in (Tilted(), Slide()):
    run = mode.run(mode, scene, 1e-3)
    out.append([run.status, float(run.centres[-1, 0, 0] - run.centres[0, 0, 0])])
print(json.dumps(out))
"""


@pytest.mark.parametrize("mode_id", ["mujoco:rk4", "pybullet:sequential_impulse"])
def test_an_engine_poses_the_scenes_own_gravity(mode_id):
    """The slide in a field tilted along its push (0.5 m/s^2 along +x, the box pushed along +x at
    2 m/s): it stops after v0^2 / (2 (mu g - 0.5)), 11% further than on level ground; each engine's
    pose moves it that much further than its own level slide (the engine's friction model's own
    error, pybullet's pyramid among them, divides out), not as far as a field down z alone would."""
    import json
    import subprocess
    import sys

    code = TILTED_RUN.format(engine=mode_id.split(":")[0])
    done = subprocess.run([sys.executable, "-c", code, mode_id], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    (status, tilted), (level_status, level) = json.loads(done.stdout.strip().splitlines()[-1])
    scene = _Tilted()
    further = scene.mu * scene.g / (scene.mu * scene.g - 0.5)  # v0^2/(2 (mu g - 0.5)) over v0^2/(2 mu g)
    assert status == level_status == "ok"
    assert tilted / level == pytest.approx(further, rel=0.02)  # a field down z alone: 1


def test_a_scenes_declarations_are_checked_where_it_is_written():
    with pytest.raises(TypeError, match="twice"):
        type("Twice", (Slide,), {"id": "twice", "FIGURES": (Figure("stop"), Figure("stop"))})
    with pytest.raises(TypeError, match="a scene charts one figure"):
        type("Two", (Slide,), {"id": "two", "FIGURES": (Figure("stop", chart="a"), Figure("creep", chart="b"))})


def test_a_figure_compared_with_a_truth_the_scene_does_not_give_is_an_error():
    """A declaration whose ``truth`` names no key of ``truth()``: the tables would print it beside
    nothing, so the run's figures are refused with the reason (the cell records it)."""
    import numpy as np

    from harness.contact.figures import contact_figures
    from records.contact import ContactTrajectory

    class Untrue(Slide):
        id = "untrue_test"
        FIGURES = (*Slide.FIGURES, Figure("speed_at_stop", "speed (m/s)", truth="speed_at_stop"))

    scene = Untrue()
    t = np.arange(0.0, scene.duration, 1e-3)  # the truth's motion: decelerated to its stop, then at rest
    a, t_stop = scene.mu * scene.g, scene.stop_time
    x = np.where(t < t_stop, scene.v0 * t - 0.5 * a * t**2, scene.truth()["stop"])
    u = np.where(t < t_stop, scene.v0 - a * t, 0.0)
    centres = np.stack([x, 0 * t, 0 * t + scene.half], axis=1)[:, None, :]
    velocities = np.stack([u, 0 * t, 0 * t], axis=1)[:, None, :]
    run = ContactTrajectory.of(scene, "mujoco:rk4", 1e-3, t, centres, velocities)
    with pytest.raises(ValueError, match=r"compares with truth \['speed_at_stop'\]"):
        contact_figures(scene, run)
    assert contact_figures(Slide(), run).passes == {"stop": True, "creep": True, "veer": True}


def test_the_full_suite_takes_every_registered_contact_scene(monkeypatch):
    from harness.nightly.run import contact_scene_list
    from harness.nightly.suites import SUITES
    from scenarios import ENGINE_SCENES, contact_scenes

    monkeypatch.setitem(ENGINE_SCENES, _Thrown.id, _Thrown)
    listed = contact_scene_list(SUITES["full"].contact)
    also = {"ball": 1, "slide": 2}  # the variants the full suite names beside each default
    assert [s for s, _ in listed] == [x for s in contact_scenes() for x in [s] * (1 + also.get(s, 0))]
    assert (_Thrown.id, {}) in listed and ("ball", {"e": 1.0}) in listed
    assert contact_scene_list(SUITES["standard"].contact) == SUITES["standard"].contact["scenes"]


def test_a_cells_name_tells_two_values_apart_and_keeps_the_short_ones():
    from harness.nightly.measures.contact_cells import cell_scene

    assert cell_scene("ball", {"e": 1.0}) == "ball_e1"
    assert cell_scene("ball", {"e": 0.9}) == "ball_e0.9"
    assert cell_scene("ball", {"e": 0.9000001}) != cell_scene("ball", {"e": 0.9000002})


def test_a_suite_mode_no_engine_declares_is_listed_with_its_reason():
    import dataclasses

    from harness.nightly.run import contact_tasks
    from harness.nightly.suites import SUITES

    suite = SUITES["standard"]
    contact = {**suite.contact, "scenes": (("rest", {}),), "modes": ("mujoco:rk4", "nonsense:mode"), "penalty": ()}
    skipped: list = []
    tasks = contact_tasks(dataclasses.replace(suite, contact=contact), (), skipped)
    assert [t.method for t in tasks] == ["mujoco:rk4"]
    assert any(s["method"] == "nonsense:mode" and "no contact mode nonsense:mode" in s["reason"] for s in skipped)


class _Up(Ball):
    """The ball thrown straight up at 3 m/s from its drop height."""

    id = "up_test"

    def initial_velocities(self):
        return [(0.0, 0.0, 3.0)]


class _Offset(Ball):
    """The ball dropped 0.4 m along x from the origin."""

    id = "offset_test"

    def initial_centres(self):
        return [(0.4, 0.0, self.h0 + self.radius)]


def test_a_ball_held_to_z_starts_with_the_scenes_vertical_speed_and_refuses_an_offset_start(monkeypatch):
    """REBOUND's ball (a test particle over its planet) thrown up at 3 m/s rises to h0 + 9/(2 g)
    before its first fall; a ball held to z refuses to start 0.4 m off its axis."""
    from adapters import CONTACT_MODES, SPHERE
    from adapters.mujoco import contact as mujoco_contact
    from adapters.rebound import contact as rebound_contact

    monkeypatch.setitem(rebound_contact.POSES, _Up.id, SPHERE)
    monkeypatch.setitem(mujoco_contact.POSES, _Offset.id, SPHERE)
    scene = _Up()
    mode = CONTACT_MODES["rebound:hardsphere"]
    assert mode.supports(scene) == (True, "")
    run = mode.run(mode, scene, 1e-3)
    apex = float(run.centres[: int(0.5 / 1e-3), 0, 2].max()) - scene.radius
    assert apex == pytest.approx(scene.h0 + 9.0 / (2.0 * scene.g), rel=1e-3)
    ok, why = CONTACT_MODES["mujoco:rk4"].supports(_Offset())
    assert not ok and "off the axis" in why


def test_a_run_stored_before_warp_was_among_its_engines_stays_in_its_series():
    from harness.history.storage import engine_series

    old = {"warp-lang": "1.19.0", "engines": {"newton": "1.8.0", "mujoco": "4.0.0"}}
    new = {"warp-lang": "1.19.0", "engines": {"newton": "1.8.0", "mujoco": "4.0.0", "warp-lang": "1.19.0"}}
    assert engine_series(old) == engine_series(new)
    assert engine_series(new) != engine_series({**new, "engines": {**new["engines"], "warp-lang": "1.20.0"}})
