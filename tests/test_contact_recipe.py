"""The recipe of docs/contributing.md held: a new contact scene is one module plus one pose per
engine. ``tests/contact_incline.py`` defines the box on an incline (its truth: it stops after
v0^2/(2 g (mu cos θ - sin θ))) and MuJoCo's one pose of it, and names it nowhere else; here it
appears in ``harness contact``, its ``--json``, a nightly's cells and its report, and a mode asked
for that does not pose it is listed with its reason."""

from __future__ import annotations

import importlib
import json
import math
import sys

import pytest

PLUGIN = "tests.contact_incline"


@pytest.fixture
def incline(monkeypatch):
    """The new scene's module loaded (as a ``HARNESS_PLUGINS`` module, so that every worker loads it
    too), and taken away afterwards."""
    monkeypatch.setenv("HARNESS_PLUGINS", PLUGIN)
    module = importlib.import_module(PLUGIN)
    module.register()
    yield module
    module.unregister()


def test_the_new_scene_is_a_scene_with_its_truth(incline):
    from scenarios import ENGINE_SCENES, Scene, contact_scenes, make_scene

    scene = make_scene("incline", theta=0.3)
    assert isinstance(scene, Scene) and not scene.has_kernels and "incline" in contact_scenes()
    g, mu, v0, th = scene.g, scene.mu, scene.v0, scene.theta
    assert scene.truth()["stop"] == pytest.approx(v0**2 / (2 * g * (mu * math.cos(th) - math.sin(th))))
    q, v = scene.initial_state()
    assert q.tolist() == [0.0, 0.0, scene.half] and v.tolist() == [v0, 0.0, 0.0]
    assert ENGINE_SCENES["incline"] is type(scene)


def test_harness_contact_shows_the_new_scene_and_lists_a_mode_that_cannot_pose_it(incline, capsys):
    from harness.cli import main

    argv = ["contact", "incline", "--modes", "mujoco:rk4,rebound:hardsphere", "--dt", "1/240"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert lines[0].startswith("judged by the robotics profile") and lines[1].startswith("incline (mu=0.5, v0=2")
    assert "stop" in lines[2] and "creep" in lines[2]
    mujoco_line = next(line for line in out.splitlines() if line.strip().startswith("mujoco:rk4"))
    assert "0.69" in mujoco_line and "within" in mujoco_line  # the box stops after 0.70 m: within 5%
    rebound_line = next(line for line in out.splitlines() if line.strip().startswith("rebound:hardsphere"))
    assert "unsupported: rebound:hardsphere does not pose incline" in rebound_line

    assert main([*argv, "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    ran = next(r for r in rows if r["method"] == "mujoco:rk4")
    truth = ran["truth"]["stop"]
    assert ran["scene"] == "incline" and ran["status"] == "ok" and abs(ran["stop"] - truth) < 0.1 * truth
    assert set(ran["passes"]) == {"stop", "creep", "veer"} and "creep" in ran
    left = next(r for r in rows if r["method"] == "rebound:hardsphere")
    assert left["status"] == "unsupported" and "does not pose incline" in left["detail"]


def test_the_command_line_takes_the_new_scene_from_harness_plugins():
    """As a user runs it: ``HARNESS_PLUGINS`` names the module, and ``harness contact`` loads it."""
    import os
    import subprocess

    env = {**os.environ, "HARNESS_PLUGINS": PLUGIN, "PYTHONPATH": "."}
    argv = [sys.executable, "-m", "harness", "contact", "incline", "--modes", "mujoco:rk4", "--dt", "1/240", "--json"]
    done = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    (row,) = json.loads(done.stdout)
    assert (row["scene"], row["method"], row["status"]) == ("incline", "mujoco:rk4", "ok")


def test_a_nightly_measures_and_reports_the_new_scene(incline, tmp_path):
    from harness.history.storage import History
    from harness.nightly.run import run_nightly
    from harness.nightly.suites import Suite

    suite = Suite(
        "recipe",
        scenes={},
        methods=(),
        bounds=False,
        identify=False,
        cell_timeout=60.0,
        contact={
            "scenes": (("incline", {"theta": 0.1}),),
            "modes": ("mujoco:rk4",),
            "ladder": (1 / 240,),
            "penalty": (),
            "penalty_scene": "penalty_ball",
        },
    )
    result = run_nightly(suite, tmp_path / "out", tmp_path / "h.sqlite", jobs=1)
    cells = History(tmp_path / "h.sqlite").cells(result["run_id"])
    assert list(zip(cells.scene, cells.method, cells.measure, cells.status)) == [
        ("incline_theta0.1", "mujoco:rk4", "contact", "ok")
    ]
    report = (tmp_path / "out" / "report.md").read_text()
    assert "**Contact: `incline`** (theta = 0.1)" in report and "v0²/(2 g (μ cos θ − sin θ))" in report
    assert "| mode | step | stop distance (m) | creep (m) | ✓/✗ | CPU s per s |" in report
    assert "| `mujoco:rk4` | 1/240 s |" in report
    assert (tmp_path / "out" / "charts" / f"run{result['run_id']}-incline_theta0.1-contact.png").exists()
    assert PLUGIN in sys.modules
