"""Drake's contact poses: the discrete ``MultibodyPlant`` under TAMSI and under SAP, and the
continuous plant (time step 0) under Kutta's RK3 at a fixed step.

The contact is Drake's compliant point contact (``ContactModel.kPoint``; Drake's default is
hydroelastic with a point-contact fallback): a penetration x gives a normal force
``k x (1 + d xdot)`` (Hunt & Crossley; TAMSI and the continuous plant) or ``k (x + tau xdot)``
(a linear Kelvin-Voigt spring-dashpot; SAP, ``tau`` its ``relaxation_time``), never pulling.
Drake has no coefficient of restitution; each pose derives its dissipation from the requested e:

* ``k`` from the contact's natural frequency ``OMEGA_C`` (200 rad/s, MuJoCo's poses' too):
  ``k = m omega_c^2`` for the ball, a quarter of that at each of a box's four corner contacts.
  Drake combines two geometries' stiffnesses in series and their relaxation times by sum, their
  Hunt & Crossley dissipations weighted by stiffness: every geometry is given ``2 k``, ``tau / 2``
  and ``d``, so that the pair's are k, tau and d.
* Hunt & Crossley: the restitution depends on ``d v`` alone (v the impact speed; scaled, the
  contact is ``X'' = -X (1 + d v X')+``), so d is solved for e at the ball's first impact speed
  ``sqrt(2 g h0)`` (``hunt_crossley_for``); the later, slower impacts lose less (measured in
  docs/engines.md). e = 1 is d = 0.
* Kelvin-Voigt (SAP): the restitution depends on the damping ratio ``zeta = omega_c tau / 2``
  alone, the force cut off where it would pull (``relaxation_for``). e = 1 is tau = 0.
* The boxes' contacts (slide, rest, stack) are critically damped about the resting load:
  ``d = 2 omega_c / g`` (Hunt & Crossley's damping ``k x0 d`` at the static sink ``x0 = g / omega_c^2``
  is ``2 m omega_c``), ``tau = 2 / omega_c``.

Drake's defaults each change the answer (docs/engines.md, measured): ``point_stiffness`` 1e6 per
geometry (5e5 N/m a pair, 707 rad/s on 1 kg), ``hunt_crossley_dissipation`` 50 s/m, and
``relaxation_time`` 0.1 s a geometry (0.2 s a pair). With them SAP's and TAMSI's ball does not
bounce at all, and RK3 at h = 1e-3 throws it 55 m high.

Each scene is the smallest model that poses its question: the ball a solid sphere on one
``PrismaticJoint`` along z (a frictionless up-and-down contact with the ``HalfSpace``); each box a
free body whose contact is four small spheres (``CORNER`` of its half side) at its bottom
corners, and, for a box that carries another, its ``Box`` to be touched from above (Drake's
box-on-half-space point contact is one point, on which a box rocks; measured 4e-3 rad of tilt
while sliding at h = 1e-3 and 0.3 rad at h = 1/60). Box-against-box and box-against-plane pairs are
filtered out, so every contact is a corner on a face. Friction: ``CoulombFriction(mu, mu)`` on
every geometry (Drake's combination ``2 mu1 mu2 / (mu1 + mu2)`` is then mu); the Stribeck
stiction tolerance is Drake's default 1e-4 m/s, stated.

The integrator of the continuous plant is ``runge_kutta3`` with error control off (fixed step
h): explicit, so it integrates Hunt & Crossley's law as written and its restitution is the
model's (measured 0.997..1.001 a bounce at h = 1e-3 for e = 1, where Drake's fixed-step ``implicit_euler``
gives 0.85); its cost is three force evaluations a step. Its stability limit h omega_c <= 2.51
is crossed at h = 1/60 (h omega_c = 3.3): that run is recorded as unstable.

The loop is Drake's: ``Simulator.AdvanceTo`` step by step while recording (the discrete plant's
updates fall at k h; the continuous plant advances to t_n = fl(t_(n-1) + h)), and one
``AdvanceTo(end)`` when timed.
"""

from __future__ import annotations

import functools
import logging
import math

import numpy as np

from .._contact import BOX, SPHERE, ContactMode, record_loop, timed_loop
from .._engine import import_engine

#: The contact's natural frequency (rad/s): MuJoCo's poses' (``adapters.mujoco.contact``).
OMEGA_C = 200.0
#: How Drake poses each contact scene (the scene's kind -> its ``ContactPose``): the ball a sphere on a
#: PrismaticJoint along z, each box a free body touching by its corners. A new contact scene is one entry here.
POSES = {"ball": SPHERE, "slide": BOX, "rest": BOX, "stack": BOX}
#: The corner spheres' radius as a fraction of the box's half side.
CORNER = 0.01
#: Our mode name -> the plant it builds: a discrete contact approximation, or the continuous plant's integrator.
APPROXIMATIONS = {"tamsi": "kTamsi", "sap": "kSap"}
INTEGRATOR = "runge_kutta3"
#: The Stribeck stiction tolerance (m/s): Drake's default, set so that a new default cannot change it.
STICTION_TOLERANCE = 1e-4


def _exit_speed(damping, law: str) -> float:
    """The rebound speed of a unit-frequency contact entered at unit speed, gravity left out:
    ``law`` "hc": X'' = -X (1 + a X')+ (a = d v); "kv": X'' = -(X + 2 zeta X')+. Integrated by
    DOP853 to the instant the force vanishes with the body moving out (then it flies free)."""
    from scipy.integrate import solve_ivp

    if law == "hc":

        def force(x, u):
            return max(x * (1.0 + damping * u), 0.0)
    else:

        def force(x, u):
            return max(x + 2.0 * damping * u, 0.0)

    def rhs(t, y):
        return [y[1], -force(y[0], y[1])]

    def released(t, y):
        return (y[0] * (1.0 + damping * y[1]) if law == "hc" else y[0] + 2.0 * damping * y[1]) if y[1] < 0 else 1.0

    released.terminal, released.direction = True, -1
    out = solve_ivp(
        rhs, (0.0, 100.0), [0.0, 1.0], method="DOP853", events=released, rtol=1e-11, atol=1e-13, max_step=0.05
    )
    return -float(out.y[1, -1])


@functools.lru_cache(maxsize=64)
def _solve(e: float, law: str) -> float:
    from scipy.optimize import brentq

    if e >= 1.0:
        return 0.0
    hi = 1.0
    while _exit_speed(hi, law) > e:
        hi *= 2.0
    return brentq(lambda a: _exit_speed(a, law) - e, 0.0, hi, xtol=1e-12)


def hunt_crossley_for(e: float, speed: float) -> float:
    """Hunt & Crossley's d (s/m) that restores a fraction e of the impact ``speed``."""
    return _solve(e, "hc") / speed


def relaxation_for(e: float, omega: float) -> float:
    """The Kelvin-Voigt relaxation time (s) whose contact of frequency ``omega`` restores a fraction e."""
    return 2.0 * _solve(e, "kv") / omega


def _dissipation(scene) -> dict:
    """The pair's stiffness per contact, Hunt & Crossley d and relaxation time, with how they were derived."""
    if POSES[scene.kind] is SPHERE:
        speed = math.sqrt(2.0 * scene.g * scene.h0)
        return {
            "k": scene.mass * OMEGA_C**2,
            "d": hunt_crossley_for(scene.e, speed),
            "tau": relaxation_for(scene.e, OMEGA_C),
            "derived": (
                f"e = {scene.e:g}: Hunt & Crossley d for e at the first impact speed "
                f"sqrt(2 g h0) = {speed:.6g} m/s; relaxation time for e at any speed (zeta = omega_c tau / 2)"
            ),
        }
    return {
        "k": scene.mass * OMEGA_C**2 / 4.0,
        "d": 2.0 * OMEGA_C / scene.g,
        "tau": 2.0 / OMEGA_C,
        "derived": "critically damped about the resting load: d = 2 omega_c / g, tau = 2 / omega_c",
    }


class _NoDeformableNote(logging.Filter):
    """Drops the one warning a half space draws (deformable bodies, none here, cannot touch it) and
    nothing else: Drake's log is process-wide, and its parser's warnings are what another adapter
    reads (``adapters._drake_model.parser_warnings``)."""

    def filter(self, record) -> bool:
        return "half spaces are not currently supported for deformable contact" not in record.getMessage()


def _quiet_drake() -> None:
    log = logging.getLogger("drake")
    if not any(isinstance(f, _NoDeformableNote) for f in log.filters):
        log.addFilter(_NoDeformableNote())


class _Pose:
    """The scene's plant in a ``Simulator`` at its initial state (module docstring)."""

    def __init__(self, mode: ContactMode, scene, dt: float, defaults: bool = False):
        import_engine("pydrake")
        _quiet_drake()
        from pydrake.geometry import (
            AddContactMaterial,
            Box,
            CollisionFilterDeclaration,
            GeometrySet,
            HalfSpace,
            ProximityProperties,
            Sphere,
        )
        from pydrake.math import RigidTransform
        from pydrake.multibody.plant import (
            AddMultibodyPlantSceneGraph,
            ContactModel,
            CoulombFriction,
            DiscreteContactApproximation,
        )
        from pydrake.multibody.tree import PrismaticJoint, SpatialInertia
        from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
        from pydrake.systems.framework import DiagramBuilder

        approximation = mode.settings["plant"]
        self.discrete = approximation != "continuous"
        builder = DiagramBuilder()
        plant, scene_graph = AddMultibodyPlantSceneGraph(builder, dt if self.discrete else 0.0)
        plant.set_contact_model(ContactModel.kPoint)
        plant.set_stiction_tolerance(STICTION_TOLERANCE)
        if self.discrete:
            plant.set_discrete_contact_approximation(
                getattr(DiscreteContactApproximation, APPROXIMATIONS[approximation])
            )
        c = _dissipation(scene)
        self.sphere = sphere = POSES[scene.kind] is SPHERE
        # The ball's contact is frictionless (it only moves along z); a box's the scene's mu, or 1 where it has none.
        mu = 0.0 if sphere else getattr(scene, "mu", 1.0)

        def material():
            p = ProximityProperties()
            if defaults:  # Drake's defaults: nothing but the friction, which Drake requires
                AddContactMaterial(friction=CoulombFriction(mu, mu), properties=p)
            else:
                AddContactMaterial(
                    dissipation=c["d"], point_stiffness=2.0 * c["k"], friction=CoulombFriction(mu, mu), properties=p
                )
                p.AddProperty("material", "relaxation_time", c["tau"] / 2.0)
            return p

        ground = plant.RegisterCollisionGeometry(
            plant.world_body(), HalfSpace.MakePose([0.0, 0.0, 1.0], [0.0, 0.0, 0.0]), HalfSpace(), "ground", material()
        )
        self.bodies = []
        if sphere:
            body = plant.AddRigidBody("ball", SpatialInertia.SolidSphereWithMass(scene.mass, scene.radius))
            plant.AddJoint(PrismaticJoint("z", plant.world_frame(), body.body_frame(), [0.0, 0.0, 1.0], damping=0.0))
            plant.RegisterCollisionGeometry(body, RigidTransform(), Sphere(scene.radius), "ball", material())
            self.bodies.append(body)
            model = "a solid sphere on a PrismaticJoint along z (damping 0) over a HalfSpace"
        else:
            half, r = scene.half, CORNER * scene.half
            faces = [ground]
            for i, _ in enumerate(scene.initial_centres()):
                body = plant.AddRigidBody(f"box{i}", SpatialInertia.SolidBoxWithMass(scene.mass, *(3 * [2.0 * half])))
                for j, (sx, sy) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1))):
                    plant.RegisterCollisionGeometry(
                        body,
                        RigidTransform([sx * (half - r), sy * (half - r), -(half - r)]),
                        Sphere(r),
                        f"box{i}_corner{j}",
                        material(),
                    )
                if i < scene.bodies - 1:
                    faces.append(
                        plant.RegisterCollisionGeometry(
                            body, RigidTransform(), Box(*(3 * [2.0 * half])), f"box{i}", material()
                        )
                    )
                self.bodies.append(body)
            model = (
                f"{scene.bodies} free solid box(es), each touching by four spheres of radius {r:g} m at its bottom "
                "corners; a box that carries another has its Box for the corners above to touch; box-box and "
                "box-plane pairs filtered out"
            )
        plant.mutable_gravity_field().set_gravity_vector([float(x) for x in scene.gravity])
        plant.Finalize()
        if len(faces if not sphere else []) > 1:
            scene_graph.collision_filter_manager().Apply(CollisionFilterDeclaration().ExcludeWithin(GeometrySet(faces)))
        diagram = builder.Build()
        self.plant, self.dt, self.scene = plant, dt, scene
        self.sim = sim = Simulator(diagram)
        self.context = context = plant.GetMyMutableContextFromRoot(sim.get_mutable_context())
        if sphere:  # held to z on its joint (``holds_ball_to_z``): the scene's height and vertical speed
            plant.SetPositions(context, [float(scene.initial_centres()[0][2])])
            plant.SetVelocities(context, [float(scene.initial_velocities()[0][2])])
        else:
            for body, centre in zip(self.bodies, scene.initial_centres()):
                plant.SetFreeBodyPose(context, body, RigidTransform(list(centre)))
            velocities = scene.initial_velocities()
            if any(any(u) for u in velocities):
                v = np.zeros(plant.num_velocities())
                for i, u in enumerate(velocities):
                    v[6 * i + 3 : 6 * i + 6] = u  # a free body's velocities: angular, then translational
                plant.SetVelocities(context, v)
        sim.set_target_realtime_rate(0.0)
        self.settings = {
            "plant": (
                f"discrete, time_step {dt!r}, {APPROXIMATIONS[approximation]}"
                if self.discrete
                else "continuous (time_step 0)"
            ),
            "contact_model": "kPoint (Drake's default: hydroelastic with point fallback)",
            "model": model,
            "gravity": [float(x) for x in scene.gravity],
        }
        if defaults:
            self.settings["contact material"] = "Drake's defaults (DefaultProximityProperties)"
        else:
            self.settings.update(
                {
                    "contact omega_c (rad/s)": OMEGA_C,
                    "point_contact_stiffness (pair, N/m)": c["k"],
                    "hunt_crossley_dissipation (s/m)": c["d"],
                    "relaxation_time (pair, s)": c["tau"],
                    "used": (
                        "relaxation_time (Kelvin-Voigt)"
                        if approximation == "sap"
                        else "hunt_crossley_dissipation (Hunt & Crossley)"
                    ),
                    "dissipation derived": c["derived"],
                    "per geometry": "point_stiffness 2 k, relaxation_time tau / 2, dissipation d (Drake combines "
                    "stiffness in series, relaxation times by sum)",
                }
            )
        self.settings.update(
            {
                "friction": f"CoulombFriction({mu:g}, {mu:g}) on every geometry (combined: {mu:g})",
                "stiction_tolerance (m/s)": STICTION_TOLERANCE,
            }
        )
        if approximation == "sap":
            self.settings["sap_near_rigid_threshold"] = float(plant.get_sap_near_rigid_threshold())
        if not self.discrete:
            integrator = ResetIntegratorFromFlags(sim, INTEGRATOR, dt)
            integrator.set_fixed_step_mode(True)
            integrator.set_maximum_step_size(dt)
            self.settings.update(
                {
                    "integrator": INTEGRATOR,
                    "fixed_step_mode": bool(integrator.get_fixed_step_mode()),
                    "maximum_step_size": float(integrator.get_maximum_step_size()),
                }
            )
        sim.Initialize()
        self.n, self.time = 0, 0.0
        self.nq = plant.num_positions()

    def step(self) -> None:
        self.n += 1
        self.time = self.n * self.dt if self.discrete else self.time + self.dt
        self.sim.AdvanceTo(self.time)

    def read(self):
        q = self.plant.GetPositions(self.context)
        v = self.plant.GetVelocities(self.context)
        if self.sphere:
            return np.array([[0.0, 0.0, q[0]]]), np.array([[0.0, 0.0, v[0]]])
        nb = len(self.bodies)
        # Free bodies in the order added: (qw, qx, qy, qz, x, y, z) each, velocities (w, v) each.
        c = np.array([q[7 * i + 4 : 7 * i + 7] for i in range(nb)])
        u = np.array([v[6 * i + 3 : 6 * i + 6] for i in range(nb)])
        return c, u

    def end_time(self, steps: int) -> float:
        if self.discrete:
            return steps * self.dt
        t = 0.0
        for _ in range(steps):
            t = t + self.dt
        return t


def run(mode: ContactMode, scene, dt: float, defaults: bool = False):
    """The scene in ``mode`` at step ``dt`` (``defaults``: Drake's own contact material instead of
    the derived one, to measure what the defaults do)."""
    pose = _Pose(mode, scene, dt, defaults)

    def step():
        try:
            pose.step()
        except RuntimeError as exc:  # a state Drake refuses: a blow-up
            pose.read = lambda: (np.full((len(pose.bodies), 3), np.nan),) * 2
            pose.settings["drake stopped"] = " ".join(str(exc).split())[:160]

    def time_again(steps: int) -> float:
        again = _Pose(mode, scene, dt, defaults)
        end = again.end_time(steps)
        return timed_loop(lambda: again.sim.AdvanceTo(end), 1)

    return record_loop(
        mode,
        scene,
        dt,
        step,
        lambda: pose.read(),
        pose.settings,
        loop="Simulator.AdvanceTo(end), one call",
        time_again=time_again,
    )


_DOC = {
    "tamsi": "Drake's discrete plant under TAMSI; Hunt & Crossley point contact, d derived from e",
    "sap": "Drake's discrete plant under SAP; Kelvin-Voigt point contact, relaxation time derived from e",
    "continuous": "Drake's continuous plant, runge_kutta3 at a fixed step; Hunt & Crossley point contact, d from e",
}

MODES = {
    f"drake:{name}": ContactMode(
        "drake",
        name,
        "drake",
        run,
        poses=POSES,
        holds_ball_to_z=True,
        settings={
            "plant": name,
            "contact_model": "kPoint",
            **({"integrator": INTEGRATOR, "fixed_step_mode": True} if name == "continuous" else {}),
        },
        doc=_DOC[name],
        module="pydrake",
    )
    for name in ("tamsi", "sap", "continuous")
}
