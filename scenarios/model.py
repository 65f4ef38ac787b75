"""A user's own model, from an MJCF (``.xml``) or URDF (``.urdf``) file, as one more scene.

Where a built-in scene has a closed form, a model file has the engine: its state, energy,
characteristic frequency and reference come from the model as MuJoCo compiles it.

* **Identity**: ``model:<file name>@<first 8 hex digits of the file's SHA-256>``: an edited file
  is another scene (another series in the history), never a regression of the old one.
* **What perturbs an integrator** (``FEATURES``): contacts, joint (and tendon) damping and
  fluid drag, friction loss, actuators, joint limits, equality constraints, armature, gravity.
  Each is a parameter, 1 (kept, as written) or 0 (switched off through MuJoCo's own disable
  flags and model fields, ``switch_off``); ``VARIANTS`` names the two the harness measures: the
  model as written, and the **conservative** one, which switches off exactly what dissipates or
  injects energy (``DISSIPATIVE``: contacts, damping, friction loss, actuators, limits, equality
  constraints) and keeps every conservative term: inertia, armature (rotor inertia: removing it
  changes the model's frequencies, not its energy balance), joint and tendon springs, and
  gravity, which stays a choice the user makes (``harness model --off gravity``).
* **Initial state**: the model's first keyframe where it has one; else its reference pose
  ``qpos0`` moved by ``dq ~ N(0, perturb^2)`` per degree of freedom (``mj_integratePos``, limited
  joints kept inside their range) and ``qvel ~ N(0, perturb^2)``, drawn from
  ``numpy.random.default_rng(seed)``. Controls are held at 0.
* **Energy**: ``mj_energyPos + mj_energyVel`` evaluated on each reported state itself (never
  ``d.energy``, which describes the state before the last step); gravity counts only where it
  is on.
* **omega**: the largest |eigenvalue| of the continuous-time Jacobian d(qvel, qacc)/d(qpos, qvel)
  at the initial state (finite differences in MuJoCo's tangent space), at least OMEGA_FLOOR: on a
  linear undamped model the largest natural frequency, sqrt(max eig(K, M)).
* **Reference** (``scenarios/_model_reference.py``): MuJoCo's RK4, the step halved until two
  successive halvings agree to REFERENCE_RTOL; its estimated error is ``reference_error``.
"""

from __future__ import annotations

import hashlib
import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from records import InvalidInput

from ._contact_pairs import collidable_pairs
from ._mass_matrix import mass_matrix_variation as _mass_matrix_variation
from ._model_reference import RefinedRunReference
from .scene import Param, Scene

#: The model features that change an integrator's behaviour, in the order reports list them.
FEATURES = {
    "contact": "contacts (mjDSBL_CONTACT)",
    "damping": "joint and tendon damping, fluid drag (dof_damping, tendon_damping, opt.density, opt.viscosity = 0)",
    "frictionloss": "friction loss (dof_frictionloss, tendon_frictionloss = 0)",
    "actuators": "actuators (mjDSBL_ACTUATION)",
    "limits": "joint and tendon limits (mjDSBL_LIMIT)",
    "equality": "equality constraints (mjDSBL_EQUALITY)",
    "armature": "armature (dof_armature = 0)",
    "gravity": "gravity (mjDSBL_GRAVITY)",
}

#: The features that dissipate or inject energy: what the conservative variant switches off.
DISSIPATIVE = ("contact", "damping", "frictionloss", "actuators", "limits", "equality")
#: The features that are conservative: kept in the conservative variant unless the user says otherwise.
CONSERVATIVE_TERMS = ("armature", "gravity")

#: The two variants measured, each by the features it switches off.
VARIANTS = {"as_written": (), "conservative": DISSIPATIVE}

SUFFIXES = {".xml": "MJCF", ".urdf": "URDF"}
#: The model of ``ModelScene()``: the built-in unit spring as an MJCF file.
DEFAULT_FILE = os.path.join(os.path.dirname(__file__), "data", "unit_spring.xml")
#: The smallest characteristic frequency (rad/s): a model that has none at its initial state
#: (free floating, no springs) is given a period of 2 pi seconds.
OMEGA_FLOOR = 1.0
#: Relative finite-difference step of the Jacobian behind omega.
FD_EPS = 1e-6
#: A run whose energy rises by more than this many times the initial energy scale
#: (kinetic + |potential|) has blown up (``runaway``). Above the bounded energy swing of a
#: symplectic method near its limit (1 / (1 - (h omega / 2)^2) is 1e3 at h omega = 1.999).
ENERGY_GROWTH = 1e3


@dataclass(frozen=True)
class ModelFile:
    """A model file as read: where, what kind, and its content hash."""

    path: str
    name: str
    kind: str  # MJCF or URDF
    sha256: str

    @property
    def sha8(self) -> str:
        return self.sha256[:8]


def read_model_file(path) -> ModelFile:
    """Check the file before any engine sees it: it exists, its suffix names a format, it is
    well-formed XML with the format's root element. One-line InvalidInput otherwise."""
    path = os.fspath(path)
    suffix = os.path.splitext(path)[1].lower()
    if suffix not in SUFFIXES:
        raise InvalidInput(
            f"model file {path!r}: unknown format {suffix or '(no suffix)'!r} (valid: .xml for MJCF, .urdf for URDF)"
        )
    if not os.path.isfile(path):
        raise InvalidInput(f"model file {path!r}: no such file")
    with open(path, "rb") as f:
        data = f.read()
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise InvalidInput(f"model file {path!r}: malformed XML ({exc})") from None
    want = "mujoco" if suffix == ".xml" else "robot"
    if root.tag != want:
        raise InvalidInput(f"model file {path!r}: root element <{root.tag}> (valid: <{want}> for {SUFFIXES[suffix]})")
    return ModelFile(os.path.abspath(path), os.path.basename(path), SUFFIXES[suffix], hashlib.sha256(data).hexdigest())


_COMPILED: dict[tuple[str, str], object] = {}


def compile_model(mf: ModelFile):
    """MuJoCo's compiled model of the file, as written (cached per process). A file MuJoCo
    cannot compile (a missing mesh, an unknown attribute) is InvalidInput with MuJoCo's own
    message; so is a file changed since it was read."""
    key = (mf.path, mf.sha256)
    if key not in _COMPILED:
        import mujoco

        with open(mf.path, "rb") as f:
            if hashlib.sha256(f.read()).hexdigest() != mf.sha256:
                raise InvalidInput(f"model file {mf.path!r} changed since it was read (sha256 differs)")
        try:
            m = mujoco.MjModel.from_xml_path(mf.path)
        except ValueError as exc:
            msg = " ".join(str(exc).split())
            raise InvalidInput(f"model file {mf.path!r}: MuJoCo cannot compile it: {msg}") from None
        if m.nv == 0:
            raise InvalidInput(f"model file {mf.path!r}: the model has no degrees of freedom (no joints)")
        _COMPILED[key] = m
    return _COMPILED[key]


def features_found(m) -> dict[str, str]:
    """{feature: what the model has of it}, for the features present in the compiled model."""
    import mujoco

    found = {}
    pairs = collidable_pairs(m)
    if pairs:
        found["contact"] = f"{len(pairs)} collidable geom pairs" + (f" ({m.npair} explicit)" if m.npair else "")
    damped = int(np.count_nonzero(m.dof_damping)) + int(np.count_nonzero(m.tendon_damping))
    if damped or m.opt.density or m.opt.viscosity:
        found["damping"] = f"{damped} damped dofs/tendons" + (
            ", fluid drag" if m.opt.density or m.opt.viscosity else ""
        )
    fl = int(np.count_nonzero(m.dof_frictionloss)) + int(np.count_nonzero(m.tendon_frictionloss))
    if fl:
        found["frictionloss"] = f"{fl} dofs/tendons with friction loss"
    if m.nu:
        found["actuators"] = f"{m.nu} actuators"
    limited = int(np.count_nonzero(m.jnt_limited)) + int(np.count_nonzero(m.tendon_limited))
    if limited:
        found["limits"] = f"{limited} limited joints/tendons"
    if m.neq:
        found["equality"] = f"{m.neq} equality constraints"
    if np.any(m.dof_armature):
        found["armature"] = f"{int(np.count_nonzero(m.dof_armature))} dofs with armature"
    if np.any(m.opt.gravity) and not m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY):
        found["gravity"] = "gravity " + " ".join(f"{g:g}" for g in m.opt.gravity)
    return found


def switch_off(m, off) -> None:
    """Switch the features ``off`` out of the compiled model ``m`` in place, through MuJoCo's
    disable flags and model fields (``FEATURES`` says which)."""
    import mujoco

    bits = mujoco.mjtDisableBit
    flags = {
        "contact": bits.mjDSBL_CONTACT,
        "actuators": bits.mjDSBL_ACTUATION,
        "limits": bits.mjDSBL_LIMIT,
        "equality": bits.mjDSBL_EQUALITY,
        "gravity": bits.mjDSBL_GRAVITY,
    }
    for name in off:
        if name in flags:
            m.opt.disableflags |= int(flags[name])
        elif name == "damping":
            m.dof_damping[:] = 0.0
            m.tendon_damping[:] = 0.0
            m.opt.density = 0.0
            m.opt.viscosity = 0.0
        elif name == "frictionloss":
            m.dof_frictionloss[:] = 0.0
            m.tendon_frictionloss[:] = 0.0
        elif name == "armature":
            m.dof_armature[:] = 0.0


def coordinate_names(m) -> tuple[str, ...]:
    """A name per qpos entry: the joint's name (or ``joint<j>``), with a suffix per coordinate of
    a free or ball joint."""
    import mujoco

    names = []
    for j in range(m.njnt):
        base = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"
        kind = int(m.jnt_type[j])
        if kind == int(mujoco.mjtJoint.mjJNT_FREE):
            names += [f"{base}.{c}" for c in ("x", "y", "z", "qw", "qx", "qy", "qz")]
        elif kind == int(mujoco.mjtJoint.mjJNT_BALL):
            names += [f"{base}.{c}" for c in ("qw", "qx", "qy", "qz")]
        else:
            names.append(base)
    return tuple(names)


def _switch(doc: str) -> Param:
    return Param(1, f"{doc}: 1 as written, 0 switched off", lo=0.0, hi=1.0, integer=True)


class ModelScene(RefinedRunReference, Scene):
    """A model file as a scene (module docstring). ``ModelScene(path, **params)``."""

    id = "model"
    title = "a user's MJCF or URDF model; reference: MuJoCo RK4, step halved until two halvings agree"
    params = {
        "seed": Param(0, "seed of the initial perturbation (no keyframe)", lo=0.0, hi=2.0**32 - 1, integer=True),
        "perturb": Param(
            0.5, "standard deviation of the initial perturbation of qpos and qvel (no keyframe)", lo=0.0, hi=1.0
        ),
        **{name: _switch(doc) for name, doc in FEATURES.items()},
    }
    runaway_limit = ENERGY_GROWTH
    has_kernels = False

    def __init__(self, path=None, **overrides):
        if path is None:
            path = DEFAULT_FILE
        self.file = path if isinstance(path, ModelFile) else read_model_file(path)
        super().__init__(**overrides)
        self.id = f"model:{self.file.name}@{self.file.sha8}{variant_suffix(self.values)}"
        written = compile_model(self.file)
        self.found = features_found(written)
        self._m = self._d = None
        self._omega = None
        self.dof_names = coordinate_names(written)
        self.nv = int(written.nv)
        self.own_timestep = float(written.opt.timestep)
        self.has_keyframe = bool(written.nkey)

    def copy_with(self, **values) -> ModelScene:
        return type(self)(self.file, **values)

    def __getstate__(self):
        # The compiled model is not pickled: a worker compiles the file again (and checks its hash).
        state = dict(self.__dict__)
        state["_m"] = state["_d"] = None
        return state

    # ------------------------------------------------------------ the model
    @property
    def switched_off(self) -> list[str]:
        """The features present in the model that this variant switches off."""
        return [name for name in FEATURES if name in self.found and self.values[name] == 0]

    def engine_model(self):
        """A fresh MuJoCo model of this variant: the file compiled, the features switched off."""
        m = _copy_model(compile_model(self.file))
        switch_off(m, [name for name in FEATURES if self.values[name] == 0])
        return m

    def engine_state(self, q, v):
        """The scene's coordinates are MuJoCo's (qpos, qvel)."""
        return q, v

    def scene_state(self, qpos, qvel):
        return np.array(qpos, dtype=float), np.array(qvel, dtype=float)

    def _model(self):
        if self._m is None:
            import mujoco

            self._m = self.engine_model()
            self._d = mujoco.MjData(self._m)
        return self._m, self._d

    def describe_state(self) -> str:
        if self.has_keyframe:
            return "the model's first keyframe (qpos, qvel); controls 0"
        return (
            f"reference pose qpos0 moved by dq ~ N(0, {self.values['perturb']:g}^2) per dof, qvel ~ "
            f"N(0, {self.values['perturb']:g}^2), numpy default_rng(seed={self.values['seed']}); controls 0"
        )

    def initial_state(self):
        import mujoco

        m, d = self._model()
        if m.nkey:
            return m.key_qpos[0].copy(), m.key_qvel[0].copy()
        rng = np.random.default_rng(int(self.values["seed"]))
        s = float(self.values["perturb"])
        dq = rng.normal(0.0, s, m.nv) if s > 0 else np.zeros(m.nv)
        dv = rng.normal(0.0, s, m.nv) if s > 0 else np.zeros(m.nv)
        q = m.qpos0.copy()
        mujoco.mj_integratePos(m, q, dq, 1.0)
        for j in range(m.njnt):
            if m.jnt_limited[j] and int(m.jnt_type[j]) in (
                int(mujoco.mjtJoint.mjJNT_HINGE),
                int(mujoco.mjtJoint.mjJNT_SLIDE),
            ):
                lo, hi = m.jnt_range[j]
                a = m.jnt_qposadr[j]
                q[a] = min(max(q[a], lo + 0.1 * (hi - lo)), hi - 0.1 * (hi - lo))
        return q, dv

    def energy(self, q, v):
        """The energy of each state (rows of q, v); NaN where a state is not finite."""
        q = np.asarray(q, dtype=float)
        v = np.asarray(v, dtype=float)
        shape = q.shape[:-1]
        qs, vs = q.reshape(-1, q.shape[-1]), v.reshape(-1, v.shape[-1])
        out = np.empty(len(qs))
        for i in range(len(qs)):
            finite = np.all(np.isfinite(qs[i])) and np.all(np.isfinite(vs[i]))
            out[i] = self._state_energy(qs[i], vs[i]) if finite else np.nan
        return out.reshape(shape)

    def _state_energy(self, q, v) -> float:
        """One finite state's energy: MuJoCo's mj_energyPos + mj_energyVel of it."""
        import mujoco

        m, d = self._model()
        d.qpos[:] = q
        d.qvel[:] = v
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_tendon(m, d)
        mujoco.mj_crb(m, d)
        mujoco.mj_energyPos(m, d)
        mujoco.mj_energyVel(m, d)
        return d.energy[0] + d.energy[1]

    def energy_scale(self) -> float:
        """Initial kinetic energy + |initial potential energy|: what energy growth is measured in."""

        m, d = self._model()
        q, v = self.initial_state()
        self.energy(q, v)
        return float(abs(d.energy[0]) + abs(d.energy[1])) or 1.0

    def runaway(self, energy: np.ndarray) -> float:
        """How many times the initial energy scale the energy rose above its start over a run."""
        e = np.asarray(energy, dtype=float).reshape(len(energy), -1)[:, 0]
        with np.errstate(all="ignore"):
            rise = float(np.max(e - e[0]))
        return rise / self.energy_scale() if math.isfinite(rise) else math.inf

    def jacobian(self) -> np.ndarray:
        """d(qvel, qacc)/d(qpos, qvel) at the initial state, (2 nv, 2 nv), central differences."""
        import mujoco

        m, d = self._model()
        q0, v0 = self.initial_state()
        nv = m.nv

        def acc(q, v):
            d.qpos[:] = q
            d.qvel[:] = v
            d.ctrl[:] = 0.0
            mujoco.mj_forward(m, d)
            return d.qacc.copy()

        a = np.zeros((2 * nv, 2 * nv))
        a[:nv, nv:] = np.eye(nv)
        for i in range(nv):
            e = np.zeros(nv)
            e[i] = FD_EPS
            qp, qm = q0.copy(), q0.copy()
            mujoco.mj_integratePos(m, qp, e, 1.0)
            mujoco.mj_integratePos(m, qm, -e, 1.0)
            a[nv:, i] = (acc(qp, v0) - acc(qm, v0)) / (2 * FD_EPS)
            a[nv:, nv + i] = (acc(q0, v0 + e) - acc(q0, v0 - e)) / (2 * FD_EPS)
        return a

    @property
    def omega(self) -> float:
        if self._omega is None:
            with np.errstate(all="ignore"):
                eig = np.linalg.eigvals(self.jacobian())
            w = float(np.max(np.abs(eig))) if np.all(np.isfinite(eig)) else OMEGA_FLOOR
            self._omega = max(w, OMEGA_FLOOR)
        return self._omega

    def mass_matrix_variation(self, q) -> float | None:
        """How much MuJoCo's M(q) changes over the configurations ``q`` (``scenarios._mass_matrix``)."""
        return _mass_matrix_variation(self, q)

    @property
    def slowest_omega(self) -> float:
        """The smallest |eigenvalue| of the Jacobian above 1e-6 of the largest (a rigid-body mode
        has none), at least OMEGA_FLOOR: the model's slowest natural frequency (rad/s)."""
        with np.errstate(all="ignore"):
            eig = np.abs(np.linalg.eigvals(self.jacobian()))
        if not np.all(np.isfinite(eig)):
            return OMEGA_FLOOR
        moving = eig[eig > 1e-6 * max(float(np.max(eig)), OMEGA_FLOOR)]
        return max(float(np.min(moving)) if moving.size else OMEGA_FLOOR, OMEGA_FLOOR)

    @property
    def conservative(self) -> bool:
        """Nothing that dissipates or injects energy is on (``DISSIPATIVE``)."""
        return all(self.values[name] == 0 for name in DISSIPATIVE if name in self.found)

    @property
    def kept(self) -> list[str]:
        """The conservative features present in the model that this variant keeps."""
        return [name for name in CONSERVATIVE_TERMS if name in self.found and self.values[name] == 1]

    @property
    def velocity_dependent(self) -> bool:
        return True  # Coriolis and centrifugal terms, in general

    # ------------------------------------------------------------ reference
    @property
    def reference_horizon(self) -> float:
        """One characteristic period: how far the halved RK4 run is used as the truth."""
        return self.period

    def describe(self) -> dict:
        out = super().describe()
        out.update(
            file=self.file.path,
            format=self.file.kind,
            sha256=self.file.sha256,
            features=dict(self.found),
            switched_off=self.switched_off,
            kept=self.kept,
            initial_state=self.describe_state(),
            own_timestep=self.own_timestep,
            nv=self.nv,
        )
        return out

    def __repr__(self) -> str:
        return f"ModelScene({self.file.path!r}, {', '.join(f'{k}={v:g}' for k, v in self.values.items())})"


def _copy_model(m):
    import copy

    return copy.copy(m)


def variant_suffix(values: dict) -> str:
    """What a scene id adds for its variant: nothing as written; ``~conservative`` with exactly
    ``DISSIPATIVE`` off, ``~conservative-gravity`` (and so on) where a conservative term is off
    too; else ``~off:`` and the features switched off."""
    off = [name for name in FEATURES if values[name] == 0]
    if not off:
        return ""
    if set(DISSIPATIVE) <= set(off):
        return "~conservative" + "".join(f"-{name}" for name in off if name not in DISSIPATIVE)
    return "~off:" + "+".join(off)


def variant(scene: ModelScene, name: str, keep=(), off=()) -> ModelScene:
    """The scene's file as the variant ``name`` (``VARIANTS``), the seed and perturbation kept;
    ``keep``: features the variant leaves on after all; ``off``: features it switches off as well
    (gravity, armature)."""
    if name not in VARIANTS:
        raise InvalidInput(f"unknown variant {name!r} (valid: {', '.join(VARIANTS)})")
    for f in (*keep, *off):
        if f not in FEATURES:
            raise InvalidInput(f"unknown feature {f!r} (valid: {', '.join(FEATURES)})")
    switched = (set(VARIANTS[name]) | set(off)) - set(keep)
    values = {**scene.values, **{f: 0 if f in switched else 1 for f in FEATURES}}
    return scene.copy_with(**values)
