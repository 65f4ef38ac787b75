"""A model file MuJoCo cannot compile but Bullet loads (``pybullet_data``'s ``mjcf/hopper.xml``,
written in global coordinates, which MuJoCo 4 refuses): the scene is what Bullet builds, and
pybullet's modes are measured on it against their own refined runs.

What MuJoCo supplies for a ``ModelScene`` comes from Bullet here:

* **Coordinates**: Bullet's revolute and prismatic joints, in load order, by name; a root that
  Bullet's loader leaves free is fixed (base mass 0), as the pybullet adapter fixes it.
* **Features** (``scenarios.model.FEATURES``): contacts (links with collision shapes), joint
  damping, friction and limits as Bullet holds them, gravity (the MJCF's ``<option gravity>``,
  else MuJoCo's default 0 0 -9.81), and from the file's text what Bullet does not model at all
  (actuators, equality constraints, armature, joint stiffness): listed, never applied.
* **Initial state**: every joint at Bullet's load position moved by ``dq ~ N(0, perturb^2)``,
  ``qvel ~ N(0, perturb^2)`` (``numpy.random.default_rng(seed)``), limited joints kept inside
  their range, as ``ModelScene`` does.
* **Energy**: ``0.5 v^T M(q) v`` (``calculateMassMatrix``) plus the links' gravitational
  potential ``-m g . x_com``; **omega** from the Jacobian of ``qacc = -M^-1 ID(q, v, 0)``
  (``calculateInverseDynamics``: Coriolis and gravity), by central differences.
* **Reference**: none of another engine: every mode is measured against its own run at half the
  step (``Scene.own_run_reference``).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np

from .model import FD_EPS, OMEGA_FLOOR, ModelFile, ModelScene, read_model_file, variant_suffix
from .scene import Scene

#: MuJoCo's default gravity, which an MJCF without ``<option gravity>`` means.
DEFAULT_GRAVITY = (0.0, 0.0, -9.81)
#: MuJoCo's default timestep, which an MJCF without ``<option timestep>`` means.
DEFAULT_TIMESTEP = 0.002


def _option(root, name: str):
    opt = root.find("option")
    return None if opt is None else opt.get(name)


def file_facts(mf: ModelFile) -> dict:
    """What the file's text says that Bullet does not hold: timestep, gravity, and the counts of
    actuators, equality constraints, armature and joint stiffness attributes."""
    root = ET.parse(mf.path).getroot()
    if mf.kind != "MJCF":
        return {
            "timestep": DEFAULT_TIMESTEP,
            "gravity": DEFAULT_GRAVITY,
            "actuators": 0,
            "equality": 0,
            "armature": 0,
            "stiffness": 0,
            "colliding": sum(1 for _ in root.iter("collision")),
        }
    g = _option(root, "gravity")
    act, eq = root.find("actuator"), root.find("equality")
    return {
        "timestep": float(_option(root, "timestep") or DEFAULT_TIMESTEP),
        "gravity": tuple(float(x) for x in g.split()) if g else DEFAULT_GRAVITY,
        "actuators": 0 if act is None else len(list(act)),
        "equality": 0 if eq is None else len(list(eq)),
        "armature": sum(1 for e in root.iter() if float(e.get("armature", "0") or 0) != 0),
        "stiffness": sum(1 for e in root.iter("joint") if float(e.get("stiffness", "0") or 0) != 0),
        "colliding": sum(
            1 for e in root.iter("geom") if e.get("contype", "1") != "0" or e.get("conaffinity", "1") != "0"
        ),
    }


class BulletWorld:
    """The file loaded into a pybullet client of its own, its root fixed, gravity set; the
    movable joints by name."""

    def __init__(self, mf: ModelFile, gravity):
        import pybullet as p

        self.p = p
        self.cid = cid = p.connect(p.DIRECT)
        if mf.kind == "URDF":
            bodies = [p.loadURDF(mf.path, useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)]
        else:
            bodies = list(p.loadMJCF(mf.path, physicsClientId=cid))
        p.setGravity(*gravity, physicsClientId=cid)
        self.gravity = np.array(gravity, dtype=float)
        self.joints, self.names, self.info = [], [], []
        for b in bodies:
            if p.getDynamicsInfo(b, -1, physicsClientId=cid)[0] > 0:
                p.changeDynamics(b, -1, mass=0.0, physicsClientId=cid)
            for j in range(p.getNumJoints(b, physicsClientId=cid)):
                info = p.getJointInfo(b, j, physicsClientId=cid)
                if info[2] in (p.JOINT_REVOLUTE, p.JOINT_PRISMATIC):
                    self.joints.append((b, j))
                    self.names.append(info[1].decode())
                    self.info.append(info)
        self.bodies = sorted({b for b, _ in self.joints})
        self.q0 = np.array([p.getJointState(b, j, physicsClientId=cid)[0] for b, j in self.joints])

    def found(self, facts: dict) -> dict[str, str]:
        """{feature: what the model has of it}, as ``scenarios.model.features_found`` says it."""
        out = {}
        # From the file: pybullet 3.2.7's getCollisionShapeData crashes the process on a capsule
        # that loadMJCF built.
        if facts["colliding"]:
            out["contact"] = f"{facts['colliding']} colliding geoms or collision elements in the file"
        damped = sum(1 for i in self.info if i[6] > 0)
        if damped:
            out["damping"] = f"{damped} damped joints (Bullet's)"
        rubbing = sum(1 for i in self.info if i[7] > 0)
        if rubbing:
            out["frictionloss"] = f"{rubbing} joints with friction (Bullet's)"
        if facts["actuators"]:
            out["actuators"] = f"{facts['actuators']} actuators in the file (Bullet models none)"
        limited = sum(1 for i in self.info if i[8] < i[9])
        if limited:
            out["limits"] = f"{limited} limited joints (Bullet's)"
        if facts["equality"]:
            out["equality"] = f"{facts['equality']} equality constraints in the file (Bullet models none)"
        if facts["armature"]:
            out["armature"] = f"armature in {facts['armature']} elements of the file (Bullet has none)"
        if np.any(self.gravity):
            out["gravity"] = "gravity " + " ".join(f"{g:g}" for g in self.gravity)
        return out

    def _set(self, q, v) -> None:
        for (b, j), x, u in zip(self.joints, q, v):
            self.p.resetJointState(b, j, float(x), float(u), physicsClientId=self.cid)

    def _index(self, b: int) -> list[int]:
        p, cid = self.p, self.cid
        movable = [
            j
            for j in range(p.getNumJoints(b, physicsClientId=cid))
            if p.getJointInfo(b, j, physicsClientId=cid)[2] in (p.JOINT_REVOLUTE, p.JOINT_PRISMATIC)
        ]
        return movable

    def mass_matrix(self, q) -> np.ndarray:
        if len(self.bodies) != 1:
            raise ValueError("pybullet: the file's joints lie in several multibodies: no single mass matrix")
        b = self.bodies[0]
        full = np.array(self.p.calculateMassMatrix(b, [float(x) for x in q], physicsClientId=self.cid))
        return full[-len(q) :, -len(q) :]

    def parts(self, q, v) -> tuple[float, float]:
        """(potential, kinetic) energy of one state."""
        p, cid = self.p, self.cid
        self._set(q, v)
        kinetic = 0.5 * float(v @ self.mass_matrix(q) @ v)
        potential = 0.0
        for b in self.bodies:
            for j in range(-1, p.getNumJoints(b, physicsClientId=cid)):
                mass = p.getDynamicsInfo(b, j, physicsClientId=cid)[0]
                if mass <= 0:
                    continue
                com = (
                    p.getBasePositionAndOrientation(b, physicsClientId=cid)[0]
                    if j < 0
                    else p.getLinkState(b, j, computeForwardKinematics=True, physicsClientId=cid)[0]
                )
                potential -= mass * float(self.gravity @ np.array(com))
        return potential, kinetic

    def qacc(self, q, v) -> np.ndarray:
        """Free motion's acceleration: -M^-1 (Coriolis + gravity), from inverse dynamics at qacc 0."""
        b = self.bodies[0]
        self._set(q, v)
        bias = np.array(
            self.p.calculateInverseDynamics(
                b, [float(x) for x in q], [float(x) for x in v], [0.0] * len(q), physicsClientId=self.cid
            )
        )
        return -np.linalg.solve(self.mass_matrix(q), bias)

    def close(self) -> None:
        self.p.disconnect(physicsClientId=self.cid)


class BulletModelScene(ModelScene):
    """A model file as Bullet builds it (module docstring): ``BulletModelScene(path, mujoco_refusal,
    **params)``, ``mujoco_refusal`` MuJoCo's own one-line reason."""

    reference_engine = "pybullet"
    own_run_reference = True
    bullet_only = True

    def __init__(self, path, mujoco_refusal: str = "", **overrides):
        self.file = path if isinstance(path, ModelFile) else read_model_file(path)
        self.mujoco_refusal = mujoco_refusal
        Scene.__init__(self, **overrides)
        self.id = f"model:{self.file.name}@{self.file.sha8}{variant_suffix(self.values)}"
        self.facts = file_facts(self.file)
        world = BulletWorld(self.file, self.facts["gravity"])
        try:
            self.found = world.found(self.facts)
            self.dof_names = tuple(world.names)
            self._q0 = world.q0.copy()
            self._ranges = [(float(i[8]), float(i[9])) if i[8] < i[9] else None for i in world.info]
        finally:
            world.close()
        if not self.dof_names:
            from records import InvalidInput

            raise InvalidInput(f"model file {self.file.path!r}: Bullet's model of it has no movable joints")
        self.nv = len(self.dof_names)
        self.own_timestep = float(self.facts["timestep"])
        self.has_keyframe = False
        self._m = self._d = None
        self._world = None
        self._omega = None

    def copy_with(self, **values) -> BulletModelScene:
        return type(self)(self.file, self.mujoco_refusal, **values)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_world"] = None
        return state

    # ------------------------------------------------------------ the model
    def engine_model(self):
        raise ValueError(self.mujoco_refusal or "MuJoCo cannot compile the file")

    def gravity_vector(self) -> list[float]:
        """The gravity Bullet is given in this variant."""
        return [0.0, 0.0, 0.0] if self.values["gravity"] == 0 else [float(g) for g in self.facts["gravity"]]

    def _bullet(self) -> BulletWorld:
        if self._world is None:
            self._world = BulletWorld(self.file, self.gravity_vector())
        return self._world

    def describe_state(self) -> str:
        return (
            f"Bullet's load pose moved by dq ~ N(0, {self.values['perturb']:g}^2) per joint, qvel ~ "
            f"N(0, {self.values['perturb']:g}^2), numpy default_rng(seed={self.values['seed']})"
        )

    def initial_state(self):
        rng = np.random.default_rng(int(self.values["seed"]))
        s = float(self.values["perturb"])
        dq = rng.normal(0.0, s, self.nv) if s > 0 else np.zeros(self.nv)
        dv = rng.normal(0.0, s, self.nv) if s > 0 else np.zeros(self.nv)
        q = self._q0 + dq
        for i, r in enumerate(self._ranges):
            if r is not None:
                lo, hi = r
                q[i] = min(max(q[i], lo + 0.1 * (hi - lo)), hi - 0.1 * (hi - lo))
        return q, dv

    def _state_energy(self, q, v) -> float:
        """One finite state's energy: Bullet's potential plus kinetic (``BulletWorld.parts``)."""
        return sum(self._bullet().parts(q, v))

    def energy_scale(self) -> float:
        potential, kinetic = self._bullet().parts(*self.initial_state())
        return float(abs(potential) + abs(kinetic)) or 1.0

    def jacobian(self) -> np.ndarray:
        world = self._bullet()
        q0, v0 = self.initial_state()
        nv = self.nv
        a = np.zeros((2 * nv, 2 * nv))
        a[:nv, nv:] = np.eye(nv)
        for i in range(nv):
            e = np.zeros(nv)
            e[i] = FD_EPS
            a[nv:, i] = (world.qacc(q0 + e, v0) - world.qacc(q0 - e, v0)) / (2 * FD_EPS)
            a[nv:, nv + i] = (world.qacc(q0, v0 + e) - world.qacc(q0, v0 - e)) / (2 * FD_EPS)
        return a

    @property
    def omega(self) -> float:
        if self._omega is None:
            with np.errstate(all="ignore"):
                eig = np.linalg.eigvals(self.jacobian())
            w = float(np.max(np.abs(eig))) if np.all(np.isfinite(eig)) else OMEGA_FLOOR
            self._omega = max(w, OMEGA_FLOOR) if math.isfinite(w) else OMEGA_FLOOR
        return self._omega

    def mass_matrix_variation(self, q) -> float | None:
        """How much Bullet's M(q) changes over the configurations ``q`` (``scenarios._mass_matrix``)."""
        from ._mass_matrix import MAX_CONFIGURATIONS, kinetic_change

        q = np.asarray(q, dtype=float).reshape(-1, self.nv)
        q = q[np.all(np.isfinite(q), axis=1)]
        if len(q) == 0:
            return None
        rows = q[np.unique(np.linspace(0, len(q) - 1, min(len(q), MAX_CONFIGURATIONS)).astype(int))]
        world = self._bullet()
        m0 = world.mass_matrix(rows[0])
        return max(kinetic_change(m0, world.mass_matrix(x)) for x in rows)

    # ------------------------------------------------------------ reference
    def reference_solution(self, t):
        return None

    def reference_error(self, t) -> float | None:
        return None

    def describe(self) -> dict:
        out = super().describe()
        out.update(built_by="pybullet", mujoco_cannot_load=self.mujoco_refusal)
        return out


def open_model(path, **params) -> ModelScene:
    """The model file as a scene: MuJoCo's model of it, or, where MuJoCo cannot compile the file
    and Bullet loads it, Bullet's (``BulletModelScene``, carrying MuJoCo's reason). A file
    neither engine loads: MuJoCo's InvalidInput."""
    from records import InvalidInput

    mf = path if isinstance(path, ModelFile) else read_model_file(path)
    try:
        return ModelScene(mf, **params)
    except InvalidInput as refused:
        if "MuJoCo cannot compile it" not in str(refused):
            raise
        try:
            import pybullet  # noqa: F401
        except ImportError:
            raise refused from None
        reason = str(refused).split("MuJoCo cannot compile it: ", 1)[1]
        try:
            return BulletModelScene(mf, f"MuJoCo cannot compile it: {reason}", **params)
        except InvalidInput:
            raise
        except Exception as exc:  # Bullet's loader failed too: both engines' reasons in one line
            raise InvalidInput(
                f"{refused}; pybullet cannot load it either: {' '.join((str(exc) or type(exc).__name__).split())}"
            ) from None
