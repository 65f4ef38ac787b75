"""MuJoCo: one method per integrator (``mujoco:euler``, ``rk4``, ``implicit``, ``implicitfast``,
``discrete``) on the spring, the damped spring, the pendulum, the projectile, the spring chain
and the rope.

Minimal models (measured semantics in docs/engines.md): one body with the scene's exact mass on
slide joints along world axes (spring and drag as joint stiffness and damping), or on a hinge
with a point mass for the pendulum; the chain as one world-child body per mass on its own
slide joint, the wall springs as joint stiffness and each spring between neighbours as a
fixed tendon (coefficients -1, +1, stiffness k, spring length 0); the rope as a hinge chain,
link j's hinge at mass j-1 and its point mass at the link end. Contacts and constraints off,
gravity only where the scene has it, armature 0. Autoreset is disabled and every bad-state warning ends the run as
``unstable`` at that step: MuJoCo otherwise silently resets a diverged state to the initial
one, and a blow-up would look like a calm spring. Warnings go to a handler, not to stdout or
MUJOCO_LOG.TXT.

The engine's own loop is ``mujoco.rollout`` (``Model.run``): one C call steps a span of up to
ROLLOUT_SPAN_VALUES / nstate steps, MuJoCo recording every state, and the output points are
read from its state array. A rollout stops stepping at the first warning; any warning in a
span sends the run back to the per-step path, which stops it at that step as before.
Force evaluations are MuJoCo's forward passes, counted by ``d.timer[mjTIMER_FORWARD]``
(RK4: 4 a step; every other integrator: 1).

Releases: ``VERSIONS`` (from 2.3.7). Where the bindings differ between releases the model asks
the imported module what it has, never its version number: ``mj_fullM``'s arguments (``(m, dst,
M)`` with ``d.qM`` up to 3.3, ``(m, d, dst)`` after), the ``rollout.Rollout`` class with
``control_spec`` (without it the run is stepped one ``mj_step`` at a time: the same bits), the
disable flags ``mjDSBL_AUTORESET`` and ``mjDSBL_EULERDAMP`` (where autoreset cannot be disabled
a bad-state warning still ends the run at its step), and ``mjINT_DISCRETE`` for the discrete mode.
"""

from __future__ import annotations

import functools
import inspect
from dataclasses import dataclass
from collections.abc import Callable

import numpy as np

from records.method import Behaviour
from scenarios import Scene
from scenarios import full_mass_matrix

from .._engine import Engine, EngineVersions, import_engine
from .._mode import EngineMode
from .._model import EngineModel
from . import bench

#: The releases this adapter supports and was measured on: 2.3.7 is the oldest whose Python
#: bindings have everything the models use (mjtState, rollout's state layout, the warning hook).
VERSIONS = EngineVersions(low="2.3.7", below="5", tested=("2.3.7", "3.0.0", "3.3.7", "4.0.0"))

#: Our mode name -> what it selects in MuJoCo: the integrator, by its name in MJCF.
MODES = {"euler": "Euler", "rk4": "RK4", "implicit": "implicit", "implicitfast": "implicitfast", "discrete": "discrete"}

UNSUPPORTED = {
    "kepler": "MuJoCo has no central 1/r^2 force (an mjcb_passive callback would be our force, not MuJoCo's)",
}

#: Divergence warnings. MuJoCo raises them when a qpos/qvel/qacc entry is NaN, inf or
#: larger than 1e10 (mjMAXVAL), so an engine run may stop earlier than a reference one.
_BAD_STATE = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")

#: Most state values one rollout call records (steps x nstate): 8 MiB of float64, so that a
#: long run of a large model is rolled out in spans instead of one array of every state.
ROLLOUT_SPAN_VALUES = 1 << 20

#: ``opt.tolerance`` on the chain (see ``_Model``); other scenes keep MuJoCo's default.
CHAIN_TOLERANCE = 1e-14

_OPTION = (
    '<option timestep="{dt!r}" integrator="{integrator}" gravity="0 0 {gz!r}">'
    '<flag contact="disable" constraint="disable"{gravity_flag}/></option>'
)

_SLIDES = """<mujoco>{option}<worldbody><body name="mass">
  <inertial pos="0 0 0" mass="{m!r}" diaginertia="1 1 1"/>
  {joints}
</body></worldbody></mujoco>"""

_SLIDE = (
    '<joint name="{name}" type="slide" axis="{axis}" stiffness="{k!r}" springref="0" damping="{c!r}" armature="0"/>'
)

# MuJoCo rejects a principal inertia below 1e-15 at compile time; it is zeroed after
# compiling so that the joint mass is exactly m L^2 (a point mass).
_PENDULUM = """<mujoco>{option}<worldbody><body name="bob">
  <joint name="theta" type="hinge" axis="0 1 0" pos="0 0 0" stiffness="0" damping="0" armature="0"/>
  <inertial pos="0 0 {z!r}" mass="{m!r}" diaginertia="1e-15 1e-15 1e-15"/>
</body></worldbody></mujoco>"""


# The chain: one world-child body per mass (M diagonal, exactly m), the wall springs as the end
# joints' stiffness, the springs between neighbours as fixed tendons of length q_{i+1} - q_i.
_CHAIN_BODY = (
    '<body name="m{i}"><inertial pos="0 0 0" mass="{m!r}" diaginertia="1 1 1"/>'
    '<joint name="x{i}" type="slide" axis="1 0 0" stiffness="{k!r}" springref="0" damping="{c!r}" '
    'armature="0"/></body>'
)
_CHAIN_TENDON = (
    '<fixed name="s{i}" stiffness="{k!r}" springlength="0" damping="{c!r}">'
    '<joint joint="x{i}" coef="-1"/><joint joint="x{j}" coef="1"/></fixed>'
)
_CHAIN = "<mujoco>{option}<worldbody>{bodies}</worldbody><tendon>{tendons}</tendon></mujoco>"

# The rope: link j (1-based) hinges at mass j-1 (the origin for j = 1) about -y, so that a
# positive angle swings the link from hanging straight down towards +x, and carries mass j at
# its end as a point (inertia zeroed after compiling, as for the pendulum). In the reference
# configuration every link hangs down; qpos are the angles of each link relative to its parent.
_ROPE_LINK = (
    '<body name="link{j}" pos="0 0 {z!r}">'
    '<joint name="phi{j}" type="hinge" axis="0 -1 0" pos="0 0 0" stiffness="0" damping="0" armature="0"/>'
    '<inertial pos="0 0 {zl!r}" mass="{m!r}" diaginertia="1e-15 1e-15 1e-15"/>'
)


@functools.cache
def _rollout_class(mj):
    """``mujoco.rollout.Rollout`` where it exists with the arguments ``_Model._roll`` passes
    (``control_spec``, ``initial_warmstart``, ``skip_checks``), else None: older releases have only
    a ``rollout()`` function with another state layout, and their runs are stepped one
    ``mj_step`` at a time (the same bits, ``tests/test_engine_loops.py``)."""
    try:
        module = import_engine(f"{mj.__name__}.rollout")
    except ImportError:
        return None
    cls = getattr(module, "Rollout", None)
    if cls is None:
        return None
    try:
        names = inspect.signature(cls.rollout).parameters
    except (TypeError, ValueError):
        return None
    return cls if {"control_spec", "initial_warmstart", "skip_checks", "state"} <= set(names) else None


def has_mode(mode: str) -> Callable[[object], bool]:
    """Whether the imported MuJoCo has the mode's integrator in ``mjtIntegrator``."""

    def present(mj) -> bool:
        return hasattr(mj.mjtIntegrator, f"mjINT_{MODES[mode].upper()}")

    return present


def _disable_bit(mj, name: str) -> int:
    """The bit of disable flag ``mjDSBL_<name>``, 0 where this release has no such flag."""
    member = getattr(mj.mjtDisableBit, f"mjDSBL_{name}", None)
    return 0 if member is None else int(member)


def _option(integrator: str, dt: float, g: float | None) -> str:
    """The option element: gravity g along -z, or gravity disabled where the scene has none."""
    if g is None:
        return _OPTION.format(dt=dt, integrator=integrator, gz=0.0, gravity_flag=' gravity="disable"')
    return _OPTION.format(dt=dt, integrator=integrator, gz=-g, gravity_flag="")


def _spring_xml(integrator: str, scene: Scene, dt: float) -> str:
    p = scene.values
    joints = _SLIDE.format(name="x", axis="1 0 0", k=p["k"], c=p.get("c", 0.0))
    return _SLIDES.format(option=_option(integrator, dt, None), m=p["m"], joints=joints)


def _projectile_xml(integrator: str, scene: Scene, dt: float) -> str:
    p = scene.values
    # The scene's (x, y) with y up are MuJoCo's x and z (gravity along -z); drag is joint damping.
    joints = "\n  ".join(_SLIDE.format(name=n, axis=a, k=0.0, c=p["c"]) for n, a in (("x", "1 0 0"), ("y", "0 0 1")))
    return _SLIDES.format(option=_option(integrator, dt, p["g"]), m=p["m"], joints=joints)


def _pendulum_xml(integrator: str, scene: Scene, dt: float) -> str:
    p = scene.values
    return _PENDULUM.format(option=_option(integrator, dt, p["g"]), z=-p["L"], m=p["m"])


def _chain_xml(integrator: str, scene: Scene, dt: float) -> str:
    p = scene.values
    # The dashpots sit where the springs do: the wall ones as the end joints' damping, the
    # others as the tendons' damping.
    n, k, c = p["N"], p["k"], p["c"]
    bodies = "".join(
        _CHAIN_BODY.format(i=i, m=p["m"], k=k * ((i == 0) + (i == n - 1)), c=c * ((i == 0) + (i == n - 1)))
        for i in range(n)
    )
    tendons = "".join(_CHAIN_TENDON.format(i=i, j=i + 1, k=k, c=c) for i in range(n - 1))
    return _CHAIN.format(option=_option(integrator, dt, None), bodies=bodies, tendons=tendons)


def _rope_xml(integrator: str, scene: Scene, dt: float) -> str:
    p = scene.values
    n, l = p["N"], p["l"]
    links = "".join(_ROPE_LINK.format(j=j, z=0.0 if j == 1 else -l, zl=-l, m=p["m"]) for j in range(1, n + 1))
    return f"<mujoco>{_option(integrator, dt, p['g'])}<worldbody>{links}{'</body>' * n}</worldbody></mujoco>"


# The cloth: one world-child body per free mass, at the origin, on slide joints along world
# axes (qpos = the mass's position, exactly), a site at its origin; the pinned masses as world
# sites at their start; every spring a spatial tendon between two sites (stiffness k, spring
# length = the rest length, no damping). The planar net's (x, y), y up, are MuJoCo's x and z.
_CLOTH_BODY = (
    '<body name="n{i}_{j}"><inertial pos="0 0 0" mass="{m!r}" diaginertia="1 1 1"/>{joints}'
    '<site name="s{i}_{j}" pos="0 0 0"/></body>'
)
_CLOTH_JOINT = '<joint name="{c}{i}_{j}" type="slide" axis="{axis}" stiffness="0" damping="0" armature="0"/>'
_CLOTH_TENDON = (
    '<spatial name="t{k}" stiffness="{stiff!r}" springlength="{rest!r}" damping="0">'
    '<site site="s{a}"/><site site="s{b}"/></spatial>'
)


def _cloth_xml(integrator: str, scene: Scene, dt: float) -> str:
    n, m, d = scene.grid
    axes = (("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")) if d == 3 else (("x", "1 0 0"), ("y", "0 0 1"))
    free = set(scene.free_nodes())
    start = scene.rest_positions()
    parts = []
    for i in range(n):
        for j in range(m):
            if (i, j) in free:
                joints = "".join(_CLOTH_JOINT.format(c=c, i=i, j=j, axis=axis) for c, axis in axes)
                parts.append(_CLOTH_BODY.format(i=i, j=j, m=float(scene.node_mass), joints=joints))
            else:
                x = start[i * m + j]
                x = [float(c) for c in x]
                pos = f"{x[0]!r} {x[1]!r} {x[2]!r}" if d == 3 else f"{x[0]!r} 0 {x[1]!r}"
                parts.append(f'<site name="s{i}_{j}" pos="{pos}"/>')
    a, b, k, rest = scene.springs()
    tendons = "".join(
        _CLOTH_TENDON.format(
            k=t, stiff=float(k[t]), rest=float(rest[t]), a=f"{a[t] // m}_{a[t] % m}", b=f"{b[t] // m}_{b[t] % m}"
        )
        for t in range(len(a))
    )
    return (
        f"<mujoco>{_option(integrator, dt, scene.values['g'])}<worldbody>{''.join(parts)}</worldbody>"
        f"<tendon>{tendons}</tendon></mujoco>"
    )


def _joint_coordinates(scene: Scene, q: np.ndarray, v: np.ndarray):
    """The scene's coordinates are MuJoCo's qpos and qvel."""
    return q, v


def _scene_coordinates(scene: Scene, qpos: np.ndarray, qvel: np.ndarray):
    return qpos.copy(), qvel.copy()


def _no_settings(m) -> dict:
    return {}


def _tendon_settings(m) -> dict:
    return {
        "tendon_stiffness": [float(x) for x in m.tendon_stiffness],
        "tendon_springlength": [float(x) for x in m.tendon_lengthspring[:, 0]],
        "tendon_damping": [float(x) for x in m.tendon_damping],
    }


def _link_settings(m) -> dict:
    return {
        "body_mass": [float(x) for x in m.body_mass[1:]],
        "body_inertia": [float(x) for x in m.body_inertia[1:].ravel()],
        "link_lengths": [float(-z) for z in m.body_ipos[1:, 2]],
    }


@dataclass(frozen=True)
class Pose:
    """How MuJoCo poses one scene: the MJCF, and what differs from the slide-joint default.

    ``point_masses``: every body's inertia is zeroed after compiling (MuJoCo rejects a principal
    inertia below 1e-15 at compile time), so that a hinge's joint mass is exactly m L^2.
    ``tolerance``: ``opt.tolerance`` where MuJoCo's default is not tight enough (None: default).
    ``to_joints``/``from_joints``: the scene's (q, v) to MuJoCo's (qpos, qvel) and back; ``from_joints``
    also maps rows of states (arrays of shape (k, nq), (k, nv)) at once.
    ``settings``: what the pose adds to the settings read back from the compiled model.
    """

    xml: Callable[[str, Scene, float], str] | None
    point_masses: bool = False
    tolerance: float | None = None
    to_joints: Callable = _joint_coordinates
    from_joints: Callable = _scene_coordinates
    settings: Callable = _no_settings
    #: A scene that brings its own compiled model (a model file): ``(mujoco, integrator, scene,
    #: dt) -> MjModel`` in place of ``xml``.
    compiled: Callable | None = None


class _Model(EngineModel):
    own_loop = settable = True

    def __init__(self, mujoco, mode: str, scene: Scene, dt: float):
        self.mj = mujoco
        # The engine's own loop where this release's rollout takes what ``_roll`` passes.
        self.own_loop = _rollout_class(mujoco) is not None
        self.pose = pose = POSES[scene.kind]
        if pose.compiled is not None:
            self.m = m = pose.compiled(mujoco, MODES[mode], scene, dt)
        else:
            self.m = m = mujoco.MjModel.from_xml_string(pose.xml(MODES[mode], scene, dt))
        self.scene = scene
        if pose.point_masses:
            m.body_inertia[1:] = 0.0
        if pose.tolerance is not None:
            m.opt.tolerance = pose.tolerance
        # Where a release cannot disable autoreset, its bad-state warning still ends the run (trouble()).
        m.opt.disableflags |= _disable_bit(mujoco, "AUTORESET")
        self.d = d = mujoco.MjData(m)
        q0, v0 = pose.to_joints(scene, *scene.initial_state())
        d.qpos[:] = q0
        d.qvel[:] = v0
        self._bad = [int(getattr(mujoco.mjtWarning, w)) for w in _BAD_STATE]
        self._counts = self._bad_counts()
        mujoco.mj_forward(m, d)
        full = full_mass_matrix(mujoco, m, d)
        disabled = [
            name
            for name, bit in mujoco.mjtDisableBit.__members__.items()
            if name != "mjNDISABLE" and m.opt.disableflags & int(bit)
        ]
        self.settings = {
            "integrator": mujoco.mjtIntegrator(m.opt.integrator).name,
            "timestep": float(m.opt.timestep),
            "gravity": [float(x) for x in m.opt.gravity],
            "disabled": disabled,
            "eulerdamp": "mjDSBL_EULERDAMP" not in disabled,
            "autoreset": "mjDSBL_AUTORESET" not in disabled,
            "tolerance": float(m.opt.tolerance),
            "iterations": int(m.opt.iterations),
            "mass_matrix_diagonal": [float(x) for x in np.diag(full)],
            "joint_stiffness": [float(x) for x in m.jnt_stiffness],
            "joint_damping": [float(x) for x in m.dof_damping],
            "armature": [float(x) for x in m.dof_armature],
            "ngeom": int(m.ngeom),
        }
        self.settings.update(pose.settings(m))
        self._forward = int(mujoco.mjtTimer.mjTIMER_FORWARD)
        self._forward_at_build = int(d.timer[self._forward].number)
        self._full = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
        self._nstate = mujoco.mj_stateSize(m, self._full)
        self._span = max(1, ROLLOUT_SPAN_VALUES // self._nstate)
        self._rollout = None
        self.settings["engine_loop"] = "rollout" if self.own_loop else "mj_step (this release has no Rollout class)"
        # Last, so that nothing can fail between installing the handler and close() restoring it.
        self.warnings: list[str] = []
        self._previous_handler = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(self.warnings.append)

    def set_state(self, q: np.ndarray, v: np.ndarray) -> None:
        """As if built at (q, v): every derived quantity and warm start cleared."""
        self.mj.mj_resetData(self.m, self.d)
        q, v = self.pose.to_joints(self.scene, q, v)
        self.d.qpos[:] = q
        self.d.qvel[:] = v
        self.mj.mj_forward(self.m, self.d)  # as after building
        self._counts = self._bad_counts()

    def _bad_counts(self) -> list[int]:
        return [int(self.d.warning[i].number) for i in self._bad]

    def advance(self) -> None:
        self.mj.mj_step(self.m, self.d)

    def state(self):
        return self._scene_state(self.d.qpos, self.d.qvel)

    def _scene_state(self, qpos: np.ndarray, qvel: np.ndarray):
        return self.pose.from_joints(self.scene, qpos, qvel)

    def run(self, marks: np.ndarray):
        """``Model.run`` through ``mujoco.rollout``: spans of whole output intervals (at most
        ``self._span`` steps each, an interval longer than that in several calls), each one C
        call from the data's current full physics state and warm start; the output states are
        rows of the state array MuJoCo records (time, qpos, qvel, ...)."""
        if self._rollout is None:
            self._rollout = _rollout_class(self.mj)(nthread=0)
        nq, nv = self.m.nq, self.m.nv
        out = []
        at, i = int(marks[0]), 1
        while i < len(marks):
            j = i
            while j < len(marks) and marks[j] - at <= self._span:
                j += 1
            n = int(marks[j - 1] - at) if j > i else self._span
            rows = self._roll(n)
            if rows is None:
                return out, False
            # The span's output rows converted at once (a pose's ``from_joints`` maps rows of
            # (qpos, qvel) row by row: the same bits as one row at a time, in one numpy call).
            rows = rows[(marks[i:j] - at - 1).astype(int)]
            q, v = self._scene_state(rows[:, 1 : 1 + nq], rows[:, 1 + nq : 1 + nq + nv])
            out.extend(zip(q, v))
            at += n
            i = j
        return out, True

    def _roll(self, n: int) -> np.ndarray | None:
        """n steps in one ``rollout`` call from the data's state; the (n, nstate) states, or None
        if MuJoCo warned (a rollout clears the warning counters first and stops at a warning)."""
        mj, m, d = self.mj, self.m, self.d
        state0 = np.empty((1, self._nstate))
        mj.mj_getState(m, d, state0[0], self._full)
        warmstart = d.qacc_warmstart.copy()[None, :]
        states = np.empty((1, n, self._nstate))
        self._rollout.rollout(
            [m],
            [d],
            state0,
            nstep=n,
            initial_warmstart=warmstart,
            state=states,
            control_spec=int(mj.mjtState.mjSTATE_CTRL),
            skip_checks=True,
        )
        if any(w.number for w in d.warning):
            return None
        return states[0]

    def anatomy(self) -> dict:
        """What MuJoCo built, read from the compiled model at the initial state
        (``harness.measures.cross_engine`` says the schema): each moving body's mass and principal
        inertia, each hinge or slide joint's type, world axis, stiffness, spring reference,
        damping, armature, limits (None where off) and friction loss, and ``mj_fullM``."""
        mj, m, d = self.mj, self.m, self.d
        mj.mj_forward(m, d)
        full = full_mass_matrix(mj, m, d)
        limits_on = not m.opt.disableflags & int(mj.mjtDisableBit.mjDSBL_LIMIT)
        bodies = {}
        turning = {int(mj.mjtJoint.mjJNT_HINGE), int(mj.mjtJoint.mjJNT_BALL), int(mj.mjtJoint.mjJNT_FREE)}
        for b in range(1, m.nbody):
            if int(m.body_weldid[b]) == 0:
                continue  # welded to the world: no part of the dynamics
            name = mj.mj_id2name(m, mj.mjtObj.mjOBJ_BODY, b) or f"body{b}"
            chain, rotates = b, False
            while chain > 0 and not rotates:  # a joint that turns it, on the path to the world
                rotates = any(
                    int(m.jnt_type[j]) in turning
                    for j in range(m.body_jntadr[chain], m.body_jntadr[chain] + m.body_jntnum[chain])
                )
                chain = int(m.body_parentid[chain])
            bodies[name] = {
                "mass": float(m.body_mass[b]),
                "inertia": sorted(float(x) for x in m.body_inertia[b]),
                "rotates": rotates,
            }
        joints, axes = {}, []
        kinds = {int(mj.mjtJoint.mjJNT_HINGE): "hinge", int(mj.mjtJoint.mjJNT_SLIDE): "slide"}
        for j in range(m.njnt):
            kind = kinds.get(int(m.jnt_type[j]))
            if kind is None:
                continue
            dof = int(m.jnt_dofadr[j])
            name = mj.mj_id2name(m, mj.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"
            axes.append(d.xaxis[j].tolist())
            joints[name] = {
                "type": kind,
                "axis": d.xaxis[j].tolist(),
                "stiffness": float(m.jnt_stiffness[j]),
                "spring_ref": float(m.qpos_spring[m.jnt_qposadr[j]]),
                "damping": float(m.dof_damping[dof]),
                "armature": float(m.dof_armature[dof]),
                "frictionloss": float(m.dof_frictionloss[dof]),
                "limits": [float(x) for x in m.jnt_range[j]] if limits_on and m.jnt_limited[j] else None,
            }
        return {
            "engine": "mujoco",
            "total_mass": float(np.sum(m.body_mass)),
            "mass_matrix": full.tolist(),
            "joint_axes": axes,
            "bodies": bodies,
            "joints": joints,
            "notes": [],
        }

    def evaluations(self):
        return (
            int(self.d.timer[self._forward].number) - self._forward_at_build,
            "MuJoCo forward passes (d.timer[mjTIMER_FORWARD])",
        )

    def trouble(self) -> str | None:
        counts = self._bad_counts()
        if counts == self._counts:
            return None
        self._counts = counts
        said = self.warnings[-1] if self.warnings else "bad state"
        return f"MuJoCo warned: {said.strip()}"

    def close(self) -> None:
        self.mj.set_mju_user_warning(self._previous_handler)


def _rope_joint_state(scene: Scene, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rope's Cartesian state -> MuJoCo's relative joint angles and rates. The state must
    have every link at length l (the scene's initial state does): each link's absolute angle
    from the downward vertical is read from its direction, its rate from the perpendicular
    velocity difference of its ends."""
    x = np.concatenate([[0.0], q[0::2]])
    y = np.concatenate([[0.0], q[1::2]])
    vx = np.concatenate([[0.0], v[0::2]])
    vy = np.concatenate([[0.0], v[1::2]])
    dx, dy, dvx, dvy = np.diff(x), np.diff(y), np.diff(vx), np.diff(vy)
    theta = np.arctan2(dx, -dy)
    omega = (dx * dvy - dy * dvx) / (dx * dx + dy * dy)
    return np.diff(theta, prepend=0.0), np.diff(omega, prepend=0.0)


def _rope_scene_state(scene: Scene, qpos: np.ndarray, qvel: np.ndarray):
    """MuJoCo's relative joint angles -> absolute link angles -> the scene's Cartesian state
    (of one state, or of rows of states)."""
    theta, omega = np.cumsum(qpos, axis=-1), np.cumsum(qvel, axis=-1)
    return scene.angles_to_state(np.concatenate([theta, omega], axis=-1))


def _model_file(mujoco, integrator: str, scene: Scene, dt: float):
    """The scene's own compiled model (a model file's variant, its features switched off through
    MuJoCo's disable flags and model fields; the flex cloth), with this mode's integrator and dt."""
    m = scene.engine_model()
    m.opt.integrator = int(getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}"))
    m.opt.timestep = dt
    return m


def _model_settings(m) -> dict:
    return {
        "nq": int(m.nq),
        "nv": int(m.nv),
        "nu": int(m.nu),
        "total_mass": float(sum(m.body_mass)),
        "frictionloss": [float(x) for x in m.dof_frictionloss],
        "solver": int(m.opt.solver),
        "dof_damping_zeroed": not bool(np.any(m.dof_damping)),
    }


def _engine_state(scene: Scene, q: np.ndarray, v: np.ndarray):
    return scene.engine_state(q, v)


def _engine_scene_state(scene: Scene, qpos: np.ndarray, qvel: np.ndarray):
    return scene.scene_state(qpos, qvel)


def _flex_settings(m) -> dict:
    return {
        "flex_vertices": int(m.flex_vertnum[0]),
        "flex_triangles": int(m.flex_elemnum[0]),
        "pinned_vertices": int(np.count_nonzero(m.flex_vertbodyid == 0)),
        "total_mass": float(sum(m.body_mass)),
        "stretch": bool(m.flex_stiffness[m.flex_stiffnessadr[0]] != 0),
        "bending": bool(m.flex_bendingadr[0] >= 0),
        "edge_stiffness": float(m.flex_edgestiffness[0]),
        "edge_damping": float(m.flex_edgedamping[0]),
        "elasticity_damping": float(m.flex_damping[0]),
        "edge_equality": int(m.flex_edgeequality[0]),
        "contype": int(m.flex_contype[0]),
        "conaffinity": int(m.flex_conaffinity[0]),
        "selfcollide": int(m.flex_selfcollide[0]),
    }


#: How MuJoCo poses each scene it poses; a new scene is one entry here.
POSES: dict[str, Pose] = {
    "spring": Pose(_spring_xml),
    "damped_spring": Pose(_spring_xml),
    "pendulum": Pose(_pendulum_xml, point_masses=True),
    "projectile": Pose(_projectile_xml),
    # The discrete integrator solves for the tendon springs iteratively; at the default
    # tolerance (1e-8) it leaves 2.6e-8 (relative) of backward Euler's step unsolved,
    # measured on the chain over 1000 steps; at 1e-14, 1.5e-15.
    "chain": Pose(_chain_xml, tolerance=CHAIN_TOLERANCE, settings=_tendon_settings),
    "rope": Pose(
        _rope_xml,
        point_masses=True,
        to_joints=_rope_joint_state,
        from_joints=_rope_scene_state,
        settings=_link_settings,
    ),
    # As the chain's: the discrete integrator's iterative solve at 1e-14, not the default 1e-8.
    "cloth": Pose(_cloth_xml, tolerance=CHAIN_TOLERANCE, settings=_tendon_settings),
    "net": Pose(_cloth_xml, tolerance=CHAIN_TOLERANCE, settings=_tendon_settings),
    "model": Pose(None, settings=_model_settings, compiled=_model_file),
    "cloth_flex": Pose(
        None, compiled=_model_file, to_joints=_engine_state, from_joints=_engine_scene_state, settings=_flex_settings
    ),
}
SCENES = tuple(POSES)

#: Scenes a mode cannot step, measured: mujoco 4.0.0 stops mj_step (FatalError, mj_checkDiscrete)
#: on a flex with elasticity under implicit and implicitfast (tests/test_cloth_flex.py).
_FLEX_REFUSED = (
    "MuJoCo refuses it: 'flex elasticity is no longer integrated implicitly under integrator='implicit' "
    "and 'implicitfast': set integrator='discrete', or 'Euler' with a small timestep' (mujoco 4.0.0)"
)
_REFUSED = {"implicit": {"cloth_flex": _FLEX_REFUSED}, "implicitfast": {"cloth_flex": _FLEX_REFUSED}}


def build(mujoco, mode: str, scene: Scene, dt: float, count: bool = False) -> _Model:
    """``count`` changes nothing: MuJoCo's timers count forward passes in every run."""
    return _Model(mujoco, mode, scene, dt)


_DOCS = {
    "euler": """semi-implicit Euler (velocity first); joint damping implicit (eulerdamp)
        Measured: equals ref:semi_implicit_euler bitwise on the spring and to roundoff on the
        chain; with damping c it is v += h(-k x - c v)/(m + h c), x += h v. On the rope's hinge
        chain bitwise the same as implicitfast and discrete (nothing there is implicit).""",
    "rk4": """classical RK4
        Measured: equals ref:rk4 to ~1e-14 on the spring and to roundoff on the chain; on the
        rope it follows the reduced-coordinate reference to 1.3e-9 over 2 s at dt = 1e-4.""",
    "implicit": """semi-implicit Euler, implicit in velocity-dependent forces only
        Measured: equals ref:semi_implicit_euler bitwise on the undamped spring and to roundoff
        on the chain (spring and tendon forces stay explicit); with damping the same update as
        mujoco:euler. On the rope its Coriolis terms are implicit: a different scheme.""",
    "implicitfast": """semi-implicit Euler, implicit in velocity-dependent forces only (no Coriolis terms)
        Measured: as mujoco:euler on these scenes.""",
    "discrete": """backward (implicit) Euler: solves (M + hD + h^2 K) a = f - h K v
        Measured: on the cloth's spatial tendons K is k J^T J alone (no geometric stiffness), so
        one step is ref:linearly_implicit_euler with that K: no reference scheme there.
        Equals ref:implicit_euler to ~1e-14 on the spring; on the chain to 4e-13
        over 1000 steps from any state with every tendon stretched (opt.tolerance 1e-14; 7e-6
        at the default 1e-8), but a tendon exactly at its rest length is left out of the
        implicit step, as in the chain's initial state. Gravity stays explicit.""",
}

#: Why a mode matches no reference scheme on a scene, where measured so (the damped chain,
#: c > 0; an undamped chain matches, see _DOCS). Measured on mujoco 4.0.0 against
#: v_1 = v + h (M + h D)^-1 f(x, v) for the candidate damping matrices D.
_NO_MATCH = {
    "euler": {
        "chain": "eulerdamp makes only joint damping implicit, v += h (M + h diag(joint damping))^-1 f: "
        "the tendons' dashpots stay explicit, a mix of two schemes"
    },
    "implicit": {
        "chain": "only the diagonal of the damping matrix is implicit, v += h (M + h diag(D))^-1 f: the "
        "tendon dashpots' coupling of neighbours stays explicit"
    },
    "implicitfast": {
        "chain": "only the diagonal of the damping matrix is implicit, v += h (M + h diag(D))^-1 f: "
        "the tendon dashpots' coupling of neighbours stays explicit"
    },
    "discrete": {
        "chain": "a tendon exactly at its rest length (most of them in the chain's initial state) is "
        "left out of the implicit step",
        **{
            scene: "one linear solve with the tendons' stiffness k J^T J alone, (M + h^2 k J^T J) dv = "
            "h (f - h k J^T J v): linearly implicit Euler without the springs' geometric stiffness "
            "k (1 - L/|d|)(I - u u^T) (measured 3e-16 from a generic state); and every tendon of the "
            "flat sheet starts exactly at its rest length, where it is left out"
            for scene in ("cloth", "net")
        },
    },
}

#: What each mode was measured to do that its name does not say (``records.method.Behaviour``): the
#: modes of semi-implicit Euler step it in the generalized velocity (docs/findings.md).
_IN_VELOCITY = Behaviour(integrates_as={"cloth": "ref:semi_implicit_euler"}, in_velocity="ref:semi_implicit_euler")
_BEHAVIOUR = {
    "euler": _IN_VELOCITY,
    "implicit": _IN_VELOCITY,
    "implicitfast": _IN_VELOCITY,
    "rk4": Behaviour(integrates_as={"cloth": "ref:rk4"}),
    "discrete": Behaviour(from_a_generic_state={"chain": "ref:implicit_euler"}),
}

METHODS = {
    f"mujoco:{mode}": EngineMode(
        engine="mujoco",
        mode=mode,
        module="mujoco",
        dist="mujoco",
        build=build,
        scenes=tuple(x for x in SCENES if x not in _REFUSED.get(mode, {})),
        unsupported={**UNSUPPORTED, **_REFUSED.get(mode, {})},
        doc=_DOCS[mode],
        no_match=_NO_MATCH.get(mode, {}),
        versions=VERSIONS,
        present=has_mode(mode),
        behaviour=_BEHAVIOUR[mode],
        settings={
            "integrator": name,
            "autoreset": "disabled",
            "contact": "disabled",
            "constraint": "disabled",
            "gravity": "scene's g along -z, else disabled",
            "armature": 0,
            "warnings": "collected, never printed or logged",
        },
    )
    for mode, name in MODES.items()
}

from . import contact  # noqa: E402  (its contact poses, which read MODES above)

#: The engine, declared once: ``adapters.ENGINES`` and every list of engines the harness keeps read it.
ENGINE = Engine(
    id="mujoco",
    module="mujoco",
    dists=("mujoco",),
    versions=VERSIONS,
    methods=METHODS,
    poses=POSES,
    build=build,
    bare_loops=bench.bare_loops,
    model_loader="MuJoCo's own compiler (MJCF, or URDF as MuJoCo compiles it)",
    contact_modes=contact.MODES,
)
