"""The scenes whose bodies turn (``scenarios.contact_turning``): their truths by independent routes
(the tip's pivot time by integrating the pendulum's equation of motion step by step, not by its
energy integral; the roll's closed form from Newton's laws for a sphere), and their judges on
synthetic runs whose figures are known by construction. The engines' poses of them are tested in
each engine's tests/test_contact_<engine>.py against a bare loop of that engine.

Tolerances: the pivot time against an adaptive integration to 1e-10 relative: 1e-7 relative; the
judges' figures on synthetic runs: exact to roundoff, or to the sampling step where a figure is
read at a recorded step."""

from __future__ import annotations

import math

import numpy as np
import pytest

from records.contact import ContactTrajectory
from records import InvalidInput
from scenarios import make_scene
from scenarios.contact_turning import TIP_ANGLE, cube_corners, pivot, quat_about, rotation


def _run(scene, t, centres, velocities, quats, spins):
    return ContactTrajectory.of(
        scene,
        "synthetic",
        float(t[1] - t[0]),
        t,
        np.asarray(centres)[:, None],
        np.asarray(velocities)[:, None],
        orientations=np.asarray(quats)[:, None],
        angular=np.asarray(spins)[:, None],
    )


@pytest.mark.parametrize("angle", [46.0, 50.0, 60.0])
def test_the_pivot_time_is_the_pendulums_integrated_step_by_step(angle):
    from scipy.integrate import solve_ivp

    theta, a, g = math.radians(angle), 0.1, 9.81
    inertia = 8.0 / 3.0 * a * a  # about the edge, per unit mass: 2/3 a^2 + (a sqrt 2)^2

    def rhs(t, y):
        return [y[1], g * a * math.sqrt(2.0) * math.sin(y[0] + theta - math.pi / 4) / inertia]

    def reached(t, y):
        return y[0] - math.radians(TIP_ANGLE)

    reached.terminal = True
    sol = solve_ivp(rhs, (0.0, 10.0), [0.0, 0.0], events=reached, rtol=1e-12, atol=1e-14, method="DOP853")
    assert pivot(theta, a, g)[0] == pytest.approx(sol.t_events[0][0], rel=1e-7)


def test_the_tip_refuses_an_incline_its_edge_cannot_hold_and_a_box_that_would_slide():
    with pytest.raises(InvalidInput, match="lets the edge slip"):
        make_scene("tip", angle=65.0)
    with pytest.raises(InvalidInput, match="lets the box slide"):
        make_scene("tip", angle=40.0, mu=0.5)
    with pytest.raises(InvalidInput, match="lets the ball slip"):
        make_scene("roll", angle=40.0, mu=0.1)


def test_the_tip_judge_reads_the_turn_about_y_from_the_quaternion():
    """A box turning about its downhill edge at the pivot's own rate (its centre carried about the
    edge): tipped, at the truth's time to the sampling step, its edge not slipping; the same turn
    the other way (-y) has not tipped."""
    scene = make_scene("tip")
    a, t_tip = scene.half, scene.truth()["tip_time"]
    t = np.linspace(0.0, scene.duration, 4001)
    phi = np.radians(TIP_ANGLE) * (t / t_tip) ** 2  # reaches TIP_ANGLE at t_tip, past 90 degrees by the end
    quats = np.array([quat_about((0.0, 1.0, 0.0), math.degrees(p)) for p in phi])
    edge = np.array([a, 0.0, 0.0])
    centres = edge + np.einsum("nij,j->ni", rotation(quats), np.array([-a, 0.0, a]))
    zeros = np.zeros_like(centres)
    f = scene.measure(_run(scene, t, centres, zeros, quats, zeros))
    assert f["tipped"] and f["tip_time"] == pytest.approx(t_tip, abs=2 * (t[1] - t[0]))
    assert f["pivot_slip"] < 1e-12 and all(f["passes"].values())
    back = np.array([quat_about((0.0, -1.0, 0.0), math.degrees(p)) for p in phi])
    g = scene.measure(_run(scene, t, centres, zeros, back, zeros))
    assert not g["tipped"] and g["tip_time"] is None and not g["passes"]["tipped"]


def test_the_roll_judge_on_the_closed_form_and_on_a_slide():
    """Rolling without slipping (omega_y = v / r): the distance 5/14 g sin(theta) t^2 and no slip;
    the same centre motion with the ball not turning slips at its full speed."""
    scene = make_scene("roll")
    r, acc = scene.radius, 5.0 / 7.0 * scene.g * math.sin(math.radians(scene.angle))
    t = np.linspace(0.0, scene.duration, 2001)
    x, v = 0.5 * acc * t**2, acc * t
    centres = np.stack([x, 0 * t, 0 * t + r], axis=1)
    vel = np.stack([v, 0 * t, 0 * t], axis=1)
    spins = np.stack([0 * t, v / r, 0 * t], axis=1)
    quats = np.array([quat_about((0.0, 1.0, 0.0), math.degrees(xi / r)) for xi in x])
    f = scene.measure(_run(scene, t, centres, vel, quats, spins))
    assert f["distance"] == pytest.approx(scene.truth()["distance"], rel=1e-12) and f["slip"] < 1e-12
    assert all(f["passes"].values())
    g = scene.measure(_run(scene, t, centres, vel, quats, 0 * spins))
    assert g["slip"] == pytest.approx(v[-1]) and not g["passes"]["slip"]


def test_the_drop_judge_rests_a_box_on_a_face_and_catches_an_energy_gain():
    """The edge drop's box brought to rest on a face: at rest from where its speed stops, tilt 0,
    no sink, no rise, every figure ✓; a spin left at the end is no rest; an energy above its value
    at first contact is a rise, as a fraction of what the box has to lose to rest on a face, and
    one in the fall before is the flight's, apart."""
    scene = make_scene("edge")
    t = np.linspace(0.0, scene.duration, 3001)
    z0, half = scene.initial_centres()[0][2], scene.half
    fall = np.clip(t / 0.5, 0.0, 1.0)
    z = z0 + (half - z0) * fall
    q0, q1 = np.array(scene.initial_orientations()[0]), np.array([1.0, 0.0, 0.0, 0.0])
    quats = np.array([(1 - s) * q0 + s * q1 for s in fall])
    vz = np.where(t < 0.5, (half - z0) / 0.5, 0.0)
    centres = np.stack([0 * t, 0 * t, z], axis=1)
    vel = np.stack([0 * t, 0 * t, vz], axis=1)
    spins = np.zeros_like(vel)
    f = scene.measure(_run(scene, t, centres, vel, quats, spins))
    assert f["rest_time"] == pytest.approx(0.5, abs=2 * (t[1] - t[0])) and f["tilt"] < 1e-6
    assert f["sink"] == 0.0 and f["energy_rise"] == 0.0 and all(f["passes"].values())
    spun = spins.copy()
    spun[-1, 2] = 1.0
    g = scene.measure(_run(scene, t, centres, vel, quats, spun))
    assert g["rest_time"] is None and not g["passes"]["rest_time"] and not g["passes"]["kinetic"]
    thrown = vel.copy()
    thrown[10, 0] = 4.0  # in the fall, before any corner reaches the plane: the flight's rise
    thrown[2000, 0] = 1.0  # resting on its face: a rise above its energy at first contact
    h = scene.measure(_run(scene, t, centres, thrown, quats, spins))
    lowest = centres[:, 2] + np.min(np.einsum("nij,kj->nki", rotation(quats), cube_corners(half))[:, :, 2], axis=1)
    k = int(np.argmax(lowest <= 1e-3 * half))
    assert 10 < k < 2000
    lose = scene.energy(centres[0], thrown[0]) - scene.mass * scene.g * half
    rise = (scene.energy(centres[2000], thrown[2000]) - scene.energy(centres[k], thrown[k])) / lose
    flight = (scene.energy(centres[10], thrown[10]) - scene.energy(centres[0], thrown[0])) / lose
    assert h["energy_rise"] == pytest.approx(float(rise)) and rise > 0 and not h["passes"]["energy_rise"]
    assert h["flight_rise"] == pytest.approx(float(flight)) and flight > 0


def test_a_pose_that_recorded_no_turning_is_said_so():
    scene = make_scene("roll")
    t = np.linspace(0.0, 1.0, 11)
    run = ContactTrajectory.of(scene, "m", 0.1, t, np.zeros((11, 1, 3)), np.zeros((11, 1, 3)))
    f = scene.measure(run)
    assert f["distance"] is None and "no orientations" in f["detail"] and not any(f["passes"].values())


def test_a_planar_pose_refuses_a_turn_out_of_its_plane():
    from adapters import TURNING_BOX, ContactMode

    mode = ContactMode("flat", "m", "pymunk", run=None, poses={"edge": TURNING_BOX, "corner": TURNING_BOX}, dims=2)
    assert mode.supports(make_scene("edge")) == (True, "")
    ok, why = mode.supports(make_scene("corner"))
    assert not ok and "about an axis other than y" in why


def test_the_energy_counts_the_turning():
    scene = make_scene("roll")
    q, v = scene.initial_state()
    spin = np.array([0.0, 10.0, 0.0])
    assert scene.energy(q, v, spin) - scene.energy(q, v) == pytest.approx(0.5 * 0.4 * scene.radius**2 * 100.0)
