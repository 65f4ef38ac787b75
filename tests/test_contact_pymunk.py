"""pymunk's contact poses (``adapters.pymunk.contact``, 2-D), in both modes: every scene at the
three report steps, the exact velocity impulse of its rebound, the turning poses (edge, tip, roll)
against bare pymunk loops written here and against their closed forms, the sign of a turn in the
plane, the documented defaults the default mode reads back, and each default that changes the
answer (measured 2026-11-28 on pymunk 7.3.1; docs/engines.md)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

pymunk = pytest.importorskip("pymunk")

from adapters import CONTACT_MODES  # noqa: E402
from adapters.pymunk import contact as pose  # noqa: E402
from harness.contact.figures import contact_figures  # noqa: E402
from harness.contact.run import REPORT_DTS, run_contact  # noqa: E402
from scenarios.contact import PROFILES, TOLERANCES, make_contact_scene  # noqa: E402
from scenarios.contact_turning import TIP_ANGLE, pivot, quat_about, rotation  # noqa: E402

MODE = "pymunk:sequential_impulse"
DEFAULT = "pymunk:sequential_impulse?contact=default"
GAME = PROFILES["game"]


def stepped(scene_id, dt, params=None, mode_id=MODE, **changed):
    """The mode's run of a scene with ``changed`` settings (None: Chipmunk's default, not set)."""
    scene = make_contact_scene(scene_id, **(params or {}))
    mode = CONTACT_MODES[mode_id]
    if changed:
        mode = dataclasses.replace(mode, settings={**mode.settings, **changed})
    run = pose.run(mode, scene, dt)
    assert run.status == "ok", run.detail
    return scene, run


def figures(scene_id, dt, params=None, mode_id=MODE, tol=TOLERANCES, **changed):
    return contact_figures(*stepped(scene_id, dt, params, mode_id, **changed), tol)


def bare_space(gravity, slop=0.0, iterations=100):
    """A pymunk space as the stiff mode sets it, written out here: the plane a static segment along
    x, elasticity and friction 1 (a body's own combine with it by product)."""
    space = pymunk.Space()
    space.gravity = gravity
    space.collision_slop, space.iterations = slop, iterations
    plane = pymunk.Segment(space.static_body, (-50.0, 0.0), (50.0, 0.0), 0.0)
    plane.elasticity = plane.friction = 1.0
    space.add(plane)
    return space


def bare_box(space, half, mass, centre, angle=0.0, mu=1.0, e=0.0):
    body = pymunk.Body(mass, mass * (2 * half) ** 2 / 6.0)  # a square lamina's moment: the cube's 2/3 m half^2
    shape = pymunk.Poly.create_box(body, (2 * half, 2 * half))
    shape.friction, shape.elasticity = mu, e
    body.position, body.angle = centre, angle
    space.add(body, shape)
    return body


def arbiters(body) -> list:
    """The body's arbiters this step (each a pair of shapes Chipmunk found overlapping)."""
    found = []
    body.each_arbiter(found.append)
    return found


def incline(angle_deg, g=9.81):
    th = math.radians(angle_deg)
    return (g * math.sin(th), -g * math.cos(th))


@pytest.mark.parametrize("scene_id", ["ball", "slide", "rest", "stack"])
def test_every_scene_poses_at_the_report_steps(scene_id):
    for dt in REPORT_DTS:
        run = run_contact(MODE, scene_id, {}, dt, isolated=False)
        assert run.status == "ok", run.detail
        assert run.centres.shape == (run.steps + 1, make_contact_scene(scene_id).bodies, 3)
        assert not run.centres[:, :, 1].any() and not run.velocities[:, :, 1].any()  # the plane x-z
        assert run.loop_cpu_s is not None and run.settings["collision_slop (read back)"] == 0.0


@pytest.mark.parametrize("mode_id", [MODE, DEFAULT])
def test_every_turning_scene_poses_and_reads_turns_about_y(mode_id):
    """Edge, tip and roll run in both modes at the coarsest report step; the orientations read back
    are unit turns about y alone and the angular velocities about y alone."""
    for scene_id in ("edge", "tip", "roll"):
        run = run_contact(mode_id, scene_id, {}, REPORT_DTS[-1], isolated=False)
        assert run.status == "ok", run.detail
        q, w = run.orientations[:, 0], run.angular[:, 0]
        assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
        assert not q[:, 1].any() and not q[:, 3].any() and not w[:, 0].any() and not w[:, 2].any()
        assert np.abs(w[:, 1]).max() > 1.0, scene_id  # it turned


# ----------------------------------------------------------------------------------------- the signs of a turn
def test_a_turn_about_y_is_clockwise_in_pymunks_plane():
    """A rotation about +y by phi maps body z to (sin phi, 0, cos phi); pymunk's plane is the scene's
    (x, z), so that turn is clockwise there: body.angle = -phi, whose body y axis (the scene's z)
    pymunk itself maps to (sin phi, cos phi). Read back, the angle gives the quaternion again."""
    for phi_deg in (30.0, -50.0, 135.0):
        phi = math.radians(phi_deg)
        q = quat_about((0.0, 1.0, 0.0), phi_deg)
        angle = pose.pymunk_angle(q)
        assert angle == pytest.approx(-phi, abs=1e-15)
        body = pymunk.Body(1.0, 1.0)
        body.angle = angle
        up = body.local_to_world((0.0, 1.0))
        assert (up.x, up.y) == pytest.approx((math.sin(phi), math.cos(phi)), abs=1e-15)
        back = np.array(pose.scene_orientation(angle))
        assert np.allclose(back, q, atol=1e-15)
        assert np.allclose(rotation(back) @ [0.0, 0.0, 1.0], [math.sin(phi), 0.0, math.cos(phi)], atol=1e-15)


def test_a_box_tipping_downhill_turns_clockwise_in_pymunk_and_reads_phi_increasing():
    """The tip tips its top downhill (+x): in a bare pymunk loop the body's angle falls (clockwise),
    and the harness reads the rotation about y rising, with angular velocity about +y."""
    scene, run = stepped("tip", 1 / 240)
    space = bare_space(incline(scene.angle))
    body = bare_box(space, scene.half, scene.mass, (0.0, scene.half), mu=scene.mu)
    angles = []
    for _ in range(40):
        space.step(1 / 240)
        angles.append(body.angle)
    assert np.all(np.diff(angles[2:]) < 0.0) and angles[-1] < -0.01
    rot = rotation(run.orientations[:41, 0])
    phi = np.arctan2(rot[:, 0, 2], rot[:, 2, 2])
    assert np.allclose(phi[1:], -np.array(angles), atol=1e-12)
    assert np.all(run.angular[3:41, 0, 1] > 0.0)


# ----------------------------------------------------------------------------------------- the turning scenes
def test_the_edge_drop_rests_on_a_face_as_a_bare_loop_does():
    """The box dropped on an edge (leaning 30 degrees about y: pymunk angle -30 degrees) topples onto
    a face and rests; the rest time, tilt and energy rises computed here from a bare pymunk loop are
    the harness's: the rise from the first step a corner is within 1e-3 half of the plane on,
    relative to the energy there, and the free fall's before it, each a fraction of what the box
    has to lose (the square's lowest corner is half (|cos a| + |sin a|) below its centre)."""
    dt = 1 / 240
    scene, run = stepped("edge", dt)
    f = contact_figures(scene, run)
    space = bare_space((0.0, -scene.g))
    low = scene.half * (math.cos(math.radians(30)) + math.sin(math.radians(30)))
    body = bare_box(space, scene.half, scene.mass, (0.0, scene.h0 + low), -math.radians(30), scene.mu, scene.e)
    moment = 2.0 / 3.0 * scene.mass * scene.half**2
    states = [(*body.position, *body.velocity, body.angle, body.angular_velocity)]
    for _ in range(run.steps):
        space.step(dt)
        states.append((*body.position, *body.velocity, body.angle, body.angular_velocity))
    x, z, vx, vz, angle, w = np.array(states).T
    energy = 0.5 * scene.mass * (vx**2 + vz**2) + 0.5 * moment * w**2 + scene.mass * scene.g * z
    lose = energy[0] - scene.mass * scene.g * scene.half
    lowest = z - scene.half * (np.abs(np.cos(angle)) + np.abs(np.sin(angle)))
    k = np.nonzero(lowest <= 1e-3 * scene.half)[0][0]  # first contact
    rise = (energy[k:] - energy[k]).max() / lose
    flight = (energy[: k + 1] - energy[0]).max() / lose
    fastest = np.hypot(vx, vz) + np.abs(w) * math.sqrt(3) * scene.half
    rest_i = np.nonzero(fastest >= 1e-3)[0][-1] + 1
    tilt = abs(math.degrees(angle[-1])) % 90.0
    assert 0 < k < len(z) - 1
    # The bare box's moment rounds otherwise than the pose's: the runs part by 2e-9 of the rise after the bounces.
    assert f.energy_rise == pytest.approx(rise, rel=1e-8) and f.flight_rise == pytest.approx(flight, rel=1e-9)
    assert f.rest_time == pytest.approx(rest_i * dt, abs=1e-12) and f.rest_time <= scene.rest_by
    assert f.tilt == pytest.approx(min(tilt, 90.0 - tilt), abs=1e-6) and f.tilt < 0.01  # acos resolves 1e-6 deg
    assert f.sink == pytest.approx(max(0.0, scene.half - z[-1]), abs=1e-7)  # the start's roundoff, grown


def test_the_edge_drops_energy_rises_are_its_free_flights_before_and_after_it_lands():
    """The edge's energy rises at 1/240 and 1/60 are no contact's: Chipmunk moves positions first, so
    in free flight a body's velocity runs ahead of its height, its energy rising g^2 h^2 / 2 a step
    per unit mass. The fall before first contact (``flight_rise``) is largest the step before the box
    touches, g^2 h t / 2, to roundoff; first contact is the step the box first turns (positions
    move, then the impulse acts). From there (``energy_rise``) the edge rebounds and the box flies
    clear until it lands again: once the bias has pushed the landing's overlap out (the step or two
    after it, worth under four steps of flight), every step of that flight gains exactly
    g^2 h^2 / 2, and the rise is largest the step before it lands again: still ✗ (1.3% of what the
    box loses at 1/240, 5.6% at 1/60)."""
    for dt in (1 / 240, 1 / 60):
        scene, run = stepped("edge", dt)
        f = contact_figures(scene, run)
        z, v, w = run.centres[:, 0, 2], run.velocities[:, 0], run.angular[:, 0, 1]
        q = run.orientations[:, 0]
        angle = 2.0 * np.arctan2(q[:, 2], q[:, 0])  # the turn about y
        touch = z - scene.half * (np.abs(np.cos(angle)) + np.abs(np.sin(angle))) <= 1e-3 * scene.half
        k = int(np.nonzero(touch)[0][0])
        assert k == int(np.nonzero(w)[0][0])  # first contact: the first step the box turns
        moment = 2.0 / 3.0 * scene.mass * scene.half**2
        energy = 0.5 * scene.mass * np.sum(v * v, axis=1) + 0.5 * moment * w**2 + scene.mass * scene.g * z
        lose = scene.mass * scene.g * (z[0] - scene.half)
        step = 0.5 * scene.mass * scene.g**2 * dt**2
        assert f.flight_rise == pytest.approx(0.5 * scene.mass * scene.g**2 * dt * run.t[k - 1] / lose, rel=1e-9)
        off = k + int(np.nonzero(~touch[k:])[0][0])  # the first step clear of the plane after first contact
        on = off + int(np.nonzero(touch[off:])[0][0])  # the step it lands again
        assert on - off > 5
        assert np.allclose(np.diff(energy)[off : on - 1], step, rtol=1e-6, atol=0.0)  # free flight
        assert 0.0 < energy[off] - energy[k] < 4.0 * step  # the bias pushing the landing's overlap out
        assert f.energy_rise == pytest.approx((energy[on - 1] - energy[k]) / lose, rel=1e-9)
        assert f.energy_rise > TOLERANCES.gain and not f.passes["energy_rise"]


def test_the_tip_time_is_the_pivots_and_a_bare_loops():
    """At 1 ms the box on a 50-degree incline reaches 30 degrees within 0.5% of the pivot's energy
    integral (measured 0.17%; the square lamina's moment about its centre, m (2a)^2 / 6, is the
    cube's, so the 3-D pivot applies); the time is the one a bare pymunk loop reaches -30 degrees
    of angle, read linearly between the two steps that straddle it (the first step past it is up to
    a step later)."""
    dt = 1e-3
    scene, run = stepped("tip", dt)
    f = contact_figures(scene, run)
    truth = pivot(math.radians(scene.angle), scene.half, scene.g)[0]
    assert f.tip_time == pytest.approx(truth, rel=5e-3) and all(f.passes.values())
    space = bare_space(incline(scene.angle))
    body = bare_box(space, scene.half, scene.mass, (0.0, scene.half), mu=scene.mu)
    phi = [0.0]
    while phi[-1] < TIP_ANGLE:
        space.step(dt)
        phi.append(math.degrees(-body.angle))
    n = len(phi) - 1  # the first step at or past 30 degrees
    crossed = (n - 1 + (TIP_ANGLE - phi[n - 1]) / (phi[n] - phi[n - 1])) * dt
    assert (n - 1) * dt < crossed <= n * dt
    # The bare box's moment rounds otherwise than the pose's: the runs part by 1e-9 degrees by then.
    assert f.tip_time == pytest.approx(crossed, abs=1e-10)


def test_the_pivot_slips_a_step_of_downhill_fall_each_step_it_leaves_the_plane():
    """At 1/60 the pivot edge slips 2-4 mm before 30 degrees (✗ robotics): position-first steps
    lift the turning edge off the plane now and then, Chipmunk counts only an overlap as a contact,
    and each step with no contact the box falls freely, g sin(theta) h^2 = 2.1 mm down the slope.
    Counted in a bare loop, those steps are the slip (to 15%), in both modes."""
    dt = 1 / 60
    for mode_id, slop, iterations in ((MODE, 0.0, 100), (DEFAULT, 0.005, 10)):
        scene, run = stepped("tip", dt, mode_id=mode_id)
        f = contact_figures(scene, run)
        space = bare_space(incline(scene.angle), slop, iterations)
        body = bare_box(space, scene.half, scene.mass, (0.0, scene.half), mu=scene.mu)
        free = 0
        while math.degrees(-body.angle) < TIP_ANGLE:
            space.step(dt)
            free += not any(len(arbiter.contact_point_set.points) for arbiter in arbiters(body))
        fall = scene.g * math.sin(math.radians(scene.angle)) * dt**2
        assert free >= 1 and free * fall <= f.pivot_slip <= 1.15 * free * fall, (mode_id, free, f.pivot_slip)
        assert not f.passes["pivot_slip"] and contact_figures(scene, run, GAME).passes["pivot_slip"]


def test_the_ball_rolls_5_14_g_sin_theta_t2_with_the_spheres_moment():
    """The rolling ball's moment is set to the solid sphere's 2/5 m r^2 (read back): at 1 ms it rolls
    within 0.2% of 5/14 g sin(theta) t^2, as a bare loop does; with pymunk's moment_for_circle (a
    disc's 1/2 m r^2) it would roll 1/3 g sin(theta) t^2, 7% shorter. It rolls toward +x turning
    about +y (clockwise in pymunk)."""
    dt = 1e-3
    scene, run = stepped("roll", dt)
    f = contact_figures(scene, run)
    assert run.settings["moment (read back)"] == pytest.approx(0.4 * scene.mass * scene.radius**2, rel=1e-15)
    assert f.distance == pytest.approx(scene.truth()["distance"], rel=2e-3) and all(f.passes.values())
    assert np.all(run.angular[2:, 0, 1] > 0.0)

    def bare(moment):
        space = bare_space(incline(scene.angle))
        body = pymunk.Body(scene.mass, moment)
        ball = pymunk.Circle(body, scene.radius)
        ball.friction = scene.mu
        body.position = (0.0, scene.radius)
        space.add(body, ball)
        for _ in range(round(scene.t_end / dt)):
            space.step(dt)
        return body.position.x

    assert f.distance == pytest.approx(bare(0.4 * scene.mass * scene.radius**2), abs=1e-12)
    disc = bare(pymunk.moment_for_circle(scene.mass, 0.0, scene.radius))
    sin_t = math.sin(math.radians(scene.angle))
    assert disc == pytest.approx(scene.g * sin_t * scene.t_end**2 / 3.0, rel=2e-3)


def test_the_rolls_slip_is_its_first_steps_fall_and_its_distance_lags_a_step():
    """The roll's start and its distance at 1/60 are the start and the integrator, not the rolling: a circle
    exactly touching a segment is no contact to Chipmunk (a circle must overlap; a box exactly
    touching is one), so the ball placed touching falls freely
    for one step, its contact point slipping g sin(theta) h; from the next step on it rolls without
    slipping (to 1e-12 m/s). Its distance is position-first Euler's, a (t^2 - t h) / 2 for the
    closed form's a t^2 / 2: 1.6% short at 1/60."""
    for dt in (1 / 240, 1 / 60):
        scene, run = stepped("roll", dt)
        f = contact_figures(scene, run)
        slip = run.velocities[:, 0, 0] - scene.radius * run.angular[:, 0, 1]
        sin_t = math.sin(math.radians(scene.angle))
        assert slip[1] == pytest.approx(scene.g * sin_t * dt, rel=1e-12) and f.start_slip == slip[1]
        assert np.abs(slip[2:]).max() < 1e-12 and f.slip < 1e-12  # judged once rolling (from settle on)
        t = scene.t_end
        assert f.distance == pytest.approx(scene.truth()["distance"] * (1.0 - dt / t), rel=1e-3)


def test_the_planar_modes_refuse_a_corner_and_a_push_off_x_saying_why():
    for mode_id in (MODE, DEFAULT):
        mode = CONTACT_MODES[mode_id]
        ok, why = mode.supports(make_contact_scene("corner"))
        assert not ok and "planar" in why and "about an axis other than y" in why
        ok, why = mode.supports(make_contact_scene("slide", angle=45.0))
        assert not ok and "planar" in why and "y component" in why
        assert mode.supports(make_contact_scene("slide", angle=180.0)) == (True, "")
        assert mode.supports(make_contact_scene("edge")) == (True, "")


# ----------------------------------------------------------------------------------------- the rebound and the rest
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
    the bias that pushes the overlap out adds 0.1-0.2% a bounce), no bounce gaining. The ball lands
    inside the plane (no speculative contact), but positions move first and the impulse then turns
    it: each step that first finds it under the plane is a step it turns at, the deepest of that
    contact, so the engine adds no depth (impact depth 0, ✓). That first sample's depth, where in
    the step it met the plane times u h, is the overshoot: not the first impact's at every step (at
    1/240, e 0.8, the third's)."""
    for e, within in ((0.8, 0.01), (1.0, 0.003)):
        for dt in REPORT_DTS:
            scene, run = stepped("ball", dt, {"e": e})
            f = contact_figures(scene, run)
            assert all(abs(r - e) <= within for r in f.restitution), (e, dt, f.restitution)
            assert f.passes["restitution"] and f.passes["apex_ratio"] and f.passes["gain"], (e, dt, f.passes)
            z = run.centres[:, 0, 2] - scene.radius
            vz = run.velocities[:, 0, 2]
            turns = np.nonzero((vz[:-1] < 0) & (vz[1:] > 0))[0] + 1
            firsts = np.nonzero((z[1:] < 0.0) & (z[:-1] >= 0.0))[0] + 1  # the first sample of each contact
            assert len(firsts) >= 5 and np.array_equal(firsts, turns), (e, dt)
            added = 0.0
            for i in firsts:
                j = i
                while j < len(z) and z[j] < 0.0:
                    j += 1
                added = max(added, -z[i:j].min() + z[i])
            assert added == 0.0 and f.impact_depth == 0.0 and f.passes["impact_depth"], (e, dt, f.impact_depth)
            assert f.overshoot == pytest.approx(max(-z[firsts]), abs=1e-15)
            assert 0.0 < f.overshoot <= math.sqrt(2 * scene.g * scene.h0) * dt


def test_the_slide_stops_and_the_box_rests_at_every_report_step():
    for dt in REPORT_DTS:
        assert all(figures("slide", dt).passes.values()), dt
        f = figures("rest", dt)
        assert all(f.passes.values()) and f.penetration == 0.0 and f.transient == 0.0, (dt, f.penetration)


def test_the_stack_holds_within_tolerance_to_1_240_and_under_the_game_profile_at_1_60():
    for dt in REPORT_DTS[:2]:
        assert all(figures("stack", dt).passes.values()), dt
    f = figures("stack", 1 / 60, tol=GAME)
    assert all(f.passes.values()) and f.penetration < 2e-4, f.passes
    assert f.by_profile["robotics"]["creep"] is False  # it moves 1.2 mm sideways while it settles


def test_the_stacks_transient_is_one_step_of_free_fall_through_a_roundoff_gap():
    """The stack's start reaches g h^2 into the box below at every report step, exactly. The scene
    places the middle box at 3 half = 0.30000000000000004 m, its bottom a roundoff above the lower
    box's top: a gap, which to Chipmunk is no contact (boxes that overlap or exactly touch are), so
    the upper boxes fall freely for the first step. A bare loop: at 3 x 0.1 the middle box falls
    g h that step; at 0.3 (a roundoff of overlap), or exactly touching (half 0.125, exact in
    binary), it is held from the first step. Judged only once settled."""
    for dt in REPORT_DTS:
        f = figures("stack", dt)
        assert f.transient == pytest.approx(9.81 * dt * dt, rel=1e-9), dt
        assert f.penetration < 0.06 * f.transient

    def first_step(half, middle_z):
        space = bare_space((0.0, -9.81))
        lower = bare_box(space, half, 1.0, (0.0, half))
        middle = bare_box(space, half, 1.0, (0.0, middle_z))
        space.step(1 / 60)
        return lower.velocity.y, middle.velocity.y

    assert 3 * 0.1 - 0.1 > 0.1 + 0.1 and 0.3 - 0.1 < 0.1 + 0.1 and 3 * 0.125 - 0.125 == 0.125 + 0.125
    lower, middle = first_step(0.1, 3 * 0.1)
    assert lower == 0.0 and middle == pytest.approx(-9.81 / 60, rel=1e-12)
    for half, middle_z in ((0.1, 0.3), (0.125, 3 * 0.125)):
        lower, middle = first_step(half, middle_z)
        assert abs(lower) < 1e-6 and abs(middle) < 1e-6, (half, middle_z)


# ----------------------------------------------------------------------------------------- the default mode
def test_the_default_mode_reads_back_chipmunks_defaults_and_a_5_mm_slop():
    """Every space setting of ``?contact=default`` but the slop is left unset and reads back what a
    fresh pymunk.Space() has: 10 iterations, collision_bias (1 - 0.1)^60 (in Chipmunk's float
    arithmetic), persistence 3, damping 1, sleeping off; the slop is the 5 mm set."""
    _, run = stepped("rest", 1 / 60, mode_id=DEFAULT)
    s, fresh = run.settings, pymunk.Space()
    assert s["collision_slop (read back)"] == 0.005 and fresh.collision_slop == pytest.approx(0.1, rel=1e-7)
    for name in ("iterations", "collision_bias", "collision_persistence", "damping", "sleep_time_threshold"):
        assert s[f"{name} (read back)"] == getattr(fresh, name), name
        assert s[name] == "Chipmunk's default, not set", name
    assert s["iterations (read back)"] == 10 and s["collision_persistence (read back)"] == 3
    assert s["collision_bias (read back)"] == pytest.approx(0.9**60, rel=1e-5)
    assert s["damping (read back)"] == 1.0 and s["sleep_time_threshold (read back)"] == math.inf


def test_the_default_mode_rests_within_its_slop_and_its_stack_sways_at_1_60():
    """With a 5 mm slop the bias leaves the box's first sink alone: it rests 1.8 mm in the plane at
    1/60 (✓ game, ✗ robotics), its settled depth its start's. Ten iterations do not hold the stack
    still at 1/60: it sways sideways and sinks past 5 mm (✗ game)."""
    f = figures("rest", 1 / 60, mode_id=DEFAULT, tol=GAME)
    assert 1e-3 < f.penetration < 5e-3 and f.penetration == pytest.approx(f.transient, rel=0.01)
    assert all(f.passes.values()) and not f.by_profile["robotics"]["penetration"]
    f = figures("stack", 1 / 60, mode_id=DEFAULT, tol=GAME)
    assert f.creep > 5e-3 and not f.passes["creep"]


# ------------------------------------------------------------------------- each default that changes the answer
def test_ten_iterations_sink_a_box_at_rest_at_the_start_and_sway_the_stack():
    """Chipmunk's default 10 iterations (slop 0) sink the box placed on the plane 1.7 mm at the start
    at 1/60 and sway it 1 mm sideways; the bias pushes the overlap out by the time the box is judged
    settled (0.11 mm). The stack of three at 1/60 sways 1 cm and keeps moving (✗ under both
    profiles). With 100 iterations the box never leaves the surface."""
    f = figures("rest", 1 / 60, iterations=None)
    assert f.transient > 1e-3 and f.creep > 5e-4 and f.penetration < 0.1 * f.transient
    f = figures("rest", 1 / 60)
    assert f.transient == 0.0 and f.penetration == 0.0 and f.creep < 1e-15
    f = figures("stack", 1 / 60, iterations=None, tol=GAME)
    assert f.creep > 5e-3 and f.kinetic > 1e-6 and not f.passes["creep"] and not f.passes["kinetic"]


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
