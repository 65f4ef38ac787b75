"""Drake's contact poses, in three contacts: the stiff pose (the discrete ``MultibodyPlant`` under
TAMSI and under SAP, and the continuous plant under Kutta's RK3 at a fixed step, every contact of
the common frequency ``OMEGA_C``: the controlled comparison), Drake's own defaults, and the
hydroelastic contact Drake's documentation recommends (under the discrete plant's default
approximation ``kLagged``, and hydroelastic also under ``kSimilar``).

The stiff pose (``drake:tamsi``, ``drake:sap``, ``drake:continuous``)
----------------------------------------------------------------------
Drake's compliant point contact (``ContactModel.kPoint``): a penetration x gives a normal force
``k x (1 + d xdot)`` (Hunt & Crossley; TAMSI and the continuous plant) or ``k (x + tau xdot)``
(a linear Kelvin-Voigt spring-dashpot; SAP, ``tau`` its ``relaxation_time``), never pulling.
Drake has no coefficient of restitution; each pose derives its dissipation from the requested e:

* ``k`` from the contact's natural frequency ``OMEGA_C`` (200 rad/s, MuJoCo's poses' too):
  ``k = m omega_c^2`` for a sphere, a quarter of that at each of a box's corner contacts.
  Drake combines two geometries' stiffnesses in series and their relaxation times by sum, their
  Hunt & Crossley dissipations weighted by stiffness: every geometry is given ``2 k``, ``tau / 2``
  and ``d``, so that the pair's are k, tau and d.
* Hunt & Crossley: the restitution depends on ``d v`` alone (v the impact speed; scaled, the
  contact is ``X'' = -X (1 + d v X')+``, whatever the mass and stiffness), so d is solved for e at
  the first impact speed ``sqrt(2 g h0)`` (``hunt_crossley_for``); the later, slower impacts lose
  less (measured in docs/engines.md). e = 1 is d = 0.
* Kelvin-Voigt (SAP): the restitution depends on the damping ratio ``zeta = omega tau / 2``
  alone, the force cut off where it would pull (``relaxation_for``), solved at omega_c: exact for
  the ball, approximate for a box's corner (its contact's frequency depends on how the box meets
  the plane). e = 1 is tau = 0.
* A resting contact (the boxes that slide, rest and stack, the tipping box, the rolling ball, and
  a scene asking e = 0, which no finite dissipation reaches) is critically damped about the
  resting load: ``d = 2 omega_c / g`` (Hunt & Crossley's damping ``k x0 d`` at the static sink
  ``x0 = g / omega_c^2`` is ``2 m omega_c``), ``tau = 2 / omega_c``.

Drake's defaults each change the answer (docs/engines.md, measured): ``point_stiffness`` 1e6 per
geometry (5e5 N/m a pair, 707 rad/s on 1 kg), ``hunt_crossley_dissipation`` 50 s/m, and
``relaxation_time`` 0.1 s a geometry (0.2 s a pair). With them SAP's and TAMSI's ball does not
bounce at all, and RK3 at h = 1e-3 throws it 55 m high.

The integrator of the continuous plant is ``runge_kutta3`` with error control off (fixed step
h): explicit, so it integrates Hunt & Crossley's law as written and its restitution is the
model's (measured 0.997..1.001 a bounce at h = 1e-3 for e = 1, where Drake's fixed-step ``implicit_euler``
gives 0.85); its cost is three force evaluations a step. Its stability limit h omega_c <= 2.51
is crossed at h = 1/60 (h omega_c = 3.3): that run is recorded as unstable.

Drake's defaults (``drake:lagged?contact=default``)
---------------------------------------------------
What a user gets who sets nothing but the geometry and its friction (Drake's "Proposed Modeling
Workflow": "Author a first pass of your model without specifying contact parameters. Drake will
default to parameters in drake::geometry::SceneGraphConfig",
https://drake.mit.edu/doxygen_cxx/group__contact__defaults.html): the plant's default contact
model ``kHydroelasticWithFallback`` (no geometry is given a hydroelastic representation, so every
pair falls back to point contact), its default discrete approximation ``kLagged`` (set, as the
mode's id names it: "kLagged is the preferred approximation when strong transients are not
expected", ``DiscreteContactApproximation``), its default stiction tolerance, and every contact
material from ``DefaultProximityProperties`` (point_stiffness 1e6 N/m a geometry,
hunt_crossley_dissipation 50 s/m: "values around 40 - 50 s/m effectively approximate [inelastic
contact]"). The plant's penetration allowance (``MultibodyPlantConfig.penetration_allowance``,
1e-3 m) is not used: it only estimates a stiffness and dissipation for a geometry that has none,
and ``DefaultProximityProperties`` gives every one ("Values provided in
DefaultProximityProperties have precedence", ``set_penetration_allowance``). The requested e is
not approached: the default dissipation is the documented inelastic one. Every value is read back
from the scene graph into the run's settings.

Hydroelastic (``drake:lagged?contact=hydroelastic``, ``drake:similar?contact=hydroelastic``)
-------------------------------------------------------------------------------------------
The Hydroelastic Contact User Guide
(https://drake.mit.edu/doxygen_cxx/group__hydroelastic__user__guide.html): contact model
``kHydroelasticWithFallback`` (the default, set); each body compliant-hydroelastic
(``AddCompliantHydroelasticProperties``) with ``HYDROELASTIC_MODULUS`` (``DefaultProximityProperties``'
1e7 Pa, the contact_defaults page's "good starting point") and ``RESOLUTION_HINT`` (its 0.02 m: a
sphere of radius 0.1 m is 512 tetrahedra; a box's mesh does not depend on it), and the
``MARGIN`` the guide advises for the discrete plant ("a good start is a margin value of
δ = 10⁻⁴ m", hug_properties); the plane a rigid-hydroelastic ``HalfSpace``
(``AddRigidHydroelasticProperties``), as the guide's tutorial drops a compliant block on a rigid
plate. A box is its ``Box``: a face on the plane or on the box below is a pressure field over the
patch, not points. Two discrete approximations, both Hunt & Crossley (hug_dissipation_and_solver):
``kLagged``, the default, "preferred ... when strong transients are not expected", and
``kSimilar``, "if strong transients do need to be accurately resolved" (``DiscreteContactApproximation``):
a drop is one. Restitution: the guide links Hunt & Crossley's dissipation to it ("the inverse of
the Hunt-Crossley dissipation is the maximum bounce velocity"); where a scene requests e, d is
solved for e at the first impact speed for the force law of the first touch (``HYDRO_POWER``:
f ∝ x² for a compliant sphere on a rigid plane, the guide's π E x², and for a box's edge, a
wedge; x³ for a corner); elsewhere a box's is Drake's default 50 s/m (``RESTING_DISSIPATION``: at
the guide's start, 0, the boxes jitter as it warns) and the rolling ball's 0 (``ROLLING_DISSIPATION``:
on a patch Hunt & Crossley dissipation is a rolling resistance). The discrete solver is implicit: what
restitution results is measured (docs/engines.md), far below the material's at every report step.

Geometry (every contact)
------------------------
The ball is a solid sphere on one ``PrismaticJoint`` along z (a frictionless up-and-down contact
with the ``HalfSpace``). In the point contacts (stiff and default) each box is a free body touching
by small spheres (``CORNER`` of its half side) at its corners: the four bottom ones for a box
that stays upright (with its ``Box`` where a box stands on it), all eight for a box that turns
(the edge, corner and tipping scenes); Drake's box-on-half-space point contact is one point, on
which a box rocks (measured 4e-3 rad of tilt while sliding at h = 1e-3 and 0.3 rad at h = 1/60).
Box-against-box and box-against-plane pairs are filtered out, so every point contact is a corner
on a face. The rolling ball is a free solid sphere (``SpatialInertia.SolidSphereWithMass``, 2/5 m
r^2). A free body starts at the scene's orientation (``Quaternion(w, x, y, z)``, body to world) and
its spatial velocity (angular velocity in world axes); ``read`` gives each body's centre and
orientation from ``EvalBodyPoseInWorld`` (``ToQuaternion().wxyz()``) and its velocities from
``EvalBodySpatialVelocityInWorld`` (world axes). Friction: ``CoulombFriction(mu, mu)`` on every
geometry (Drake's combination ``2 mu1 mu2 / (mu1 + mu2)`` is then mu); the Stribeck stiction
tolerance is Drake's default 1e-4 m/s (set where the contact is not Drake's defaults).

The loop is Drake's: ``Simulator.AdvanceTo`` step by step while recording (the discrete plant's
updates fall at k h; the continuous plant advances to t_n = fl(t_(n-1) + h)), and one
``AdvanceTo(end)`` when timed.
"""

from __future__ import annotations

import functools
import logging
import math

import numpy as np

from .._contact import BOX, ROLLING_SPHERE, SPHERE, TURNING_BOX, ContactMode, record_loop, timed_loop
from .._engine import import_engine

#: The contact's natural frequency (rad/s): MuJoCo's poses' (``adapters.mujoco.contact``).
OMEGA_C = 200.0
#: How Drake poses each contact scene (the scene's kind -> its ``ContactPose``): the ball a sphere on a
#: PrismaticJoint along z, each box a free body (touching by its corners in a point contact), the rolling
#: ball a free sphere. A new contact scene is one entry here.
POSES = {
    "ball": SPHERE,
    "slide": BOX,
    "rest": BOX,
    "stack": BOX,
    "edge": TURNING_BOX,
    "corner": TURNING_BOX,
    "tip": TURNING_BOX,
    "roll": ROLLING_SPHERE,
}
#: The corner spheres' radius as a fraction of the box's half side.
CORNER = 0.01
#: Our mode name -> the plant it builds: a discrete contact approximation, or the continuous plant's integrator.
APPROXIMATIONS = {"tamsi": "kTamsi", "sap": "kSap", "lagged": "kLagged", "similar": "kSimilar"}
INTEGRATOR = "runge_kutta3"
#: The Stribeck stiction tolerance (m/s): Drake's default, set so that a new default cannot change it.
STICTION_TOLERANCE = 1e-4
#: The hydroelastic contact's material (``DefaultProximityProperties``' modulus (Pa) and resolution hint (m),
#: set so that a new default cannot change them; the user guide's margin (m) for the discrete plant).
HYDROELASTIC_MODULUS = 1e7
RESOLUTION_HINT = 0.02
MARGIN = 1e-4
#: The hydroelastic pose's Hunt & Crossley dissipation (s/m) where the scene requests no restitution. A box's:
#: Drake's default 50 s/m ("inelastic", contact_defaults; the user guide's "10 to 50 being a typical damping
#: amount"): the guide's start, 0, is "jittery" here as it warns (measured: the box sliding at 1/60 s under
#: kSimilar gains speed, 3.9 m/s at the end). The rolling ball's: 0 (the guide's "for objects that are nominally
#: rigid, starting with zero-damping is good"): on a patch Hunt & Crossley is a rolling resistance (the pressure
#: is higher where the patch is pressed in than where it is released), which the scene has none of; with 50 s/m
#: the ball rolls 10% short at h = 1e-3.
RESTING_DISSIPATION = 50.0
ROLLING_DISSIPATION = 0.0
#: The hydroelastic force's power of the penetration at a scene's first touch, for the dissipation that
#: restores e: a compliant sphere on a rigid plane pi E x^2; a box's edge a wedge (patch width and pressure
#: each grow with x), its corner a pyramid (patch area x^2, pressure x).
HYDRO_POWER = {"ball": 2, "edge": 2, "corner": 3}
#: Where Drake's documentation says each setting of the default and hydroelastic contacts.
SOURCES = {
    "contact_defaults": "https://drake.mit.edu/doxygen_cxx/group__contact__defaults.html",
    "hydroelastic_user_guide": "https://drake.mit.edu/doxygen_cxx/group__hydroelastic__user__guide.html",
    "DiscreteContactApproximation": (
        "https://drake.mit.edu/doxygen_cxx/namespacedrake_1_1multibody.html "
        "(DiscreteContactApproximation: 'How to choose an approximation')"
    ),
    "DefaultProximityProperties": (
        "https://drake.mit.edu/doxygen_cxx/structdrake_1_1geometry_1_1_default_proximity_properties.html"
    ),
}
#: The contacts a mode poses: the stiff common-omega_c pose, Drake's defaults, hydroelastic.
CONTACTS = ("stiff", "default", "hydroelastic")


def _exit_speed(damping, law: str, power: int = 1) -> float:
    """The rebound speed of a unit contact entered at unit speed, gravity left out:
    ``law`` "hc": X'' = -X^power (1 + a X')+ (a = d v); "kv": X'' = -(X + 2 zeta X')+. Integrated by
    DOP853 to the instant the force vanishes with the body moving out (then it flies free)."""
    from scipy.integrate import solve_ivp

    if law == "hc":

        def force(x, u):
            return max(max(x, 0.0) ** power * (1.0 + damping * u), 0.0)
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
def _solve(e: float, law: str, power: int = 1) -> float:
    from scipy.optimize import brentq

    if e >= 1.0:
        return 0.0
    if e <= 0.0:
        raise ValueError("no finite dissipation stops a compliant contact's rebound (e = 0): pose a resting contact")
    hi = 1.0
    while _exit_speed(hi, law, power) > e:
        hi *= 2.0
    return brentq(lambda a: _exit_speed(a, law, power) - e, 0.0, hi, xtol=1e-12)


def hunt_crossley_for(e: float, speed: float, power: int = 1) -> float:
    """Hunt & Crossley's d (s/m) that restores a fraction e of the impact ``speed``, for a contact
    force ``c x^power (1 + d xdot)`` (whatever c and the mass: scaled, e depends on d v alone)."""
    return _solve(e, "hc", power) / speed


def relaxation_for(e: float, omega: float) -> float:
    """The Kelvin-Voigt relaxation time (s) whose contact of frequency ``omega`` restores a fraction e."""
    return 2.0 * _solve(e, "kv") / omega


def _requested_e(scene) -> float | None:
    """The restitution the scene requests of its impacts (None: a resting contact)."""
    e = scene.values.get("e")
    return None if e is None or e <= 0.0 else float(e)


def _impact_speed(scene) -> float:
    """The first impact's speed: a fall from h0 (the ball's lowest point, the dropped box's lowest corner)."""
    return math.sqrt(2.0 * scene.g * scene.h0)


def _dissipation(scene) -> dict:
    """The stiff pose's pair stiffness per contact, Hunt & Crossley d and relaxation time, with how
    they were derived."""
    shape = POSES[scene.kind].shape
    k = scene.mass * OMEGA_C**2 * (0.25 if shape in ("box", "turning_box") else 1.0)
    e = _requested_e(scene)
    if e is not None:
        speed = _impact_speed(scene)
        return {
            "k": k,
            "d": hunt_crossley_for(e, speed),
            "tau": relaxation_for(e, OMEGA_C),
            "derived": (
                f"e = {e:g}: Hunt & Crossley d for e at the first impact speed sqrt(2 g h0) = {speed:.6g} m/s; "
                "relaxation time for e at any speed (zeta = omega_c tau / 2)"
            ),
        }
    return {
        "k": k,
        "d": 2.0 * OMEGA_C / scene.g,
        "tau": 2.0 / OMEGA_C,
        "derived": "a resting contact, critically damped about the resting load: d = 2 omega_c / g, tau = 2 / omega_c",
    }


def _hydro_dissipation(scene) -> tuple[float, str]:
    """The hydroelastic pose's Hunt & Crossley d (s/m) and how it was derived."""
    e = _requested_e(scene)
    if e is None:
        if POSES[scene.kind] is ROLLING_SPHERE:
            return ROLLING_DISSIPATION, "a rolling contact: 0 s/m, no rolling resistance (ROLLING_DISSIPATION)"
        return RESTING_DISSIPATION, "a resting contact: Drake's default 50 s/m (RESTING_DISSIPATION)"
    power, speed = HYDRO_POWER[scene.kind], _impact_speed(scene)
    return hunt_crossley_for(e, speed, power), (
        f"e = {e:g}: Hunt & Crossley d for e at the first impact speed sqrt(2 g h0) = {speed:.6g} m/s, "
        f"for a force growing as x^{power} (HYDRO_POWER)"
    )


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


#: The material properties read back from the scene graph (group, name) into a run's settings.
_READ_BACK = {
    "point": (
        ("material", "point_contact_stiffness"),
        ("material", "hunt_crossley_dissipation"),
        ("material", "relaxation_time"),
    ),
    "hydroelastic": (
        ("material", "hunt_crossley_dissipation"),
        ("hydroelastic", "hydroelastic_modulus"),
        ("hydroelastic", "resolution_hint"),
        ("hydroelastic", "margin"),
    ),
}


def material_of(inspector, geometry, contact: str) -> dict:
    """A geometry's contact material as the scene graph holds it (Drake's defaults filled in):
    the properties a ``contact`` ("point" or "hydroelastic") uses, its friction, and for
    hydroelastic its representation (a compliant geometry's tetrahedral mesh; none for a rigid
    half space, which is not meshed)."""
    props = inspector.GetProximityProperties(geometry)
    out = {
        name: float(props.GetProperty(group, name))
        for group, name in _READ_BACK[contact]
        if props.HasProperty(group, name)
    }
    friction = props.GetProperty("material", "coulomb_friction")
    out["coulomb_friction (static, dynamic)"] = (friction.static_friction(), friction.dynamic_friction())
    if contact == "hydroelastic":
        mesh = inspector.maybe_get_hydroelastic_mesh(geometry)
        out["mesh"] = (
            "none (a half space)" if mesh is None else f"{type(mesh).__name__}, {mesh.num_elements()} elements"
        )
    return out


class _Pose:
    """The scene's plant in a ``Simulator`` at its initial state (module docstring). ``defaults``:
    the stiff modes with Drake's own contact material instead of the derived one (to measure what
    the defaults do)."""

    def __init__(self, mode: ContactMode, scene, dt: float, defaults: bool = False):
        import_engine("pydrake")
        _quiet_drake()
        from pydrake.common.eigen_geometry import Quaternion
        from pydrake.geometry import (
            AddCompliantHydroelasticProperties,
            AddContactMaterial,
            AddRigidHydroelasticProperties,
            Box,
            CollisionFilterDeclaration,
            GeometrySet,
            HalfSpace,
            ProximityProperties,
            Sphere,
        )
        from pydrake.math import RigidTransform
        from pydrake.multibody.math import SpatialVelocity
        from pydrake.multibody.plant import (
            AddMultibodyPlantSceneGraph,
            ContactModel,
            CoulombFriction,
            DiscreteContactApproximation,
            MultibodyPlantConfig,
        )
        from pydrake.multibody.tree import PrismaticJoint, SpatialInertia
        from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
        from pydrake.systems.framework import DiagramBuilder

        approximation = mode.settings["plant"]
        self.contact = contact = mode.settings.get("contact", "stiff")
        self.discrete = approximation != "continuous"
        builder = DiagramBuilder()
        plant, scene_graph = AddMultibodyPlantSceneGraph(builder, dt if self.discrete else 0.0)
        if contact == "stiff":
            plant.set_contact_model(ContactModel.kPoint)
        elif contact == "hydroelastic":
            plant.set_contact_model(ContactModel.kHydroelasticWithFallback)
        if contact != "default":
            plant.set_stiction_tolerance(STICTION_TOLERANCE)
        if self.discrete:
            plant.set_discrete_contact_approximation(
                getattr(DiscreteContactApproximation, APPROXIMATIONS[approximation])
            )
        self.shape = shape = POSES[scene.kind].shape
        self.turns = shape in ("turning_box", "rolling_sphere")
        # The ball's contact is frictionless (it only moves along z); a box's the scene's mu, or 1 where it has none.
        mu = 0.0 if shape == "sphere" else getattr(scene, "mu", 1.0)
        c = _dissipation(scene)
        hydro_d, hydro_derived = _hydro_dissipation(scene) if contact == "hydroelastic" else (None, "")

        def material(ground: bool = False):
            p = ProximityProperties()
            friction = CoulombFriction(mu, mu)
            if contact == "default" or defaults:  # Drake's defaults: nothing but the friction, which Drake requires
                AddContactMaterial(friction=friction, properties=p)
            elif contact == "hydroelastic":
                AddContactMaterial(dissipation=hydro_d, friction=friction, properties=p)
                if ground:
                    AddRigidHydroelasticProperties(p)
                else:
                    AddCompliantHydroelasticProperties(RESOLUTION_HINT, HYDROELASTIC_MODULUS, p)
                    p.AddProperty("hydroelastic", "margin", float(MARGIN))
            else:
                AddContactMaterial(dissipation=c["d"], point_stiffness=2.0 * c["k"], friction=friction, properties=p)
                p.AddProperty("material", "relaxation_time", c["tau"] / 2.0)
            return p

        ground = plant.RegisterCollisionGeometry(
            plant.world_body(),
            HalfSpace.MakePose([0.0, 0.0, 1.0], [0.0, 0.0, 0.0]),
            HalfSpace(),
            "ground",
            material(ground=True),
        )
        self.bodies, faces, self.geometries = [], [ground], []
        points = contact != "hydroelastic"
        if shape == "sphere":
            body = plant.AddRigidBody("ball", SpatialInertia.SolidSphereWithMass(scene.mass, scene.radius))
            plant.AddJoint(PrismaticJoint("z", plant.world_frame(), body.body_frame(), [0.0, 0.0, 1.0], damping=0.0))
            self.geometries.append(
                plant.RegisterCollisionGeometry(body, RigidTransform(), Sphere(scene.radius), "ball", material())
            )
            self.bodies.append(body)
            model = "a solid sphere on a PrismaticJoint along z (damping 0) over a HalfSpace"
        elif shape == "rolling_sphere":
            body = plant.AddRigidBody("ball", SpatialInertia.SolidSphereWithMass(scene.mass, scene.radius))
            self.geometries.append(
                plant.RegisterCollisionGeometry(body, RigidTransform(), Sphere(scene.radius), "ball", material())
            )
            self.bodies.append(body)
            model = "a free solid sphere (SpatialInertia.SolidSphereWithMass: 2/5 m r^2) over a HalfSpace"
        else:
            half, r = scene.half, CORNER * scene.half
            side = 3 * [2.0 * half]
            signs = (1, -1)
            corners = (
                [(sx, sy, sz) for sx in signs for sy in signs for sz in signs]
                if shape == "turning_box"
                else [(sx, sy, -1) for sx in signs for sy in signs]
            )
            for i, _ in enumerate(scene.initial_centres()):
                body = plant.AddRigidBody(f"box{i}", SpatialInertia.SolidBoxWithMass(scene.mass, *side))
                if not points:
                    self.geometries.append(
                        plant.RegisterCollisionGeometry(body, RigidTransform(), Box(*side), f"box{i}", material())
                    )
                else:
                    for j, corner in enumerate(corners):
                        self.geometries.append(
                            plant.RegisterCollisionGeometry(
                                body,
                                RigidTransform([s * (half - r) for s in corner]),
                                Sphere(r),
                                f"box{i}_corner{j}",
                                material(),
                            )
                        )
                    if i < scene.bodies - 1:
                        faces.append(
                            plant.RegisterCollisionGeometry(body, RigidTransform(), Box(*side), f"box{i}", material())
                        )
                self.bodies.append(body)
            if not points:
                model = (
                    f"{scene.bodies} free solid box(es), each its Box (side {2 * half:g} m), compliant-hydroelastic, "
                    "on a rigid-hydroelastic HalfSpace"
                )
            else:
                model = (
                    f"{scene.bodies} free solid box(es), each touching by {len(corners)} spheres of radius {r:g} m at "
                    f"its {'corners' if shape == 'turning_box' else 'bottom corners'}"
                    + (
                        "; a box that carries another has its Box for the corners above to touch; box-box and "
                        "box-plane pairs filtered out"
                        if scene.bodies > 1
                        else ""
                    )
                )
        plant.mutable_gravity_field().set_gravity_vector([float(x) for x in scene.gravity])
        plant.Finalize()
        if len(faces) > 1:
            scene_graph.collision_filter_manager().Apply(CollisionFilterDeclaration().ExcludeWithin(GeometrySet(faces)))
        diagram = builder.Build()
        self.plant, self.scene_graph, self.dt, self.scene = plant, scene_graph, dt, scene
        self.sim = sim = Simulator(diagram)
        self.context = context = plant.GetMyMutableContextFromRoot(sim.get_mutable_context())
        if shape == "sphere":  # held to z on its joint (``holds_ball_to_z``): the scene's height and vertical speed
            plant.SetPositions(context, [float(scene.initial_centres()[0][2])])
            plant.SetVelocities(context, [float(scene.initial_velocities()[0][2])])
        else:
            for body, centre, u, q, w in zip(
                self.bodies,
                scene.initial_centres(),
                scene.initial_velocities(),
                scene.initial_orientations(),
                scene.initial_angular_velocities(),
            ):
                q = np.asarray(q, dtype=float) / np.linalg.norm(q)  # (w, x, y, z): Drake's Quaternion order
                plant.SetFreeBodyPose(context, body, RigidTransform(Quaternion(*q), [float(x) for x in centre]))
                plant.SetFreeBodySpatialVelocity(
                    context, body, SpatialVelocity(w=[float(x) for x in w], v=[float(x) for x in u])
                )
        sim.set_target_realtime_rate(0.0)
        self.settings = {
            "plant": (
                f"discrete, time_step {dt!r}, {APPROXIMATIONS[approximation]}"
                if self.discrete
                else "continuous (time_step 0)"
            ),
            "contact": contact,
            "contact_model": _contact_model_text(plant.get_contact_model(), contact),
            "model": model,
            "gravity": [float(x) for x in scene.gravity],
        }
        if self.discrete:
            self.settings["discrete_contact_approximation (read back)"] = (
                plant.get_discrete_contact_approximation().name
            )
        inspector = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(sim.get_context()))
        inspector = inspector.inspector()
        read_as = "hydroelastic" if contact == "hydroelastic" else "point"
        self.settings["material (read back: ground)"] = material_of(inspector, ground, read_as)
        self.settings["material (read back: body)"] = material_of(inspector, self.geometries[0], read_as)
        if contact == "default" or defaults:
            self.settings["contact material"] = (
                "Drake's defaults (SceneGraphConfig().default_proximity_properties, read back above); the "
                f"penetration allowance ({MultibodyPlantConfig().penetration_allowance:g} m) unused: the defaults "
                f"have precedence ({SOURCES['contact_defaults']})"
            )
        elif contact == "hydroelastic":
            self.settings.update(
                {
                    "hydroelastic": (
                        f"bodies compliant (AddCompliantHydroelasticProperties: modulus {HYDROELASTIC_MODULUS:g} Pa, "
                        f"resolution_hint {RESOLUTION_HINT:g} m, DefaultProximityProperties'; margin {MARGIN:g} m, "
                        "the user guide's start for the discrete plant); the plane rigid "
                        f"(AddRigidHydroelasticProperties) ({SOURCES['hydroelastic_user_guide']})"
                    ),
                    "hunt_crossley_dissipation (s/m)": hydro_d,
                    "dissipation derived": hydro_derived,
                    "restitution": (
                        "Drake has no coefficient of restitution; Hunt & Crossley's d, solved for e, is the "
                        "material's; the discrete solver's own loss comes on top (measured in docs/engines.md)"
                    ),
                }
            )
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
                "stiction_tolerance (m/s)": (
                    f"{MultibodyPlantConfig().stiction_tolerance:g} (Drake's default, not set)"
                    if contact == "default"
                    else STICTION_TOLERANCE
                ),
            }
        )
        if approximation in ("sap", "lagged", "similar"):
            self.settings["sap_near_rigid_threshold"] = float(plant.get_sap_near_rigid_threshold())
        if contact != "stiff":
            self.settings["sources"] = dict(SOURCES)
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

    def step(self) -> None:
        self.n += 1
        self.time = self.n * self.dt if self.discrete else self.time + self.dt
        self.sim.AdvanceTo(self.time)

    def read(self):
        """(centres, velocities), and for a pose whose bodies turn (orientations (w, x, y, z), angular
        velocities in world axes)."""
        if self.shape == "sphere":
            q = self.plant.GetPositions(self.context)
            v = self.plant.GetVelocities(self.context)
            return np.array([[0.0, 0.0, q[0]]]), np.array([[0.0, 0.0, v[0]]])
        poses = [self.plant.EvalBodyPoseInWorld(self.context, b) for b in self.bodies]
        spins = [self.plant.EvalBodySpatialVelocityInWorld(self.context, b) for b in self.bodies]
        c = np.array([p.translation() for p in poses])
        u = np.array([s.translational() for s in spins])
        if not self.turns:
            return c, u
        q = np.array([p.rotation().ToQuaternion().wxyz() for p in poses])
        w = np.array([s.rotational() for s in spins])
        return c, u, q, w

    def contacts(self) -> tuple[int, int]:
        """The contacts Drake resolves now: (point pairs, hydroelastic surfaces)."""
        results = self.plant.get_contact_results_output_port().Eval(self.context)
        return results.num_point_pair_contacts(), results.num_hydroelastic_contacts()

    def end_time(self, steps: int) -> float:
        if self.discrete:
            return steps * self.dt
        t = 0.0
        for _ in range(steps):
            t = t + self.dt
        return t


def _contact_model_text(model, contact: str) -> str:
    """The plant's contact model (read back), and what it does here."""
    name = model.name
    if contact == "default":
        return f"{name} (Drake's default; no geometry is hydroelastic, so every pair is point contact)"
    if contact == "hydroelastic":
        return f"{name} (Drake's default, set)"
    return f"{name} (Drake's default: hydroelastic with point fallback)"


def run(mode: ContactMode, scene, dt: float, defaults: bool = False):
    """The scene in ``mode`` at step ``dt`` (``defaults``: Drake's own contact material instead of
    the derived one, to measure what the defaults do)."""
    pose = _Pose(mode, scene, dt, defaults)

    def step():
        try:
            pose.step()
        except RuntimeError as exc:  # a state Drake refuses: a blow-up
            nan = np.full((len(pose.bodies), 3), np.nan)
            state = (nan, nan, np.full((len(pose.bodies), 4), np.nan), nan) if pose.turns else (nan, nan)
            pose.read = lambda: state
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
    ("tamsi", "stiff"): "Drake's discrete plant under TAMSI; Hunt & Crossley point contact, d derived from e",
    ("sap", "stiff"): "Drake's discrete plant under SAP; Kelvin-Voigt point contact, relaxation time derived from e",
    ("continuous", "stiff"): (
        "Drake's continuous plant, runge_kutta3 at a fixed step; Hunt & Crossley point contact, d from e"
    ),
    ("lagged", "default"): (
        "Drake's defaults: discrete plant under kLagged, point contact (hydroelastic with fallback, no "
        "hydroelastic geometry) with DefaultProximityProperties' material (1e6 N/m, 50 s/m: no bounce)"
    ),
    ("lagged", "hydroelastic"): (
        "Drake's recommended contact: discrete plant under kLagged, compliant-hydroelastic bodies (1e7 Pa, "
        "margin 1e-4 m) on a rigid half space; Hunt & Crossley d from e where e is requested, else 50 s/m "
        "(rolling: 0)"
    ),
    ("similar", "hydroelastic"): (
        "Drake's recommended contact for strong transients: discrete plant under kSimilar, compliant-hydroelastic "
        "bodies (1e7 Pa, margin 1e-4 m) on a rigid half space; Hunt & Crossley d from e where e is requested, "
        "else 50 s/m (rolling: 0)"
    ),
}


def _mode_name(plant: str, contact: str) -> str:
    return plant if contact == "stiff" else f"{plant}?contact={contact}"


MODES = {
    f"drake:{_mode_name(name, contact)}": ContactMode(
        "drake",
        _mode_name(name, contact),
        "drake",
        run,
        poses=POSES,
        holds_ball_to_z=True,
        settings={
            "plant": name,
            "contact": contact,
            "contact_model": {"stiff": "kPoint", "default": "default", "hydroelastic": "kHydroelasticWithFallback"}[
                contact
            ],
            **({"integrator": INTEGRATOR, "fixed_step_mode": True} if name == "continuous" else {}),
        },
        doc=_DOC[name, contact],
        module="pydrake",
    )
    for name, contact in _DOC
}
