"""pymunk's contact poses (``adapters.pymunk.contact``, 2-D): every scene at the three report steps,
the exact velocity impulse of its rebound, the figures its settings get, and each default that
changes the answer (measured 2026-11-27 on pymunk 7.3.1; docs/engines.md)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pytest.importorskip("pymunk")

from adapters import CONTACT_MODES  # noqa: E402
from adapters.pymunk import contact as pose  # noqa: E402
from harness.contact.figures import contact_figures  # noqa: E402
from harness.contact.run import REPORT_DTS, run_contact  # noqa: E402
from scenarios.contact import TOLERANCES, make_contact_scene  # noqa: E402

MODE = "pymunk:sequential_impulse"


def stepped(scene_id, dt, params=None, **changed):
    """The mode's run of a scene with ``changed`` settings (None: Chipmunk's default, not set)."""
    scene = make_contact_scene(scene_id, **(params or {}))
    mode = CONTACT_MODES[MODE]
    if changed:
        mode = dataclasses.replace(mode, settings={**mode.settings, **changed})
    run = pose.run(mode, scene, dt)
    assert run.status == "ok", run.detail
    return scene, run


def figures(scene_id, dt, params=None, **changed):
    return contact_figures(*stepped(scene_id, dt, params, **changed))


@pytest.mark.parametrize("scene_id", ["ball", "slide", "rest", "stack"])
def test_every_scene_poses_at_the_report_steps(scene_id):
    for dt in REPORT_DTS:
        run = run_contact(MODE, scene_id, {}, dt, isolated=False)
        assert run.status == "ok", run.detail
        assert run.centres.shape == (run.steps + 1, make_contact_scene(scene_id).bodies, 3)
        assert not run.centres[:, :, 1].any() and not run.velocities[:, :, 1].any()  # the plane x-z
        assert run.loop_cpu_s is not None and run.settings["collision_slop (read back)"] == 0.0


def test_the_rebound_is_an_exact_velocity_impulse():
    """At the step the ball turns, its velocity is -e times the one before the step, to roundoff:
    Chipmunk's restitution acts on the velocity the contact began with, not on the step's gravity."""
    for e in (0.8, 1.0):
        for dt in REPORT_DTS:
            _, run = stepped("ball", dt, {"e": e})
            vz = run.velocities[:, 0, 2]
            turns = np.nonzero((vz[:-1] < 0) & (vz[1:] > 0))[0] + 1
            assert len(turns) >= 5
            for i in turns[:5]:
                assert abs(vz[i] + e * vz[i - 1]) < 1e-12 * abs(vz[i - 1]), (e, dt, i)


def test_the_ball_keeps_its_restitution_at_every_report_step():
    """Each bounce within the scene's tolerance of e (0.5% measured at e 0.8: the ball turns up to
    u h inside the plane, at any phase of the step), a perfectly elastic ball within 0.3% (at 1/60
    the bias that pushes the overlap out adds 0.1-0.2% a bounce), no bounce gaining."""
    for e, within in ((0.8, 0.01), (1.0, 0.003)):
        for dt in REPORT_DTS:
            f = figures("ball", dt, {"e": e})
            assert all(abs(r - e) <= within for r in f.restitution), (e, dt, f.restitution)
            assert all(f.passes.values()), (e, dt, f.passes)
            assert all(abs(r - e) <= TOLERANCES.restitution for r in f.restitution)


def test_the_slide_stops_and_the_box_rests_at_every_report_step():
    for dt in REPORT_DTS:
        assert all(figures("slide", dt).passes.values()), dt
        f = figures("rest", dt)
        assert all(f.passes.values()) and f.penetration == 0.0, (dt, f.penetration)


def test_the_stack_holds_within_tolerance_to_1_240():
    for dt in REPORT_DTS[:2]:
        assert all(figures("stack", dt).passes.values()), dt


# ------------------------------------------------------------------------- each default that changes the answer
def test_ten_iterations_let_a_box_at_rest_sink():
    """Chipmunk's default 10 iterations leave the box at rest 1.7 mm in the plane at 1/60 (the
    tolerance is 1 mm); 100 hold it at the surface."""
    assert figures("rest", 1 / 60, iterations=None).penetration > 1e-3
    assert figures("rest", 1 / 60).penetration == 0.0


def test_collision_slop_leaves_a_landed_ball_sunk():
    """A ball at e = 0 lands up to one step's fall inside the plane (30 mm at 1/60). collision_slop
    0.1 (the default) leaves any overlap under 0.1 m alone: the ball stays that deep; with 0 the bias
    pushes it out (27% of the way by the scene's end)."""

    def depth(**changed):
        _, run = stepped("ball", 1 / 60, {"e": 0.0}, **changed)
        z = run.centres[:, 0, 2] - 0.1
        return -z.min(), -z[-1]

    deepest, end = depth(collision_slop=None)
    assert deepest > 0.02 and end == deepest
    deepest, end = depth()
    assert end < 0.8 * deepest


def test_elasticity_and_friction_combine_by_product():
    f = figures("ball", 1e-3, {"e": 0.8}, **{"plane elasticity": 0.8})
    assert all(abs(r - 0.64) < 0.01 for r in f.restitution), f.restitution
    f = figures("slide", 1e-3, **{"plane friction": 0.5})
    assert abs(f.stop - 2.0**2 / (2 * 0.25 * 9.81)) < 0.05 * f.stop, f.stop
