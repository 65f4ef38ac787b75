"""Newton's contact poses: ``SolverSemiImplicit`` (penalty contact) and ``SolverXPBD`` (contact as
a positional constraint, restitution applied after it), on Warp on the CPU in float32.

The bodies are Newton's rigid bodies with collision shapes: the ball a sphere on a free body, each
box a box shape on a free body, the ground ``add_ground_plane``. Newton's collision pipeline
(``CollisionPipeline(model)``, its defaults) finds the contacts every step before the solver's step.

* ``semi_implicit``: each contact is a penalty force ``ke d + kd min(vn, 0)`` (d the
  penetration, the damping only while the bodies approach), with regularised Coulomb friction
  ``kf vt`` up to ``mu`` times the normal force; a pair's ke, kd, kf and mu are the means of its
  two shapes', so both shapes are given the same. ke from the contact frequency ``OMEGA_C`` (200
  rad/s, MuJoCo's and Drake's poses' too): ``m omega_c^2`` for the ball, a quarter of it for a box
  (four corner contacts). With the damping on approach only, a contact entered at speed v
  reaches the depth of a damped oscillator's first maximum and springs back undamped, so
  ``e = exp(-zeta atan(sqrt(1 - zeta^2) / zeta) / sqrt(1 - zeta^2))`` at damping ratio
  ``zeta = kd / (2 m omega_c)``: kd is solved from e (``zeta_for``); e = 1 is kd = 0; the boxes'
  contacts are critically damped (zeta = 1). kf is Newton's default 1000 (stated).
  Newton's ShapeConfig defaults (ke 2500, kd 100, restitution 0) are replaced.
* ``xpbd``: contact is a constraint projection (``rigid_contact_relaxation`` 0.8, Newton's default,
  ``iterations`` 2): no stiffness and no bounce of its own. The requested e is each shape's
  ``restitution`` (a pair's is their mean), which XPBD applies only with
  ``enable_restitution=True``; Newton's default is False, and its ball then does not bounce
  (measured in docs/engines.md, tested). Friction is the shapes' ``mu``.

Every default that changes the answer is set and stated: gravity (Newton's -9.81 along z is the
scene's g), the shapes' ``margin`` 0 and ``gap`` (Newton's 0.1 m contact detection distance,
kept: contacts are found before touching, as a speculative margin), ``angular_damping`` 0 (both
solvers; SemiImplicit's default 0.05), the shapes' density (a body's mass is set, its shapes add
none: density 0), the torsional and rolling friction 0.

Warp compiles the kernels the run launches, forward only, its cache under the harness cache
(``adapters.newton._warp``). The loop is Newton's: ``pipeline.collide`` and ``solver.step`` from
Python once a step, the states swapped.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .._contact import BOX, SPHERE, ContactMode, record_loop, timed_loop
from .._engine import import_engine, quiet_fds

#: The contact's natural frequency (rad/s): MuJoCo's and Drake's poses' too.
OMEGA_C = 200.0
#: Newton's own defaults, kept and stated.
FRICTION_GAIN = 1000.0
XPBD_ITERATIONS = 2
CONTACT_RELAXATION = 0.8
SOLVERS = {"semi_implicit": "SolverSemiImplicit", "xpbd": "SolverXPBD"}
#: How Newton poses each contact scene (the scene's kind -> its ``ContactPose``): a free body each, a
#: sphere shape for the ball, a box shape for each box. A new contact scene is one entry here.
POSES = {"ball": SPHERE, "slide": BOX, "rest": BOX, "stack": BOX}


def restitution_of(zeta: float) -> float:
    """The restitution of a linear contact damped only while approaching, at damping ratio zeta:
    the depth of the damped oscillator's first maximum over v / omega (it springs back undamped)."""
    if zeta <= 0.0:
        return 1.0
    if zeta == 1.0:
        return math.exp(-1.0)
    if zeta < 1.0:
        s = math.sqrt(1.0 - zeta * zeta)
        return math.exp(-zeta * math.atan2(s, zeta) / s)
    s = math.sqrt(zeta * zeta - 1.0)
    return math.exp(-zeta * math.atanh(s / zeta) / s)


@functools.lru_cache(maxsize=64)
def zeta_for(e: float) -> float:
    """The damping ratio at which that contact restores a fraction e (below exp(-1), overdamped;
    e = 0 would need an infinite one: 1e6)."""
    from scipy.optimize import brentq

    if e >= 1.0:
        return 0.0
    if e <= 0.0:
        return 1e6
    return brentq(lambda z: restitution_of(z) - e, 0.0, 1e6, xtol=1e-14)


def _material(scene) -> dict:
    if POSES[scene.kind] is SPHERE:
        zeta = zeta_for(scene.e)
        return {
            "ke": scene.mass * OMEGA_C**2,
            "kd": 2.0 * zeta * scene.mass * OMEGA_C,
            "zeta": zeta,
            "restitution": float(scene.e),
            "mu": 0.0,
        }
    mu = getattr(scene, "mu", 1.0)
    return {
        "ke": scene.mass * OMEGA_C**2 / 4.0,
        "kd": 2.0 * scene.mass * OMEGA_C / 4.0,
        "zeta": 1.0,
        "restitution": 0.0,
        "mu": mu,
    }


class _Pose:
    def __init__(self, mode: ContactMode, scene, dt: float, enable_restitution: bool = True):
        from . import _warp

        newton = import_engine("newton")
        self.wp = wp = _warp(newton)
        solver_name = mode.settings["solver"]
        mat = _material(scene)
        sphere = POSES[scene.kind] is SPHERE
        with quiet_fds():
            builder = newton.ModelBuilder(gravity=tuple(float(x) for x in scene.gravity), up_axis=newton.Axis.Z)
            cfg = newton.ModelBuilder.ShapeConfig(
                density=0.0,
                ke=mat["ke"],
                kd=mat["kd"],
                kf=FRICTION_GAIN,
                mu=mat["mu"],
                restitution=mat["restitution"],
                mu_torsional=0.0,
                mu_rolling=0.0,
                margin=0.0,
            )
            builder.add_ground_plane(cfg=cfg)
            self.bodies = []
            for centre in scene.initial_centres():
                xform = wp.transform(wp.vec3(*centre), wp.quat_identity())
                if sphere:
                    r = scene.radius
                    inertia = wp.mat33(np.eye(3) * 0.4 * scene.mass * r * r)
                    body = builder.add_body(xform=xform, mass=scene.mass, inertia=inertia, lock_inertia=True)
                    builder.add_shape_sphere(body, radius=r, cfg=cfg)
                else:
                    h = scene.half
                    inertia = wp.mat33(np.eye(3) * scene.mass * (2 * h) ** 2 / 6.0)
                    body = builder.add_body(xform=xform, mass=scene.mass, inertia=inertia, lock_inertia=True)
                    builder.add_shape_box(body, hx=h, hy=h, hz=h, cfg=cfg)
                self.bodies.append(body)
            model = builder.finalize(device="cpu")
            if solver_name == "semi_implicit":
                solver = newton.solvers.SolverSemiImplicit(model, angular_damping=0.0, enable_tri_contact=False)
                solver_settings = {"angular_damping": 0.0, "enable_tri_contact": False}
            else:
                solver = newton.solvers.SolverXPBD(
                    model,
                    iterations=XPBD_ITERATIONS,
                    rigid_contact_relaxation=CONTACT_RELAXATION,
                    angular_damping=0.0,
                    enable_restitution=enable_restitution,
                )
                solver_settings = {
                    "iterations": XPBD_ITERATIONS,
                    "rigid_contact_relaxation": CONTACT_RELAXATION,
                    "angular_damping": 0.0,
                    "enable_restitution": enable_restitution,
                    "rigid_contact_restitution_iterations": solver.rigid_contact_restitution_iterations,
                }
            self.pipeline = newton.CollisionPipeline(model)
            self.contacts = self.pipeline.contacts()
            self.s0, self.s1 = model.state(), model.state()
            self.control = model.control()
            velocities = scene.initial_velocities()
            if any(any(v) for v in velocities):
                qd = self.s0.body_qd.numpy()
                for i, v in enumerate(velocities):
                    qd[i, :3] = v  # a body's velocity: linear, then angular
                self.s0.body_qd.assign(qd)
        self.model, self.solver, self.dt, self.scene = model, solver, dt, scene
        self.settings = {
            "solver": SOLVERS[solver_name],
            "precision": "float32",
            "device": "cpu",
            **solver_settings,
            "model": (
                f"{len(self.bodies)} free body(ies), a {'sphere' if sphere else 'box'} shape each "
                "(density 0, the body's mass and inertia set), add_ground_plane"
            ),
            "gravity": [float(x) for x in scene.gravity],
            "shape material (both shapes)": {
                "ke": mat["ke"],
                "kd": mat["kd"],
                "kf": FRICTION_GAIN,
                "mu": mat["mu"],
                "restitution": mat["restitution"],
                "mu_torsional": 0.0,
                "mu_rolling": 0.0,
                "margin": 0.0,
                "gap": float(model.shape_gap.numpy()[0]),
            },
            "contact omega_c (rad/s)": OMEGA_C,
            "used": (
                "ke, kd, kf, mu (penalty)"
                if solver_name == "semi_implicit"
                else "restitution, mu (constraint projection; ke, kd, kf unused)"
            ),
            "derived": (
                f"e = {scene.e:g} -> damping ratio {mat['zeta']:.6g} (damped on approach only), kd = 2 zeta m omega_c"
                if sphere
                else "critically damped resting contacts, ke a quarter of m omega_c^2 a corner"
            ),
            "engine_loop": "pipeline.collide then solver.step from Python, one call each a step",
        }

    def step(self) -> None:
        s0 = self.s0
        s0.clear_forces()
        self.pipeline.collide(s0, self.contacts)
        self.solver.step(s0, self.s1, self.control, self.contacts, self.dt)
        self.s0, self.s1 = self.s1, s0

    def read(self):
        q = self.s0.body_q.numpy().astype(float)
        qd = self.s0.body_qd.numpy().astype(float)
        return q[:, :3].copy(), qd[:, :3].copy()


def run(mode: ContactMode, scene, dt: float, enable_restitution: bool = True):
    """The scene in ``mode`` at step ``dt`` (``enable_restitution`` False: XPBD as Newton's default
    builds it, to measure what the default does)."""
    pose = _Pose(mode, scene, dt, enable_restitution)

    def time_again(steps: int) -> float:
        again = _Pose(mode, scene, dt, enable_restitution)
        return timed_loop(again.step, steps)

    with quiet_fds():
        out = record_loop(
            mode,
            scene,
            dt,
            pose.step,
            pose.read,
            pose.settings,
            loop="pipeline.collide + solver.step, once a step from Python",
            time_again=time_again,
        )
    return out


_DOC = {
    "semi_implicit": "Newton's SolverSemiImplicit on Warp (CPU, float32); penalty contact ke, kd from e",
    "xpbd": "Newton's SolverXPBD on Warp (CPU, float32); contact a constraint, restitution e enabled",
}

MODES = {
    f"newton:{name}": ContactMode(
        "newton",
        name,
        "newton",
        run,
        poses=POSES,
        settings={"solver": name, "precision": "float32", "device": "cpu"},
        doc=_DOC[name],
    )
    for name in SOLVERS
}
