"""MuJoCo's contact poses, in each integrator and each friction cone.

The contact is MuJoCo's soft constraint with solref given directly as (-stiffness, -damping) and a
constant impedance d (solimp dmin = dmax = 0.9999): inside the contact the normal acceleration is
then ``-(1 - d) g - b v - k r`` (r the penetration), a spring-dashpot of frequency
``omega_c = sqrt(k)`` and damping ratio ``zeta = b / (2 omega_c)``, whatever the mass, with gravity
all but removed while touching. The requested restitution gives zeta by the linear spring-dashpot's
``e = exp(-pi zeta / sqrt(1 - zeta^2)``; omega_c is the mode's (``OMEGA_C``). MuJoCo's default
solref (0.02, 1) is critically damped: a ball does not bounce at all (docs/engines.md).

Each scene is the smallest model that poses its question: the ball on one slide joint along z
(``condim=1``, a frictionless normal contact: it only moves up and down); the sliding box, the box
at rest and the stack on free joints (friction, tipping and lateral drift are the question).
Every geom has its mass given, margin 0 and gap 0 (no contact before touching), and the solver's
iterations are checked against its cap after every step.
"""

from __future__ import annotations

import numpy as np

from scenarios.penalty_ball import zeta_for

from .._contact import BOX, SPHERE, ContactMode, record_loop, timed_loop
from .._engine import import_engine
from . import MODES as INTEGRATORS  # MuJoCo's integrators: each smooth mode's, posed in each cone

CONES = ("pyramidal", "elliptic")
#: The contact's natural frequency (rad/s): a static penetration of g / omega_c^2 = 0.25 mm under
#: gravity; a contact pi / omega_c long, which a 60 Hz step (h omega_c = 3.3) does not
#: resolve and a 1 kHz step (0.2) does.
OMEGA_C = 200.0
#: The constant impedance (solimp dmin = dmax): 1 - d of gravity acts inside the contact.
IMPEDANCE = 0.9999
SOLVER_ITERATIONS = 100
SOLVER_TOLERANCE = 1e-10

#: How MuJoCo poses each contact scene (the scene's kind -> its ``ContactPose``): the ball a sphere on
#: one slide joint along z, each box a cube on a free joint. A new contact scene is one entry here.
POSES = {"ball": SPHERE, "slide": BOX, "rest": BOX, "stack": BOX}


def _requested_e(scene) -> float:
    """The ball's requested restitution; 0 (a critically damped contact, MuJoCo's default damping
    ratio) for the boxes, whose contacts should come to rest."""
    return getattr(scene, "e", 0.0)


def _solref(e: float) -> tuple[float, float]:
    return -(OMEGA_C**2), -2.0 * zeta_for(e) * OMEGA_C


def _gravity(scene) -> str:
    return " ".join("0" if x == 0.0 else repr(float(x)) for x in scene.gravity)


def _xml(integrator: str, cone: str, scene, dt: float) -> str:
    k, b = _solref(_requested_e(scene))
    contact = f'solref="{k!r} {b!r}" solimp="{IMPEDANCE} {IMPEDANCE} 0.001 0.5 2" margin="0" gap="0"'
    opt = (
        f'<option timestep="{dt!r}" integrator="{integrator}" cone="{cone}" gravity="{_gravity(scene)}" '
        f'iterations="{SOLVER_ITERATIONS}" tolerance="{SOLVER_TOLERANCE}" impratio="1" noslip_iterations="0">'
        '<flag warmstart="enable"/></option>'
    )
    floor = f'<geom name="floor" type="plane" size="0 0 1" condim="{{condim}}" friction="{{mu}} 0 0" {contact}/>'
    if POSES[scene.kind] is SPHERE:
        r, z0 = scene.radius, float(scene.initial_centres()[0][2])  # held to z: the scene starts it on the axis
        body = (
            f'<body name="b0" pos="0 0 0"><joint name="z" type="slide" axis="0 0 1" damping="0" armature="0"/>'
            f'<geom type="sphere" size="{r!r}" pos="0 0 0" mass="{scene.mass!r}" condim="1" {contact}/></body>'
        )
        world = floor.format(condim=1, mu=0) + body
        return f'<mujoco>{opt}<worldbody>{world}</worldbody><keyframe><key qpos="{z0!r}"/></keyframe></mujoco>'
    mu = getattr(scene, "mu", 1.0)
    half = scene.half
    bodies = []
    for i, (x, y, z) in enumerate(scene.initial_centres()):
        bodies.append(
            f'<body name="b{i}" pos="{x!r} {y!r} {z!r}"><freejoint/>'
            f'<geom type="box" size="{half!r} {half!r} {half!r}" mass="{scene.mass!r}" condim="3" '
            f'friction="{mu!r} 0 0" {contact}/></body>'
        )
    return f"<mujoco>{opt}<worldbody>{floor.format(condim=3, mu=repr(mu))}{''.join(bodies)}</worldbody></mujoco>"


def _settings(mujoco, m, scene, integrator: str, cone: str) -> dict:
    out = {
        "integrator": integrator,
        "cone": cone,
        "solref": [float(x) for x in m.geom_solref[0]],
        "solimp": [float(x) for x in m.geom_solimp[0]],
        "contact omega_c (rad/s)": OMEGA_C,
        "margin": float(m.geom_margin[0]),
        "gap": float(m.geom_gap[0]),
        "solver": "Newton",
        "iterations": int(m.opt.iterations),
        "tolerance": float(m.opt.tolerance),
        "impratio": float(m.opt.impratio),
        "noslip_iterations": int(m.opt.noslip_iterations),
    }
    if POSES[scene.kind] is SPHERE:
        e = scene.e
        out["restitution"] = f"e = {e:g} -> damping ratio {zeta_for(e):.6g} (solref damping = 2 zeta omega_c)"
        out["joint"] = "one slide joint along z, condim 1 (frictionless)"
    else:
        out["contact damping"] = "zeta 1 (critically damped: a resting contact)"
        out["friction"] = f"{float(m.geom_friction[0][0]):g} on both geoms (MuJoCo takes the larger)"
        out["joint"] = "a free joint a box"
    return out


def run(mode: ContactMode, scene, dt: float):
    mujoco = import_engine("mujoco")
    integrator, cone = mode.settings["integrator"], mode.settings["cone"]
    xml = _xml(INTEGRATORS[integrator], cone, scene, dt)

    def fresh():
        m = mujoco.MjModel.from_xml_string(xml)
        m.opt.disableflags |= (
            int(mujoco.mjtDisableBit.mjDSBL_AUTORESET) if hasattr(mujoco.mjtDisableBit, "mjDSBL_AUTORESET") else 0
        )
        d = mujoco.MjData(m)
        if m.nkey:
            mujoco.mj_resetDataKeyframe(m, d, 0)
        for i, v in enumerate(scene.initial_velocities()):  # a free joint's velocities: linear, then angular
            if any(v):
                if sphere:
                    d.qvel[0] = v[2]
                else:
                    d.qvel[6 * i : 6 * i + 3] = v
        mujoco.mj_forward(m, d)
        return m, d

    sphere = POSES[scene.kind] is SPHERE
    m, d = fresh()
    nb = scene.bodies
    worst = [0]

    def step():
        mujoco.mj_step(m, d)
        worst[0] = max(worst[0], int(d.solver_niter[0]))

    def read():
        if sphere:
            c = np.array([[0.0, 0.0, d.qpos[0]]])
            v = np.array([[0.0, 0.0, d.qvel[0]]])
        else:
            c = np.array([d.qpos[7 * i : 7 * i + 3] for i in range(nb)])
            v = np.array([d.qvel[6 * i : 6 * i + 3] for i in range(nb)])
        return c, v

    def time_again(steps: int) -> float:
        m2, d2 = fresh()
        return timed_loop(lambda: mujoco.mj_step(m2, d2, nstep=steps), 1)

    settings = _settings(mujoco, m, scene, integrator, cone)
    out = record_loop(
        mode, scene, dt, step, read, settings, loop="mujoco.mj_step(m, d, nstep=steps), one call", time_again=time_again
    )
    out.settings["solver iterations, most in a step"] = worst[0]
    out.settings["solver converged"] = worst[0] < SOLVER_ITERATIONS
    bad = int(d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number) + int(
        d.warning[mujoco.mjtWarning.mjWARN_BADQPOS].number
    )
    if bad and out.status == "ok":
        out.status, out.detail = "unstable", f"MuJoCo warned of a bad state {bad} times"
    return out


_DOC = (
    "MuJoCo {integrator} with the {cone} friction cone; contact a soft constraint of solref "
    "(-omega_c^2, -2 zeta omega_c), omega_c = {omega:g} rad/s, zeta from the requested e"
)

MODES = {
    (f"mujoco:{name}" if cone == "pyramidal" else f"mujoco:{name}?cone={cone}"): ContactMode(
        "mujoco",
        name if cone == "pyramidal" else f"{name}?cone={cone}",
        "mujoco",
        run,
        poses=POSES,
        holds_ball_to_z=True,
        settings={"integrator": name, "cone": cone},
        doc=_DOC.format(integrator=INTEGRATORS[name], cone=cone, omega=OMEGA_C),
    )
    for name in INTEGRATORS
    for cone in CONES
}
