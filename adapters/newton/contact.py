"""Newton's contact poses: ``SolverSemiImplicit`` (penalty contact) and ``SolverXPBD`` (contact as
a positional constraint, restitution applied after it), on Warp on the CPU in float32, each in
two contact settings: the controlled comparison (``newton:semi_implicit``, ``newton:xpbd``: one
step a step, contact at MuJoCo's and Drake's poses' stiffness) and Newton's documented practice
(``newton:semi_implicit?contact=default``, ``newton:xpbd?contact=default``).

The bodies are Newton's rigid bodies with collision shapes, each on a free body (``add_body``: a
free joint to the world): the ball and the rolling ball a sphere, each box a box, started at the
scene's centre, orientation (``wp.transform``: Warp's quaternion is (x, y, z, w); the scene's
(w, x, y, z) is reordered), velocity and angular velocity; the ground ``add_ground_plane``.
Newton's collision pipeline (``CollisionPipeline(model)``, its defaults) finds the contacts
before every solver step. A body's state is ``body_q`` (position, then the quaternion (x, y, z,
w), body to world) and ``body_qd`` (the centre's velocity, then the angular velocity, both in
world axes: ``State.body_qd``'s docstring, and SolverXPBD's "(v_com_world, omega_world)
convention"), so a turning pose reads the orientation reordered to (w, x, y, z) and the angular
velocity as it is (tested against a known turn: the tipping box's phi).

* ``semi_implicit``: each contact is a penalty force ``ke d + kd min(vn, 0)`` (d the
  penetration, the damping only while the bodies approach), with regularised Coulomb friction
  ``kf vt`` up to ``mu`` times the normal force; a pair's ke, kd, kf and mu are the means of its
  two shapes', so both shapes are given the same. ke from the contact frequency ``OMEGA_C`` (200
  rad/s, MuJoCo's and Drake's poses' too): ``m omega_c^2`` for a sphere, a quarter of it for a box
  (four corner contacts). With the damping on approach only, a contact entered at speed v
  reaches the depth of a damped oscillator's first maximum and springs back undamped, so
  ``e = exp(-zeta atan(sqrt(1 - zeta^2) / zeta) / sqrt(1 - zeta^2))`` at damping ratio
  ``zeta = kd / (2 m omega_c)``: kd is solved from e (``zeta_for``); e = 1 is kd = 0; a box's
  and the rolling ball's resting contacts are critically damped (zeta = 1); a dropped box's
  (edge, corner) is solved from its e as the ball's (its corner's mass is taken as a quarter of
  the box's), overdamping capped at zeta = 1 (a larger kd is past the explicit step's stability
  at the report steps). kf is Newton's default 1000 (stated). Newton's ShapeConfig defaults
  (ke 2500, kd 100, restitution 0) are replaced.
* ``xpbd``: contact is a constraint projection (``rigid_contact_relaxation`` 0.8, Newton's default,
  ``iterations`` 2): no stiffness and no bounce of its own. The requested e is each shape's
  ``restitution`` (a pair's is their mean), which XPBD applies only with
  ``enable_restitution=True``; Newton's default is False, and its ball then does not bounce
  (measured in docs/engines.md, tested). Friction is the shapes' ``mu``.
* ``?contact=default`` (``DEFAULT_CONTACT``): contact as Newton's documentation sets it. The
  shapes' contact material is ``ModelBuilder.ShapeConfig``'s defaults, read from the installed
  class (newton 1.8.0: ke 2500 N/m, kd 100 N s/m, kf 1000 N s/m, ka 0; ``_src/sim/builder.py``),
  the solvers' keywords their constructors' defaults (SemiImplicit ``angular_damping`` 0.05,
  ``enable_tri_contact`` True; XPBD ``rigid_contact_relaxation`` 0.8,
  ``rigid_contact_restitution_iterations`` 2, ``rigid_contact_con_weighting`` True,
  ``angular_damping`` 0), and the solver step the examples': a harness step of dt is
  ``substeps_for(dt)`` solver steps, as many as keep each within ``SUBSTEP`` = 1/600 s (a 60 fps
  frame in ``SUBSTEPS`` = 10: 10 at 1/60 s as the examples run, 3 at 1/240 s, 1 at 1/1000 s,
  already finer), the collision pipeline run before each ("Examples commonly use frame_dt /
  substeps and call step in a substep loop"; "Calling model.collide or pipeline.collide every
  substep is most robust": docs/concepts/simulation_tuning_solvers.rst, "dt and substeps",
  "Collision frequency", https://newton-physics.github.io/newton/latest/concepts/simulation_tuning_solvers.html;
  ``SUBSTEPS = {"xpbd": 10, ...}`` at ``fps = 60`` in examples/contacts/example_newton_cradle.py,
  example_balance_bird.py, example_domino_spiral.py). Ten substeps of every harness step would
  cut even the finest harness step, 1/1000 s, into tenths, finer than any example. XPBD's
  rigid-contact examples run ``iterations=10`` and, where bodies bounce, ``enable_restitution=True``
  (``SolverXPBD(self.model, iterations=10, enable_restitution=True)`` in example_newton_cradle.py;
  the ``restitution`` field's docstring: "SolverXPBD requires enable_restitution=True on the
  solver constructor for this field to take effect"); SemiImplicit has no iteration count and
  "Examples mostly use constructor defaults" (the same page's solver table). What the scene
  states stays the scene's: its mass and moment, gravity, friction ``mu`` (1 where it has none,
  0 for the frictionless ball), restitution ``e`` on the shapes (SemiImplicit has no restitution:
  its bounce is what ke and kd give, zeta = kd / (2 sqrt(ke m)) = 1 for the 1 kg ball, so
  exp(-1) without gravity and less with it, whatever e is asked: measured in docs/engines.md),
  and no torsional or rolling friction (the poses have none).

Every default that changes the answer is set and stated: gravity (Newton's -9.81 along z is the
scene's g), the shapes' ``margin`` 0 and ``gap`` (Newton's 0.1 m contact detection distance,
kept: contacts are found before touching, as a speculative margin), ``angular_damping`` 0 (both
solvers; SemiImplicit's default 0.05, kept by ``?contact=default``), the shapes' density (a body's
mass is set, its shapes add none: density 0), the torsional and rolling friction 0.

Warp compiles the kernels the run launches, forward only, its cache under the harness cache
(``adapters.newton._warp``). The loop is Newton's: ``pipeline.collide`` and ``solver.step`` from
Python once a substep, the states swapped.
"""

from __future__ import annotations

import functools
import inspect
import math

import numpy as np

from .._contact import BOX, ROLLING_SPHERE, SPHERE, TURNING_BOX, ContactMode, record_loop, timed_loop
from .._engine import import_engine, quiet_fds

#: The contact's natural frequency (rad/s): MuJoCo's and Drake's poses' too.
OMEGA_C = 200.0
#: Newton's own defaults, kept and stated.
FRICTION_GAIN = 1000.0
XPBD_ITERATIONS = 2
CONTACT_RELAXATION = 0.8
SOLVERS = {"semi_implicit": "SolverSemiImplicit", "xpbd": "SolverXPBD"}
#: The contact setting of Newton's documented practice (the modes' ``?contact=`` suffix).
DEFAULT_CONTACT = "default"
#: The examples' frame and its substeps: ``fps = 60``, ``SUBSTEPS["xpbd"] = 10`` in
#: examples/contacts/example_newton_cradle.py and its neighbours, so a solver step of 1/600 s.
FRAME_HZ = 60
SUBSTEPS = 10
#: The documented practice's longest solver step (s): the examples' ``frame_dt / sim_substeps``.
SUBSTEP = 1.0 / (FRAME_HZ * SUBSTEPS)


def substeps_for(dt: float) -> int:
    """The number of solver steps in a harness step of ``dt`` in the documented practice: as many
    as keep each within the examples' ``SUBSTEP`` (10 for a step of 1/60 s, as in the examples; 3
    for 1/240 s; 1 for 1/1000 s, finer already)."""
    return max(1, math.ceil(dt / SUBSTEP - 1e-9))


#: XPBD's iterations in the documented practice: its rigid-contact examples' (example_newton_cradle.py,
#: example_balance_bird.py: ``iterations=10``).
DEFAULT_XPBD_ITERATIONS = 10
#: How Newton poses each contact scene (the scene's kind -> its ``ContactPose``): a free body each, a
#: sphere shape for the ball and the rolling ball, a box shape for each box. A new contact scene is
#: one entry here.
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


def shape_defaults(newton) -> dict:
    """Newton's ``ModelBuilder.ShapeConfig`` contact material defaults, as the installed class has them."""
    cfg = newton.ModelBuilder.ShapeConfig()
    return {
        k: float(getattr(cfg, k)) for k in ("ke", "kd", "kf", "ka", "mu", "restitution", "mu_torsional", "mu_rolling")
    }


def solver_defaults(cls) -> dict:
    """A solver's constructor keywords and their defaults, as the installed class has them."""
    return {
        k: p.default
        for k, p in inspect.signature(cls.__init__).parameters.items()
        if p.default is not inspect.Parameter.empty and p.default is not None
    }


def _material(scene, shape: str, contact: str, newton) -> dict:
    """The shapes' contact material for ``scene`` posed as ``shape`` in the contact setting
    ``contact`` ("omega_c": the controlled comparison; ``DEFAULT_CONTACT``: Newton's defaults)."""
    e = getattr(scene, "e", None)
    mu = 0.0 if shape == "sphere" else float(getattr(scene, "mu", 1.0))
    restitution = float(e) if e is not None and shape in ("sphere", "turning_box") else 0.0
    if contact == DEFAULT_CONTACT:
        d = shape_defaults(newton)
        return {"ke": d["ke"], "kd": d["kd"], "kf": d["kf"], "zeta": None, "restitution": restitution, "mu": mu}
    # A sphere's one contact carries the body; a box's four corners a quarter each.
    share = 1.0 if shape in ("sphere", "rolling_sphere") else 0.25
    if shape == "sphere":
        zeta = zeta_for(restitution)
    elif shape == "turning_box" and e is not None:
        zeta = min(zeta_for(restitution), 1.0)
    else:
        zeta = 1.0
    m = scene.mass * share
    return {
        "ke": m * OMEGA_C**2,
        "kd": 2.0 * zeta * m * OMEGA_C,
        "kf": FRICTION_GAIN,
        "zeta": zeta,
        "restitution": restitution,
        "mu": mu,
    }


def _derived(scene, shape: str, contact: str, mat: dict) -> str:
    if contact == DEFAULT_CONTACT:
        zeta = mat["kd"] / (2.0 * math.sqrt(mat["ke"] * scene.mass))
        return (
            f"Newton's ShapeConfig defaults: a body's contact at omega = sqrt(ke / m) = "
            f"{math.sqrt(mat['ke'] / scene.mass):.4g} rad/s, zeta = kd / (2 sqrt(ke m)) = {zeta:.4g} (one contact); "
            f"SolverSemiImplicit's bounce from them, gravity aside, e = {restitution_of(zeta):.4g}"
        )
    if shape == "sphere":
        return f"e = {scene.e:g} -> damping ratio {mat['zeta']:.6g} (damped on approach only), kd = 2 zeta m omega_c"
    if shape == "rolling_sphere":
        return "a critically damped resting contact, ke = m omega_c^2"
    if shape == "turning_box" and getattr(scene, "e", None) is not None:
        return (
            f"e = {scene.e:g} -> damping ratio {mat['zeta']:.6g} (capped at 1), kd = 2 zeta (m / 4) omega_c, "
            "ke a quarter of m omega_c^2 a corner"
        )
    return "critically damped resting contacts, ke a quarter of m omega_c^2 a corner"


class _Pose:
    def __init__(self, mode: ContactMode, scene, dt: float, enable_restitution: bool = True):
        from . import _warp

        newton = import_engine("newton")
        self.wp = wp = _warp(newton)
        solver_name = mode.settings["solver"]
        contact = mode.settings.get("contact", "omega_c")
        practice = contact == DEFAULT_CONTACT
        self.substeps = substeps_for(dt) if practice else 1
        shape = mode.pose(scene).shape
        self.turns = shape in ("turning_box", "rolling_sphere")
        mat = _material(scene, shape, contact, newton)
        sphere = shape in ("sphere", "rolling_sphere")
        with quiet_fds():
            builder = newton.ModelBuilder(gravity=tuple(float(x) for x in scene.gravity), up_axis=newton.Axis.Z)
            cfg = newton.ModelBuilder.ShapeConfig(
                density=0.0,
                ke=mat["ke"],
                kd=mat["kd"],
                kf=mat["kf"],
                mu=mat["mu"],
                restitution=mat["restitution"],
                mu_torsional=0.0,
                mu_rolling=0.0,
                margin=0.0,
            )
            builder.add_ground_plane(cfg=cfg)
            self.bodies = []
            for centre, (qw, qx, qy, qz) in zip(scene.initial_centres(), scene.initial_orientations()):
                # Warp's quaternion is (x, y, z, w); the scene's (w, x, y, z).
                xform = wp.transform(wp.vec3(*centre), wp.quat(float(qx), float(qy), float(qz), float(qw)))
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
            if solver_name == "semi_implicit" and practice:
                solver = newton.solvers.SolverSemiImplicit(model)
                defaults = solver_defaults(newton.solvers.SolverSemiImplicit)
                solver_settings = {k: defaults[k] for k in ("angular_damping", "enable_tri_contact")}
            elif solver_name == "semi_implicit":
                solver = newton.solvers.SolverSemiImplicit(model, angular_damping=0.0, enable_tri_contact=False)
                solver_settings = {"angular_damping": 0.0, "enable_tri_contact": False}
            elif practice:
                solver = newton.solvers.SolverXPBD(
                    model, iterations=DEFAULT_XPBD_ITERATIONS, enable_restitution=enable_restitution
                )
                defaults = solver_defaults(newton.solvers.SolverXPBD)
                solver_settings = {
                    "iterations": DEFAULT_XPBD_ITERATIONS,
                    "enable_restitution": enable_restitution,
                    **{
                        k: defaults[k]
                        for k in (
                            "rigid_contact_relaxation",
                            "rigid_contact_restitution_iterations",
                            "rigid_contact_con_weighting",
                            "angular_damping",
                        )
                    },
                }
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
            velocities, spins = scene.initial_velocities(), scene.initial_angular_velocities()
            if any(any(v) for v in velocities) or any(any(w) for w in spins):
                qd = self.s0.body_qd.numpy()
                for i, (v, w) in enumerate(zip(velocities, spins)):
                    qd[i, :3] = v  # the centre's velocity, world axes
                    qd[i, 3:] = w  # the angular velocity, world axes
                self.s0.body_qd.assign(qd)
        self.model, self.solver, self.dt, self.scene = model, solver, dt, scene
        self.h = dt / self.substeps
        shape_name = {"sphere": "sphere", "rolling_sphere": "sphere", "box": "box", "turning_box": "box"}[shape]
        self.settings = {
            "solver": SOLVERS[solver_name],
            "precision": "float32",
            "device": "cpu",
            "contact": "Newton's documented defaults" if practice else f"stiff, omega_c = {OMEGA_C:g} rad/s",
            "substeps": self.substeps,
            "solver dt (s)": self.h,
            **solver_settings,
            "model": (
                f"{len(self.bodies)} free body(ies), a {shape_name} shape each "
                "(density 0, the body's mass and inertia set), add_ground_plane"
            ),
            "gravity": [float(x) for x in scene.gravity],
            "shape material (both shapes)": {
                "ke": mat["ke"],
                "kd": mat["kd"],
                "kf": mat["kf"],
                "mu": mat["mu"],
                "restitution": mat["restitution"],
                "mu_torsional": 0.0,
                "mu_rolling": 0.0,
                "margin": 0.0,
                "gap": float(model.shape_gap.numpy()[0]),
            },
            "used": (
                "ke, kd, kf, mu (penalty)"
                if solver_name == "semi_implicit"
                else "restitution, mu (constraint projection; ke, kd, kf unused)"
            ),
            "derived": _derived(scene, shape, contact, mat),
            "engine_loop": (
                f"pipeline.collide then solver.step from Python, {self.substeps} of each a step"
                if practice
                else "pipeline.collide then solver.step from Python, one call each a step"
            ),
        }
        if practice:
            self.settings["source"] = _SOURCES[solver_name]
        else:
            self.settings["contact omega_c (rad/s)"] = OMEGA_C

    def step(self) -> None:
        for _ in range(self.substeps):
            s0 = self.s0
            s0.clear_forces()
            self.pipeline.collide(s0, self.contacts)
            self.solver.step(s0, self.s1, self.control, self.contacts, self.h)
            self.s0, self.s1 = self.s1, s0

    def read(self):
        q = self.s0.body_q.numpy().astype(float)
        qd = self.s0.body_qd.numpy().astype(float)
        if self.turns:
            # body_q is (position, x, y, z, w); body_qd's angular half is in world axes already.
            return q[:, :3].copy(), qd[:, :3].copy(), q[:, [6, 3, 4, 5]].copy(), qd[:, 3:6].copy()
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
            loop=(
                f"{pose.substeps} x (pipeline.collide + solver.step) a step, from Python"
                if pose.substeps > 1
                else "pipeline.collide + solver.step, once a step from Python"
            ),
            time_again=time_again,
        )
    return out


_DOCS_PAGE = (
    "https://newton-physics.github.io/newton/latest/concepts/simulation_tuning_solvers.html "
    "(docs/concepts/simulation_tuning_solvers.rst: 'dt and substeps', 'Collision frequency', the solver table)"
)
#: Where Newton's documentation sets each solver's contact (the ``?contact=default`` modes' ``source``).
_SOURCES = {
    "semi_implicit": (
        "ShapeConfig defaults (newton/_src/sim/builder.py, ModelBuilder.ShapeConfig: ke 2.5e3, kd 100, kf 1000); "
        "SolverSemiImplicit's constructor defaults ('Examples mostly use constructor defaults'); "
        f"substeps of at most 1/{FRAME_HZ * SUBSTEPS} s (a {FRAME_HZ} fps frame in {SUBSTEPS}), collide each: "
        f"{_DOCS_PAGE}"
    ),
    "xpbd": (
        "SolverXPBD(model, iterations=10, enable_restitution=True) with SUBSTEPS['xpbd'] = 10 a 60 fps frame: "
        "newton/examples/contacts/example_newton_cradle.py (iterations=10 also example_balance_bird.py); "
        "enable_restitution: ShapeConfig.restitution's docstring ('SolverXPBD requires enable_restitution=True'); "
        f"the other keywords the constructor's defaults; collide each substep: {_DOCS_PAGE}"
    ),
}

_DOC = {
    "semi_implicit": "Newton's SolverSemiImplicit on Warp (CPU, float32); penalty contact ke, kd from e",
    "xpbd": "Newton's SolverXPBD on Warp (CPU, float32); contact a constraint, restitution e enabled",
    f"semi_implicit?contact={DEFAULT_CONTACT}": (
        "Newton's SolverSemiImplicit as its documentation sets contact: ShapeConfig's default ke 2500, kd 100, "
        "kf 1000 (no restitution of its own), the constructor's defaults (angular_damping 0.05), substeps of at "
        "most the examples' 1/600 s with collide each"
    ),
    f"xpbd?contact={DEFAULT_CONTACT}": (
        "Newton's SolverXPBD as its contact examples set it: iterations 10, enable_restitution, the other "
        "keywords' defaults (rigid_contact_relaxation 0.8), substeps of at most the examples' 1/600 s with collide "
        "each"
    ),
}


def _mode(name: str, contact: str | None) -> ContactMode:
    mode = name if contact is None else f"{name}?contact={contact}"
    settings = {"solver": name, "precision": "float32", "device": "cpu"}
    if contact is not None:
        settings.update(contact=contact, substep=SUBSTEP)
    return ContactMode("newton", mode, "newton", run, poses=POSES, settings=settings, doc=_DOC[mode])


MODES = {
    f"newton:{m.mode}": m for m in (_mode(name, contact) for contact in (None, DEFAULT_CONTACT) for name in SOLVERS)
}
