"""Newton (``newton`` on NVIDIA Warp): its particle and articulation solvers as modes,
``newton:semi_implicit``, ``newton:xpbd``, ``newton:vbd`` and ``newton:featherstone``, on the
CPU in float32 (Warp's ``float`` is 32 bits: every mode declares ``precision = "float32"`` and is
identified against the reference schemes to float32 rounding, ``harness.measures.identify``).

Minimal models, Newton's own physics:

* ``spring`` / ``damped_spring`` (semi_implicit, xpbd, vbd): a free particle of mass m on a
  particle spring (stiffness k, damping c along the spring) to a particle of mass 0 (fixed) at
  x = -s, rest length s = ``REACH`` (20) x max(amplitude, 1); the scene's x is the free
  particle's x. A spring of rest length 0 to an anchor at the origin has length |x|, and VBD damps
  the change of length over a step: where the mass passes the anchor that is not the change of x
  (1.3e-2 off implicit Euler on the damped spring; 3.2e-6 with the anchor at -s). The model is the
  scene's linear spring only while the mass stays on its side of the anchor, so the anchor is
  beyond every size a run can reach and still be called stable (``REACH``).
* ``spring`` / ``damped_spring`` (featherstone) and ``pendulum``: one body on one joint of the
  world, its stiffness and damping the scene's: a prismatic joint along x (stiffness k, rest 0,
  damping c), or a revolute joint about y with a point mass m at L below it (inertia zero:
  the joint's mass is m L^2) under the scene's gravity along -z.
* ``chain``: N particles on the x axis at spacing s = 2 max(|x0|, 1) (centred on the origin, so
  float32 keeps as many digits of every displacement as it can), springs of rest length s between
  neighbours and to two fixed particles (the walls); q_i is particle i's x less its rest place.
  A spring of rest length 0 between particles at one place has no direction (Newton divides by
  its length), so the chain cannot start with every particle at its rest place 0.
* ``cloth`` / ``net``: one particle per grid node at the scene's start, the pinned ones of mass
  0, one particle spring per scene spring (structural, shear, bending) with the scene's stiffness
  and rest length, no triangles; gravity along the last axis (the net lies in the x-y plane).
* ``model`` (featherstone): a model file as Newton's own loaders build it (``add_urdf`` /
  ``add_mjcf``), in the joint coordinates, mapped to the scene's by joint name; what the loader
  ignores or SolverFeatherstone does not apply is listed (``adapters/newton/model.py``). The
  particle and maximal-coordinate solvers step free bodies held by penalty or relaxed joints: they
  run no model file, each with its reason.

Every default that would change the physics is set off and recorded in the run's settings:
gravity (Newton's default is -9.81 along its up axis: zero for the springs and the chain, the
scene's g otherwise); a spring's rest length (``add_spring`` takes the particles' initial
distance: set to the scene's, 0 for the spring); the particle radius (0.1 by default, which
switches particle-particle contact on: 0, and ``model.particle_grid`` None, so no contact pass
runs); triangle contact (``SolverSemiImplicit(enable_tri_contact=True)``: off; no triangles are
built either, so the cloth membrane's default ``tri_ke`` 100 and damping ``tri_kd`` 10 never
enter); the particle velocity clamp (``particle_max_velocity`` 1e5: raised to 1e30, so a blow-up
is not held finite); the solvers' angular damping (SemiImplicit and Featherstone default to
0.05: 0); joint limits (unlimited, as Newton's default); joint armature 0; ``finalize``'s inertia
check, which raises the pendulum's zero point-mass inertia to 1e-6 (skipped).

The loop is Newton's: ``solver.step(state_in, state_out, control, None, h)`` once a step from
Python, the two states swapped, the forces cleared, nothing read in between. Warp captures a
step as a graph on CUDA devices only (``wp.ScopedCapture``), so on the CPU there is no graph to
replay and each step is a handful of kernel launches from Python. First use of a solver compiles
the Warp modules of the kernels it launches, forward passes only (``forward_only``: the harness
never differentiates); Warp caches them under the harness cache (``<cache>/warp``, ``_warp``), so
that a machine compiles them once and emptying the harness cache empties them too, unless the
user named a cache of their own (``WARP_CACHE_PATH`` or ``warp.config.kernel_cache_dir``).
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass
from collections.abc import Callable

import numpy as np

from scenarios import Scene

from .._engine import Engine, EngineVersions, quiet_fds
from .._mode import EngineMode
from .._model import SteppedModel
from . import bench

#: The releases this adapter supports: the 1.x solver constructors (SolverSemiImplicit's
#: ``enable_tri_contact``, SolverXPBD's ``iterations``, SolverVBD's ``iterations``) and
#: ``ModelBuilder(gravity=...)``; measured on 1.8.0 with warp-lang 1.19.0.
VERSIONS = EngineVersions(low="1.8", below="2", tested=("1.8.0",))

#: Our mode name -> what it selects in Newton: the solver class in ``newton.solvers``.
MODES = {
    "semi_implicit": "SolverSemiImplicit",
    "xpbd": "SolverXPBD",
    "vbd": "SolverVBD",
    "featherstone": "SolverFeatherstone",
}

#: Newton's own defaults for the iterative solvers, kept and recorded (at each of them the unit
#: spring is implicit Euler: one constraint, solved exactly by the first iteration).
XPBD_ITERATIONS = 2
VBD_ITERATIONS = 10

#: Larger than any state a run can reach before the harness calls it diverged.
MAX_VELOCITY = 1e30

#: The subfolder of the harness cache that holds Warp's compiled kernels.
WARP_CACHE = "warp"

_STYLE3D = (
    "Style3D's cloth is an anisotropic triangle membrane with bending edges (tri_aniso_ke) under its own "
    "projective-dynamics solve; it reads no particle springs, so no scene's springs can be posed"
)

UNSUPPORTED_ALL = {
    "kepler": "Newton has no central 1/r^2 force (a force applied from Python each step would be ours, not Newton's)",
    "solar_system": "Newton has no N-body gravity between particles or bodies",
    "projectile": "Newton has no quadratic drag on a particle or body (its triangle drag acts on cloth faces)",
    "rope": "a hinge chain of point masses: not posed yet (one revolute joint per link in an articulation, its "
    "relative angles mapped to the scene's Cartesian state)",
    "cloth_flex": "MuJoCo's flex membrane: Newton's triangles are another membrane law (tri_ke, tri_ka), not the "
    "same model",
    "penalty_ball": "the reference schemes' contact, a spring-dashpot under x = 0: Newton's own contact poses a "
    "ball in harness contact (adapters/newton/contact.py)",
}

#: Why a particle or maximal-coordinate solver runs no model file: the file's joints are the
#: scene's coordinates, and these solvers step free bodies held together (module docstring).
_MODEL_MAXIMAL = {
    "semi_implicit": "SolverSemiImplicit steps each body free in maximal coordinates, its joints penalty springs "
    "(joint_attach_ke 1e4), and applies no joint armature: not the file's joint coordinates",
    "xpbd": "SolverXPBD steps each body free, its joints relaxed positional constraints, and applies no joint "
    "armature or passive joint damping: not the file's joint coordinates",
    "vbd": "SolverVBD steps each body free, its joints augmented penalty constraints, and applies no passive joint "
    "damping: not the file's joint coordinates",
}

_PENDULUM_MAXIMAL = {
    "semi_implicit": "SolverSemiImplicit steps bodies in maximal coordinates and holds a revolute joint by penalty "
    "springs (joint_attach_ke 1e4, joint_attach_kd 1e2): not the pendulum's one coordinate",
    "xpbd": "SolverXPBD holds a revolute joint as a relaxed positional constraint on a free body "
    "(joint_linear_relaxation 0.7, joint_angular_relaxation 0.4): not the pendulum's one coordinate",
    "vbd": "SolverVBD holds a revolute joint as an augmented penalty constraint on a free body: not the "
    "pendulum's one coordinate",
}

UNSUPPORTED = {
    mode: {**UNSUPPORTED_ALL, "pendulum": _PENDULUM_MAXIMAL[mode], "model": _MODEL_MAXIMAL[mode]}
    for mode in ("semi_implicit", "xpbd", "vbd")
}
UNSUPPORTED["featherstone"] = dict(UNSUPPORTED_ALL)

#: The modes that step articulations in joint coordinates: they pose a scene on a joint where its pose
#: has one, else as particles (module docstring); the others pose particles only.
ARTICULATED = ("featherstone",)


def _warp(newton):
    """Warp, started quietly, its kernel cache under the harness cache unless the user named one
    (``WARP_CACHE_PATH``, ``warp.config.kernel_cache_dir``), and Newton's kernels set to compile
    forward only (``forward_only``)."""
    import warp as wp

    # Warp resolves kernel_cache_dir to a path when it starts: None means neither started nor
    # named by the user.
    if wp.config.kernel_cache_dir is None and "WARP_CACHE_PATH" not in os.environ:
        from reference import kernel_cache_dir

        wp.config.kernel_cache_dir = str(kernel_cache_dir().parent / WARP_CACHE)
    wp.config.log_level = wp.LOG_WARNING  # no line per module loaded or compiled
    with quiet_fds():
        wp.init()  # nothing where Warp has started
    forward_only(wp, newton)
    return wp


def forward_only(wp, newton) -> None:
    """Newton's Warp modules compile their kernels without their backward (adjoint) passes: the
    harness never differentiates a step, and Warp compiles a whole module, backward passes
    included, at the first launch of any of its kernels. The forward code is the same either way
    (the same states bit for bit, ``tests/test_newton.py``). A Warp module takes Warp's default
    when it is created, and Newton imports a solver's kernels when the solver is first asked for:
    the default is set off for the modules created from now on (the harness runs no Warp code that
    differentiates), and the option on every module of Newton's created before, each only where
    not set yet (setting one marks the module changed, to be compiled again)."""
    wp.config.enable_backward = False
    prefix = newton.__name__ + "."
    modules = {
        id(k.module): k.module
        for name, python_module in list(sys.modules.items())
        if python_module is not None and (name == newton.__name__ or name.startswith(prefix))
        for k in list(vars(python_module).values())
        if isinstance(k, wp.Kernel)
    }
    for module in modules.values():
        if wp.get_module_options(module).get("enable_backward") is not False:
            wp.set_module_options({"enable_backward": False}, module=module)


#: The spring's anchor, in amplitudes from the origin. The stability measure's finite horizon calls
#: a run stable while its size stays within 10 times the true solution's
#: (``harness.measures.stability.GROWTH``), so the model must be the linear spring that far out:
#: twice that. Near its limit an integrator's orbit is far larger than the true one (semi-implicit
#: Euler's reaches 1/sqrt(1 - (h omega / 2)^2) of it in x): with the anchor at twice the amplitude,
#: semi-implicit Euler's mass passed it from h omega = sqrt(3) on, and the spring pushed it on
#: instead of back, a limit of the model (1.73), not of the integrator (2). Float32 keeps the
#: spring's length (s + x) to 2^-24 of s: the identities stay within a sixth of their tolerance
#: (``harness.measures.identify.FLOAT32_MATCH_RTOL``; measured in tests/test_newton.py).
REACH = 20.0


def spring_rest(scene: Scene) -> float:
    """The spring's rest length, its anchor at x = -rest: ``REACH`` times the amplitude
    sqrt(x0^2 + m v0^2 / k), at least ``REACH``."""
    p = scene.values
    return rest_length(p["m"], p["k"], p["x0"], p["v0"])


def rest_length(m: float, k: float, x0: float, v0: float) -> float:
    """``spring_rest`` of the spring of mass m and stiffness k from (x0, v0)."""
    return REACH * max(math.sqrt(x0**2 + m * v0**2 / k), 1.0)


def _spring_particles(scene: Scene):
    """(positions, velocities, masses, springs (a, b, k, c, rest), gravity) of the spring scenes."""
    p = scene.values
    rest = spring_rest(scene)
    x = np.array([[-rest, 0.0, 0.0], [p["x0"], 0.0, 0.0]])
    v = np.array([[0.0, 0.0, 0.0], [p["v0"], 0.0, 0.0]])
    springs = ([0], [1], [p["k"]], [p.get("c", 0.0)], [rest])
    return x, v, np.array([0.0, p["m"]]), springs, (0.0, 0.0, 0.0)


def chain_spacing(scene: Scene) -> float:
    """The chain's rest spacing: twice the largest displacement the initial state carries (a
    spring of the undamped chain stretches at most sqrt(2) x0), at least 1."""
    return 2.0 * max(abs(scene.values["x0"]), 1.0)


def _chain_rest(scene: Scene) -> np.ndarray:
    """Rest x of the walls and the N particles: wall, 0 .. N-1, wall, centred on the origin."""
    n = scene.values["N"]
    return (np.arange(-1, n + 1) - (n - 1) / 2.0) * chain_spacing(scene)


def _chain_particles(scene: Scene):
    p = scene.values
    n, s = p["N"], chain_spacing(scene)
    rest = _chain_rest(scene)
    q0, v0 = scene.initial_state()
    x = np.zeros((n + 2, 3))
    v = np.zeros((n + 2, 3))
    x[:, 0] = rest
    x[1:-1, 0] += q0
    v[1:-1, 0] = v0
    mass = np.full(n + 2, float(p["m"]))
    mass[0] = mass[-1] = 0.0
    a = np.arange(n + 1)
    springs = (a, a + 1, np.full(n + 1, float(p["k"])), np.full(n + 1, float(p["c"])), np.full(n + 1, s))
    return x, v, mass, springs, (0.0, 0.0, 0.0)


def _cloth_particles(scene: Scene):
    n, m, d = scene.grid
    x = np.zeros((n * m, 3))
    x[:, :d] = scene.rest_positions()
    mass = np.zeros(n * m)
    free = scene._free_index()
    mass[free] = scene.node_mass
    a, b, k, rest = scene.springs()
    gravity = [0.0, 0.0, 0.0]
    gravity[d - 1] = -scene.values["g"]
    return x, np.zeros_like(x), mass, (a, b, k, np.zeros_like(k), rest), tuple(gravity)


def _spring_put(model, scene: Scene, x, u, q, v) -> None:
    # As a model built at this state: its anchor and rest length follow the amplitude
    # (spring_rest), and in float32 another anchor rounds the spring's length otherwise.
    p = scene.values
    rest = rest_length(p["m"], p["k"], float(q[0]), float(v[0]))
    x[0] = (-rest, 0.0, 0.0)
    x[1] = (q[0], 0.0, 0.0)
    u[1] = (v[0], 0.0, 0.0)
    model.spring_rest_length.assign(np.asarray([rest], dtype=np.float32))


def _spring_read(scene: Scene, x, u):
    return np.array([x[1, 0]]), np.array([u[1, 0]])


def _chain_put(model, scene: Scene, x, u, q, v) -> None:
    x[:, 0] = _chain_rest(scene)
    x[1:-1, 0] += q
    u[1:-1, 0] = v


def _chain_read(scene: Scene, x, u):
    return x[1:-1, 0] - _chain_rest(scene)[1:-1], u[1:-1, 0].copy()


def _sheet_put(model, scene: Scene, x, u, q, v) -> None:
    n, m, d = scene.grid
    free = scene._free_index()
    x[free, :d] = q.reshape(-1, d)
    u[free, :d] = v.reshape(-1, d)


def _sheet_read(scene: Scene, x, u):
    d = scene.grid[2]
    free = scene._free_index()
    return x[free, :d].ravel(), u[free, :d].ravel()


@dataclass(frozen=True)
class ParticlePose:
    """How a scene is particles and springs: ``particles(scene) -> (x, v, mass, springs, gravity)``,
    ``put(model, scene, x, u, q, v)`` writes the scene's state into the particle arrays (and what
    of the model follows it), ``read(scene, x, u) -> (q, v)`` reads it back."""

    particles: Callable
    put: Callable
    read: Callable


_SPRING = ParticlePose(_spring_particles, _spring_put, _spring_read)
_SHEET = ParticlePose(_cloth_particles, _sheet_put, _sheet_read)
_CHAIN = ParticlePose(_chain_particles, _chain_put, _chain_read)


def _revolute(builder, wp, p) -> None:
    body = builder.add_link(com=wp.vec3(0.0, 0.0, -p["L"]), mass=p["m"], inertia=wp.mat33(np.zeros((3, 3))))
    builder.add_joint_revolute(-1, body, axis=(0.0, 1.0, 0.0), stiffness=0.0, damping=0.0, armature=0.0)


def _prismatic(builder, wp, p) -> None:
    body = builder.add_link(mass=p["m"], inertia=wp.mat33(np.eye(3)))
    builder.add_joint_prismatic(
        -1, body, axis=(1.0, 0.0, 0.0), stiffness=p["k"], rest_q=0.0, damping=p.get("c", 0.0), armature=0.0
    )


@dataclass(frozen=True)
class JointPose:
    """How a scene is one body on one joint of the world: ``what`` (in words, each run's ``model``
    setting), ``gravity(params)`` and ``add(builder, wp, params)`` its body and joint."""

    what: str
    gravity: Callable | None
    add: Callable | None


_PRISMATIC = JointPose(
    "one body of mass m on a prismatic joint along x, joint stiffness k at rest 0, joint damping c",
    lambda p: (0.0, 0.0, 0.0),
    _prismatic,
)
_REVOLUTE = JointPose(
    "a point mass m at L below a revolute joint about y (inertia zero), gravity g along -z",
    lambda p: (0.0, 0.0, -p["g"]),
    _revolute,
)
#: A model file's joints, as Newton's loaders build them (``_FileModel``).
_FILE_JOINTS = JointPose("the file as Newton's own loaders build it (adapters/newton/model.py)", None, None)


def _solver(newton, mode: str, model):
    """The mode's solver with every perturbing default off (module docstring) and its settings."""
    solvers = newton.solvers
    if mode == "semi_implicit":
        return (
            solvers.SolverSemiImplicit(model, angular_damping=0.0, enable_tri_contact=False),
            {"angular_damping": 0.0, "enable_tri_contact": False},
        )
    if mode == "xpbd":
        return solvers.SolverXPBD(model, iterations=XPBD_ITERATIONS), {"iterations": XPBD_ITERATIONS}
    if mode == "vbd":
        return (
            solvers.SolverVBD(model, iterations=VBD_ITERATIONS, particle_enable_self_contact=False),
            {"iterations": VBD_ITERATIONS, "particle_enable_self_contact": False},
        )
    return (
        solvers.SolverFeatherstone(model, angular_damping=0.0, update_mass_matrix_interval=1),
        {"angular_damping": 0.0, "update_mass_matrix_interval": 1},
    )


class _Model(SteppedModel):
    """A Newton model of the scene, its solver and two states (module docstring)."""

    settable = True

    def __init__(self, newton, mode: str, scene: Scene, dt: float):
        self.wp = _warp(newton)
        self.newton, self.mode, self.scene, self.dt = newton, mode, scene, dt
        self.pose = POSES[scene.kind]
        self.joint = mode in ARTICULATED and self.pose.joint is not None
        with quiet_fds():
            if self.joint:
                model, settings = self._joint_model(newton, scene)
            else:
                model, settings = self._particle_model(newton, mode, scene)
            self.model = model
            self.solver, solver_settings = _solver(newton, mode, model)
            self.s0, self.s1 = model.state(), model.state()
            self.control = model.control()
        self.set_state(*scene.initial_state())
        self.settings = {
            "solver": MODES[mode],
            "precision": "float32",
            "device": str(model.device),
            **solver_settings,
            **settings,
            "gravity": [float(g) for g in model.gravity.numpy().reshape(-1, 3)[0]],
            "engine_loop": "solver.step from Python, one call a step (warp captures graphs on CUDA "
            "devices only: none on the CPU)",
        }

    # -------------------------------------------------------------- building
    def _particle_model(self, newton, mode: str, scene: Scene):
        x, v, mass, (a, b, k, c, rest), gravity = self.pose.particles.particles(scene)
        builder = newton.ModelBuilder(gravity=gravity)
        for i in range(len(mass)):
            builder.add_particle(
                tuple(float(z) for z in x[i]), tuple(float(z) for z in v[i]), float(mass[i]), radius=0.0
            )
        for t in range(len(a)):
            builder.add_spring(int(a[t]), int(b[t]), float(k[t]), float(c[t]), 0.0)
        if mode == "vbd":
            builder.color()  # SolverVBD refuses a model without particle colour groups
        model = builder.finalize(device="cpu")
        # add_spring takes the rest length from the particles' initial distance: the scene's instead.
        model.spring_rest_length.assign(np.asarray(rest, dtype=np.float32))
        model.particle_grid = None  # no particle-particle contact pass
        model.particle_max_velocity = MAX_VELOCITY
        self.n_particles = len(mass)
        self.free = np.flatnonzero(mass > 0.0)
        settings = {
            "model": f"{len(mass)} particles ({len(self.free)} free), {len(a)} particle springs, no "
            f"triangles, no bodies",
            "particle_radius": float(model.particle_max_radius),
            "particle_grid": None,
            "particle_max_velocity": float(model.particle_max_velocity),
            "spring_rest_length": [float(z) for z in model.spring_rest_length.numpy()[:1]]
            + (["..."] if model.spring_count > 1 else []),
            "spring_damping": float(np.max(c)) if len(c) else 0.0,
            "triangles": int(model.tri_count),
        }
        return model, settings

    def _joint_model(self, newton, scene: Scene):
        p = scene.values
        wp = self.wp
        what, gravity, add = self.pose.joint.what, self.pose.joint.gravity, self.pose.joint.add
        builder = newton.ModelBuilder(gravity=gravity(p))
        add(builder, wp, p)
        builder.add_articulation([builder.joint_count - 1])
        # finalize's inertia check raises the point mass's zero inertia to 1e-6 (its joint mass
        # then m L^2 + 1e-6): skipped, so the pendulum's is m L^2.
        model = builder.finalize(device="cpu", skip_validation_inertia=True)
        settings = {
            "model": what,
            "joint_stiffness": [float(z) for z in model.joint_stiffness.numpy()],
            "joint_damping": [float(z) for z in model.joint_damping.numpy()],
            "joint_armature": [float(z) for z in model.joint_armature.numpy()],
            "joint_limits": "none (Newton's default +-MAXVAL)",
            "body_inertia": [float(z) for z in model.body_inertia.numpy().ravel()[[0, 4, 8]]],
            "inertia_validation": "skipped (it raises a zero inertia to 1e-6)",
        }
        return model, settings

    # -------------------------------------------------------------- state
    def set_state(self, q: np.ndarray, v: np.ndarray) -> None:
        q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
        if self.joint:
            self.s0.joint_q.assign(q.astype(np.float32))
            self.s0.joint_qd.assign(v.astype(np.float32))
            self.newton.eval_fk(self.model, self.s0.joint_q, self.s0.joint_qd, self.s0)
            return
        x = self.s0.particle_q.numpy().astype(float)
        u = np.zeros_like(x)
        self.pose.particles.put(self.model, self.scene, x, u, q, v)
        self.s0.particle_q.assign(x.astype(np.float32))
        self.s0.particle_qd.assign(u.astype(np.float32))

    def state(self):
        if self.joint:
            return (self.s0.joint_q.numpy().astype(float), self.s0.joint_qd.numpy().astype(float))
        x = self.s0.particle_q.numpy().astype(float)
        u = self.s0.particle_qd.numpy().astype(float)
        return self.pose.particles.read(self.scene, x, u)

    # -------------------------------------------------------------- stepping
    def steps(self, n: int) -> None:
        step, s0, s1, control, dt = self.solver.step, self.s0, self.s1, self.control, self.dt
        for _ in range(n):
            s0.clear_forces()
            step(s0, s1, control, None, dt)
            s0, s1 = s1, s0
        self.s0, self.s1 = s0, s1

    def advance(self) -> None:
        self.steps(1)

    def evaluations(self):
        return None, "Newton's solvers count no force evaluations"


class _FileModel(_Model):
    """A model file (``harness model``) as Newton's loaders build it, stepped by SolverFeatherstone
    in the joint coordinates; its coordinates mapped to the scene's by joint name and its anatomy
    read back from the model and the solver (``adapters/newton/model.py``)."""

    def _joint_model(self, newton, scene: Scene):
        from . import model as _newton_model

        model, gravity, self._facts = _newton_model.build_model(newton, scene)
        self._names = list(scene.dof_names)
        self._index, self._offset, self._angular = _newton_model.coordinates(model, self._names, self._facts)
        return model, _newton_model.settings(model, self._facts)

    def set_state(self, q: np.ndarray, v: np.ndarray) -> None:
        n = self.model.joint_coord_count
        full_q, full_v = np.zeros(n), np.zeros(n)
        # Newton's coordinate is MuJoCo's qpos less the joint's ref (its qpos0).
        full_q[self._index] = np.asarray(q, dtype=float) - self._offset
        full_v[self._index] = np.asarray(v, dtype=float)
        super().set_state(full_q, full_v)

    def state(self):
        q, v = super().state()
        return q[self._index] + self._offset, v[self._index]

    def anatomy(self) -> dict:
        """What Newton built, at the model's current state: one step from it into a scratch state
        fills SolverFeatherstone's mass matrix and motion subspaces (the state itself unchanged)."""
        from . import model as _newton_model

        scratch = self.model.state()
        with quiet_fds():
            self.s0.clear_forces()
            self.solver.step(self.s0, scratch, self.control, None, self.dt)
        return _newton_model.anatomy(
            self.model, self.solver, self._index, self._offset, self._angular, self._names, self._facts
        )


@dataclass(frozen=True)
class Pose:
    """How Newton poses one scene: as particles and particle springs (``particles``: every solver),
    on a joint of an articulation (``joint``: the modes of ``ARTICULATED``, which take it where a
    scene has both), and the model class that builds it (a model file's own)."""

    particles: ParticlePose | None = None
    joint: JointPose | None = None
    model: type = _Model


#: How Newton poses each scene it poses; a new scene is one entry here.
POSES = {
    "spring": Pose(_SPRING, _PRISMATIC),
    "damped_spring": Pose(_SPRING, _PRISMATIC),
    "pendulum": Pose(joint=_REVOLUTE),
    "chain": Pose(_CHAIN),
    "cloth": Pose(_SHEET),
    "net": Pose(_SHEET),
    "model": Pose(joint=_FILE_JOINTS, model=_FileModel),
}


def scenes(mode: str) -> tuple[str, ...]:
    """The scenes ``mode`` poses: those with particles, and for an articulated mode those on a joint."""
    return tuple(
        kind
        for kind, pose in POSES.items()
        if pose.particles is not None or (mode in ARTICULATED and pose.joint is not None)
    )


def build(newton, mode: str, scene: Scene, dt: float, count: bool = False) -> _Model:
    """``count`` changes nothing: Newton counts no force evaluations."""
    return POSES[scene.kind].model(newton, mode, scene, dt)


def has_mode(mode: str):
    """Whether the imported Newton has the mode's solver class."""

    def present(newton) -> bool:
        return hasattr(newton.solvers, MODES[mode])

    return present


_DOCS = {
    "semi_implicit": """semi-implicit Euler (velocity first, then position with the new velocity), float32
        Measured: ref:semi_implicit_euler to 4.2e-7 on the spring, 1.6e-7 on the damped spring
        (damping explicit), 3.3e-3 of |v| <= 200 on the chain (float32 rounding throughout).""",
    "xpbd": """implicit Euler on a linear spring (XPBD's compliant constraint solved exactly), float32
        Measured: ref:implicit_euler to 3.8e-6 on the spring and 2.0e-6 on the damped spring (float32
        rounding; 1, 2 and 10 iterations alike); on the chain and the cloth no scheme.""",
    "vbd": """implicit Euler on a linear spring (vertex block descent: one Newton step per vertex), float32
        Measured: ref:implicit_euler to 6.3e-6 on the spring and 4.4e-6 on the damped spring (float32
        rounding); on the chain and the cloth no scheme.""",
    "featherstone": """semi-implicit Euler in the joint coordinates (Featherstone's articulated bodies), float32
        Measured: ref:semi_implicit_euler to float32 rounding on the prismatic spring and the pendulum;
        particles (chain, cloth) are integrated as by newton:semi_implicit; a model file (add_urdf,
        add_mjcf) follows mujoco:euler to float32 rounding where Newton builds MuJoCo's model.""",
}

_SWEEPS = (
    "{solver} sweeps the coupled springs {how} and stops after {n} iterations, unconverged: at 100 steps "
    "a period the nearest scheme is {dev}"
)
#: Why a mode matches no reference scheme on a scene, measured (newton 1.8.0, ``harness identify``).
_FLOAT32_CLOTH = (
    "at 100 steps a period of the stiffest mode (h = 1.7e-4 on the default cloth) float32 roundoff, "
    "3.2e-4 of the state (each step adds h v, 1e-4 of a position), is as large as the schemes' "
    "differences: no scheme within 5e-5; a 4 x 4 cloth over 200 steps is semi-implicit Euler to 1.4e-5"
)
_NO_MATCH = {
    "semi_implicit": {"cloth": _FLOAT32_CLOTH},
    "featherstone": {"cloth": _FLOAT32_CLOTH},
    "xpbd": {
        scene: _SWEEPS.format(
            solver="SolverXPBD",
            how="as Jacobi constraint projections",
            n=XPBD_ITERATIONS,
            dev="ref:pbd, 0.20 away on the chain (ref:implicit_euler, 1.8e-2 on the cloth)",
        )
        for scene in ("chain", "cloth")
    },
    "vbd": {
        scene: _SWEEPS.format(
            solver="SolverVBD",
            how="vertex by vertex, colour by colour",
            n=VBD_ITERATIONS,
            dev="ref:implicit_euler, 0.24 away on the chain",
        )
        for scene in ("chain", "cloth")
    },
}

METHODS = {
    f"newton:{mode}": EngineMode(
        engine="newton",
        mode=mode,
        module="newton",
        dist="newton",
        build=build,
        scenes=scenes(mode),
        unsupported=UNSUPPORTED[mode],
        doc=_DOCS[mode],
        versions=VERSIONS,
        present=has_mode(mode),
        precision="float32",
        no_match=_NO_MATCH[mode],
        settings={
            "solver": MODES[mode],
            "precision": "float32",
            "device": "cpu",
            "gravity": "scene's g along the last axis (cloth, net) or -z (pendulum), else zero",
            "particle_radius": 0.0,
            "particle_contact": "off (particle_grid None)",
            "enable_tri_contact": False if mode == "semi_implicit" else None,
            "triangles": "none (tri_ke, tri_kd never enter)",
            "spring_rest_length": "the scene's (add_spring's initial distance replaced)",
            "particle_max_velocity": MAX_VELOCITY,
            "angular_damping": 0.0 if mode in ("semi_implicit", "featherstone") else None,
            "iterations": {"xpbd": XPBD_ITERATIONS, "vbd": VBD_ITERATIONS}.get(mode),
        },
    )
    for mode in MODES
}

#: Style3D is not a mode: it poses no scene (``_STYLE3D``).
NOT_MODES = {"style3d": _STYLE3D}

from . import contact  # noqa: E402  (its contact poses, joined to its entry below)

#: The engine, declared once: ``adapters.ENGINES`` and every list of engines the harness keeps read it.
ENGINE = Engine(
    id="newton",
    module="newton",
    dists=("newton", "warp-lang"),
    versions=VERSIONS,
    methods=METHODS,
    poses=POSES,
    build=build,
    bare_loops=bench.bare_loops,
    model_loader="ModelBuilder.add_urdf / add_mjcf, stepped by SolverFeatherstone",
    loader_without_contact="Newton's model-file loader here runs with contacts off",
    contact_modes=contact.MODES,
)
