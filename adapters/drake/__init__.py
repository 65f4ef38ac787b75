"""Drake (pydrake): every integrator of ``pydrake.systems.analysis`` at a fixed step on a
continuous ``MultibodyPlant``, and the discrete ``MultibodyPlant`` (time step h) under each of
its contact approximations, on the spring, the damped spring and the pendulum.

Minimal models, Drake's own physics: one body on one joint of the world, nothing else.

* ``spring`` / ``damped_spring``: a body of mass m (unit rotational inertia, which a prismatic
  joint never sees) on a ``PrismaticJoint`` along x with the scene's ``damping`` c, and a
  ``PrismaticSpring`` of stiffness k at rest length 0; gravity zeroed.
* ``pendulum``: a point mass m (``UnitInertia.PointMass``) at distance L below a
  ``RevoluteJoint`` about y, gravity the scene's g along -z: its generalised mass is m L^2.
* ``chain``: N bodies of mass m, each on its own ``PrismaticJoint`` along x from the world (M
  exactly m I); the wall springs a ``PrismaticSpring`` k at rest 0 on each end joint (2 k on a
  single mass), each spring between neighbours a ``LinearBushingRollPitchYaw`` between the two
  bodies' frames (force stiffness k and damping c along x only, the torques' zero), the wall
  dashpots the end joints' damping c; gravity zeroed.
* ``projectile``: the scene's (x, y), y up, are Drake's x and z: a massless carriage on a
  ``PrismaticJoint`` along x carries the body of mass m on a ``PrismaticJoint`` along z, each
  joint's damping the scene's linear drag c (force -c v on each axis), gravity the scene's g along -z.
* ``model``: a model file as Drake's parser builds it (``adapters/drake/model.py``).

Every default that would change the physics is set off or set to the scene's value and recorded
in each run's settings: gravity (Drake's default is 9.81 along -z), the plant's time step
(``MultibodyPlant(0.0)``: continuous, where Drake's usual builder makes a discrete plant of time step 0.001 s),
the simulator's integrator (Drake's default is RK3, error-controlled at accuracy 1e-4:
``ResetIntegratorFromFlags`` replaces it), error control (``set_fixed_step_mode(True)``, maximum
step h), and the implicit integrators' Newton tolerance, which follows the target accuracy
(``set_target_accuracy(1e-14)``; the explicit integrators throw on it and have no Newton loop).

Error-controlled (a tolerance in the method's id, ``drake:runge_kutta3@1e-6``, for the integrators
of ``ERROR_CONTROLLED``): fixed-step mode off, ``set_target_accuracy(tolerance)`` (Drake's local
error per step, and the implicit integrators' Newton tolerance), the step at most the output
interval; ``dt`` is then the output interval, and each run records the steps Drake took and
rejected (``get_num_step_shrinkages_from_error_control``).

The loop is Drake's: ``Simulator.AdvanceTo`` from one output point to the next, one call over
the whole run when one output is asked for. Drake steps by h from the context's time, so the
step n ends at t_n = fl(t_{n-1} + h); the model advances to exactly that time, and Drake takes
exactly n steps (advancing to n h instead, which differs from t_n by roundoff, inserts a short
extra step: measured 1001 steps for 1000 at h = 0.1). The discrete plant's updates fall at k h.
Force evaluations are Drake's own count (``get_num_derivative_evaluations``, error estimates
included).
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Callable

import numpy as np

from scenarios import Scene

from records.method import NO_BEHAVIOUR, Behaviour
from records.method_id import TOLERANCE, Option

from .._engine import Engine, EngineVersions
from .._mode import EngineMode
from .._model import SteppedModel
from . import bench

#: The releases this adapter supports: ``ResetIntegratorFromFlags`` by scheme name and
#: ``DiscreteContactApproximation`` (SAP, lagged, similar) are in every release from 1.22;
#: measured on 1.51.1.
VERSIONS = EngineVersions(low="1.22", below="2", tested=("1.51.1",))


#: Implicit integrators: their Newton iteration stops at the target accuracy, set this tight (at
#: Drake's default 1e-4 radau3 strays 2e-6 from the two-stage Radau IIA on the spring).
IMPLICIT = ("radau1", "radau3", "implicit_euler", "velocity_implicit_euler")
NEWTON_ACCURACY = 1e-14

#: The integrators with an error estimate: each also runs error-controlled at a tolerance
#: (``drake:runge_kutta3@1e-6``); the others throw on a target accuracy.
ERROR_CONTROLLED = (
    "bogacki_shampine3",
    "runge_kutta3",
    "runge_kutta5",
    "radau1",
    "radau3",
    "implicit_euler",
    "velocity_implicit_euler",
)

#: The modes of the discrete plant: our mode name -> its contact approximation (``DiscreteContactApproximation``).
DISCRETE = {
    "discrete_tamsi": "kTamsi",
    "discrete_sap": "kSap",
    "discrete_lagged": "kLagged",
    "discrete_similar": "kSimilar",
}

#: Our mode name -> what it selects in Drake: an integration scheme of the continuous plant, by its
#: name in ``GetIntegrationSchemes()`` (the mode's own), or the discrete plant's contact approximation.
MODES = {
    **{
        name: name
        for name in (
            "semi_explicit_euler",
            "explicit_euler",
            "runge_kutta2",
            "runge_kutta3",
            "bogacki_shampine3",
            "runge_kutta5",
            "radau1",
            "radau3",
            "implicit_euler",
            "velocity_implicit_euler",
        )
    },
    **DISCRETE,
}

_NOT_POSED = (
    "not posed yet: a LeafSystem evaluating the scene's force from Python would be our force, "
    "not Drake's, and no force element of the plant poses it minimally in this adapter"
)
UNSUPPORTED = {
    "kepler": "Drake's MultibodyPlant has no central 1/r^2 force element "
    "(a LeafSystem would be our force, not Drake's)",
    "solar_system": "Drake's MultibodyPlant has no N-body gravity force element",
    "rope": "a hinge chain of point masses: not posed yet (each link's revolute joint and point mass, "
    "its reduced coordinates as the scene's)",
    "cloth": "rest-length springs between free masses: LinearSpringDamper between bodies on three prismatic "
    "joints each; not posed yet",
    "net": "as the cloth: not posed yet",
    "cloth_flex": "MuJoCo's flex membrane: no Drake counterpart",
}


def _pendulum(plant, values):
    """A point mass m L below a revolute joint about y, the scene's gravity."""
    from pydrake.multibody.tree import RevoluteJoint, SpatialInertia, UnitInertia

    bob = [0.0, 0.0, -values["L"]]
    body = plant.AddRigidBody("bob", SpatialInertia(values["m"], bob, UnitInertia.PointMass(bob)))
    joint = plant.AddJoint(RevoluteJoint("theta", plant.world_frame(), body.body_frame(), [0.0, 1.0, 0.0], damping=0.0))
    return joint, [0.0, 0.0, -values["g"]]


def _spring(plant, values):
    """A mass on a prismatic joint along x with a PrismaticSpring (and the scene's damping), no gravity."""
    from pydrake.multibody.tree import PrismaticJoint, PrismaticSpring, SpatialInertia, UnitInertia

    body = plant.AddRigidBody("mass", SpatialInertia(values["m"], np.zeros(3), UnitInertia(1.0, 1.0, 1.0)))
    joint = plant.AddJoint(
        PrismaticJoint("x", plant.world_frame(), body.body_frame(), [1.0, 0.0, 0.0], damping=values.get("c", 0.0))
    )
    plant.AddForceElement(PrismaticSpring(joint, 0.0, values["k"]))
    return joint, [0.0, 0.0, 0.0]


def _chain(plant, values):
    """N bodies on prismatic joints along x, the walls' springs and dashpots on the end joints,
    a bushing (force along x only) between each pair of neighbours; no gravity."""
    from pydrake.multibody.tree import (
        LinearBushingRollPitchYaw,
        PrismaticJoint,
        PrismaticSpring,
        SpatialInertia,
        UnitInertia,
    )

    n, k, c = values["N"], values["k"], values["c"]
    bodies, joints = [], []
    for i in range(n):
        walls = (i == 0) + (i == n - 1)  # 2 for a single mass between both walls
        body = plant.AddRigidBody(f"m{i}", SpatialInertia(values["m"], np.zeros(3), UnitInertia(1.0, 1.0, 1.0)))
        joint = plant.AddJoint(
            PrismaticJoint(f"x{i}", plant.world_frame(), body.body_frame(), [1.0, 0.0, 0.0], damping=c * walls)
        )
        if walls:
            plant.AddForceElement(PrismaticSpring(joint, 0.0, k * walls))
        bodies.append(body)
        joints.append(joint)
    for a, b in zip(bodies[:-1], bodies[1:]):
        plant.AddForceElement(
            LinearBushingRollPitchYaw(
                a.body_frame(), b.body_frame(), [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [k, 0.0, 0.0], [c, 0.0, 0.0]
            )
        )
    return joints[0], [0.0, 0.0, 0.0]


def _projectile(plant, values):
    """A massless carriage on x carrying the mass on z, each joint damped by the drag c; gravity g along -z."""
    from pydrake.multibody.tree import PrismaticJoint, SpatialInertia, UnitInertia

    carriage = plant.AddRigidBody("carriage", SpatialInertia(0.0, np.zeros(3), UnitInertia(0.0, 0.0, 0.0)))
    body = plant.AddRigidBody("mass", SpatialInertia(values["m"], np.zeros(3), UnitInertia(1.0, 1.0, 1.0)))
    plant.AddJoint(
        PrismaticJoint("x", plant.world_frame(), carriage.body_frame(), [1.0, 0.0, 0.0], damping=values["c"])
    )
    joint = plant.AddJoint(
        PrismaticJoint("y", carriage.body_frame(), body.body_frame(), [0.0, 0.0, 1.0], damping=values["c"])
    )
    return joint, [0.0, 0.0, -values["g"]]


def _plant(pydrake, scene: Scene, time_step: float):
    """The scene's MultibodyPlant (module docstring) and its one joint."""
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(time_step)
    joint, gravity = POSES[scene.kind].add(plant, scene.values)
    plant.mutable_gravity_field().set_gravity_vector(gravity)
    return plant, joint, gravity


class _Model(SteppedModel):
    """The scene's plant in a ``Simulator``, at the scene's initial state (module docstring)."""

    settable = True
    #: Each scene coordinate's place in Drake's positions and velocities (None: the same order).
    _index = None
    _plant = staticmethod(_plant)

    def __init__(self, pydrake, mode: str, scene: Scene, dt: float, tolerance: float | None = None):
        from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator

        self.discrete = mode in DISCRETE
        plant, joint, gravity = self._plant(pydrake, scene, dt if self.discrete else 0.0)
        if self.discrete:
            from pydrake.multibody.plant import DiscreteContactApproximation

            plant.set_discrete_contact_approximation(getattr(DiscreteContactApproximation, MODES[mode]))
        plant.Finalize()
        self.plant, self.dt, self.n, self._trouble = plant, dt, 0, None
        self.sim = sim = Simulator(plant)
        self._context = plant.GetMyMutableContextFromRoot(sim.get_mutable_context())
        self._put(*scene.initial_state())
        self.settings = {
            "plant": f"discrete, time_step {dt!r}" if self.discrete else "continuous (time_step 0)",
            "gravity": gravity,
            "model": POSES[scene.kind].what,
            "advance": (
                "AdvanceTo(k h): one discrete update a step"
                if self.discrete
                else "AdvanceTo(t_n), t_n = fl(t_{n-1} + h): exactly n steps, none inserted"
            ),
            "target_realtime_rate": 0.0,
        }
        if self.discrete:
            self.integrator = self.tolerance = None
            self.settings["contact_approximation"] = MODES[mode]
        else:
            self.integrator = integrator = ResetIntegratorFromFlags(sim, MODES[mode], dt)
            self.tolerance = tolerance
            # Error-controlled (a tolerance set): Drake's own step-size control at that target
            # accuracy, its steps at most the output interval dt (each output is an AdvanceTo).
            integrator.set_fixed_step_mode(tolerance is None)
            integrator.set_maximum_step_size(dt)
            self.settings.update(
                {
                    "integrator": mode,
                    "fixed_step_mode": bool(integrator.get_fixed_step_mode()),
                    "maximum_step_size": float(integrator.get_maximum_step_size()),
                }
            )
            if tolerance is not None:
                integrator.set_target_accuracy(tolerance)
                self.settings.update(
                    target_accuracy=float(integrator.get_target_accuracy()),
                    advance="AdvanceTo(n dt) at every output; Drake's error control picks the steps",
                    error_control=f"Drake's, at target accuracy {tolerance:g} (its Newton tolerance "
                    "follows it in the implicit integrators)",
                )
            elif mode in IMPLICIT:
                integrator.set_target_accuracy(NEWTON_ACCURACY)
                self.settings["target_accuracy"] = float(integrator.get_target_accuracy())
            else:
                self.settings["target_accuracy"] = (
                    "none (an explicit integrator has no Newton loop; Drake throws on it)"
                )
        sim.set_target_realtime_rate(0.0)
        sim.Initialize()
        self._time, self._steps0 = 0.0, 0

    def set_state(self, q: np.ndarray, v: np.ndarray) -> None:
        # Back to time 0 at the state, and the simulator initialised again (the integrator's
        # cached Jacobians and step data with it), as a model built there would be.
        self.sim.get_mutable_context().SetTime(0.0)
        self._put(q, v)
        self.sim.Initialize()
        self.n, self._time, self._trouble = 0, 0.0, None
        self._steps0 = int(self.integrator.get_num_steps_taken()) if self.integrator is not None else 0

    def _target(self, n: int) -> float:
        if self.discrete:
            return (self.n + n) * self.dt
        t = self._time
        for _ in range(n):
            t = t + self.dt
        return t

    def steps(self, n: int) -> None:
        target = self._target(n)
        try:
            self.sim.AdvanceTo(target)
        except RuntimeError as exc:  # a Newton failure, or a state Drake refuses
            self._trouble = f"Drake stopped: {' '.join(str(exc).split())[:160]}"
        self.n += n
        self._time = target
        # Where an implicit integrator's Newton iteration fails at h, Drake shrinks the step even in
        # fixed-step mode (measured on the pendulum at h omega = 3: 255 steps for 240): the run is
        # then no longer the scheme at h, and stops there.
        if self.integrator is not None and self._trouble is None and self.tolerance is None:
            taken = int(self.integrator.get_num_steps_taken()) - self._steps0
            if taken != self.n:
                self._trouble = (
                    f"Drake took {taken} steps for {self.n}: its Newton iteration failed at h and it "
                    f"shrank the step ({int(self.integrator.get_num_substep_failures())} substep failures)"
                )

    def advance(self) -> None:
        self.steps(1)

    def trouble(self) -> str | None:
        return self._trouble

    def state(self):
        context = self.plant.GetMyContextFromRoot(self.sim.get_context())
        q, v = (
            np.array(self.plant.GetPositions(context), dtype=float),
            np.array(self.plant.GetVelocities(context), dtype=float),
        )
        return (q, v) if self._index is None else (q[self._index], v[self._index])

    def _put(self, q, v) -> None:
        """The plant's state from the scene's coordinates."""
        if self._index is not None:
            full_q, full_v = np.zeros(self.plant.num_positions()), np.zeros(self.plant.num_velocities())
            full_q[self._index], full_v[self._index] = q, v
            q, v = full_q, full_v
        self.plant.SetPositions(self._context, q)
        self.plant.SetVelocities(self._context, v)

    def evaluations(self):
        if self.integrator is None:
            return None, "the discrete plant has no derivative evaluations (one discrete update a step)"
        return (
            int(self.integrator.get_num_derivative_evaluations()),
            "Drake's derivative evaluations (get_num_derivative_evaluations, error estimates included)",
        )

    def close(self) -> None:
        # The discrete plant advances by unrestricted updates (Drake 1.51.1), counted with the discrete ones.
        self.settings["steps_taken"] = (
            int(self.sim.get_num_discrete_updates() + self.sim.get_num_unrestricted_updates())
            if self.discrete
            else int(self.integrator.get_num_steps_taken())
        )
        if self.integrator is not None and self.tolerance is not None:
            # A step rejected by the error estimate is retried smaller: Drake counts each shrinkage.
            self.settings["steps_rejected"] = int(self.integrator.get_num_step_shrinkages_from_error_control())
            self.settings["substep_failures"] = int(self.integrator.get_num_substep_failures())


class _FileModel(_Model):
    """A model file (``harness model``) as Drake's parser builds it, stepped as every scene is; its
    coordinates mapped to the scene's by joint name and its anatomy read back from the plant
    (``adapters/drake/model.py``)."""

    def _plant(self, pydrake, scene: Scene, time_step: float):
        from . import model as _drake_model

        plant, gravity, self._facts = _drake_model.build_plant(scene, time_step)
        self._names, self._coordinates = list(scene.dof_names), None
        return plant, None, gravity

    @property
    def _index(self):
        # Read from the finalized plant, at the first state put into it.
        if self._coordinates is None:
            from . import model as _drake_model

            self._coordinates = _drake_model.coordinates(self.plant, self._names)
        return self._coordinates

    def __init__(self, pydrake, mode: str, scene: Scene, dt: float, **options):
        super().__init__(pydrake, mode, scene, dt, **options)
        from . import model as _drake_model

        self.settings.update(_drake_model.settings(self.plant, self._facts))

    def anatomy(self) -> dict:
        from . import model as _drake_model

        context = self.plant.GetMyContextFromRoot(self.sim.get_context())
        return _drake_model.anatomy(self.plant, context, self._index, self._names, self._facts, self.discrete)


@dataclass(frozen=True)
class Pose:
    """How Drake poses one scene: ``what`` it builds (in words, each run's ``model`` setting),
    ``add(plant, params) -> (joint, gravity)`` its bodies, joints and force elements, and the model
    class that steps it (a model file's own, which builds its plant from the file)."""

    what: str
    add: Callable | None
    model: type = _Model


#: How Drake poses each scene it poses; a new scene is one entry here.
POSES = {
    "spring": Pose("one body of mass m on a PrismaticJoint along x (damping 0), PrismaticSpring k at rest 0", _spring),
    "damped_spring": Pose(
        "one body of mass m on a PrismaticJoint along x with damping c, PrismaticSpring k at rest 0", _spring
    ),
    "pendulum": Pose("a point mass m (UnitInertia.PointMass) L below a RevoluteJoint about y, damping 0", _pendulum),
    "chain": Pose(
        "N bodies of mass m on PrismaticJoints along x; PrismaticSpring k at rest 0 on the end joints (walls), "
        "LinearBushingRollPitchYaw between neighbours (force stiffness k, damping c along x), end joints' "
        "damping c",
        _chain,
    ),
    "projectile": Pose(
        "a massless carriage on a PrismaticJoint along x carrying mass m on a PrismaticJoint along z, "
        "each joint's damping the drag c",
        _projectile,
    ),
    "model": Pose("the file as pydrake's Parser builds it, no SceneGraph (adapters/drake/model.py)", None, _FileModel),
}
SCENES = tuple(POSES)


def build(pydrake, mode: str, scene: Scene, dt: float, count: bool = False, tolerance: float | None = None) -> _Model:
    """``count`` changes nothing: Drake counts its derivative evaluations in every run.
    ``tolerance``: error-controlled at that target accuracy (the modes of ``ERROR_CONTROLLED``)."""
    return POSES[scene.kind].model(
        pydrake, mode, scene, dt, **({"tolerance": tolerance} if tolerance is not None else {})
    )


def has_mode(mode: str):
    """Whether the imported Drake offers what ``mode`` selects (``MODES``: a scheme of its
    ``GetIntegrationSchemes()``, or the contact approximation's member)."""

    def present(pydrake) -> bool:
        if mode in DISCRETE:
            from pydrake.multibody.plant import DiscreteContactApproximation

            return hasattr(DiscreteContactApproximation, MODES[mode])
        from pydrake.systems.analysis import GetIntegrationSchemes

        return MODES[mode] in GetIntegrationSchemes()

    return present


_DOCS = {
    "semi_explicit_euler": """semi-implicit Euler (velocity first, then position with the new velocity)
        Measured: equals ref:semi_implicit_euler bit for bit on the spring at h = 0.125.""",
    "explicit_euler": """explicit Euler
        Measured: equals ref:explicit_euler bit for bit on the spring at h = 0.125.""",
    "runge_kutta2": """Heun's RK2 (explicit trapezoidal rule), not the midpoint rule
        Measured: ref:heun to 2e-15 on the spring at h = 0.125 over 1000 steps.""",
    "runge_kutta3": """Kutta's RK3 (its error estimate costs nothing at a fixed step), not Bogacki-Shampine
        Measured: ref:kutta_rk3 to 3e-15 on the spring at h = 0.125 over 1000 steps.""",
    "bogacki_shampine3": """Bogacki-Shampine 3 (its fourth, error-estimate stage evaluated too: 4 evaluations a step)
        Measured: ref:bogacki_shampine3 to 4e-15 on the spring at h = 0.125 over 1000 steps.""",
    "runge_kutta5": """Dormand-Prince 5, its fifth-order solution (7 evaluations a step, error estimate included)
        Measured: ref:dormand_prince5 to 1e-14 on the spring at h = 0.125 over 1000 steps.""",
    "radau1": """implicit (backward) Euler, one-stage Radau IIA
        Measured: ref:implicit_euler to 6e-16 on the spring at h = 0.125 over 1000 steps.""",
    "radau3": """two-stage Radau IIA (order 3, L-stable)
        Measured: ref:radau_iia2 to 1.3e-15 on the spring at h = 0.125 over 1000 steps, and to
        3.1e-12 on the pendulum at h = 0.02 (as the explicit modes: Drake's time and sin roundoff).""",
    "implicit_euler": """implicit Euler by step doubling: two implicit Euler steps of h/2 a step
        Measured: ref:implicit_euler_doubled to 1e-13 on the spring at h = 0.125; after 1000 steps of
        0.1 the spring keeps 3.39e-3 of its energy 0.5 where implicit Euler keeps 2.39e-5.""",
    "velocity_implicit_euler": """implicit Euler by step doubling, Newton in velocities only
        Measured: ref:implicit_euler_doubled to 6e-14 on the spring at h = 0.125.""",
    "discrete_tamsi": """discrete MultibodyPlant (TAMSI): semi-implicit Euler; joint damping explicit""",
    "discrete_sap": """discrete MultibodyPlant (SAP): semi-implicit Euler; joint damping implicit""",
    "discrete_lagged": """discrete MultibodyPlant (lagged): semi-implicit Euler; joint damping implicit""",
    "discrete_similar": """discrete MultibodyPlant (similar): semi-implicit Euler; joint damping implicit""",
}

#: What a mode was measured to do that its name does not say (``records.method.Behaviour``): the two
#: implicit Euler modes step by step doubling (``_DOCS``).
_HALVES = Behaviour(integrates_as={"spring": "ref:implicit_euler_doubled"}, half_steps_of="ref:implicit_euler")
_BEHAVIOUR = {"implicit_euler": _HALVES, "velocity_implicit_euler": _HALVES}

METHODS = {
    f"drake:{mode}": EngineMode(
        engine="drake",
        mode=mode,
        module="pydrake",
        dist="drake",
        build=build,
        scenes=SCENES,
        unsupported=UNSUPPORTED,
        doc=_DOCS[mode],
        versions=VERSIONS,
        present=has_mode(mode),
        behaviour=_BEHAVIOUR.get(mode, NO_BEHAVIOUR),
        options_declared=(
            {TOLERANCE: Option(TOLERANCE, float, 1e-14, 0.1, "error-controlled at this target accuracy")}
            if mode in ERROR_CONTROLLED
            else {}
        ),
        adaptive_with=TOLERANCE if mode in ERROR_CONTROLLED else None,
        settings={
            "scheme": MODES[mode],
            "plant": "discrete, time_step h" if mode in DISCRETE else "continuous (time_step 0)",
            "fixed_step_mode": None if mode in DISCRETE else True,
            "target_accuracy": NEWTON_ACCURACY if mode in IMPLICIT else None,
            "gravity": "scene's g along -z (pendulum), else zero",
            "joint_damping": "scene's c (damped spring), else 0",
        },
    )
    for mode in MODES
}

from . import contact  # noqa: E402  (its contact poses, joined to its entry below)

#: The engine, declared once: ``adapters.ENGINES`` and every list of engines the harness keeps read it.
ENGINE = Engine(
    id="drake",
    module="pydrake",
    dists=("drake",),
    versions=VERSIONS,
    methods=METHODS,
    poses=POSES,
    build=build,
    bare_loops=bench.bare_loops,
    model_loader="pydrake.multibody.parsing.Parser.AddModels, no SceneGraph",
    loader_without_contact="Drake's parser here builds no contact geometry (no SceneGraph)",
    submodules=(
        "pydrake.geometry",
        "pydrake.math",
        "pydrake.multibody.parsing",
        "pydrake.multibody.plant",
        "pydrake.multibody.tree",
        "pydrake.systems.analysis",
        "pydrake.systems.framework",
    ),
    contact_modes=contact.MODES,
)
