"""A model file (``harness model``) in Drake: the file as Drake's own parser builds it
(``pydrake.multibody.parsing.Parser.AddModels``, URDF or MJCF), in a ``MultibodyPlant``; what
``adapters/drake/__init__.py``'s file model steps and reads back.

* **The plant**: the file parsed with no ``SceneGraph`` (no geometry is registered, so nothing
  collides in any variant); a URDF's root links welded to the world, as MuJoCo compiles a URDF and
  as pybullet loads it (``useFixedBase``); an MJCF's bodies as Drake's parser joins them (a body
  without a joint welded to its parent). Gravity is MuJoCo's of the variant (the file's ``<option
  gravity>``, zero where the variant switches gravity off), set after parsing.
* **The variant's switches** (``scenarios.model.FEATURES``), Drake's counterparts set before
  ``Finalize``: damping (each joint's default damping 0), limits (position limits +-inf),
  armature (each actuator's rotor inertia 0: Drake's parser makes MJCF armature the reflected
  inertia of the joint's actuator, rotor inertia times gear ratio squared). Contacts, friction loss,
  actuation and joint springs are absent in every variant (no geometry; Drake has no joint friction;
  the actuation input is left at zero; the parser reads no MJCF joint ``stiffness``).
* **Coordinates**: the scene's are MuJoCo's qpos (hinge and slide joints by name); each is the
  Drake joint of the same name (``index``: its position in Drake's state). A MuJoCo model with a
  free or ball joint (quaternion coordinates) is refused, as pybullet refuses it.
* **What Drake ignores is listed, never silent**: every warning Drake's parser gives (an
  attribute or tag it does not support: ``<option timestep/integrator>``, ``<flag>``, joint
  ``stiffness``/``springref``, condim, ...) is collected from its log and becomes a note of the
  model's anatomy, and every quantity Drake built differently from MuJoCo is a line of the
  cross-engine comparison (``anatomy``).
* **A file Drake refuses**: ``ValueError`` with Drake's own reason in one line.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import math
import re

import numpy as np

#: Drake's parser warnings start with the file and line: stripped, so that one ignored attribute
#: on many elements is one note with a count.
_WHERE = re.compile(r"^.*?:\d+: warning: ")
#: Warnings that name a geom (contact parameters, one per geom) are counted as one.
_GEOM = re.compile(r"^geom \S+ ")


@contextlib.contextmanager
def parser_warnings():
    """Collect what Drake's log says at WARNING and above (its parser reports every attribute it
    ignores there) instead of printing it; yields the list of messages."""
    log = logging.getLogger("drake")
    said: list[str] = []

    class Collect(logging.Handler):
        def emit(self, record):
            if record.levelno >= logging.WARNING:
                said.append(record.getMessage())

    handler, propagate = Collect(), log.propagate
    log.addHandler(handler)
    log.propagate = False
    try:
        yield said
    finally:
        log.removeHandler(handler)
        log.propagate = propagate


def ignored_lines(said: list[str]) -> list[str]:
    """Drake's parser warnings as notes: each distinct one once, with how often it was said."""
    counts = collections.Counter(_GEOM.sub("geom ", " ".join(_WHERE.sub("", m).split())) for m in said)
    return [f"drake: Drake's parser: {text}" + (f" ({n} times)" if n > 1 else "") for text, n in counts.items()]


def one_line(exc: BaseException) -> str:
    return " ".join((str(exc) or type(exc).__name__).split())


def build_plant(scene, time_step: float):
    """(plant, gravity, facts) of the scene's file, not yet finalized (the discrete plant's contact
    approximation is set before ``Finalize``; module docstring); ValueError with Drake's reason
    where its parser refuses the file."""
    import mujoco
    from pydrake.math import RigidTransform
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    m = None if getattr(scene, "bullet_only", False) else scene.engine_model()
    if m is not None and m.nq != m.nv:
        raise ValueError("drake: a free or ball joint's quaternion is not mapped to Drake's state")
    off = set(scene.switched_off)
    plant = MultibodyPlant(time_step)
    with parser_warnings() as said:
        try:
            instances = Parser(plant).AddModels(scene.file.path)
        except Exception as exc:  # Drake's parser says why in a RuntimeError
            raise ValueError(f"Drake cannot parse it: {one_line(exc)}") from None
    welded = []
    if scene.file.kind == "URDF":
        children = {plant.get_joint(j).child_body().index() for j in plant.GetJointIndices()}
        for instance in instances:
            for b in plant.GetBodyIndices(instance):
                if b not in children:
                    body = plant.get_body(b)
                    plant.WeldFrames(plant.world_frame(), body.body_frame(), RigidTransform())
                    welded.append(body.name())
    for j in plant.GetJointIndices():
        joint = plant.get_joint(j)
        if joint.num_velocities() == 0:
            continue
        if "damping" in off:
            joint.set_default_damping_vector(np.zeros(joint.num_velocities()))
        if "limits" in off:
            n = joint.num_positions()
            joint.set_position_limits(np.full(n, -math.inf), np.full(n, math.inf))
    if "armature" in off:
        for a in plant.GetJointActuatorIndices():
            plant.get_joint_actuator(a).set_default_rotor_inertia(0.0)
    if m is None:
        gravity = [float(g) for g in scene.gravity_vector()]
    else:
        gravity = (
            [0.0, 0.0, 0.0]
            if m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY)
            else [float(g) for g in m.opt.gravity]
        )
    plant.mutable_gravity_field().set_gravity_vector(gravity)
    facts = {
        "ignored": ignored_lines(said),
        "welded_roots": welded,
        "off": sorted(off),
        "fuse": scene.file.kind == "URDF",
        "kept": {f: scene.found[f] for f in scene.found if f not in off},
    }
    return plant, gravity, facts


def coordinates(plant, names) -> np.ndarray:
    """Each scene coordinate's place in the finalized plant's positions (the joint of its name);
    ValueError where Drake's model has other coordinates than the scene's."""
    missing = [n for n in names if not plant.HasJointNamed(n)]
    if missing:
        raise ValueError(
            f"drake's model of the file has no joint named {missing[0]!r} "
            f"({plant.num_joints()} joints, the scene's {len(names)} coordinates)"
        )
    if plant.num_positions() != len(names) or plant.num_velocities() != len(names):
        raise ValueError(
            f"drake's model of the file has {plant.num_positions()} positions and "
            f"{plant.num_velocities()} velocities, the scene's {len(names)} coordinates (a floating "
            "body Drake's parser left free)"
        )
    return np.array([plant.GetJointByName(n).position_start() for n in names], dtype=int)


def settings(plant, facts: dict) -> dict:
    """What the run records of the file's plant (plain JSON values)."""
    return {
        "parsed": "pydrake.multibody.parsing.Parser.AddModels, no SceneGraph (no geometry, no contact)",
        "welded_roots": facts["welded_roots"],
        "switched_off": facts["off"],
        "num_positions": int(plant.num_positions()),
        "parser_ignored": [line.split("Drake's parser: ", 1)[1] for line in facts["ignored"]],
    }


def _kind(joint) -> str | None:
    return {"revolute": "hinge", "prismatic": "slide"}.get(joint.type_name())


def anatomy(plant, context, index, names, facts: dict, discrete: bool) -> dict:
    """What Drake built, at ``context``'s state, in ``harness.measures.cross_engine``'s schema: each
    moving body (in a URDF a cluster of links welded together, named by its link on a moving joint,
    as MuJoCo fuses a URDF's fixed links) its mass and principal moments about its centre of mass;
    each hinge or slide joint its world axis, joint spring (force elements on it), damping,
    armature (its actuators' reflected inertia), friction loss (none in Drake) and position limits
    (only the discrete plant enforces them); the mass matrix (scene coordinates); and the notes:
    what Drake's parser ignored and which features of MuJoCo's model Drake's has no counterpart of."""
    from pydrake.multibody.tree import BodyIndex, PrismaticSpring, RevoluteSpring

    world = plant.world_body()
    inboard = {int(plant.get_joint(j).child_body().index()): plant.get_joint(j) for j in plant.GetJointIndices()}
    seen = {int(b.index()) for b in plant.GetBodiesWeldedTo(world)}
    bodies = {}
    for b in range(plant.num_bodies()):
        if b in seen:
            continue
        # MuJoCo fuses a URDF's fixed links into their parent and keeps an MJCF's welded bodies apart.
        cluster = (
            plant.GetBodiesWeldedTo(plant.get_body(BodyIndex(b))) if facts["fuse"] else [plant.get_body(BodyIndex(b))]
        )
        seen |= {int(x.index()) for x in cluster}
        root = next(
            (x for x in cluster if int(x.index()) in inboard and inboard[int(x.index())].num_velocities() > 0),
            cluster[0],
        )
        rotates, at = False, root
        while int(at.index()) in inboard and not rotates:
            joint = inboard[int(at.index())]
            rotates = joint.type_name() != "prismatic" and joint.num_velocities() > 0
            at = joint.parent_body()
        spatial = plant.CalcSpatialInertia(context, root.body_frame(), [x.index() for x in cluster])
        mass = float(spatial.get_mass())
        inertia = (
            sorted(
                float(x)
                for x in spatial.Shift(spatial.get_com()).CalcRotationalInertia().CalcPrincipalMomentsOfInertia()
            )
            if mass > 0
            else [0.0, 0.0, 0.0]
        )
        bodies[root.name()] = {"mass": mass, "inertia": inertia, "rotates": rotates}
    springs = {}
    for i in range(plant.num_force_elements()):
        element = plant.get_force_element(_force_index(i))
        if isinstance(element, RevoluteSpring):
            springs[element.joint().name()] = (float(element.stiffness()), float(element.nominal_angle()))
        elif isinstance(element, PrismaticSpring):
            springs[element.joint().name()] = (float(element.stiffness()), float(element.nominal_position()))
    reflected = collections.defaultdict(float)
    for a in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(a)
        reflected[actuator.joint().name()] += float(actuator.default_reflected_inertia())
    joints, axes = {}, []
    for name in names:
        joint = plant.GetJointByName(name)
        local = joint.revolute_axis() if joint.type_name() == "revolute" else joint.translation_axis()
        axis = (joint.frame_on_parent().CalcPoseInWorld(context).rotation().matrix() @ np.asarray(local)).tolist()
        axes.append(axis)
        lo, hi = float(joint.position_lower_limits()[0]), float(joint.position_upper_limits()[0])
        k, ref = springs.get(name, (0.0, 0.0))
        joints[name] = {
            "type": _kind(joint) or joint.type_name(),
            "axis": axis,
            "stiffness": k,
            "spring_ref": ref,
            "damping": float(joint.GetDampingVector(context)[0]),
            "armature": reflected[name],
            "frictionloss": 0.0,
            "limits": [lo, hi] if discrete and (math.isfinite(lo) or math.isfinite(hi)) else None,
        }
    full = np.asarray(plant.CalcMassMatrix(context))
    notes = list(facts["ignored"])
    kept = facts["kept"]
    for feature, why in (
        ("contact", "the plant has no geometry (no SceneGraph): nothing collides"),
        ("frictionloss", "Drake has no joint friction loss"),
        ("actuators", "the actuators' input is zero: no force (MuJoCo's act at ctrl 0, bias terms included)"),
        ("equality", "Drake applies equality constraints only in a discrete SAP plant"),
        ("limits", "the continuous plant enforces no joint limits" if not discrete else None),
    ):
        if feature in kept and why:
            notes.append(f"drake: the model keeps {feature} ({kept[feature]}) and {why}")
    return {
        "engine": "drake",
        "total_mass": float(sum(v["mass"] for v in bodies.values())),
        "mass_matrix": full[np.ix_(index, index)].tolist(),
        "joint_axes": axes,
        "bodies": bodies,
        "joints": joints,
        "notes": notes,
    }


def _force_index(i: int):
    from pydrake.multibody.tree import ForceElementIndex

    return ForceElementIndex(i)
