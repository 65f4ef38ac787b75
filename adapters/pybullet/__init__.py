"""pybullet (Bullet, double precision): ``pybullet:semi_implicit`` on the spring, the damped
spring, the projectile (a free multibody with a force applied each step, as users write it),
the pendulum (a revolute joint, the reduced-coordinate way), the spring chain (a fixed base
with one prismatic link per mass, every link a child of the base, the spring forces applied
as joint forces each step: Bullet has no spring between bodies) and the triangulated cloth (a
mass-spring soft body in Bullet's deformable world, ``adapters.pybullet.cloth``).

Defaults that silently change the physics are switched off and recorded (docs/engines.md):
linear/angular damping 0.04 -> 0, the velocity clamp (100, and any finite clamp would hide a
blow-up) -> inf, sleeping -> disabled, the joints' velocity motors -> zero force, sub-steps -> 0,
joint damping -> 0.
The bodies have no collision shape, so there is nothing to collide with and no shape inertia:
the pendulum bob is a point mass.

Bullet has no loop of its own to call and no spring element: the engine's loop (``steps(n)``)
is a Python loop that calls ``stepSimulation`` alone on the pendulum, and on the other scenes
reads the position (and the velocity, where the scene has drag) and applies the scene's force
before each ``stepSimulation``, the least a Python user can do; the state is read only at
output points. Bullet evaluates its forces inside ``stepSimulation`` and has no counter or
callback for them, so force evaluations are not counted.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from scenarios import Scene

from .._engine import Engine, EngineVersions
from .._mode import EngineMode
from .._model import SteppedModel
from .._posing import chain_force
from .cloth import SoftBodyCloth, refusal
from . import bench

#: How the engine's own loop steps a scene whose force is applied from Python (recorded with every run).
ENGINE_LOOP_APPLIED = (
    "from Python every step (Bullet has no spring or drag element): position (and velocity where "
    "the scene has drag) read, applyExternalForce, stepSimulation"
)

UNSUPPORTED = {
    "kepler": "not posed: Bullet has no 1/r^2 force, and one applied from Python would only repeat what "
    "the spring shows (same force path, same scheme); Kepler is REBOUND's scene",
    "rope": "not posed: the rope's engine models are MuJoCo's hinge chain and pymunk's pin joints; a Bullet "
    "revolute chain is the reduced-coordinate model MuJoCo already poses",
    "net": "the planar net is the cloth's variant for 2-D engines; Bullet poses the 3-D sheet, the scene cloth "
    "with shear=1, k_shear=k, k_bend=0, as a mass-spring soft body",
}


#: Free steps of the damping probe, and its speeds (linear, angular, joint).
PROBE_STEPS = 100
PROBE_DT = 0.01


@functools.cache
def applied_damping(p, linear_damping: float = 0.0, angular_damping: float = 0.0) -> dict:
    """The damping the engine really applies to a multibody set up as the adapter sets its bodies
    up (``changeDynamics`` linear/angular damping 0): getDynamicsInfo reports -1.0 for both on a
    multibody, which says nothing. Measured instead, once per process, on a probe in its own
    client: a free base moving and spinning, and a fixed base with one prismatic link sliding,
    stepped PROBE_STEPS times with no force and no gravity. Returns, for each, the relative
    change of the speed per step, (|v_N| / |v_0|)^(1/N) - 1 (0: nothing applied; Bullet's
    default 0.04 reads -7.8e-4 on the free base and the sliding link at this dt), and the free base's kinetic energy
    change over the steps. ``linear_damping``/``angular_damping``: what the probe asks for (the
    adapter's 0 by default)."""
    cid = p.connect(p.DIRECT)
    try:
        p.setPhysicsEngineParameter(fixedTimeStep=PROBE_DT, numSubSteps=0, physicsClientId=cid)
        p.setGravity(0.0, 0.0, 0.0, physicsClientId=cid)
        free = dict(
            linearDamping=linear_damping,
            angularDamping=angular_damping,
            maxJointVelocity=math.inf,
            activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
        )
        base = p.createMultiBody(1.0, -1, basePosition=[0, 0, 0], physicsClientId=cid)
        p.changeDynamics(base, -1, physicsClientId=cid, **free)
        p.resetBaseVelocity(base, [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], physicsClientId=cid)
        slider = p.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=-1,
            basePosition=[0, 5, 0],
            linkMasses=[1.0],
            linkCollisionShapeIndices=[-1],
            linkVisualShapeIndices=[-1],
            linkPositions=[[0, 0, 0]],
            linkOrientations=[[0, 0, 0, 1]],
            linkInertialFramePositions=[[0, 0, 0]],
            linkInertialFrameOrientations=[[0, 0, 0, 1]],
            linkParentIndices=[0],
            linkJointTypes=[p.JOINT_PRISMATIC],
            linkJointAxis=[[1, 0, 0]],
            physicsClientId=cid,
        )
        p.changeDynamics(slider, 0, jointDamping=0.0, localInertiaDiagonal=[0.0, 0.0, 0.0], physicsClientId=cid, **free)
        p.setJointMotorControl2(slider, 0, p.VELOCITY_CONTROL, force=0.0, physicsClientId=cid)
        p.resetJointState(slider, 0, 0.0, 1.0, physicsClientId=cid)
        for _ in range(PROBE_STEPS):
            p.stepSimulation(physicsClientId=cid)
        lin, ang = p.getBaseVelocity(base, physicsClientId=cid)
        joint = p.getJointState(slider, 0, physicsClientId=cid)[1]

        def per_step(speed):
            return float(abs(speed) ** (1.0 / PROBE_STEPS) - 1.0)

        return {
            "linear": per_step(float(np.linalg.norm(lin))),
            "angular": per_step(float(np.linalg.norm(ang))),
            "joint": per_step(joint),
            "steps": PROBE_STEPS,
            "dt": PROBE_DT,
            "kinetic_energy_change": float(np.linalg.norm(lin)) ** 2 / 2 - 0.5,
        }
    finally:
        p.disconnect(physicsClientId=cid)


class _Bullet(SteppedModel):
    """What every pose shares: its own client, the step, gravity, and the settings read back.
    A pose builds its body (``_build``) and says how the scene's force is applied (``FORCE``),
    how its loop steps (``ENGINE_LOOP``) and what its joints add to the settings."""

    settable = True
    FORCE = ""
    ENGINE_LOOP = ENGINE_LOOP_APPLIED
    #: Whether the scene's force is the spring's -k x alone (``harness bench``'s ``bare loop + force``).
    spring_alone = False

    def __init__(self, p, scene: Scene, dt: float):
        self.p = p
        self.cid = cid = p.connect(p.DIRECT)
        values = scene.values
        self.k, self.c = values.get("k", 0.0), values.get("c", 0.0)
        p.setPhysicsEngineParameter(fixedTimeStep=dt, numSubSteps=0, physicsClientId=cid)
        p.setGravity(0.0, 0.0, -values.get("g", 0.0), physicsClientId=cid)
        free = dict(
            linearDamping=0.0,
            angularDamping=0.0,
            maxJointVelocity=math.inf,
            activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
        )
        link = self._build(scene, *scene.initial_state(), free)
        b = self.body
        info = p.getDynamicsInfo(b, link, physicsClientId=cid)
        engine = p.getPhysicsEngineParameters(physicsClientId=cid)
        self.settings = {
            "fixedTimeStep": float(engine["fixedTimeStep"]),
            "numSubSteps": int(engine["numSubSteps"]),
            "gravity": [
                float(engine["gravityAccelerationX"]),
                float(engine["gravityAccelerationY"]),
                float(engine["gravityAccelerationZ"]),
            ],
            "mass": float(info[0]),
            "local_inertia_diagonal": [float(x) for x in info[2]],
            # getDynamicsInfo reads -1.0 for a multibody's damping: what was asked for is 0; what
            # the engine applies is measured (applied_damping).
            "linearDamping_reported": float(info[8]),
            "angularDamping_reported": float(info[9]),
            "damping_measured_per_step": applied_damping(p),
            "maxJointVelocity": "inf",
            "sleeping": "disabled",
            "collision_shape": "none",
            "force": self.FORCE,
            "engine_loop": self.ENGINE_LOOP,
            **self._joint_settings(),
        }

    def _build(self, scene: Scene, q0: np.ndarray, v0: np.ndarray, free: dict) -> int:
        """Create ``self.body`` at the initial state; the link whose dynamics are read back."""
        raise NotImplementedError  # pragma: no cover - every pose defines it

    def _joint_settings(self) -> dict:
        return {}

    def steps(self, n: int) -> None:
        """n steps, nothing read but what the scene's force needs (module docstring)."""
        advance = self.advance
        for _ in range(n):
            advance()

    def evaluations(self):
        return None, "Bullet evaluates its forces inside stepSimulation and has no counter or callback for them"

    def close(self) -> None:
        self.p.disconnect(physicsClientId=self.cid)


class _Pendulum(_Bullet):
    """Fixed base at the pivot; one revolute link about y with the bob's mass at (0, 0, -L)."""

    FORCE = "none: gravity and the revolute joint"
    ENGINE_LOOP = "stepSimulation only, between output points"

    def _build(self, scene, q0, v0, free):
        p, cid, values = self.p, self.cid, scene.values
        self.body = b = p.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=-1,
            basePosition=[0, 0, 0],
            linkMasses=[values["m"]],
            linkCollisionShapeIndices=[-1],
            linkVisualShapeIndices=[-1],
            linkPositions=[[0, 0, 0]],
            linkOrientations=[[0, 0, 0, 1]],
            linkInertialFramePositions=[[0, 0, -values["L"]]],
            linkInertialFrameOrientations=[[0, 0, 0, 1]],
            linkParentIndices=[0],
            linkJointTypes=[p.JOINT_REVOLUTE],
            linkJointAxis=[[0, 1, 0]],
            physicsClientId=cid,
        )
        p.changeDynamics(b, 0, jointDamping=0.0, localInertiaDiagonal=[0.0, 0.0, 0.0], physicsClientId=cid, **free)
        p.setJointMotorControl2(b, 0, p.VELOCITY_CONTROL, force=0.0, physicsClientId=cid)
        p.resetJointState(b, 0, float(q0[0]), float(v0[0]), physicsClientId=cid)
        return 0

    def _joint_settings(self):
        joint = self.p.getJointInfo(self.body, 0, physicsClientId=self.cid)
        return {
            "joint": "revolute about y",
            "jointDamping": float(joint[6]),
            "jointFriction": float(joint[7]),
            "velocity_motor_force": 0.0,
        }

    def advance(self) -> None:
        self.p.stepSimulation(physicsClientId=self.cid)

    def steps(self, n: int) -> None:
        step, cid = self.p.stepSimulation, self.cid
        for _ in range(n):
            step(physicsClientId=cid)

    def set_state(self, q, v) -> None:
        self.p.resetJointState(self.body, 0, float(q[0]), float(v[0]), physicsClientId=self.cid)

    def state(self):
        theta, omega = self.p.getJointState(self.body, 0, physicsClientId=self.cid)[:2]
        return np.array([theta]), np.array([omega])


class _Chain(_Bullet):
    """Fixed base; link i slides along x from the base's origin (its joint coordinate is the
    scene's q_i), its mass a point at the joint."""

    FORCE = "joint forces set each step (TORQUE_CONTROL), from the state before the step"
    ENGINE_LOOP = (
        "from Python every step (Bullet has no spring between bodies): joint positions read, "
        "joint forces set, stepSimulation"
    )

    def _build(self, scene, q0, v0, free):
        p, cid, values = self.p, self.cid, scene.values
        n = scene.ndof
        self.joints = list(range(n))
        self.body = b = p.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=-1,
            basePosition=[0, 0, 0],
            linkMasses=[values["m"]] * n,
            linkCollisionShapeIndices=[-1] * n,
            linkVisualShapeIndices=[-1] * n,
            linkPositions=[[0, 0, 0]] * n,
            linkOrientations=[[0, 0, 0, 1]] * n,
            linkInertialFramePositions=[[0, 0, 0]] * n,
            linkInertialFrameOrientations=[[0, 0, 0, 1]] * n,
            linkParentIndices=[0] * n,
            linkJointTypes=[p.JOINT_PRISMATIC] * n,
            linkJointAxis=[[1, 0, 0]] * n,
            physicsClientId=cid,
        )
        p.changeDynamics(b, -1, physicsClientId=cid, **free)
        for j in self.joints:
            p.changeDynamics(b, j, jointDamping=0.0, localInertiaDiagonal=[0.0, 0.0, 0.0], physicsClientId=cid, **free)
            p.resetJointState(b, j, float(q0[j]), float(v0[j]), physicsClientId=cid)
        p.setJointMotorControlArray(b, self.joints, p.VELOCITY_CONTROL, forces=[0.0] * n, physicsClientId=cid)
        return 0

    def _joint_settings(self):
        infos = [self.p.getJointInfo(self.body, j, physicsClientId=self.cid) for j in self.joints]
        return {
            "joint": "prismatic along x, one per mass, each a child of the fixed base",
            "jointDamping": sorted({float(i[6]) for i in infos}),
            "jointFriction": sorted({float(i[7]) for i in infos}),
            "joint_limits": "none" if all(i[8] > i[9] for i in infos) else [[i[8], i[9]] for i in infos],
            "velocity_motor_force": 0.0,
        }

    def advance(self) -> None:
        p, cid = self.p, self.cid
        # The scene's force, k (q_{i-1} - 2 q_i + q_{i+1}) with the walls at 0, from the joint
        # positions, and the dashpots' c (v_{i-1} - 2 v_i + v_{i+1}) from the joint velocities.
        q, v = self.state()
        f = chain_force(self.k, self.c, q, lambda: v)
        p.setJointMotorControlArray(self.body, self.joints, p.TORQUE_CONTROL, forces=f.tolist(), physicsClientId=cid)
        p.stepSimulation(physicsClientId=cid)

    def set_state(self, q, v) -> None:
        for j in self.joints:
            self.p.resetJointState(self.body, j, float(q[j]), float(v[j]), physicsClientId=self.cid)

    def state(self):
        states = self.p.getJointStates(self.body, self.joints, physicsClientId=self.cid)
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])


class _FreeBody(_Bullet):
    """A free multibody with the scene's mass: scene x (and y, up, for the projectile) are
    Bullet's x and z, gravity along -z; the scene's force applied at the centre of mass."""

    FORCE = "applied each step at the centre of mass, from the state before the step"

    def _build(self, scene, q0, v0, free):
        p, cid = self.p, self.cid
        pos = [q0[0], 0.0, q0[1] if scene.ndof == 2 else 0.0]
        vel = [v0[0], 0.0, v0[1] if scene.ndof == 2 else 0.0]
        self.body = b = p.createMultiBody(scene.values["m"], -1, basePosition=pos, physicsClientId=cid)
        p.changeDynamics(b, -1, physicsClientId=cid, **free)
        p.resetBaseVelocity(b, vel, [0, 0, 0], physicsClientId=cid)
        return -1

    def set_state(self, q, v) -> None:
        p, cid, b = self.p, self.cid, self.body
        two = len(q) == 2
        p.resetBasePositionAndOrientation(
            b, [float(q[0]), 0.0, float(q[1]) if two else 0.0], [0, 0, 0, 1], physicsClientId=cid
        )
        p.resetBaseVelocity(b, [float(v[0]), 0.0, float(v[1]) if two else 0.0], [0, 0, 0], physicsClientId=cid)

    def _force(self, pos, vel) -> list:
        raise NotImplementedError  # pragma: no cover - every free pose defines it

    def advance(self) -> None:
        p, cid, b = self.p, self.cid, self.body
        pos = p.getBasePositionAndOrientation(b, physicsClientId=cid)[0]
        vel = p.getBaseVelocity(b, physicsClientId=cid)[0]
        p.applyExternalForce(b, -1, self._force(pos, vel), pos, p.WORLD_FRAME, physicsClientId=cid)
        p.stepSimulation(physicsClientId=cid)


class _Spring(_FreeBody):
    def _force(self, pos, vel):
        return [-self.k * pos[0] - self.c * vel[0], 0.0, 0.0]  # -k x - c v along x

    @property
    def spring_alone(self) -> bool:
        return self.c == 0.0

    def steps(self, n: int) -> None:
        if self.c != 0.0:
            return super().steps(n)
        # advance()'s force with c = 0 (the spring has no drag): -k x - 0 v is -k x.
        p, cid, b, step = self.p, self.cid, self.body, self.p.stepSimulation
        k, base_position, apply, frame = self.k, p.getBasePositionAndOrientation, p.applyExternalForce, p.WORLD_FRAME
        for _ in range(n):
            pos = base_position(b, physicsClientId=cid)[0]
            apply(b, -1, [-k * pos[0], 0.0, 0.0], pos, frame, physicsClientId=cid)
            step(physicsClientId=cid)

    def state(self):
        p, cid, b = self.p, self.cid, self.body
        pos = p.getBasePositionAndOrientation(b, physicsClientId=cid)[0]
        vel = p.getBaseVelocity(b, physicsClientId=cid)[0]
        return np.array([pos[0]]), np.array([vel[0]])


class _Projectile(_FreeBody):
    def _force(self, pos, vel):
        return [-self.c * vel[0], 0.0, -self.c * vel[2]]  # drag -c v on both axes; gravity is Bullet's

    def state(self):
        p, cid, b = self.p, self.cid, self.body
        pos = p.getBasePositionAndOrientation(b, physicsClientId=cid)[0]
        vel = p.getBaseVelocity(b, physicsClientId=cid)[0]
        return np.array([pos[0], pos[2]]), np.array([vel[0], vel[2]])


class _ModelFile(SteppedModel):
    """A model file loaded by Bullet (``loadMJCF``, or ``loadURDF`` with URDF_USE_INERTIA_FROM_FILE
    and a fixed base, as MuJoCo compiles a URDF), its state in the scene's (MuJoCo's) coordinates:
    each MuJoCo hinge or slide joint is the Bullet joint of the same name. Bullet's own perturbing
    defaults are off in every variant (damping 0.04, the velocity clamp, sleeping, the joints'
    velocity motors); the variant's switches are Bullet's dynamics settings: contact (collision
    filter masks 0), joint damping (0), limits (lower > upper: none), gravity (0). A root that
    MuJoCo fixes to the world (no free joint) is fixed here too (base mass 0)."""

    settable = True

    def __init__(self, p, scene: Scene, dt: float):
        import mujoco

        self.p, self.scene = p, scene
        # A file only Bullet loads (scenarios.BulletModelScene) has no MuJoCo model: Bullet's joints
        # are the coordinates, gravity is the scene's, and no spring is applied.
        m = None if getattr(scene, "bullet_only", False) else scene.engine_model()
        self.cid = cid = p.connect(p.DIRECT)
        if m is not None and m.nq != m.nv:
            raise ValueError("pybullet: a free or ball joint's quaternion is not mapped to Bullet's base state")
        if (
            m is not None
            and m.ntendon
            and (np.any(m.tendon_stiffness) or np.any(m.tendon_damping) or np.any(m.tendon_limited))
        ):
            raise ValueError(
                "pybullet: Bullet has no tendons, and the file's tendons exert forces (stiffness, "
                "damping or limits): its model would be another model"
            )
        path, off = scene.file.path, set(scene.switched_off)
        if scene.file.kind == "URDF":
            bodies = [p.loadURDF(path, useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)]
        else:
            bodies = list(p.loadMJCF(path, physicsClientId=cid))
        p.setPhysicsEngineParameter(fixedTimeStep=dt, numSubSteps=0, physicsClientId=cid)
        if m is None:
            gravity = scene.gravity_vector()
        else:
            gravity = (
                [0.0, 0.0, 0.0]
                if m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY)
                else list(m.opt.gravity)
            )
        p.setGravity(*gravity, physicsClientId=cid)
        names = {}
        for b in bodies:
            if p.getDynamicsInfo(b, -1, physicsClientId=cid)[0] > 0:
                p.changeDynamics(b, -1, mass=0.0, physicsClientId=cid)  # MuJoCo's root is fixed (nq == nv)
            for j in range(-1, p.getNumJoints(b, physicsClientId=cid)):
                kw = dict(
                    linearDamping=0.0,
                    angularDamping=0.0,
                    maxJointVelocity=math.inf,
                    activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
                )
                if j >= 0:
                    info = p.getJointInfo(b, j, physicsClientId=cid)
                    if info[2] in (p.JOINT_REVOLUTE, p.JOINT_PRISMATIC):
                        names[info[1].decode()] = (b, j)
                        p.setJointMotorControl2(b, j, p.VELOCITY_CONTROL, force=0.0, physicsClientId=cid)
                p.changeDynamics(b, j, physicsClientId=cid, **kw)
                # A separate call: jointDamping=0 given with maxJointVelocity in one changeDynamics
                # call left a URDF's joint damping (0.5) applied (measured on kuka_iiwa, pybullet 3.2.7).
                joint = {}
                if j >= 0 and "damping" in off:
                    joint["jointDamping"] = 0.0
                if j >= 0 and "limits" in off:
                    joint.update(jointLowerLimit=1.0, jointUpperLimit=-1.0)
                if joint:
                    p.changeDynamics(b, j, physicsClientId=cid, **joint)
                if "contact" in off:
                    p.setCollisionFilterGroupMask(b, j, 0, 0, physicsClientId=cid)
        missing = [n for n in scene.dof_names if n not in names]
        if missing:
            raise ValueError(
                f"pybullet's model of the file has no joint named {missing[0]!r} "
                f"({len(names)} movable joints, the scene's {len(scene.dof_names)})"
            )
        self.joints = [names[n] for n in scene.dof_names]
        self._mujoco_bodies = (
            {"bodies": set(), "joint_body": {}}
            if m is None
            else {
                "bodies": {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(1, m.nbody)} - {None},
                "joint_body": {
                    mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j): mujoco.mj_id2name(
                        m, mujoco.mjtObj.mjOBJ_BODY, int(m.jnt_bodyid[j])
                    )
                    for j in range(m.njnt)
                },
            }
        )
        # Bullet's loaders read no joint stiffness: each spring is a torque -k (q - q_spring)
        # applied from Python before every step (TORQUE_CONTROL, the velocity motors at zero force).
        jnt = [] if m is None else [int(m.dof_jntid[i]) for i in range(m.nv)]
        self.springs = [
            (self.joints[i], float(m.jnt_stiffness[jnt[i]]), float(m.qpos_spring[m.jnt_qposadr[jnt[i]]]))
            for i in range(len(jnt))
            if m.jnt_stiffness[jnt[i]] != 0.0
        ]
        self.set_state(*scene.initial_state())
        infos = [p.getJointInfo(b, j, physicsClientId=cid) for b, j in self.joints]
        self.settings = {
            "loaded": "loadURDF(useFixedBase=True, URDF_USE_INERTIA_FROM_FILE)"
            if scene.file.kind == "URDF"
            else "loadMJCF",
            "fixedTimeStep": dt,
            "numSubSteps": 0,
            "gravity": [float(g) for g in gravity],
            "linearDamping": 0,
            "angularDamping": 0,
            "maxJointVelocity": "inf",
            "sleeping": "disabled",
            "joint_motor": "zero force",
            "switched_off": sorted(off),
            "jointDamping": [0.0] * len(infos) if "damping" in off else [float(i[6]) for i in infos],
            "jointDamping_read_from_file": [float(i[6]) for i in infos],  # getJointInfo keeps it after the change
            "jointFriction": [float(i[7]) for i in infos],
            "limits": "none" if "limits" in off else [[float(i[8]), float(i[9])] for i in infos],
            "contact": "filtered out (group 0, mask 0)" if "contact" in off else "Bullet's",
            "not_modelled_by_bullet": [f for f in ("actuators", "equality", "armature") if f in scene.found],
            "joint_springs": (
                f"{len(self.springs)} applied from Python before each step: TORQUE_CONTROL torque "
                "-k (q - q_spring), k and q_spring as MuJoCo compiled them"
            )
            if self.springs
            else "none",
            "engine_loop": (
                "joint springs' torques applied from Python, then stepSimulation, every step"
                if self.springs
                else "stepSimulation only, between output points"
            ),
        }

    def set_state(self, q, v) -> None:
        for (b, j), x, u in zip(self.joints, q, v):
            self.p.resetJointState(b, j, float(x), float(u), physicsClientId=self.cid)

    def state(self):
        s = [self.p.getJointState(b, j, physicsClientId=self.cid)[:2] for b, j in self.joints]
        return np.array([x for x, _ in s]), np.array([u for _, u in s])

    def advance(self) -> None:
        p, cid = self.p, self.cid
        for (b, j), k, ref in self.springs:
            q = p.getJointState(b, j, physicsClientId=cid)[0]
            p.setJointMotorControl2(b, j, p.TORQUE_CONTROL, force=-k * (q - ref), physicsClientId=cid)
        p.stepSimulation(physicsClientId=cid)

    def steps(self, n: int) -> None:
        if self.springs:
            for _ in range(n):
                self.advance()
            return
        step, cid = self.p.stepSimulation, self.cid
        for _ in range(n):
            step(physicsClientId=cid)

    def evaluations(self):
        return None, "Bullet evaluates its forces inside stepSimulation and has no counter or callback for them"

    def anatomy(self) -> dict:
        """What Bullet built (``harness.measures.cross_engine`` says the schema), read back from
        Bullet: each link's mass and principal inertia, summed into the MuJoCo body it stands for
        (a link of the body's name, or the link Bullet's loader adds for one of the body's joints),
        each mapped joint's type, world axis, damping, limits and friction as Bullet holds them,
        armature 0 (Bullet has none), the stiffness the harness applies as a torque (Bullet's
        loaders read none), and ``calculateMassMatrix`` where one multibody holds every joint."""
        p, cid = self.p, self.cid
        bodies = sorted({b for b, _ in self.joints})
        mass = sum(
            p.getDynamicsInfo(b, j, physicsClientId=cid)[0]
            for b in bodies
            for j in range(-1, p.getNumJoints(b, physicsClientId=cid))
        )
        owner = self._mujoco_bodies
        links: dict[str, list] = {}
        notes = []
        for b in bodies:
            for j in range(p.getNumJoints(b, physicsClientId=cid)):
                info = p.getJointInfo(b, j, physicsClientId=cid)
                dyn = p.getDynamicsInfo(b, j, physicsClientId=cid)
                link, joint = info[12].decode(), info[1].decode()
                name = link if link in owner["bodies"] else owner["joint_body"].get(joint)
                if name is None:
                    if dyn[0] > 0:
                        notes.append(f"pybullet: link {link} ({dyn[0]:.6g} kg) stands for no body of MuJoCo's model")
                    continue
                links.setdefault(name, []).append((float(dyn[0]), sorted(float(x) for x in dyn[2])))
        built = {}
        for name, parts in links.items():
            heavy = [inertia for m, inertia in parts if m > 0]
            built[name] = {"mass": sum(m for m, _ in parts), "inertia": heavy[0] if len(heavy) == 1 else None}
        if self.scene.file.kind == "MJCF":
            notes.append(
                "pybullet: Bullet's MJCF loader takes a geom's mass from its volume and density "
                "(a geom's mass attribute is not read) and reads no joint stiffness or armature"
            )
        springs = {jb: (k, ref) for jb, k, ref in self.springs}
        if self.springs:
            sprung = ", ".join(
                f"{name} (k {springs[jb][0]:.6g})"
                for name, jb in zip(self.scene.dof_names, self.joints)
                if jb in springs
            )
            notes.append(
                f"pybullet: Bullet's model has no joint stiffness; the harness applies it on {sprung} as a "
                "torque -k (q - q_spring) before each step, k and q_spring as MuJoCo compiled them"
            )
        off = set(self.scene.switched_off)
        kinds = {p.JOINT_REVOLUTE: "hinge", p.JOINT_PRISMATIC: "slide"}
        joints, axes = {}, []
        for name, (b, j) in zip(self.scene.dof_names, self.joints):
            info = p.getJointInfo(b, j, physicsClientId=cid)
            orn = p.getLinkState(b, j, computeForwardKinematics=True, physicsClientId=cid)[5]
            rot = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
            axis = (rot @ np.array(info[13])).tolist()
            axes.append(axis)
            k, ref = springs.get((b, j), (0.0, 0.0))
            lo, hi = float(info[8]), float(info[9])
            joints[name] = {
                "type": kinds.get(info[2], str(info[2])),
                "axis": axis,
                "stiffness": k,
                "spring_ref": ref,
                "damping": 0.0 if "damping" in off else float(info[6]),
                "armature": 0.0,
                "frictionloss": float(info[7]),
                "limits": None if "limits" in off or lo > hi else [lo, hi],
            }
        matrix = None
        if len(bodies) == 1:
            b = bodies[0]
            movable = [
                j
                for j in range(p.getNumJoints(b, physicsClientId=cid))
                if p.getJointInfo(b, j, physicsClientId=cid)[2] in (p.JOINT_REVOLUTE, p.JOINT_PRISMATIC)
            ]
            q = [p.getJointState(b, j, physicsClientId=cid)[0] for j in movable]
            full = np.array(p.calculateMassMatrix(b, q, physicsClientId=cid))
            at = {j: full.shape[0] - len(movable) + i for i, j in enumerate(movable)}  # a floating base's 6 first
            idx = [at[j] for _, j in self.joints]
            matrix = full[np.ix_(idx, idx)].tolist()
        return {
            "engine": "pybullet",
            "total_mass": float(mass),
            "mass_matrix": matrix,
            "joint_axes": axes,
            "bodies": built,
            "joints": joints,
            "notes": notes,
        }

    def close(self) -> None:
        self.p.disconnect(physicsClientId=self.cid)


#: How Bullet poses each scene it poses (the model class); a new scene is one entry here.
POSES: dict[str, type] = {
    "spring": _Spring,
    "damped_spring": _Spring,
    "pendulum": _Pendulum,
    "projectile": _Projectile,
    "chain": _Chain,
    "model": _ModelFile,
    "cloth": SoftBodyCloth,
}
SCENES = tuple(POSES)


def build(pybullet, mode: str, scene: Scene, dt: float, count: bool = False) -> _Bullet:
    """``count`` changes nothing: Bullet's force evaluations cannot be counted."""
    return POSES[scene.kind](pybullet, scene, dt)


#: The releases this adapter supports: 3.2.7 is the only one whose wheel imports with numpy 2 (the
#: project's numpy): 3.2.6 and older were built against numpy 1 ("numpy.core.multiarray failed to
#: import"). The calls the poses make (changeDynamics' maxJointVelocity, calculateMassMatrix,
#: loadMJCF, setJointMotorControlArray) are older than that.
VERSIONS = EngineVersions(low="3.2.7", below="4", tested=("3.2.7",))

#: Its step is semi-implicit Euler in the generalized velocity, as MuJoCo's Euler, but it declares no
#: ``Behaviour.in_velocity``: on a model file its energy is MuJoCo's energy function on the trajectory
#: of the model Bullet built, which can differ (masses, armature), so its energy class is not the
#: scheme's alone.
METHODS = {
    "pybullet:semi_implicit": EngineMode(
        engine="pybullet",
        mode="semi_implicit",
        module="pybullet",
        dist="pybullet",
        build=build,
        versions=VERSIONS,
        scenes=SCENES,
        unsupported=UNSUPPORTED,
        refuses={"cloth": refusal},
        doc="""semi-implicit Euler (velocity first), forces applied before each step
            Measured: equals ref:semi_implicit_euler bitwise on the spring, the damped spring, the
            projectile and the prismatic spring chain; the revolute pendulum to ~1e-12 over 10^4 steps;
            the cloth's mass-spring soft body (shear=1, k_shear=k, k_bend=0) to roundoff: the deformable
            solver applies the spring forces explicitly and solves for their damping alone (here 0).""",
        settings={
            "numSubSteps": 0,
            "linearDamping": 0,
            "angularDamping": 0,
            "maxJointVelocity": "inf",
            "sleeping": "disabled",
            "collision_shape": "none",
            "joint_motor": "zero force",
            "gravity": "scene's g along -z, else 0",
        },
    ),
}

from . import contact  # noqa: E402  (its contact poses, joined to its entry below)

#: The engine, declared once: ``adapters.ENGINES`` and every list of engines the harness keeps read it.
ENGINE = Engine(
    id="pybullet",
    module="pybullet",
    dists=("pybullet",),
    versions=VERSIONS,
    methods=METHODS,
    poses=POSES,
    build=build,
    bare_loops=bench.bare_loops,
    model_loader="loadMJCF, or loadURDF with URDF_USE_INERTIA_FROM_FILE and a fixed base",
    contact_modes=contact.MODES,
)
