"""pybullet's contact poses (``adapters.pybullet.contact``): every scene at the three report steps,
the figures its settings get, and each default that changes the answer (the figures that default
gives, measured 2026-11-27 on pybullet 3.2.7; docs/engines.md). Every run is in a process of its own:
Bullet's contact breaking threshold is process-wide."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("pybullet")

from adapters import CONTACT_MODES  # noqa: E402
from adapters.pybullet import contact as pose  # noqa: E402
from harness.contact.figures import contact_figures  # noqa: E402
from harness.contact.run import REPORT_DTS, run_contact  # noqa: E402
from harness.execution.isolation import WorkerFailure, run_in_worker  # noqa: E402
from scenarios.contact import TOLERANCES, make_contact_scene  # noqa: E402

MODE = "pybullet:sequential_impulse"
ROOT = Path(__file__).resolve().parents[1]


def figures(scene_id, dt, params=None, **changed):
    """The mode's figures on a scene, in a worker of its own, with ``changed`` settings (None: the
    engine's default, not set)."""
    scene = make_contact_scene(scene_id, **(params or {}))
    mode = CONTACT_MODES[MODE]
    if changed:
        mode = dataclasses.replace(mode, settings={**mode.settings, **changed})
    run = run_in_worker(pose.run, (mode, scene, dt), timeout=120)
    assert not isinstance(run, WorkerFailure), run.detail
    assert run.status == "ok", run.detail
    return contact_figures(scene, run)


@pytest.mark.parametrize("scene_id", ["ball", "slide", "rest", "stack"])
def test_every_scene_poses_at_the_report_steps(scene_id):
    for dt in REPORT_DTS:
        run = run_contact(MODE, scene_id, {}, dt, isolated=True)
        assert run.status == "ok", run.detail
        bodies = make_contact_scene(scene_id).bodies
        assert run.centres.shape == run.velocities.shape == (run.steps + 1, bodies, 3)
        assert run.loop_cpu_s is not None and run.engine_version == "3.2.7"
        assert run.settings["contactBreakingThreshold"] == 0.02 and run.settings["linearDamping"] == 0.0


def test_the_ball_rebounds_at_e_times_one_plus_g_h_over_the_impact_speed():
    """Restitution acts on the velocity after the step's gravity, so a bounce restores
    e (u + g h) / u of the impact speed u = sqrt(2 g H) from the apex H before it (a gain of
    g h / u: 0.22% at h = 1e-3, 3.7% at 1/60 from the drop): within 1% of that on the first three
    bounces (the apexes sampled at the step), and e within the scene's tolerance on the four bounces
    every step records in full (the fifth apex at 1/60 comes after the scene's end, which assumes
    the ideal e)."""
    g = 9.81
    for e in (0.8, 1.0):
        for dt in REPORT_DTS:
            f = figures("ball", dt, {"e": e})
            h = [1.0]
            for r in f.restitution:
                h.append(h[-1] * r * r)
            expected = [e * (1 + g * dt / math.sqrt(2 * g * h[n])) for n in range(3)]
            assert all(abs(r - x) < 0.01 * x for r, x in zip(f.restitution, expected)), (e, dt, f.restitution)
            assert all(abs(r - e) <= TOLERANCES.restitution for r in f.restitution[:4]), (e, dt, f.restitution)
    assert figures("ball", 1e-3, {"e": 1.0}).passes == {"restitution": True, "apex_ratio": True, "gain": True}


def test_the_slide_stops_within_tolerance_and_stays():
    for dt in REPORT_DTS:
        f = figures("slide", dt)
        assert f.passes == {"stop": True, "creep": True}, (dt, f.stop, f.creep)


def test_rest_and_stack_hold_within_tolerance_to_1_240():
    for scene_id in ("rest", "stack"):
        for dt in REPORT_DTS[:2]:
            assert all(figures(scene_id, dt).passes.values()), (scene_id, dt)


# ------------------------------------------------------------------------- each default that changes the answer
def test_contacts_solved_before_touching_kill_an_elastic_ball():
    """contactProcessingThreshold left at its default solves a contact found before touching with its
    gap allowed for, which takes part of each rebound: at h = 1e-3 a perfectly elastic ball is all
    but dead after five bounces."""
    assert figures("ball", 1e-3, {"e": 1.0}, contactProcessingThreshold=None).apex_ratio < 0.01
    assert figures("ball", 1e-3, {"e": 1.0}).apex_ratio > 0.99


def test_contact_erp_adds_energy_at_every_bounce():
    """Bullet's contactERP 0.2 on the ball pushes the penetration out with a velocity: each bounce
    gains (1.2 in restitution at h = 1e-3) and the ball is thrown off the measure."""
    f = figures("ball", 1e-3, {"e": 1.0}, **{"ball contactERP": None})
    assert f.restitution[0] > 1.1 and f.gained


def test_default_damping_takes_a_third_of_an_elastic_balls_height():
    assert figures("ball", 1e-3, {"e": 1.0}, linearDamping=None, angularDamping=None).apex_ratio < 0.7


def test_restitution_and_friction_combine_by_product():
    """The plane at 0.8 and the ball at 0.8 bounce at 0.64, not 0.8; the plane's friction 0.5 on the
    box's 0.5 stops it at v0^2 / (2 * 0.25 g), twice the slide's distance."""
    f = figures("ball", 1e-3, {"e": 0.8}, **{"plane restitution": 0.8})
    assert all(abs(r - 0.64) < 0.01 for r in f.restitution), f.restitution
    f = figures("slide", 1e-3, **{"plane lateralFriction": 0.5})
    assert abs(f.stop - 2.0**2 / (2 * 0.25 * 9.81)) < 0.05 * f.stop, f.stop


def test_cone_friction_by_default_leaves_the_stack_moving_at_1_60():
    assert figures("stack", 1 / 60, enableConeFriction=None).kinetic > 1e-3
    assert figures("stack", 1 / 60).kinetic < 1e-4


def test_no_breaking_threshold_lets_a_box_fall_through_its_contacts():
    """contactBreakingThreshold 0 drops each box contact the step it separates: the box at rest
    jitters and wanders (drift 0.44 m at h = 1e-3)."""
    assert figures("rest", 1e-3, contactBreakingThreshold=0.0).drift > 0.1


def test_the_breaking_threshold_outlives_the_client_that_set_it():
    """Two poses in one process: the second leaves contactBreakingThreshold unset, and gets the first's
    0, not Bullet's 0.02: why every run sets it and runs in a process of its own."""
    code = (
        "import dataclasses, json\n"
        "from adapters import CONTACT_MODES\n"
        "from adapters.pybullet import contact as pose\n"
        "from harness.contact.figures import contact_figures\n"
        "from scenarios.contact import make_contact_scene\n"
        f"mode = CONTACT_MODES[{MODE!r}]\n"
        "scene = make_contact_scene('rest')\n"
        "def drift(cbt):\n"
        "    m = dataclasses.replace(mode, settings={**mode.settings, 'contactBreakingThreshold': cbt})\n"
        "    return contact_figures(scene, pose.run(m, scene, 1e-3)).drift\n"
        "print(json.dumps([drift(None), drift(0.0), drift(None)]))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120, check=True)
    fresh, zero, after = json.loads(out.stdout.strip().splitlines()[-1])
    assert fresh < 1e-3 and zero > 0.1 and after == zero
