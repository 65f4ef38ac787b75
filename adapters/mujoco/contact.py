"""MuJoCo's contact poses, in each integrator and each friction cone, with three contacts:

* ``mujoco:<integrator>`` (and ``?cone=elliptic``), the controlled comparison: a stiff contact of
  one frequency at every step. solref is given directly as (-stiffness, -damping) =
  (-omega_c^2, -2 zeta omega_c) with a constant impedance d (solimp dmin = dmax = 0.9999): inside
  the contact the normal acceleration is then ``-(1 - d) g - b v - k r`` (r the penetration), a
  spring-dashpot of frequency ``omega_c = sqrt(k)`` and damping ratio ``zeta = b / (2 omega_c)``,
  whatever the mass, with gravity all but removed while touching. The requested restitution gives
  zeta by the linear spring-dashpot's ``e = exp(-pi zeta / sqrt(1 - zeta^2)``, or 1 (a resting
  contact) where the scene asks none; omega_c is ``OMEGA_C``. Newton solver, 100 iterations,
  tolerance 1e-10.
* ``mujoco:<integrator>?contact=default`` (and ``?cone=elliptic&contact=default``), the contact as
  MuJoCo's documentation tells a user to set it (``DEFAULT_DOCS``): every contact and solver
  setting at MuJoCo's default, read back from the compiled model: solref (0.02, 1) in the
  (timeconst, dampratio) format, solimp (0.9, 0.95, 0.001, 0.5, 2), the ``refsafe`` flag on (it
  raises timeconst to 2 steps where two steps exceed it), margin 0, Newton with 100
  iterations at tolerance 1e-8, impratio 1, no noslip. A critically damped contact of
  ``omega_c = 1 / (timeconst dampratio)`` at d = d_width: 50 rad/s while two steps are within the
  timeconst, 1 / (2 h) beyond. A scene that asks restitution e (the ball, the dropped boxes) gets
  the documentation's restitution recipe (modeling.rst, "Restitution"): the direct format with the
  example's stiffness, solref (-1000, -damping), damping = 2 zeta sqrt(1000) (the documentation's
  own equivalence of dampratio and damping, zeta from e as above): omega_c = sqrt(1000) =
  31.6 rad/s at every step. The other recipe it names, dampratio < 1 at the default timeconst, is a
  contact of 1 / (timeconst dampratio), 706 rad/s at e = 0.8, which refsafe does not bound.
* ``mujoco:<integrator>?cone=elliptic&contact=practice``, the contact as MuJoCo's documentation
  ADVISES a user to set it where its defaults slip (``PRACTICE_DOCS``): the default contact's solref,
  solimp and refsafe (and its restitution recipe where e is asked), with the elliptic cone, impratio
  ``PRACTICE_IMPRATIO`` (10: "large impratio"; the value of MuJoCo's own elliptic example models) and
  the Newton solver at tolerance ``PRACTICE_TOLERANCE`` (1e-10, "aggressive tolerance values, say
  1e-10"); the NoSlip solver off (``PRACTICE_NOSLIP``): the documentation names elliptic cones, a
  large impratio and Newton "the recommended way of reducing slip", NoSlip a fallback "if that is not
  sufficient" that leaves the convex problem and "may become less robust". The practice is the
  elliptic cone's alone (impratio is "not recommended" with pyramidal cones), so it has no pyramidal
  mode, and its id names the cone.

Each scene is the smallest model that poses its question: the ball on one slide joint along z
(``condim=1``, a frictionless normal contact: it only moves up and down); the sliding box, the box
at rest and the stack on free joints (friction, tipping and lateral drift are the question); the
turning boxes and the rolling ball on free joints, started at the scene's orientation (MuJoCo's
quaternions are (w, x, y, z), body to world, as the scenes') and angular velocity (a free joint's
angular velocity, qvel[3:6], is in the body's axes: the scene's world one is turned into them,
and the record turned back). Every geom has its mass given (MuJoCo's solid inertia: a cube's
2/3 m half^2, a sphere's 2/5 m r^2), and the solver's iterations are checked against its cap after
every step.
"""

from __future__ import annotations

import math

import numpy as np

from scenarios.penalty_ball import zeta_for

from .._contact import BOX, ROLLING_SPHERE, SPHERE, TURNING_BOX, ContactMode, record_loop, timed_loop
from .._engine import import_engine
from . import MODES as INTEGRATORS  # MuJoCo's integrators: each smooth mode's, posed in each cone

CONES = ("pyramidal", "elliptic")
#: The contacts each integrator is posed with, and the cones each is posed in: the stiff common one
#: and MuJoCo's default in both; the documentation's advice against slip in the elliptic cone alone.
CONTACTS = {"stiff": CONES, "default": CONES, "practice": ("elliptic",)}
#: The contact's natural frequency (rad/s): a static penetration of g / omega_c^2 = 0.25 mm under
#: gravity; a contact pi / omega_c long, which a 60 Hz step (h omega_c = 3.3) does not
#: resolve and a 1 kHz step (0.2) does.
OMEGA_C = 200.0
#: The constant impedance (solimp dmin = dmax): 1 - d of gravity acts inside the contact.
IMPEDANCE = 0.9999
SOLVER_ITERATIONS = 100
SOLVER_TOLERANCE = 1e-10

#: MuJoCo's defaults, as its documentation states them (each read back from the compiled model in
#: a run's settings): solref (timeconst, dampratio), solimp (d0, d_width, width, midpoint, power).
DEFAULT_SOLREF = (0.02, 1.0)
DEFAULT_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)
#: The documentation's restitution recipe: the direct format's stiffness in its example of a
#: bouncing sphere (modeling.rst, "Restitution": solref="-1000 0" for e = 1).
RESTITUTION_STIFFNESS = 1000.0
#: Where the documentation says each default contact setting (MuJoCo's docs, mujoco.readthedocs.io).
DEFAULT_DOCS = (
    "mujoco.readthedocs.io/en/latest/modeling.html#solver-parameters: solref (0.02, 1) and solimp "
    "(0.9, 0.95, 0.001, 0.5, 2) are the defaults; 'The timeconst parameter should be at least two times larger "
    "than the simulation time step ... This is enforced internally, unless the refsafe attribute ... is set to "
    "false. The dampratio parameter would normally be set to 1, corresponding to critical damping'; 'A dampratio "
    "of 1 in the positive-value format is equivalent to damping = 2 sqrt(stiffness) in the direct format'. "
    "XMLreference.html#option-flag-refsafe: 'the solver uses max(solref[0], 2*timestep) in place of solref[0]'. "
    "modeling.html#restitution: 'To achieve perfect restitution for contacts ... set stiffness to some reasonably "
    'large value and damping to zero\', its example solref="-1000 0". XMLreference.html#option: iterations 100, '
    "tolerance 1e-8, impratio 1, noslip_iterations 0, cone pyramidal; #body-geom: margin 0, gap 0, condim 3"
)
#: The practice contact's solver options, as MuJoCo's documentation advises them against slip.
PRACTICE_IMPRATIO = 10.0
PRACTICE_TOLERANCE = 1e-10
PRACTICE_NOSLIP = 0
#: Where the documentation advises each practice setting (the rest as ``DEFAULT_DOCS``).
PRACTICE_DOCS = (
    "mujoco.readthedocs.io/en/latest/modeling.html#solver-settings: 'While the default is pyramidal, we recommend "
    "trying the elliptic cones. When contact slip is a problem, the best way to suppress it is to use elliptic "
    "cones, large impratio, and the Newton algorithm with very small tolerance. If that is not sufficient, enable "
    "the Noslip solver'; Newton 'should be used with aggressive tolerance values, say 1e-10'. "
    "modeling.html#preventing-slip, 'Slow slippage': 'Increase the impratio parameter ... high impratio values work "
    "well only with elliptic cones'; NoSlip 'will entirely prevent slip, at the cost of making inverse dynamics "
    "ill-defined'. overview.html#softness-and-slip: NoSlip leaves the convex problem and 'the simulation may become "
    "less robust. Thus using the Newton solver with elliptic friction cones and large value of impratio is the "
    "recommended way of reducing slip' (hence noslip_iterations 0). XMLreference.html#option-impratio: 'Settings "
    'larger than 1 cause friction forces to be "harder" than normal forces ... not recommended to use high impratio '
    "values with pyramidal cones'. impratio 10: the documentation names no number; MuJoCo's own elliptic example "
    'models set it (github.com/google-deepmind/mujoco model/flex/gripper.xml, model/sleep/dominos.xml: cone="elliptic" '
    'impratio="10"). solref, solimp, refsafe, the restitution recipe, margin: the defaults, as ' + DEFAULT_DOCS
)

#: How MuJoCo poses each contact scene (the scene's kind -> its ``ContactPose``): the ball a sphere on
#: one slide joint along z, each box a cube on a free joint, the rolling ball a sphere on a free
#: joint. A new contact scene is one entry here.
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


def _requested_e(scene) -> float:
    """The scene's requested restitution; 0 (a critically damped contact, MuJoCo's default damping
    ratio) where it asks none: the sliding, resting and stacked boxes, the tip and the roll."""
    return getattr(scene, "e", 0.0)


def _solref(e: float) -> tuple[float, float]:
    return -(OMEGA_C**2), -2.0 * zeta_for(e) * OMEGA_C


def default_solref(scene) -> tuple[float, float] | None:
    """The default mode's solref for ``scene``: the documentation's restitution recipe (direct
    format, stiffness ``RESTITUTION_STIFFNESS``, damping 2 zeta sqrt(stiffness), zeta from e) where
    the scene asks restitution, else None (MuJoCo's default, left out of the model)."""
    if not hasattr(scene, "e"):
        return None
    return -RESTITUTION_STIFFNESS, -2.0 * zeta_for(scene.e) * math.sqrt(RESTITUTION_STIFFNESS)


def default_omega_c(scene, dt: float) -> float:
    """The default mode's contact frequency (rad/s) at d = d_width: sqrt(stiffness) in the direct
    format; 1 / (timeconst dampratio) in the (timeconst, dampratio) one, timeconst raised to
    2 dt by refsafe."""
    ref = default_solref(scene)
    if ref is not None:
        return math.sqrt(-ref[0])
    timeconst, dampratio = DEFAULT_SOLREF
    return 1.0 / (max(timeconst, 2.0 * dt) * dampratio)


def _gravity(scene) -> str:
    return " ".join("0" if x == 0.0 else repr(float(x)) for x in scene.gravity)


def _contact_attrs(contact: str, scene) -> str:
    """The geoms' contact attributes: every one stated for the stiff contact; for the default and
    practice ones only the restitution recipe's solref, where the scene asks restitution (the rest
    MuJoCo's)."""
    if contact == "stiff":
        k, b = _solref(_requested_e(scene))
        return f'solref="{k!r} {b!r}" solimp="{IMPEDANCE} {IMPEDANCE} 0.001 0.5 2" margin="0" gap="0"'
    ref = default_solref(scene)
    return "" if ref is None else f'solref="{ref[0]!r} {ref[1]!r}"'


def _option(integrator: str, cone: str, scene, dt: float, contact: str) -> str:
    head = f'<option timestep="{dt!r}" integrator="{integrator}" cone="{cone}" gravity="{_gravity(scene)}"'
    if contact == "stiff":
        return (
            f'{head} iterations="{SOLVER_ITERATIONS}" tolerance="{SOLVER_TOLERANCE}" impratio="1" '
            'noslip_iterations="0"><flag warmstart="enable"/></option>'
        )
    if contact == "practice":
        return (
            f'{head} impratio="{PRACTICE_IMPRATIO!r}" tolerance="{PRACTICE_TOLERANCE!r}" '
            f'noslip_iterations="{PRACTICE_NOSLIP}"/>'
        )
    return f"{head}/>"


def _friction(mu, contact: str) -> str:
    """The geom's friction: mu sliding; torsion and rolling 0 (stiff) or MuJoCo's defaults (0.005,
    0.0001), which act only at condim 4 and 6 (every geom here has condim 1 or 3)."""
    return f"{mu!r} 0 0" if contact == "stiff" else f"{mu!r} 0.005 0.0001"


def _quat_text(q) -> str:
    return " ".join(repr(float(x)) for x in q)


def _xml(integrator: str, cone: str, scene, dt: float, contact: str = "stiff") -> str:
    """The model of ``scene`` in MuJoCo's XML (``integrator`` as MJCF names it)."""
    attrs = _contact_attrs(contact, scene)
    opt = _option(integrator, cone, scene, dt, contact)
    pose = POSES[scene.kind]
    if pose is SPHERE:
        floor = f'<geom name="floor" type="plane" size="0 0 1" condim="1" friction="0 0 0" {attrs}/>'
        r, z0 = scene.radius, float(scene.initial_centres()[0][2])  # held to z: the scene starts it on the axis
        body = (
            f'<body name="b0" pos="0 0 0"><joint name="z" type="slide" axis="0 0 1" damping="0" armature="0"/>'
            f'<geom type="sphere" size="{r!r}" pos="0 0 0" mass="{scene.mass!r}" condim="1" {attrs}/></body>'
        )
        return f'<mujoco>{opt}<worldbody>{floor}{body}</worldbody><keyframe><key qpos="{z0!r}"/></keyframe></mujoco>'
    mu = float(getattr(scene, "mu", 1.0))
    friction = _friction(mu, contact)
    floor = f'<geom name="floor" type="plane" size="0 0 1" condim="3" friction="{friction}" {attrs}/>'
    bodies = []
    quats = scene.initial_orientations()
    for i, (x, y, z) in enumerate(scene.initial_centres()):
        if pose is ROLLING_SPHERE:
            geom = f'type="sphere" size="{scene.radius!r}"'
        else:
            half = scene.half
            geom = f'type="box" size="{half!r} {half!r} {half!r}"'
        bodies.append(
            f'<body name="b{i}" pos="{x!r} {y!r} {z!r}" quat="{_quat_text(quats[i])}"><freejoint/>'
            f'<geom {geom} mass="{scene.mass!r}" condim="3" friction="{friction}" {attrs}/></body>'
        )
    return f"<mujoco>{opt}<worldbody>{floor}{''.join(bodies)}</worldbody></mujoco>"


def _settings(mujoco, m, scene, integrator: str, cone: str, contact: str, dt: float) -> dict:
    pose = POSES[scene.kind]
    solref = [float(x) for x in m.geom_solref[0]]
    refsafe = not (int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_REFSAFE))
    if contact == "stiff":
        omega = OMEGA_C
    else:
        omega = default_omega_c(scene, dt)
    out = {
        "integrator": integrator,
        "cone": cone,
        "contact": {
            "stiff": "stiff: one contact frequency at every step (the controlled comparison)",
            "default": "MuJoCo's default, as its documentation tells a user to set it",
            "practice": (
                "MuJoCo's default contact with the solver options its documentation advises against slip: "
                "elliptic cone, large impratio, Newton at a very small tolerance, no NoSlip"
            ),
        }[contact],
        "contact omega_c (rad/s)": omega,
        "h * contact frequency": omega * dt,
        "solref": solref,
        "solimp": [float(x) for x in m.geom_solimp[0]],
        "refsafe": refsafe,
        "margin": float(m.geom_margin[0]),
        "gap": float(m.geom_gap[0]),
        "solver": mujoco.mjtSolver(int(m.opt.solver)).name.removeprefix("mjSOL_").title(),
        "iterations": int(m.opt.iterations),
        "tolerance": float(m.opt.tolerance),
        "impratio": float(m.opt.impratio),
        "noslip_iterations": int(m.opt.noslip_iterations),
    }
    if contact != "stiff":
        if solref[0] > 0:
            timeconst = max(solref[0], 2.0 * dt) if refsafe else solref[0]
            out["contact frequency"] = (
                f"1 / (timeconst dampratio) = 1 / ({timeconst:g} x {solref[1]:g}) at d = d_width; timeconst "
                f"{solref[0]:g}{' raised to 2 steps by refsafe' if timeconst > solref[0] else ''}"
            )
        else:
            out["contact frequency"] = (
                f"sqrt(stiffness) = sqrt({-solref[0]:g}) at d = d_width (refsafe: not this format)"
            )
        out["documentation"] = DEFAULT_DOCS if contact == "default" else PRACTICE_DOCS
    if hasattr(scene, "e"):
        e = scene.e
        if contact == "stiff":
            out["restitution"] = f"e = {e:g} -> damping ratio {zeta_for(e):.6g} (solref damping = 2 zeta omega_c)"
        else:
            out["restitution"] = (
                f"e = {e:g} -> damping ratio {zeta_for(e):.6g}: solref (-{RESTITUTION_STIFFNESS:g}, "
                f"-2 zeta sqrt({RESTITUTION_STIFFNESS:g})), the documentation's restitution recipe"
            )
    else:
        out["contact damping"] = "zeta 1 (critically damped: a resting contact)"
    if pose is SPHERE:
        out["joint"] = "one slide joint along z, condim 1 (frictionless)"
    else:
        out["friction"] = f"{float(m.geom_friction[0][0]):g} on both geoms (MuJoCo takes the larger), condim 3"
        out["joint"] = {
            BOX: "a free joint a box",
            TURNING_BOX: "a free joint a box, started at the scene's orientation and angular velocity",
            ROLLING_SPHERE: "a free joint a solid sphere (2/5 m r^2), no rolling or spinning friction (condim 3)",
        }[pose]
    return out


def _rotate(mujoco, quat, vec) -> np.ndarray:
    """``vec`` turned by the unit quaternion ``quat`` (w, x, y, z)."""
    out = np.empty(3)
    mujoco.mju_rotVecQuat(out, np.asarray(vec, dtype=float), np.asarray(quat, dtype=float))
    return out


def run(mode: ContactMode, scene, dt: float):
    mujoco = import_engine("mujoco")
    integrator, cone = mode.settings["integrator"], mode.settings["cone"]
    contact = mode.settings.get("contact", "stiff")
    xml = _xml(INTEGRATORS[integrator], cone, scene, dt, contact)
    pose = POSES[scene.kind]
    sphere = pose is SPHERE
    turns = pose in (TURNING_BOX, ROLLING_SPHERE)

    def fresh():
        m = mujoco.MjModel.from_xml_string(xml)
        m.opt.disableflags |= (
            int(mujoco.mjtDisableBit.mjDSBL_AUTORESET) if hasattr(mujoco.mjtDisableBit, "mjDSBL_AUTORESET") else 0
        )
        d = mujoco.MjData(m)
        if m.nkey:
            mujoco.mj_resetDataKeyframe(m, d, 0)
        spins = scene.initial_angular_velocities()
        for i, v in enumerate(scene.initial_velocities()):  # a free joint's velocities: linear (world), angular
            if sphere:
                d.qvel[0] = v[2]
                continue
            d.qvel[6 * i : 6 * i + 3] = v
            if any(spins[i]):  # the scene's world angular velocity in the body's axes: R^T w
                inverse = np.array(d.qpos[7 * i + 3 : 7 * i + 7]) * np.array([1.0, -1.0, -1.0, -1.0])
                d.qvel[6 * i + 3 : 6 * i + 6] = _rotate(mujoco, inverse, spins[i])
        mujoco.mj_forward(m, d)
        return m, d

    m, d = fresh()
    nb = scene.bodies
    worst = [0]

    def step():
        mujoco.mj_step(m, d)
        worst[0] = max(worst[0], int(d.solver_niter[0]))

    def read():
        if sphere:
            return np.array([[0.0, 0.0, d.qpos[0]]]), np.array([[0.0, 0.0, d.qvel[0]]])
        c = np.array([d.qpos[7 * i : 7 * i + 3] for i in range(nb)])
        v = np.array([d.qvel[6 * i : 6 * i + 3] for i in range(nb)])
        if not turns:
            return c, v
        q = np.array([d.qpos[7 * i + 3 : 7 * i + 7] for i in range(nb)])
        w = np.array([_rotate(mujoco, q[i], d.qvel[6 * i + 3 : 6 * i + 6]) for i in range(nb)])
        return c, v, q, w

    def time_again(steps: int) -> float:
        m2, d2 = fresh()
        return timed_loop(lambda: mujoco.mj_step(m2, d2, nstep=steps), 1)

    settings = _settings(mujoco, m, scene, integrator, cone, contact, dt)
    out = record_loop(
        mode, scene, dt, step, read, settings, loop="mujoco.mj_step(m, d, nstep=steps), one call", time_again=time_again
    )
    out.settings["solver iterations, most in a step"] = worst[0]
    out.settings["solver converged"] = worst[0] < int(m.opt.iterations)
    bad = int(d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number) + int(
        d.warning[mujoco.mjtWarning.mjWARN_BADQPOS].number
    )
    if bad and out.status == "ok":
        out.status, out.detail = "unstable", f"MuJoCo warned of a bad state {bad} times"
    return out


def mode_name(integrator: str, cone: str, contact: str) -> str:
    """A mode's name after ``mujoco:``: the integrator, its options sorted by key (the canonical
    method id, ``records.method_id``)."""
    options = {k: v for k, v in (("cone", cone), ("contact", contact)) if v not in ("pyramidal", "stiff")}
    return integrator + ("?" + "&".join(f"{k}={v}" for k, v in sorted(options.items())) if options else "")


_DOC = {
    "stiff": (
        "MuJoCo {integrator} with the {cone} friction cone; contact a soft constraint of solref "
        "(-omega_c^2, -2 zeta omega_c), omega_c = {omega:g} rad/s, zeta from the requested e"
    ),
    "default": (
        "MuJoCo {integrator} with the {cone} friction cone; contact at MuJoCo's defaults as its documentation "
        "tells a user to set it: solref (0.02, 1) with refsafe (timeconst at least 2 steps), solimp "
        "(0.9, 0.95, 0.001, 0.5, 2), omega_c = 1 / max(0.02 s, 2 h); where e is asked, the documentation's "
        "restitution recipe solref (-1000, -2 zeta sqrt(1000)), omega_c = 31.6 rad/s"
    ),
    "practice": (
        "MuJoCo {integrator} as its documentation advises against slip: the elliptic friction cone, impratio "
        f"{PRACTICE_IMPRATIO:g}, Newton at tolerance {PRACTICE_TOLERANCE:g}, no NoSlip (modeling.html 'Solver "
        "settings', 'Preventing slip'; overview.html 'Softness and slip'); solref, solimp, refsafe and the "
        "restitution recipe as the default contact's"
    ),
}

MODES = {
    f"mujoco:{mode_name(name, cone, contact)}": ContactMode(
        "mujoco",
        mode_name(name, cone, contact),
        "mujoco",
        run,
        poses=POSES,
        holds_ball_to_z=True,
        settings={"integrator": name, "cone": cone} | ({"contact": contact} if contact != "stiff" else {}),
        doc=_DOC[contact].format(integrator=INTEGRATORS[name], cone=cone, omega=OMEGA_C),
    )
    for contact, cones in CONTACTS.items()
    for name in INTEGRATORS
    for cone in cones
}
