"""Drake's contact poses (``adapters/drake/contact.py``): every mode poses every scene, the figures
measured to hold hold, Drake's traps (SAP's default dissipation kills the bounce; the default
point stiffness launches the explicit integrator) are caught, the default and hydroelastic
contacts are what their settings say (read back from the plant and the scene graph), and the
turning poses are checked against closed forms and a bare pydrake loop written here."""

import math

import numpy as np
import pytest

pytest.importorskip("pydrake")

from adapters import CONTACT_MODES  # noqa: E402
from adapters.drake import contact as drake_contact  # noqa: E402
from harness.contact.figures import contact_figures  # noqa: E402
from harness.contact.run import REPORT_DTS, run_contact  # noqa: E402
from scenarios.contact import STOPPED, apexes, make_contact_scene  # noqa: E402
from scenarios.contact_turning import Edge, cube_corners, pivot, quat_about, quat_mul, rotation  # noqa: E402

MODES = ("drake:tamsi", "drake:sap", "drake:continuous")
DEFAULT = "drake:lagged?contact=default"
HYDRO = ("drake:lagged?contact=hydroelastic", "drake:similar?contact=hydroelastic")


def figures(mode, scene, params, dt):
    run = run_contact(mode, scene, params, dt, isolated=False)
    return run, contact_figures(make_contact_scene(scene, **params), run)


def test_every_mode_poses_every_scene_the_turning_ones_too():
    drake = {mid: m for mid, m in CONTACT_MODES.items() if mid.startswith("drake:")}
    assert set(drake) == {*MODES, DEFAULT, *HYDRO}
    for mode in drake.values():
        assert set(mode.scenes) >= {"ball", "slide", "rest", "stack", "edge", "corner", "tip", "roll"}


@pytest.mark.parametrize("dt", REPORT_DTS)
@pytest.mark.parametrize("mode", MODES)
def test_the_ball_runs_at_every_report_step(mode, dt):
    run, f = figures(mode, "ball", {}, dt)
    # RK3 at 1/60 s (h omega_c = 3.3, past its limit 2.51) throws the ball: a measured failure, not a crash.
    assert run.status in ("ok", "unstable"), run.detail
    assert run.settings["contact_model"].startswith("kPoint")
    if run.status == "ok":
        assert f.cpu_per_s > 0 and len(f.restitution) == 5


@pytest.mark.slow  # every mode on every box scene: the figures are held by the tests below
@pytest.mark.parametrize("scene", ["slide", "rest", "stack"])
@pytest.mark.parametrize("mode", MODES + (DEFAULT, *HYDRO))
def test_the_boxes_run(mode, scene):
    run, f = figures(mode, scene, {} if scene == "slide" else {"t_end": 1.0}, 1 / 1000)
    assert run.status == "ok", run.detail
    assert run.centres.shape[1] == make_contact_scene(scene).bodies
    if scene != "slide":  # every contact holds a box at rest at 1 ms (measured: sink below 0.3 mm a box)
        assert f.passes["creep"] and f.passes["kinetic"], (mode, f.passes)


def test_rk3_keeps_a_perfectly_elastic_bounce_at_1ms():
    # Measured (drake 1.51.1): 0.9974..1.001 a bounce, H5/H0 0.9913.
    _, f = figures("drake:continuous", "ball", {"e": 1.0}, 1 / 1000)
    assert all(abs(x - 1.0) < 0.01 for x in f.restitution), f.restitution
    assert not f.gained


def test_the_discrete_plants_stop_the_slide_and_hold_the_box():
    # Measured: stop 0.3913..0.4067 m against 0.4077 (within 5% at each step), creep < 4e-6 m;
    # the box at rest sinks 0.25 mm (g / omega_c^2) at 1 ms.
    for mode in ("drake:tamsi", "drake:sap"):
        for dt in REPORT_DTS:
            _, f = figures(mode, "slide", {}, dt)
            assert f.passes["stop"] and f.passes["creep"], (mode, dt, f.stop, f.creep)
        _, f = figures(mode, "rest", {}, 1 / 1000)
        assert f.passes == {"penetration": True, "creep": True, "sink": True, "kinetic": True}
        assert f.penetration == pytest.approx(9.81 / drake_contact.OMEGA_C**2, rel=0.1)


def test_a_ball_resting_in_the_contact_has_no_apex():
    """TAMSI at 1/60 s: after two bounces the ball rests in the soft contact, its highest point after
    the third impact below the surface (measured -1.5e-4 m). That is no apex: no bounce is counted
    as gaining on it, and the bounces it did not make restore nothing."""
    scene = make_contact_scene("ball")
    run = drake_contact.run(CONTACT_MODES["drake:tamsi"], scene, 1 / 60)
    z = run.centres[:, 0, 2] - scene.radius
    raw, _ = apexes(z, run.velocities[:, 0, 2], 2e-3 + 1e-3 * scene.h0)
    assert min(raw) <= 0.0, raw
    f = contact_figures(scene, run)
    assert f.gained == [] and f.restitution[-1] == 0.0, (f.gained, f.restitution)


def test_the_dissipation_is_derived_from_e():
    # Hunt & Crossley: d v is a function of e alone; e = 1 is no dissipation, and less e needs more.
    v = math.sqrt(2 * 9.81)
    assert drake_contact.hunt_crossley_for(1.0, v) == 0.0
    assert 0 < drake_contact.hunt_crossley_for(0.9, v) < drake_contact.hunt_crossley_for(0.8, v)
    # Kelvin-Voigt without the cut-off would be zeta = -ln e / sqrt(pi^2 + ln^2 e); the cut-off
    # (no pulling) releases the body earlier, so the same e needs more damping.
    zeta = drake_contact.relaxation_for(0.8, 1.0) / 2.0
    assert zeta > -math.log(0.8) / math.sqrt(math.pi**2 + math.log(0.8) ** 2)
    assert drake_contact._exit_speed(zeta, "kv") == pytest.approx(0.8, abs=1e-9)
    # e = 0 is out of any finite dissipation's reach: the pose rests the ball instead of searching forever.
    with pytest.raises(ValueError):
        drake_contact.hunt_crossley_for(0.0, v)
    assert drake_contact._dissipation(make_contact_scene("ball", e=0.0))["derived"].startswith("a resting contact")


@pytest.mark.parametrize("power, stiffness", [(2, math.pi * 1e7), (3, 4e9)])
def test_the_hydroelastic_dissipation_restores_e_at_its_power(power, stiffness):
    """A body of 1 kg entering c x^n (1 + d xdot) at the ball's first impact speed, integrated here in
    physical units (not the adapter's scaled one), leaves at e of that speed."""
    from scipy.integrate import solve_ivp

    v, e = math.sqrt(2 * 9.81 * 1.0), 0.8
    d = drake_contact.hunt_crossley_for(e, v, power)

    def rhs(t, y):
        x, u = y
        return [u, -max(max(x, 0.0) ** power * stiffness * (1.0 + d * u), 0.0)]

    def out(t, y):
        return y[0] if y[1] < 0 else 1.0

    out.terminal, out.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 1.0), [0.0, v], method="DOP853", events=out, rtol=1e-11, atol=1e-14, max_step=1e-4)
    assert -sol.y[1, -1] / v == pytest.approx(e, abs=1e-6)


def _default_run(mode, dt):
    scene = make_contact_scene("ball")
    return drake_contact.run(CONTACT_MODES[mode], scene, dt, defaults=True), scene


def test_sap_is_dead_by_default():
    """With Drake's default relaxation time (0.1 s a geometry, 0.2 s a pair) SAP's ball does not
    bounce (measured: every apex below 1 mm); with the derived one it does (0.63 at 1 ms)."""
    run, scene = _default_run("drake:sap", 1 / 1000)
    f = contact_figures(scene, run)
    assert max(f.restitution) < 0.05, f.restitution
    _, derived = figures("drake:sap", "ball", {}, 1 / 1000)
    assert min(derived.restitution) > 0.5, derived.restitution


def test_the_default_stiffness_launches_rk3():
    """Drake's default point stiffness (1e6 a geometry: 707 rad/s on 1 kg) puts RK3 at 1 ms past
    its limit inside the contact: the ball leaves the plane far higher than it fell (measured 62 m)."""
    run, scene = _default_run("drake:continuous", 1 / 1000)
    z = run.centres[:, 0, 2] - scene.radius
    assert run.status == "unstable" or z.max() > 2 * scene.h0, z.max()


def _pose(mode, scene_id, dt=1 / 1000, steps=0, **params):
    pose = drake_contact._Pose(CONTACT_MODES[mode], make_contact_scene(scene_id, **params), dt)
    for _ in range(steps):
        pose.step()
    return pose


def test_the_default_contact_is_drakes_own():
    """Nothing set but friction: the scene graph holds DefaultProximityProperties' material, the
    plant its default contact model and approximation, and every pair is point contact."""
    from pydrake.geometry import SceneGraphConfig
    from pydrake.multibody.plant import MultibodyPlant

    defaults, plant = SceneGraphConfig().default_proximity_properties, MultibodyPlant(0.001)
    pose = _pose(DEFAULT, "rest", steps=20)
    assert pose.plant.get_contact_model() == plant.get_contact_model()
    assert pose.plant.get_discrete_contact_approximation() == plant.get_discrete_contact_approximation()
    for where in ("ground", "body"):
        material = pose.settings[f"material (read back: {where})"]
        assert material["point_contact_stiffness"] == defaults.point_stiffness
        assert material["hunt_crossley_dissipation"] == defaults.hunt_crossley_dissipation
    assert pose.contacts() == (4, 0)  # the box's four corners, no hydroelastic surface
    # Its dissipation is the documented inelastic one: the ball does not bounce (every apex below 3 mm).
    _, f = figures(DEFAULT, "ball", {}, 1 / 240)
    assert f.restitution == [0.0] * 5, f.restitution


@pytest.mark.parametrize("mode", HYDRO)
def test_the_hydroelastic_contact_is_what_it_says(mode):
    """Compliant boxes (DefaultProximityProperties' modulus and resolution hint, the guide's margin)
    on a rigid half space: the stack's three contacts are hydroelastic surfaces, none a point."""
    from pydrake.geometry import SceneGraphConfig
    from pydrake.multibody.plant import ContactModel, DiscreteContactApproximation

    defaults = SceneGraphConfig().default_proximity_properties
    pose = _pose(mode, "stack", steps=20)
    body = pose.settings["material (read back: body)"]
    assert body["hydroelastic_modulus"] == drake_contact.HYDROELASTIC_MODULUS == defaults.hydroelastic_modulus
    assert body["resolution_hint"] == drake_contact.RESOLUTION_HINT == defaults.resolution_hint
    assert body["margin"] == drake_contact.MARGIN == 1e-4
    assert body["hunt_crossley_dissipation"] == drake_contact.RESTING_DISSIPATION == defaults.hunt_crossley_dissipation
    assert body["mesh"].startswith("VolumeMesh")
    assert pose.plant.get_contact_model() == ContactModel.kHydroelasticWithFallback
    approximation = {"lagged": "kLagged", "similar": "kSimilar"}[mode.split(":")[1].split("?")[0]]
    assert pose.plant.get_discrete_contact_approximation() == getattr(DiscreteContactApproximation, approximation)
    assert pose.contacts() == (0, 3)
    # The ball's dissipation is solved for its e at the first impact speed, for a force growing as x^2.
    ball = _pose(mode, "ball")
    d = drake_contact.hunt_crossley_for(0.8, math.sqrt(2 * 9.81 * 1.0), 2)
    assert ball.settings["material (read back: body)"]["hunt_crossley_dissipation"] == pytest.approx(d, rel=1e-12)


class _Spinning(Edge):
    """The edge scene dropped from high up with a spin (world axes): it turns in free flight for the
    first steps."""

    SPIN = (1.0, 2.0, -0.5)

    def initial_angular_velocities(self):
        return [self.SPIN]


@pytest.mark.parametrize("mode, within", [("drake:continuous", 1e-9), ("drake:similar?contact=hydroelastic", 1e-6)])
def test_a_free_turn_reads_back_in_world_axes(mode, within):
    """A cube's inertia is isotropic: in free flight its angular velocity stays what it was in world
    axes, and its orientation is the turn about that axis by |w| t after the start's, q(t) =
    q_w(t) q0. Read back at the start exactly: (w, x, y, z) body to world, the lean about +y taking
    the body's z axis to (sin 30°, 0, cos 30°); then along the flight (RK3: to roundoff; the discrete
    plant's quaternion update: measured 8e-8 off)."""
    scene = _Spinning(h0=5.0)
    pose = drake_contact._Pose(CONTACT_MODES[mode], scene, 1 / 1000)
    _, _, q, w = pose.read()
    assert np.allclose(q[0], scene.ORIENTATION, atol=1e-15) and np.allclose(w[0], _Spinning.SPIN, atol=1e-15)
    assert np.allclose(rotation(q[0]) @ [0.0, 0.0, 1.0], [0.5, 0.0, math.sqrt(3) / 2], atol=1e-15)
    spin = np.array(_Spinning.SPIN)
    for _ in range(200):
        pose.step()
    _, _, q, w = pose.read()
    t = 200 / 1000
    expected = quat_mul(quat_about(spin, math.degrees(np.linalg.norm(spin) * t)), scene.ORIENTATION)
    assert np.allclose(w[0], spin, atol=within), w[0]
    assert min(np.abs(q[0] - expected).max(), np.abs(q[0] + expected).max()) < within, (q[0], expected)


def test_the_tipping_box_pivots_at_the_energy_integrals_time():
    """Point contact (SAP, eight corner spheres): it tips about +y (body z to (sin phi, 0, cos phi),
    phi growing) at the pivot's time within the scene's 5% (measured 0.3564 s against 0.3664 s),
    the time it reaches 30 degrees read linearly between the two recorded steps that straddle it."""
    scene = make_contact_scene("tip")
    run = drake_contact.run(CONTACT_MODES["drake:sap"], scene, 1 / 1000)
    truth = pivot(math.radians(scene.angle), scene.half, scene.g)[0]
    z_axis = rotation(run.orientations[:, 0]) @ np.array([0.0, 0.0, 1.0])
    phi = np.degrees(np.arctan2(z_axis[:, 0], z_axis[:, 2]))
    assert abs(z_axis[:, 1]).max() < 1e-9  # no turn off the y axis
    n = int(np.nonzero(phi >= 30.0)[0][0])  # the first step at or past 30 degrees
    t = run.t
    reached = t[n - 1] + (30.0 - phi[n - 1]) / (phi[n] - phi[n - 1]) * (t[n] - t[n - 1])
    assert n > 1 and t[n - 1] < reached <= t[n]
    assert abs(reached - truth) <= 0.05 * truth, (reached, truth)
    assert contact_figures(scene, run).tip_time == pytest.approx(reached, abs=1e-12)


def test_the_compliant_edge_tips_early_and_stiffens_to_the_truth(monkeypatch):
    """Hydroelastic at 1e7 Pa: while the box is nearly flat its downhill edge is a strip of patch
    whose centre of pressure lies millimetres inside the edge, lengthening the 12 mm lever the tip
    starts from: it tips early (measured 0.307 s against 0.366). The rigid limit is the truth:
    at 1e10 Pa (margin 0) within 5% (measured 0.356)."""
    scene = make_contact_scene("tip")
    truth = scene.truth()["tip_time"]
    mode = CONTACT_MODES["drake:lagged?contact=hydroelastic"]
    soft = contact_figures(scene, drake_contact.run(mode, scene, 1 / 1000)).tip_time
    monkeypatch.setattr(drake_contact, "HYDROELASTIC_MODULUS", 1e10)
    monkeypatch.setattr(drake_contact, "MARGIN", 0.0)
    stiff = contact_figures(scene, drake_contact.run(mode, scene, 1 / 1000)).tip_time
    assert soft < 0.9 * truth and abs(stiff - truth) <= 0.05 * truth, (soft, stiff, truth)


def test_the_ball_rolls_five_fourteenths_g_sin_theta_t_squared():
    """Point contact (SAP): x = 5/14 g sin(theta) t^2 within 1% at 1 ms, its world-axes spin about y
    the rolling one, v_x / r (measured slip 2.8e-3 m/s)."""
    scene = make_contact_scene("roll", t_end=0.5)
    run = drake_contact.run(CONTACT_MODES["drake:sap"], scene, 1 / 1000)
    x = run.centres[-1, 0, 0] - run.centres[0, 0, 0]
    closed = 5.0 / 14.0 * scene.g * math.sin(math.radians(scene.angle)) * run.t[-1] ** 2
    assert x == pytest.approx(closed, rel=0.01)
    assert run.angular[-1, 0, 1] == pytest.approx(run.velocities[-1, 0, 0] / scene.radius, rel=0.01)
    assert abs(run.angular[-1, 0, [0, 2]]).max() < 1e-9


def test_a_dissipative_patch_resists_rolling(monkeypatch):
    """Hydroelastic: on a patch Hunt & Crossley dissipation is a rolling resistance (the pressure is
    higher where the patch is pressed in than where it is released). The rolling ball's d is 0: it
    rolls within 3% of 5/14 g sin(theta) t^2 at 1 ms (measured 2.2% short); at Drake's default 50 s/m
    it rolls more than 5% short (measured 10%)."""
    scene = make_contact_scene("roll", t_end=0.5)
    truth = scene.truth()["distance"]
    mode = CONTACT_MODES["drake:similar?contact=hydroelastic"]
    free = contact_figures(scene, drake_contact.run(mode, scene, 1 / 1000))
    assert free.settings["material (read back: body)"]["hunt_crossley_dissipation"] == 0.0
    monkeypatch.setattr(drake_contact, "ROLLING_DISSIPATION", 50.0)
    damped = contact_figures(scene, drake_contact.run(mode, scene, 1 / 1000))
    assert abs(free.distance - truth) <= 0.03 * truth and damped.distance < 0.95 * truth, (free.distance, truth)


def _bare_hydroelastic_drop(scene, dt):
    """The drop built by hand: a compliant-hydroelastic Box (1e7 Pa, margin 1e-4 m, Hunt & Crossley
    d for e at the first impact speed, force as x^power) on a rigid HalfSpace under kSimilar, started
    at the scene's orientation with its lowest corner h0 up; stepped to the scene's end. Returns
    (times, centres, velocities, orientation matrices, angular velocities)."""
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.geometry import (
        AddCompliantHydroelasticProperties,
        AddContactMaterial,
        AddRigidHydroelasticProperties,
        Box,
        HalfSpace,
        ProximityProperties,
    )
    from pydrake.math import RigidTransform
    from pydrake.multibody.plant import (
        AddMultibodyPlantSceneGraph,
        ContactModel,
        CoulombFriction,
        DiscreteContactApproximation,
    )
    from pydrake.multibody.tree import SpatialInertia
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    power = {"edge": 2, "corner": 3}[scene.id]
    d = drake_contact.hunt_crossley_for(scene.e, math.sqrt(2 * scene.g * scene.h0), power)
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, dt)
    plant.set_contact_model(ContactModel.kHydroelasticWithFallback)
    plant.set_discrete_contact_approximation(DiscreteContactApproximation.kSimilar)
    plant.set_stiction_tolerance(1e-4)
    ground = ProximityProperties()
    AddContactMaterial(dissipation=d, friction=CoulombFriction(scene.mu, scene.mu), properties=ground)
    AddRigidHydroelasticProperties(ground)
    plant.RegisterCollisionGeometry(plant.world_body(), RigidTransform(), HalfSpace(), "ground", ground)
    side = 2 * scene.half
    box = plant.AddRigidBody("box", SpatialInertia.SolidBoxWithMass(scene.mass, side, side, side))
    props = ProximityProperties()
    AddContactMaterial(dissipation=d, friction=CoulombFriction(scene.mu, scene.mu), properties=props)
    AddCompliantHydroelasticProperties(0.02, 1e7, props)
    props.AddProperty("hydroelastic", "margin", 1e-4)
    plant.RegisterCollisionGeometry(box, RigidTransform(), Box(side, side, side), "box", props)
    plant.Finalize()
    sim = Simulator(builder.Build())
    context = plant.GetMyMutableContextFromRoot(sim.get_mutable_context())
    q0 = np.array(scene.ORIENTATION)
    low = -(rotation(q0) @ cube_corners(scene.half).T)[2].min()  # the lowest corner's depth below the centre
    plant.SetFreeBodyPose(context, box, RigidTransform(Quaternion(*q0), [0.0, 0.0, scene.h0 + low]))
    steps = int(math.ceil(scene.duration / dt - 1e-9))
    t, c, v, rot, w = [], [], [], [], []
    for n in range(steps + 1):
        if n:
            sim.AdvanceTo(n * dt)
        pose, spatial = plant.EvalBodyPoseInWorld(context, box), plant.EvalBodySpatialVelocityInWorld(context, box)
        t.append(n * dt)
        c.append(pose.translation())
        v.append(spatial.translational())
        rot.append(pose.rotation().matrix())
        w.append(spatial.rotational())
    return np.array(t), np.array(c), np.array(v), np.array(rot), np.array(w)


@pytest.mark.parametrize("scene_id", ["edge", "corner"])
def test_the_dropped_box_rests_as_a_bare_pydrake_loop_says(scene_id):
    """The hydroelastic pose (kSimilar, 1/240 s) against the same drop built and stepped here: the
    time from which every point is slower than STOPPED, the lean off the nearest face at the end
    and the sink, each computed by hand, are the harness's figures."""
    scene, dt = make_contact_scene(scene_id), 1 / 240
    t, c, v, rot, w = _bare_hydroelastic_drop(scene, dt)
    fastest = np.linalg.norm(v, axis=1) + np.linalg.norm(w, axis=1) * math.sqrt(3) * scene.half
    rest_time = t[np.nonzero(fastest >= STOPPED)[0][-1] + 1]
    tilt = math.degrees(math.acos(min(1.0, np.abs(rot[-1][2]).max())))
    sink = max(0.0, scene.half - c[-1, 2])
    f = contact_figures(scene, drake_contact.run(CONTACT_MODES["drake:similar?contact=hydroelastic"], scene, dt))
    assert f.rest_time == pytest.approx(rest_time, abs=1e-12)
    assert f.tilt == pytest.approx(tilt, abs=1e-6) and f.sink == pytest.approx(sink, abs=1e-9)
    assert rest_time <= scene.rest_by and all(f.passes.values()), f.passes


def test_the_exact_cone_stops_the_slide_at_every_angle():
    """Drake's discrete solvers resolve Coulomb's cone exactly (no pyramid): at 1 ms TAMSI and SAP on the
    corner spheres, and the hydroelastic box under kSimilar, stop within 1% of v0^2 / (2 mu g) pushed at
    0, 22.5 and 45 degrees (measured 0.4067..0.4094 against 0.4077)."""
    truth = make_contact_scene("slide").truth()["stop"]
    for mode in ("drake:tamsi", "drake:sap", "drake:similar?contact=hydroelastic"):
        for angle in (0.0, 22.5, 45.0):
            _, f = figures(mode, "slide", {"angle": angle}, 1 / 1000)
            assert abs(f.stop - truth) <= 0.01 * truth, (mode, angle, f.stop)


def test_the_lagged_hydroelastic_box_rocks_sliding_along_its_diagonal():
    """kLagged's friction bound is the last step's normal force ("weak coupling ... during impacts
    or strong transients"): the compliant box pushed along its diagonal rocks onto its leading edge
    and stops far short (measured 0.280 m at 1 ms), pushed along a face it stops at 0.408."""
    truth = make_contact_scene("slide").truth()["stop"]
    _, along = figures("drake:lagged?contact=hydroelastic", "slide", {}, 1 / 1000)
    _, diagonal = figures("drake:lagged?contact=hydroelastic", "slide", {"angle": 45.0}, 1 / 1000)
    assert abs(along.stop - truth) <= 0.01 * truth and diagonal.stop < 0.8 * truth, (along.stop, diagonal.stop)
