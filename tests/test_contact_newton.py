"""Newton's contact poses (``adapters/newton/contact.py``): each solver poses every scene (the
ball at the three report steps, over one bounce to keep Warp on the CPU quick), the figures
measured to hold hold, and XPBD's trap (no bounce unless ``enable_restitution``) is caught. The
documented-practice modes (``?contact=default``) state Newton's own defaults, read here from the
installed classes; the turning scenes read the orientation in Newton's (x, y, z, w) order and the
angular velocity in world axes; each pose's figures are reproduced by a Newton loop written here
or by a closed form (the roll's 5/14 g sin(theta) t^2, the tip's pivot time, the stack's weight
over ke)."""

import importlib.util
import math

import numpy as np
import pytest

# Skipped without Newton, which is imported where a test uses it: its import is seconds of every
# worker's collection.
pytestmark = pytest.mark.skipif(importlib.util.find_spec("newton") is None, reason="newton is not installed")

from adapters import CONTACT_MODES  # noqa: E402
from adapters.newton import contact as newton_contact  # noqa: E402
from harness.contact.figures import contact_figures  # noqa: E402
from harness.contact.run import REPORT_DTS, run_contact  # noqa: E402
from scenarios.contact import TOLERANCES, make_contact_scene  # noqa: E402

MODES = ("newton:semi_implicit", "newton:xpbd")
ONE_BOUNCE = {"bounces": 1}


def figures(mode, scene, params, dt):
    run = run_contact(mode, scene, params, dt, isolated=False)
    return run, contact_figures(make_contact_scene(scene, **params), run)


@pytest.mark.slow
@pytest.mark.parametrize("dt", REPORT_DTS)
@pytest.mark.parametrize("mode", MODES)
def test_the_ball_runs_at_every_report_step(mode, dt):
    run, f = figures(mode, "ball", ONE_BOUNCE, dt)
    assert run.status == "ok", run.detail
    assert run.settings["precision"] == "float32"
    assert f.cpu_per_s > 0
    if dt == 1 / 1000:
        # Measured (newton 1.8.0): semi-implicit 0.806, XPBD 0.7996 at the first bounce.
        assert abs(f.restitution[0] - 0.8) < 0.05, f.restitution


@pytest.mark.slow
@pytest.mark.parametrize("scene", ["slide", "rest", "stack"])
@pytest.mark.parametrize("mode", MODES)
def test_the_boxes_run(mode, scene):
    run, _ = figures(mode, scene, {}, 1 / 60)
    assert run.status in ("ok", "unstable"), run.detail
    if run.status == "ok":
        assert run.centres.shape[1] == make_contact_scene(scene).bodies


def test_the_penalty_damping_follows_e():
    # Damped on approach only: e = exp(-zeta atan(sqrt(1 - zeta^2) / zeta) / sqrt(1 - zeta^2)).
    assert newton_contact.zeta_for(1.0) == 0.0
    for e in (0.3, 0.8, 0.95):
        assert newton_contact.restitution_of(newton_contact.zeta_for(e)) == pytest.approx(e, abs=1e-12)


@pytest.mark.slow
def test_xpbd_ignores_restitution_unless_enabled():
    """Newton's default ``enable_restitution=False``: XPBD's ball stops at the first impact
    (measured: apex below 1 mm), where with it enabled it bounces at e."""
    scene = make_contact_scene("ball", **ONE_BOUNCE)
    mode = CONTACT_MODES["newton:xpbd"]
    off = contact_figures(scene, newton_contact.run(mode, scene, 1 / 240, enable_restitution=False))
    on = contact_figures(scene, newton_contact.run(mode, scene, 1 / 240))
    assert off.restitution[0] < 0.1, off.restitution
    assert abs(on.restitution[0] - 0.8) < 0.05, on.restitution


PRACTICE = ("newton:semi_implicit?contact=default", "newton:xpbd?contact=default")


def test_the_practice_substeps_are_the_examples():
    """The documented practice steps the examples' solver step, a 60 fps frame in 10 substeps:
    a harness step is as many substeps as keep each within 1/600 s."""
    assert newton_contact.substeps_for(1 / 60) == 10
    assert newton_contact.substeps_for(1 / 240) == 3  # 1/720 s each
    assert newton_contact.substeps_for(1 / 600) == 1
    assert newton_contact.substeps_for(1 / 1000) == 1
    for mode_id in PRACTICE:
        mode = CONTACT_MODES[mode_id]
        assert mode.settings["contact"] == "default" and mode.settings["substep"] == pytest.approx(1 / 600)
        assert set(mode.scenes) == set(CONTACT_MODES["newton:xpbd"].scenes)


def bare_newton(scene, dt, solver, substeps, material=None, sphere=False, **solver_kwargs):
    """The scene's one body stepped by a Newton loop written here (after a harness run has started
    Warp, so that its kernels come from the same cache): a free body at the scene's centre,
    orientation ((w, x, y, z) to Warp's (x, y, z, w)) and mass, a sphere of the scene's radius
    (moment 2/5 m r^2) or a cube of side 2 half (m (2 half)^2 / 6), the ground plane, both shapes
    given ``material`` (ShapeConfig's own defaults where None) with the scene's friction (none for
    the ball) and restitution and no torsional or rolling friction; ``substeps`` solver steps of
    dt / substeps a step, the contacts found before each. Returns body_q (steps + 1, 7) and body_qd (steps + 1, 6)."""
    import newton
    import warp as wp

    builder = newton.ModelBuilder(gravity=tuple(float(x) for x in scene.gravity), up_axis=newton.Axis.Z)
    cfg = newton.ModelBuilder.ShapeConfig(
        density=0.0,
        mu=getattr(scene, "mu", 0.0),
        mu_torsional=0.0,
        mu_rolling=0.0,
        restitution=getattr(scene, "e", 0.0),
        **(material or {}),
    )
    builder.add_ground_plane(cfg=cfg)
    qw, qx, qy, qz = scene.initial_orientations()[0]
    xform = wp.transform(wp.vec3(*scene.initial_centres()[0]), wp.quat(qx, qy, qz, qw))
    m = scene.mass
    moment = 0.4 * m * scene.radius**2 if sphere else m * (2 * scene.half) ** 2 / 6.0
    body = builder.add_body(xform=xform, mass=m, inertia=wp.mat33(np.eye(3) * moment), lock_inertia=True)
    if sphere:
        builder.add_shape_sphere(body, radius=scene.radius, cfg=cfg)
    else:
        builder.add_shape_box(body, hx=scene.half, hy=scene.half, hz=scene.half, cfg=cfg)
    model = builder.finalize(device="cpu")
    step = getattr(newton.solvers, solver)(model, **solver_kwargs)
    pipeline = newton.CollisionPipeline(model)
    contacts = pipeline.contacts()
    s0, s1, control = model.state(), model.state(), model.control()
    q, qd = [s0.body_q.numpy()[0].copy()], [s0.body_qd.numpy()[0].copy()]
    for _ in range(math.ceil(scene.duration / dt - 1e-9)):
        for _ in range(substeps):
            s0.clear_forces()
            pipeline.collide(s0, contacts)
            step.step(s0, s1, control, contacts, dt / substeps)
            s0, s1 = s1, s0
        q.append(s0.body_q.numpy()[0].copy())
        qd.append(s0.body_qd.numpy()[0].copy())
    return np.array(q, dtype=float), np.array(qd, dtype=float)


@pytest.mark.slow
@pytest.mark.parametrize("mode", PRACTICE)
def test_the_practice_reads_back_newtons_defaults(mode):
    """The documented-practice run states Newton's own defaults, read here from the installed
    classes: ShapeConfig's ke, kd, kf; the solvers' constructor defaults; XPBD at the contact
    examples' iterations = 10 with restitution enabled; 10 substeps of a 1/60 s step."""
    import inspect

    import newton

    run, _ = figures(mode, "roll", {"t_end": 0.05}, 1 / 60)
    assert run.status == "ok", run.detail
    s = run.settings
    d = newton.ModelBuilder.ShapeConfig()
    material = s["shape material (both shapes)"]
    assert (material["ke"], material["kd"], material["kf"]) == (d.ke, d.kd, d.kf)
    assert (material["mu_torsional"], material["mu_rolling"]) == (0.0, 0.0)  # the rolling ball has none
    assert material["mu"] == make_contact_scene("roll").mu
    assert s["substeps"] == 10 and s["solver dt (s)"] == pytest.approx(1 / 600)
    assert "simulation_tuning_solvers" in s["source"]
    solver = newton.solvers.SolverXPBD if "xpbd" in mode else newton.solvers.SolverSemiImplicit
    defaults = {k: p.default for k, p in inspect.signature(solver.__init__).parameters.items()}
    if "xpbd" in mode:
        assert s["iterations"] == 10 and s["enable_restitution"] is True
        for k in ("rigid_contact_relaxation", "rigid_contact_restitution_iterations", "angular_damping"):
            assert s[k] == defaults[k], k
        assert "example_newton_cradle.py" in s["source"]
    else:
        assert s["angular_damping"] == defaults["angular_damping"] == 0.05
        assert s["enable_tri_contact"] == defaults["enable_tri_contact"]


@pytest.mark.slow
@pytest.mark.parametrize("mode", PRACTICE)
def test_the_ball_rolls_as_the_closed_form_and_a_bare_newton_loop(mode):
    """The rolling ball (documented practice, 1/240 s: 3 substeps of 1/720 s) has rolled
    x = 5/14 g sin(theta) t^2 to 1% at 0.5 s (measured, newton 1.8.0: both 0.3% long), and a
    Newton loop written here (ShapeConfig's defaults, the solver's defaults but XPBD's iterations
    10 and restitution) gives the same states over the scene's second, its angular velocity as
    Newton's body_qd holds it (world axes).

    XPBD's ball rolls without slipping (under 0.3 mm/s) until v^2 / r reaches about 2 g (measured
    at every incline, radius, g and step tried: omega = 14 rad/s for r = 0.1 m), then its contact
    point slips forward and both accelerations drop: the scene's second ends 3.3% short at 1/240.
    SemiImplicit's friction is viscous below the slip limit, kf per contact, which an explicit
    substep settles only while kf h / m_eff < 2 (the rolling ball's m_eff = m / (1 + m r^2 / I) =
    2/7 m: h < 0.57 ms); at 1/720 s it chatters (the slip figure's 2 cm/s)."""
    params, dt = {"t_end": 1.0}, 1 / 240
    run, f = figures(mode, "roll", params, dt)
    assert run.status == "ok", run.detail
    scene = make_contact_scene("roll", **params)
    half = int(np.argmin(np.abs(run.t - 0.5)))
    x = run.centres[half, 0, 0] - run.centres[0, 0, 0]
    closed = 5.0 / 14.0 * scene.g * math.sin(math.radians(scene.angle)) * run.t[half] ** 2
    assert abs(x - closed) < 0.01 * closed, (x, closed)
    assert f.values["distance"] == pytest.approx(run.centres[-1, 0, 0] - run.centres[0, 0, 0])
    kwargs = {"iterations": 10, "enable_restitution": True} if "xpbd" in mode else {}
    q, qd = bare_newton(scene, dt, run.settings["solver"], 3, sphere=True, **kwargs)
    assert np.allclose(q[:, :3], run.centres[:, 0], atol=1e-5)
    assert np.allclose(qd[:, 3:], run.angular[:, 0], atol=1e-4)  # body_qd's angular half: world axes
    slip = np.abs(run.velocities[:, 0, 0] - scene.radius * run.angular[:, 0, 1])
    if "xpbd" in mode:
        turn = run.velocities[:, 0, 0] ** 2 / scene.radius / scene.g
        assert np.max(slip[(turn < 1.8) & (run.t >= scene.settle)]) < 3e-4
        assert np.min(slip[turn > 2.2]) > 5e-4
        assert f.values["distance"] < (1.0 - TOLERANCES.distance) * scene.truth()["distance"]
    else:
        assert f.values["slip"] > 0.01


@pytest.mark.slow
def test_the_tip_turns_about_plus_y_at_the_pivots_time():
    """The tipping box (XPBD, documented practice, 1/240 s) starts upright, turns about +y (body z
    to (sin phi, 0, cos phi) downhill: the quaternion read in Newton's (x, y, z, w) order and
    reordered) and reaches 30 degrees at the pivot's energy-integral time, to 3% (measured,
    newton 1.8.0: 0.3625 s against 0.3664 s, a step early)."""
    from scenarios.contact_turning import TIP_ANGLE, pivot, rotation

    scene = make_contact_scene("tip")
    run, f = figures("newton:xpbd?contact=default", "tip", {}, 1 / 240)
    assert run.status == "ok", run.detail
    assert np.allclose(run.orientations[0, 0], (1.0, 0.0, 0.0, 0.0), atol=1e-7)
    truth = pivot(math.radians(scene.angle), scene.half, scene.g)[0]
    assert f.values["tipped"] is True
    assert abs(f.values["tip_time"] - truth) < 0.03 * truth, (f.values["tip_time"], truth)
    i = int(np.argmin(np.abs(run.t - f.values["tip_time"])))
    z_axis = rotation(run.orientations[i, 0])[:, 2]
    phi = math.radians(TIP_ANGLE)
    assert np.allclose(z_axis, (math.sin(phi), 0.0, math.cos(phi)), atol=0.05), z_axis
    assert run.angular[i, 0, 1] > 0 and abs(run.angular[i, 0, 0]) < 1e-3 * run.angular[i, 0, 1]


def _omega_from(q: np.ndarray, dt: float, world: bool) -> np.ndarray:
    """Angular velocities from recorded (w, x, y, z) orientations by central differences:
    2 q' q^-1 in world axes, 2 q^-1 q' in body axes."""
    from scenarios.contact_turning import quat_mul

    dq = (q[2:] - q[:-2]) / (2 * dt)
    out = []
    for a, b in zip(dq, q[1:-1]):
        conj = b * np.array([1.0, -1.0, -1.0, -1.0])
        out.append(2 * (quat_mul(a, conj) if world else quat_mul(conj, a))[1:])
    return np.array(out)


@pytest.mark.slow
def test_the_corner_starts_turned_and_its_angular_velocity_is_in_world_axes():
    """The corner drop (XPBD, 1/240 s) starts at the scene's orientation, and the angular velocity
    it records is the turn of its orientations in world axes (2 q' q^-1), not in the box's own
    (2 q^-1 q', which differs once the box is turned about two axes); a Newton loop written here
    gives the same states."""
    scene = make_contact_scene("corner")
    dt = 1 / 240
    run, _ = figures("newton:xpbd", "corner", {}, dt)
    assert run.status == "ok", run.detail
    assert np.allclose(run.orientations[0, 0], scene.initial_orientations()[0], atol=1e-7)
    q, w = run.orientations[:, 0], run.angular[1:-1, 0]
    spinning = np.linalg.norm(w, axis=1) > 1.0
    assert np.count_nonzero(spinning) > 20
    world = np.linalg.norm(_omega_from(q, dt, True) - w, axis=1)[spinning] / np.linalg.norm(w, axis=1)[spinning]
    body = np.linalg.norm(_omega_from(q, dt, False) - w, axis=1)[spinning] / np.linalg.norm(w, axis=1)[spinning]
    assert np.median(world) < 0.05 and np.median(body) > 4 * np.median(world), (np.median(world), np.median(body))
    mat = {"ke": scene.mass * newton_contact.OMEGA_C**2 / 4, "kd": 0.0, "kf": newton_contact.FRICTION_GAIN}
    bq, bqd = bare_newton(
        scene, dt, "SolverXPBD", 1, mat, iterations=2, rigid_contact_relaxation=0.8, enable_restitution=True
    )
    assert np.allclose(bq[:, :3], run.centres[:, 0], atol=1e-5)
    assert np.allclose(bq[:, [6, 3, 4, 5]], run.orientations[:, 0], atol=1e-5)


@pytest.mark.slow
def test_xpbds_practice_bounces_at_e_at_60_hz_as_a_bare_newton_loop():
    """XPBD as its examples set it (iterations 10, restitution enabled, 10 substeps of a 1/60 s
    step) bounces the ball at the requested e within the judged 0.05, never below the plane
    deeper than a millimetre, and a Newton loop written here gives the same heights."""
    params, dt = {"e": 0.8, "bounces": 1}, 1 / 60
    run, f = figures("newton:xpbd?contact=default", "ball", params, dt)
    assert run.status == "ok", run.detail
    scene = make_contact_scene("ball", **params)
    assert abs(f.restitution[0] - scene.e) < 0.05, f.restitution
    assert f.values["impact_depth"] < 1e-3
    q, _ = bare_newton(scene, dt, "SolverXPBD", 10, sphere=True, iterations=10, enable_restitution=True)
    assert np.allclose(q[:, 2], run.centres[:, 0, 2], atol=1e-6)


@pytest.mark.slow
def test_the_penalty_defaults_sink_the_stack_by_its_weight_over_ke():
    """SemiImplicit at ShapeConfig's default ke (2500 N/m each shape, a pair's the mean) holds each
    box of the stack on four corner springs: at rest the bottom box is 3 m g / (4 ke) into the
    plane (2.9 mm: past the robotics millimetre) and the top one 6 m g / (4 ke) below where it was
    placed, whatever the step (1/60 s here: 10 substeps)."""
    import newton

    ke = newton.ModelBuilder.ShapeConfig().ke
    run, f = figures("newton:semi_implicit?contact=default", "stack", {}, 1 / 60)
    assert run.status == "ok", run.detail
    scene = make_contact_scene("stack")
    corner = scene.mass * scene.g / (4.0 * ke)
    assert f.values["penetration"] == pytest.approx(3 * corner, rel=0.01)
    assert f.values["sink"] == pytest.approx(6 * corner, rel=0.01)


@pytest.mark.slow
def test_the_penalty_defaults_bounce_the_same_whatever_e():
    """SemiImplicit has no restitution of its own: with ShapeConfig's default ke 2500 and kd 100
    the 1 kg ball's contact is critically damped (zeta = kd / (2 sqrt(ke m)) = 1), and a shape's
    ``restitution`` changes nothing (the same heights, bit for bit, at e = 0.8 and e = 1). Its
    first bounce is under exp(-1), the gravity-free spring-dashpot's (measured 0.31..0.34: gravity
    takes m g d of the spring-back from the depth d)."""
    runs = [figures("newton:semi_implicit?contact=default", "ball", {"e": e, "bounces": 1}, 1 / 60) for e in (0.8, 1.0)]
    (a, fa), (b, _) = runs
    assert a.status == b.status == "ok"
    n = min(len(a.t), len(b.t))  # the scene runs for its e's flights: the shorter run's steps
    assert np.array_equal(a.centres[:n], b.centres[:n])
    assert a.settings["shape material (both shapes)"]["restitution"] == 0.8
    assert 0.2 < fa.restitution[0] < math.exp(-1.0)
