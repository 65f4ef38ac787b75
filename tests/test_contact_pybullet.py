"""pybullet's contact poses (``adapters.pybullet.contact``): both modes on every scene, the figures
their settings get, each reproduced by a bare pybullet loop written here or by a closed form, and
each default that changes the answer (docs/engines.md). Every run is in a process of its own:
Bullet's contact breaking threshold is process-wide."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pybullet")

from adapters import CONTACT_MODES, ROLLING_SPHERE, TURNING_BOX  # noqa: E402
from adapters.pybullet import contact as pose  # noqa: E402
from harness.contact.figures import contact_figures  # noqa: E402
from harness.contact.run import REPORT_DTS, run_contact  # noqa: E402
from harness.execution.isolation import WorkerFailure, run_in_worker  # noqa: E402
from scenarios.contact import STOPPED, TOLERANCES, make_contact_scene  # noqa: E402
from scenarios.contact_turning import TIP_ANGLE, pivot, quat_about, quat_mul, rotation  # noqa: E402

MODE = "pybullet:sequential_impulse"
DEFAULT = "pybullet:sequential_impulse?contact=default"
MODES = (MODE, DEFAULT)
ROOT = Path(__file__).resolve().parents[1]


def _run(mode_id, scene_id, dt, params=None, **changed):
    """The mode's run of a scene, in a worker of its own, with ``changed`` settings (None: the
    engine's default, not set)."""
    scene = make_contact_scene(scene_id, **(params or {}))
    mode = CONTACT_MODES[mode_id]
    if changed:
        mode = dataclasses.replace(mode, settings={**mode.settings, **changed})
    run = run_in_worker(pose.run, (mode, scene, dt), timeout=120)
    assert not isinstance(run, WorkerFailure), run.detail
    assert run.status == "ok", run.detail
    return scene, run


def figures(scene_id, dt, params=None, mode=MODE, **changed):
    scene, run = _run(mode, scene_id, dt, params, **changed)
    return contact_figures(scene, run)


def _in_worker(fn, *args):
    out = run_in_worker(fn, args, timeout=120)
    assert not isinstance(out, WorkerFailure), out.detail
    return out


# ----------------------------------------------------------------------------------- bare pybullet loops
def _bare_world(p, dt, gravity, cone):
    """A client as the default mode sets one: the process-wide breaking threshold at Bullet's
    0.02, the cone or the pyramid, the rest left; the plane restitution 1, friction 1."""
    cid = p.connect(p.DIRECT)
    p.setPhysicsEngineParameter(
        fixedTimeStep=dt, contactBreakingThreshold=0.02, enableConeFriction=cone, physicsClientId=cid
    )
    p.setGravity(*gravity, physicsClientId=cid)
    plane = p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)
    p.changeDynamics(plane, -1, restitution=1.0, lateralFriction=1.0, physicsClientId=cid)
    return cid


def bare_turning(scene_id, dt):
    """The default mode's pose of a turning scene written out by hand: each step's centre,
    orientation (w, x, y, z, from pybullet's x, y, z, w) and angular velocity (world), and the
    body's moment as pybullet reads it back."""
    import pybullet as p

    scene = make_contact_scene(scene_id)
    cid = _bare_world(p, dt, scene.gravity, 1)
    if scene_id == "roll":
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=scene.radius, physicsClientId=cid)
        own = {"restitution": 0.0, "lateralFriction": scene.mu}
    else:
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[scene.half] * 3, physicsClientId=cid)
        own = {"restitution": getattr(scene, "e", 0.0), "lateralFriction": scene.mu}
    w, x, y, z = scene.initial_orientations()[0]
    body = p.createMultiBody(
        scene.mass,
        shape,
        basePosition=list(scene.initial_centres()[0]),
        baseOrientation=[x, y, z, w],
        physicsClientId=cid,
    )
    p.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid, **own)
    moment = p.getDynamicsInfo(body, -1, physicsClientId=cid)[2]
    out = []
    for _ in range(int(math.ceil(scene.duration / dt - 1e-9))):
        p.stepSimulation(physicsClientId=cid)
        c, (x, y, z, w) = p.getBasePositionAndOrientation(body, physicsClientId=cid)
        v, omega = p.getBaseVelocity(body, physicsClientId=cid)
        out.append([*c, w, x, y, z, *v, *omega])
    p.disconnect(cid)
    return np.array(out), moment


def bare_slide_impulses(dt, cone):
    """The controlled mode's slide along x written out by hand (the pyramid or the cone), summing
    each step's contact impulses while it slides: the normal ones, the friction ones along x, and
    the friction along x at points whose normal impulse ended the step at zero."""
    import pybullet as p

    scene = make_contact_scene("slide")
    cid = _bare_world(p, dt, scene.gravity, cone)
    p.setPhysicsEngineParameter(restitutionVelocityThreshold=0.0, contactERP=0.2, physicsClientId=cid)
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[scene.half] * 3, physicsClientId=cid)
    body = p.createMultiBody(scene.mass, shape, basePosition=list(scene.initial_centres()[0]), physicsClientId=cid)
    p.changeDynamics(
        body,
        -1,
        restitution=0.0,
        lateralFriction=scene.mu,
        linearDamping=0.0,
        angularDamping=0.0,
        contactProcessingThreshold=0.0,
        activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
        physicsClientId=cid,
    )
    p.resetBaseVelocity(body, [scene.v0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=cid)
    sums = np.zeros(3)
    for _ in range(int(2 * scene.stop_time / dt)):
        p.stepSimulation(physicsClientId=cid)
        if math.hypot(*p.getBaseVelocity(body, physicsClientId=cid)[0][:2]) < STOPPED:
            break  # the step it stops in: friction below mu N
        for point in p.getContactPoints(body, physicsClientId=cid):
            # (9) normal force, (12) friction along lateral direction 2, world x on the plane
            sums += dt * np.array([point[9], abs(point[12]), abs(point[12]) if point[9] == 0.0 else 0.0])
    p.disconnect(cid)
    return tuple(float(x) for x in sums)


def unset_and_stated(kind, settings, dt=1 / 240, steps=300):
    """A tumbling three-box stack or a bouncing ball (each in a tilted field) stepped with
    ``settings`` set explicitly: every body's state at every step."""
    import pybullet as p

    cid = p.connect(p.DIRECT)
    p.setPhysicsEngineParameter(fixedTimeStep=dt, physicsClientId=cid, **settings)
    p.setGravity(0.3, 0.0, -9.81, physicsClientId=cid)
    plane = p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)
    p.changeDynamics(plane, -1, restitution=1.0, lateralFriction=1.0, physicsClientId=cid)
    if kind == "boxes":
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.05] * 3, physicsClientId=cid)
        bodies = [
            p.createMultiBody(1.0, shape, basePosition=[0, 0, 0.05 + 0.1 * i], physicsClientId=cid) for i in range(3)
        ]
        for b in bodies:
            p.changeDynamics(b, -1, lateralFriction=0.5, physicsClientId=cid)
        p.resetBaseVelocity(bodies[0], [1.0, 0.5, 0.0], [0.0, 0.0, 3.0], physicsClientId=cid)
    else:
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=0.1, physicsClientId=cid)
        bodies = [p.createMultiBody(1.0, shape, basePosition=[0, 0, 0.4], physicsClientId=cid)]
        p.changeDynamics(bodies[0], -1, restitution=0.8, physicsClientId=cid)
    out = []
    for _ in range(steps):
        p.stepSimulation(physicsClientId=cid)
        for b in bodies:
            c, q = p.getBasePositionAndOrientation(b, physicsClientId=cid)
            v, w = p.getBaseVelocity(b, physicsClientId=cid)
            out.append([*c, *q, *v, *w])
    p.disconnect(cid)
    return np.array(out)


# ----------------------------------------------------------------------------------------------- the modes
@pytest.mark.slow  # every pose in both modes: the bare-loop tests below hold each figure
@pytest.mark.parametrize("scene_id", sorted(pose.POSES))
def test_every_scene_poses_in_both_modes(scene_id):
    scene = make_contact_scene(scene_id)
    turns = pose.POSES[scene_id] in (TURNING_BOX, ROLLING_SPHERE)
    for mode_id in MODES:
        run = run_contact(mode_id, scene_id, {}, 1 / 60, isolated=True)
        assert run.status == "ok", run.detail
        assert run.centres.shape == run.velocities.shape == (run.steps + 1, scene.bodies, 3)
        assert run.loop_cpu_s is not None and run.engine_version == "3.2.7"
        assert run.settings["contactBreakingThreshold"] == 0.02 and run.settings["linearDamping"] == 0.0
        if turns:
            assert run.orientations.shape == (run.steps + 1, scene.bodies, 4)
            assert run.angular.shape == (run.steps + 1, scene.bodies, 3)
            assert np.allclose(np.linalg.norm(run.orientations, axis=2), 1.0, atol=1e-12)
            assert np.allclose(run.orientations[0], scene.initial_orientations(), atol=1e-15)
        else:
            assert run.orientations is None


def test_the_default_mode_leaves_every_solver_setting_to_pybullet():
    """Every engine setting but the cone and the process-wide threshold is left unset, stated as
    pybullet's default with the value, and what pybullet reads back is stated beside."""
    _, run = _run(DEFAULT, "rest", 1 / 60)
    s = run.settings
    assert s["contact"] == "default" and s["friction"] == "cone (enableConeFriction 1)"
    assert s["enableConeFriction"] == 1 and s["contactBreakingThreshold"] == 0.02
    left = [k for k in pose.ENGINE_KEYS if k not in ("enableConeFriction", "contactBreakingThreshold")]
    for k in left:
        assert s[k] == f"pybullet's default ({pose.PYBULLET_DEFAULTS[k]})", k
        assert k in s["sources"] and "Quickstart" in s["sources"][k]
    assert s["numSolverIterations (read back)"] == pose.PYBULLET_DEFAULTS["numSolverIterations"]
    assert s["numSubSteps (read back)"] == pose.PYBULLET_DEFAULTS["numSubSteps"]
    assert s["fixedTimeStep (read back)"] == 1 / 60
    assert s["body rollingFriction (read back)"] == s["body spinningFriction (read back)"] == 0.0
    controlled = CONTACT_MODES[MODE].settings
    assert controlled["enableConeFriction"] == 0 and controlled["contact"] == "controlled"


@pytest.mark.parametrize("kind", ["boxes", "ball"])
def test_pybullets_defaults_are_the_values_stated(kind):
    """Left unset, the solver steps bitwise as with ``PYBULLET_DEFAULTS`` set explicitly
    (contactERP 0.08, restitution threshold 0.2 m/s, the cone, ...); a value off the default
    (contactERP 0.2 on the boxes, restitution threshold 0 on the ball) steps otherwise."""
    stated = {k: pose.PYBULLET_DEFAULTS[k] for k in pose.ENGINE_KEYS}
    unset = _in_worker(unset_and_stated, kind, {})
    assert np.array_equal(_in_worker(unset_and_stated, kind, stated), unset)
    off = {"contactERP": 0.2} if kind == "boxes" else {"restitutionVelocityThreshold": 0.0}
    assert np.max(np.abs(_in_worker(unset_and_stated, kind, {**stated, **off}) - unset)) > 1e-3


# ------------------------------------------------------------------------------------------------ the ball
def test_the_ball_rebounds_at_e_times_one_plus_g_h_over_the_impact_speed():
    """Restitution acts on the velocity after the step's gravity, so a bounce restores
    e (u + g h) / u of the impact speed u = sqrt(2 g H) from the apex H before it (a gain of
    g h / u: 0.22% at h = 1e-3, 3.7% at 1/60 from the drop): within 1% of that on the first three
    bounces (the apexes sampled at the step), and e within the scene's tolerance on the first
    four. At e = 1 the rebound speeds grow by g h a bounce: H5/H0 = (1 + 5 g h / u0)^2, 1.40 at
    1/60."""
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
            if e == 1.0 and dt == 1 / 60:
                u0 = math.sqrt(2 * g * 1.0)
                assert abs(f.apex_ratio - (1 + 5 * g * dt / u0) ** 2) < 0.01 * f.apex_ratio, f.apex_ratio


def test_the_ball_sinks_one_steps_travel_before_its_contact_is_solved():
    """Contacts solved only once touching: the step the ball arrives it moves by that step's
    velocity alone, going into the plane by up to a step's travel, (u + g h) h (4.4 mm at 1 ms from
    1 m; measured 4.3 mm: the overshoot, reported apart); the next step the contact is solved, turning the ball, and it
    goes no deeper (no contactERP pushes it, in or out): the engine's impact depth is 0 and every
    figure at e = 1 is within tolerance."""
    dt = 1e-3
    scene, run = _run(MODE, "ball", dt, {"e": 1.0})
    f = contact_figures(scene, run)
    z, vz = run.centres[:, 0, 2] - scene.radius, run.velocities[:, 0, 2]
    firsts = np.nonzero((z[1:] < 0.0) & (z[:-1] >= 0.0))[0] + 1  # the first sample of each contact
    turns = np.nonzero((vz[:-1] < 0) & (vz[1:] > 0))[0] + 1
    assert len(firsts) >= 5 and np.array_equal(turns, firsts + 1)  # solved the step after it is found
    assert np.allclose(z[firsts], z[firsts - 1] + vz[firsts] * dt, rtol=0, atol=1e-15)  # no contact acted
    assert np.all(z[firsts + 1] > z[firsts])  # and the solve takes it no deeper
    u0 = math.sqrt(2 * 9.81 * 1.0)
    assert f.overshoot == pytest.approx(max(-z[firsts]), abs=1e-15)
    assert TOLERANCES.penetration < f.overshoot <= 1.01 * (u0 + 9.81e-3) * 1e-3, f.overshoot
    assert f.impact_depth == 0.0
    assert f.passes == {"restitution": True, "apex_ratio": True, "gain": True, "impact_depth": True}


# ----------------------------------------------------------------------------------------------- the slide
def test_the_slide_along_x_stops_within_tolerance_and_stays():
    for dt in REPORT_DTS:
        f = figures("slide", dt)
        assert f.passes["stop"] and f.passes["creep"], (dt, f.stop, f.creep)


def test_the_friction_cone_off_axis():
    """Pushed at 45 degrees, the cone stops the box within 1% of v0^2 / (2 mu g) (semi-implicit
    Euler's v0 h / 2 short of it); the pyramid's two rows (world x and y) each brake at mu g, so
    each component stops on its own: the box stops at v0^2 (|cos|^3 + |sin|^3) / (2 mu g), 1/sqrt 2
    of it at 45 degrees, and at 22.5 degrees veers v0^2 sin cos (cos - sin) / (2 mu g) off the
    line of the push. The cone alone, the controlled mode's other settings kept, gives the same
    as the default mode."""
    dt = 1e-3
    params = {"angle": 45.0}
    scene = make_contact_scene("slide", **params)
    reach = scene.truth()["stop"]
    cone = figures("slide", dt, params, mode=DEFAULT)
    assert abs(cone.stop - reach) < 0.01 * reach and cone.veer < TOLERANCES.creep, (cone.stop, cone.veer)
    assert abs(cone.stop - (reach - scene.v0 * dt / 2)) < 3e-4, cone.stop
    assert abs(figures("slide", dt, params, enableConeFriction=1).stop - cone.stop) < 1e-3
    pyramid = figures("slide", dt, params)
    assert abs(pyramid.stop - reach / math.sqrt(2)) < 0.01 * pyramid.stop, pyramid.stop
    assert pyramid.passes["stop"] is False
    a = math.radians(22.5)
    skew = figures("slide", dt, {"angle": 22.5})
    assert abs(skew.stop - reach * (math.cos(a) ** 3 + math.sin(a) ** 3)) < 0.02 * skew.stop, skew.stop
    veer = reach * math.sin(a) * math.cos(a) * (math.cos(a) - math.sin(a))
    assert abs(skew.veer - veer) < 0.03 * veer, skew.veer


def test_the_pyramid_brakes_with_friction_left_at_points_that_lift():
    """Along x the pyramid should brake as the cone does, yet stops short and does not converge
    with the step: the rocking box lifts contact points, and a point whose normal impulse ends
    the solve at zero keeps the friction impulse an earlier iteration gave it (the pyramid's row
    is skipped at zero normal; the cone's pair is clipped to zero). Summed over the slide the
    friction exceeds mu times the normal impulse by exactly that; the cone's does not."""
    mu = make_contact_scene("slide").mu
    normal, friction, lifted = _in_worker(bare_slide_impulses, 1e-3, 0)
    assert lifted > 0.005 * friction
    assert abs(friction - (mu * normal + lifted)) < 1e-3 * friction, (friction, mu * normal, lifted)
    normal, friction, lifted = _in_worker(bare_slide_impulses, 1e-3, 1)
    assert lifted == 0.0 and abs(friction - mu * normal) < 1e-3 * friction, (friction, mu * normal)


# -------------------------------------------------------------------------------------- bodies that turn
def test_quaternions_cross_the_api_as_x_y_z_w():
    import pybullet as p

    q = quat_mul(quat_about((1.0, 0.0, 0.0), 25.0), quat_about((0.0, 1.0, 0.0), 30.0))
    assert pose.to_pybullet(q) == [q[1], q[2], q[3], q[0]]
    assert pose.from_pybullet(pose.to_pybullet(q)) == list(q)
    for phi in (30.0, -50.0):
        turn = quat_about((0.0, 1.0, 0.0), phi)
        matrix = np.array(p.getMatrixFromQuaternion(pose.to_pybullet(turn))).reshape(3, 3)
        assert np.allclose(matrix, rotation(turn), atol=1e-15)
        r = math.radians(phi)
        assert np.allclose(matrix[:, 2], [math.sin(r), 0.0, math.cos(r)], atol=1e-15)


def test_the_angular_velocity_read_is_in_world_axes():
    """Bullet turns the base by its new angular velocity over each step, so the recorded
    orientations' step-to-step turn, q(n+1) q(n)^-1, is exp(omega(n+1) h) with omega in world axes:
    equal to roundoff where the box tumbles, and off the body-axes reading."""
    dt = 1 / 240
    _, run = _run(DEFAULT, "corner", dt)
    q, w = run.orientations[:, 0], run.angular[:, 0]
    world, body = [], []
    for n in np.nonzero(np.linalg.norm(w[1:], axis=1) > 1.0)[0]:
        d = quat_mul(q[n + 1], q[n] * np.array([1.0, -1.0, -1.0, -1.0]))
        d = d if d[0] >= 0 else -d
        turn = d[1:] / np.linalg.norm(d[1:]) * 2.0 * math.atan2(np.linalg.norm(d[1:]), d[0]) / dt
        world.append(np.linalg.norm(turn - w[n + 1]) / np.linalg.norm(w[n + 1]))
        body.append(np.linalg.norm(turn - rotation(q[n + 1]).T @ w[n + 1]) / np.linalg.norm(w[n + 1]))
    assert len(world) > 50 and max(world) < 1e-9 and np.median(body) > 0.05


@pytest.mark.parametrize("scene_id", ["edge", "corner", "tip", "roll"])
def test_each_turning_pose_is_the_bare_loop(scene_id):
    """The default mode's run equals a bare pybullet loop written here (the scene's quaternion
    turned to (x, y, z, w) by hand), and its figures are read off that loop by hand: the edge and
    the corner come to rest face down; the tip turns 30 degrees (read linearly between the steps
    that straddle it) within 5% of the pivot's time;
    the ball rolls semi-implicit Euler's 5/14 g sin(theta) T (T + h) without slipping, its moment
    2/5 m r^2."""
    dt = 1 / 240
    scene, run = _run(DEFAULT, scene_id, dt)
    bare, moment = _in_worker(bare_turning, scene_id, dt)
    assert np.allclose(run.centres[1:, 0], bare[:, 0:3], rtol=0, atol=1e-12)
    assert np.allclose(run.orientations[1:, 0], bare[:, 3:7], rtol=0, atol=1e-12)
    assert np.allclose(run.angular[1:, 0], bare[:, 10:13], rtol=0, atol=1e-12)
    got = scene.measure(run)
    centres, quats, v, w = bare[:, 0:3], bare[:, 3:7], bare[:, 7:10], bare[:, 10:13]
    t = dt * np.arange(1, len(bare) + 1)
    if scene_id in ("edge", "corner"):
        fastest = np.linalg.norm(v, axis=1) + math.sqrt(3.0) * scene.half * np.linalg.norm(w, axis=1)
        rest = t[np.nonzero(fastest >= STOPPED)[0][-1] + 1]
        assert got["rest_time"] == pytest.approx(rest, abs=1e-12) and rest <= scene.rest_by
        assert abs(centres[-1, 2] - scene.half) < 1e-4 and all(got["passes"].values()), got
    elif scene_id == "tip":
        x, y, z = quats[:, 1], quats[:, 2], quats[:, 3]
        wq = quats[:, 0]
        phi = np.degrees(np.arctan2(2 * (x * z + wq * y), 1 - 2 * (x * x + y * y)))
        phi, t = np.concatenate([[0.0], phi]), np.concatenate([[0.0], t])  # the start: upright at t = 0
        n = np.nonzero(phi >= TIP_ANGLE)[0][0]  # the first step at or past 30 degrees
        reached = t[n - 1] + (TIP_ANGLE - phi[n - 1]) / (phi[n] - phi[n - 1]) * dt  # between the two, linearly
        assert n > 1 and t[n - 1] < reached <= t[n]
        assert got["tip_time"] == pytest.approx(reached, abs=1e-12)
        assert abs(reached - pivot(math.radians(scene.angle), scene.half, scene.g)[0]) < 0.05 * reached
    else:
        assert moment[0] == pytest.approx(0.4 * scene.mass * scene.radius**2, rel=1e-12)
        a = scene.g * math.sin(math.radians(scene.angle))
        assert got["distance"] == pytest.approx(5 / 14 * a * scene.t_end * (scene.t_end + dt), rel=1e-9)
        assert np.max(np.abs(v[:, 0] - scene.radius * w[:, 1])) < 1e-9 and got["slip"] < 1e-9


def test_restitution_at_every_speed_keeps_a_dropped_box_bouncing_on_its_face():
    """The controlled mode applies restitution at every impact speed (threshold 0): a box dropped
    with e = 0.5 that has fallen onto its face keeps bouncing on the step's own g h approach and
    never comes to rest; pybullet's threshold of 0.2 m/s (the default mode's) lets it rest."""
    dt = 1 / 240
    scene, run = _run(MODE, "edge", dt)
    assert scene.measure(run)["rest_time"] is None
    scene, run = _run(MODE, "edge", dt, restitutionVelocityThreshold=0.2)
    assert scene.measure(run)["rest_time"] is not None


# ----------------------------------------------------------------------------------------- rest and stack
def test_rest_and_stack_hold_within_tolerance_to_1_240():
    for scene_id in ("rest", "stack"):
        for dt in REPORT_DTS[:2]:
            for mode in MODES:
                assert all(figures(scene_id, dt, mode=mode).passes.values()), (scene_id, dt, mode)


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


def test_pybullets_contact_erp_leaves_the_stack_moving_at_1_60():
    """contactERP at pybullet's 0.08 on the boxes leaves the stack at 1/60 moving: 0.012 J at the
    end, against 1.1e-5 at the controlled mode's 0.2."""
    assert figures("stack", 1 / 60, contactERP=None).kinetic > 1e-3
    assert figures("stack", 1 / 60).kinetic < 1e-4


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
    jitters and wanders (creep 0.44 m at h = 1e-3)."""
    assert figures("rest", 1e-3, contactBreakingThreshold=0.0).creep > 0.1


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
        "def creep(cbt):\n"
        "    m = dataclasses.replace(mode, settings={**mode.settings, 'contactBreakingThreshold': cbt})\n"
        "    return contact_figures(scene, pose.run(m, scene, 1e-3)).creep\n"
        "print(json.dumps([creep(None), creep(0.0), creep(None)]))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120, check=True)
    fresh, zero, after = json.loads(out.stdout.strip().splitlines()[-1])
    assert fresh < 1e-3 and zero > 0.1 and after == zero
