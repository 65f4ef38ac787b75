"""pybullet's contact poses: Bullet's one multibody contact solver (sequential impulses) in two modes:

* ``pybullet:sequential_impulse``, the controlled comparison: every setting that changes the answer
  set and stated (``SETTINGS``), among them the pyramid of friction (``enableConeFriction`` 0),
  contacts solved only once touching, ``contactERP`` 0 on the bouncing ball and no restitution
  threshold;
* ``pybullet:sequential_impulse?contact=default``, as pybullet's documentation (the PyBullet
  Quickstart Guide) leaves contact to a user: every solver setting at pybullet's own default, the
  friction cone (``enableConeFriction`` 1) set explicitly (``DEFAULT_SETTINGS`` says where each comes
  from, ``PYBULLET_DEFAULTS`` what each default is).

The contact is a velocity-level constraint solved by sequential impulses (projected Gauss-Seidel,
``btMultiBodyConstraintSolver``): each contact point's normal impulse is the one that turns the
approach speed u into the rebound ``e u`` (restitution, applied at impact speeds above
``restitutionVelocityThreshold``), less what the gap d still allows (``d / h``), with any
penetration corrected by ``contactERP`` (in the same impulse: the multibody solver does not split
it); friction is two rows per point along world-fixed tangents (``btPlaneSpace1`` of the normal:
-y and x on the plane), each bounded by ``mu`` times the normal impulse (the pyramid), or the pair
clipped to the circle of radius ``mu`` times it (the cone, ``enableConeFriction`` 1).

Each scene is the smallest model: base-only multibodies (6 DOF) on a static ``GEOM_PLANE``: the
ball a sphere, each box a box, the turning box a box started at the scene's orientation and
angular velocity, the rolling ball a sphere (Bullet gives a sphere 2/5 m r^2). Orientations cross
the API as (x, y, z, w) (``to_pybullet``, ``from_pybullet``); ``resetBaseVelocity`` takes and
``getBaseVelocity`` gives the angular velocity in world axes. Restitution and lateral friction are
combined by product: the plane 1, each body its own (the ball e, frictionless; each box mu, 1 for
rest and stack, and e where its scene asks one, else 0; the rolling ball mu).

The engine's loop is a Python loop of ``stepSimulation`` alone (Bullet has none of its own to call).
"""

from __future__ import annotations

import numpy as np

from .._contact import BOX, ROLLING_SPHERE, SPHERE, TURNING_BOX, ContactMode, record_loop, timed_loop
from .._engine import engine_version, import_engine

#: How pybullet poses each contact scene (the scene's kind -> its ``ContactPose``): base-only
#: multibodies. A new contact scene is one entry here.
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

#: The ``setPhysicsEngineParameter`` settings a mode may set (None: left at pybullet's default).
ENGINE_KEYS = (
    "contactBreakingThreshold",
    "restitutionVelocityThreshold",
    "erp",
    "contactERP",
    "frictionERP",
    "useSplitImpulse",
    "splitImpulsePenetrationThreshold",
    "numSolverIterations",
    "numSubSteps",
    "enableConeFriction",
    "allowedCcdPenetration",
    "contactSlop",
    "solverResidualThreshold",
)
#: The ``changeDynamics`` settings of every body a mode may set (None: left at pybullet's default).
BODY_KEYS = (
    "linearDamping",
    "angularDamping",
    "rollingFriction",
    "spinningFriction",
    "maxJointVelocity",
    "contactProcessingThreshold",
)

#: What pybullet 3.2.7 uses where a setting is left unset: Bullet's ``btContactSolverInfo`` and
#: ``gContactBreakingThreshold`` as pybullet's physics server (``PhysicsServerCommandProcessor``,
#: ``createEmptyDynamicsWorld``) leaves or sets them, ``btMultiBodyDynamicsWorld`` (two friction
#: directions) and pybullet's ``changeDynamics`` defaults. Each engine value is reproduced bitwise
#: by setting it explicitly (``tests/test_contact_pybullet.py``); ``numSolverIterations`` and
#: ``numSubSteps`` are also read back (``getPhysicsEngineParameters``, which reads back no other).
PYBULLET_DEFAULTS = {
    "contactBreakingThreshold": 0.02,
    "restitutionVelocityThreshold": 0.2,
    "erp": 0.2,
    "contactERP": 0.08,
    "frictionERP": 0.2,
    "useSplitImpulse": 1,
    "splitImpulsePenetrationThreshold": -0.04,
    "numSolverIterations": 50,
    "numSubSteps": 0,
    "enableConeFriction": 1,
    "allowedCcdPenetration": 0.04,
    "contactSlop": 1e-5,
    "solverResidualThreshold": 1e-7,
    "linearDamping": 0.04,
    "angularDamping": 0.04,
    "rollingFriction": 0.0,
    "spinningFriction": 0.0,
    "maxJointVelocity": 100.0,
    "contactProcessingThreshold": "every point of the contact manifold (found within contactBreakingThreshold)",
    "sleeping": "as pybullet creates a multibody (no body of these scenes was put to sleep)",
}

#: The controlled comparison's settings (``setPhysicsEngineParameter`` and ``changeDynamics``).
SETTINGS = {
    "contact": "controlled",
    # Process-wide (gContactBreakingThreshold): set on every run, each run in a process of its own.
    "contactBreakingThreshold": 0.02,
    # Restitution at every impact speed (default 0.2 m/s): a box that falls onto a face keeps bouncing on it.
    "restitutionVelocityThreshold": 0.0,
    "erp": 0.2,
    # Default 0.08; the ball's is "ball contactERP".
    "contactERP": 0.2,
    "frictionERP": 0.2,
    "useSplitImpulse": 1,
    "splitImpulsePenetrationThreshold": -0.04,
    "numSolverIterations": 50,
    "numSubSteps": 0,
    # The pyramid: each tangent row bounded by mu N on its own.
    "enableConeFriction": 0,
    "allowedCcdPenetration": 0.04,
    "contactSlop": None,
    "solverResidualThreshold": None,
    # A bounce's penetration is left to its rebound: the correction adds the energy of pushing it out.
    "ball contactERP": 0.0,
    # Default 0.04 (quadratic): the scenes have no drag.
    "linearDamping": 0.0,
    "angularDamping": 0.0,
    "rollingFriction": 0.0,
    "spinningFriction": 0.0,
    "maxJointVelocity": 1e6,
    # Contacts found before touching are kept but solved only once touching.
    "contactProcessingThreshold": 0.0,
    "sleeping": False,
    "plane restitution": 1.0,
    "plane lateralFriction": 1.0,
}

#: The PyBullet Quickstart Guide (Coumans and Bai), whose sections ``DEFAULT_SOURCES`` names; the same
#: text is ``docs/pybullet_quickstartguide.pdf`` in github.com/bulletphysics/bullet3.
QUICKSTART = "PyBullet Quickstart Guide"
QUICKSTART_URL = "https://docs.google.com/document/d/10sXEhzFRSnvFcl3XxNGhnD4N2SedqwdAvK3dsihxVUA"

#: As the Quickstart Guide leaves contact to a user, with where it says so (``DEFAULT_SOURCES``):
#: every solver setting left at pybullet's default (``PYBULLET_DEFAULTS``), the cone set explicitly.
DEFAULT_SETTINGS = {
    "contact": "default",
    # Left at its default value, set explicitly only because it is process-wide.
    "contactBreakingThreshold": PYBULLET_DEFAULTS["contactBreakingThreshold"],
    "restitutionVelocityThreshold": None,
    "erp": None,
    "contactERP": None,
    "frictionERP": None,
    "useSplitImpulse": None,
    "splitImpulsePenetrationThreshold": None,
    "numSolverIterations": None,
    "numSubSteps": None,
    "enableConeFriction": 1,
    "allowedCcdPenetration": None,
    "contactSlop": None,
    "solverResidualThreshold": None,
    "ball contactERP": None,
    # The scenes have no drag: damping is the scene's model, not a contact setting.
    "linearDamping": 0.0,
    "angularDamping": 0.0,
    "rollingFriction": None,
    "spinningFriction": None,
    "maxJointVelocity": None,
    "contactProcessingThreshold": None,
    "sleeping": None,
    "plane restitution": 1.0,
    "plane lateralFriction": 1.0,
}
DEFAULT_SOURCES = {
    "enableConeFriction": f"{QUICKSTART}, setPhysicsEngineParameter: 0 disables the implicit cone friction "
    "for a pyramid approximation; the cone is the default",
    "contactBreakingThreshold": f"{QUICKSTART}, setPhysicsEngineParameter: contact points farther apart are "
    "not solved; 0.02 in Bullet 2.x",
    "restitutionVelocityThreshold": f"{QUICKSTART}, setPhysicsEngineParameter: below this relative speed "
    "restitution is zero",
    "numSolverIterations": f"{QUICKSTART}, setPhysicsEngineParameter: the most solver iterations (it may stop "
    "earlier at solverResidualThreshold)",
    "contactERP": f"{QUICKSTART}, setPhysicsEngineParameter: the contact error reduction parameter; "
    "setTimeStep: the erp values are tuned for the default 240 Hz step",
    "erp": f"{QUICKSTART}, setPhysicsEngineParameter: for non-contact, non-friction constraints (none here)",
    "frictionERP": f"{QUICKSTART}, setPhysicsEngineParameter: only where positional friction anchors are on (not here)",
    "useSplitImpulse": f"{QUICKSTART}, setPhysicsEngineParameter: only with maximal coordinates (not multibodies)",
    "splitImpulsePenetrationThreshold": f"{QUICKSTART}, setPhysicsEngineParameter: with useSplitImpulse",
    "numSubSteps": f"{QUICKSTART}, setPhysicsEngineParameter: substeps trade speed for accuracy; none by default",
    "allowedCcdPenetration": f"{QUICKSTART}, setPhysicsEngineParameter: with continuous collision detection "
    "(off: no swept sphere radius)",
    "contactSlop": f"{QUICKSTART}, setPhysicsEngineParameter: a contact's position is not corrected below it",
    "solverResidualThreshold": f"{QUICKSTART}, setPhysicsEngineParameter: the solver stops early once every "
    "constraint's velocity error is below it",
    "linearDamping": f"{QUICKSTART}, getDynamicsInfo/changeDynamics: 0.04 by default; set 0, the scenes' "
    "bodies move in no air",
    "angularDamping": f"{QUICKSTART}, getDynamicsInfo/changeDynamics: 0.04 by default; set 0 as linearDamping",
    "rollingFriction": f"{QUICKSTART}, getDynamicsInfo/changeDynamics: keep it very close to zero; left (reads back 0)",
    "spinningFriction": f"{QUICKSTART}, getDynamicsInfo/changeDynamics: left (reads back 0)",
    "contactProcessingThreshold": f"{QUICKSTART}, getDynamicsInfo/changeDynamics: contacts closer than it are "
    "solved; left, every contact found is solved",
    "maxJointVelocity": f"{QUICKSTART}, getDynamicsInfo/changeDynamics: velocities clamped at 100 by default "
    "(the scenes stay below 5 m/s)",
    "sleeping": f"{QUICKSTART}, getDynamicsInfo/changeDynamics activationState: left as pybullet creates a body",
    "restitution": f"{QUICKSTART}, getDynamicsInfo/changeDynamics: restitution and lateralFriction per body; "
    "Bullet combines each pair's by product (btManifoldResult), so the plane's are set to 1",
    "fixedTimeStep": f"{QUICKSTART}, setTimeStep: 1/240 s by default; the harness's step",
}

#: The contact settings each mode states under the engine-wide ones.
_PLANE = ("plane restitution", "plane lateralFriction")


def to_pybullet(q) -> list[float]:
    """pybullet's (x, y, z, w) of the scene's quaternion (w, x, y, z)."""
    w, x, y, z = (float(c) for c in q)
    return [x, y, z, w]


def from_pybullet(q) -> list[float]:
    """The scene's (w, x, y, z) of pybullet's quaternion (x, y, z, w)."""
    x, y, z, w = (float(c) for c in q)
    return [w, x, y, z]


def _engine_parameters(mode_settings: dict, shape: str) -> dict:
    engine = {k: mode_settings[k] for k in ENGINE_KEYS if mode_settings.get(k) is not None}
    if shape == "sphere" and mode_settings.get("ball contactERP") is not None:
        engine["contactERP"] = mode_settings["ball contactERP"]
    return engine


def _pose(p, cid, scene, dt: float, settings: dict) -> list[int]:
    shape_kind = POSES[scene.kind].shape
    p.setPhysicsEngineParameter(fixedTimeStep=dt, physicsClientId=cid, **_engine_parameters(settings, shape_kind))
    p.setGravity(*(float(x) for x in scene.gravity), physicsClientId=cid)
    plane = p.createMultiBody(0.0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)
    p.changeDynamics(
        plane,
        -1,
        restitution=settings["plane restitution"],
        lateralFriction=settings["plane lateralFriction"],
        physicsClientId=cid,
    )
    dynamics = {k: settings[k] for k in BODY_KEYS if settings.get(k) is not None}
    if settings.get("sleeping") is False:
        dynamics["activationState"] = p.ACTIVATION_STATE_DISABLE_SLEEPING
    if shape_kind in ("sphere", "rolling_sphere"):
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=scene.radius, physicsClientId=cid)
    else:
        h = scene.half
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[h, h, h], physicsClientId=cid)
    if shape_kind == "sphere":
        own = {"restitution": scene.e, "lateralFriction": 0.0}
    elif shape_kind == "turning_box":
        own = {"restitution": float(getattr(scene, "e", 0.0)), "lateralFriction": scene.mu}
    else:
        own = {"restitution": 0.0, "lateralFriction": getattr(scene, "mu", 1.0)}
    bodies = []
    for centre, q in zip(scene.initial_centres(), scene.initial_orientations()):
        b = p.createMultiBody(
            scene.mass, shape, basePosition=list(centre), baseOrientation=to_pybullet(q), physicsClientId=cid
        )
        p.changeDynamics(b, -1, physicsClientId=cid, **dynamics, **own)
        bodies.append(b)
    for b, v, w in zip(bodies, scene.initial_velocities(), scene.initial_angular_velocities()):
        if any(v) or any(w):
            p.resetBaseVelocity(b, [float(x) for x in v], [float(x) for x in w], physicsClientId=cid)
    return bodies


def run(mode: ContactMode, scene, dt: float):
    p = import_engine("pybullet")
    settings = dict(mode.settings)
    turns = POSES[scene.kind] in (TURNING_BOX, ROLLING_SPHERE)

    def fresh():
        cid = p.connect(p.DIRECT)
        return cid, _pose(p, cid, scene, dt, settings)

    cid, bodies = fresh()

    def step():
        p.stepSimulation(physicsClientId=cid)

    def read():
        poses = [p.getBasePositionAndOrientation(b, physicsClientId=cid) for b in bodies]
        speeds = [p.getBaseVelocity(b, physicsClientId=cid) for b in bodies]
        c = np.array([x[0] for x in poses])
        v = np.array([x[0] for x in speeds])
        if not turns:
            return c, v
        q = np.array([from_pybullet(x[1]) for x in poses])
        w = np.array([x[1] for x in speeds])  # world axes
        return c, v, q, w

    def time_again(steps: int) -> float:
        cid2, _ = fresh()
        try:
            return timed_loop(lambda: p.stepSimulation(physicsClientId=cid2), steps)
        finally:
            p.disconnect(physicsClientId=cid2)

    stated = _stated(p, cid, bodies, scene, settings)
    try:
        out = record_loop(
            mode, scene, dt, step, read, stated, loop="a Python loop of p.stepSimulation()", time_again=time_again
        )
    finally:
        p.disconnect(physicsClientId=cid)
    return out


def _stated(p, cid, bodies, scene, settings: dict) -> dict:
    """The settings as the run used them: each one set, or left at pybullet's default (its value
    stated), with what pybullet reads back."""
    shape_kind = POSES[scene.kind].shape
    cone = settings.get("enableConeFriction")
    cone = PYBULLET_DEFAULTS["enableConeFriction"] if cone is None else cone
    out = {
        "contact": settings.get("contact"),
        "solver": "btMultiBodyConstraintSolver (sequential impulse)",
        "pybullet": engine_version("pybullet"),
        "bodies": "base-only multibodies (6 DOF) on a static GEOM_PLANE",
        "friction": "pyramid (enableConeFriction 0)" if cone == 0 else "cone (enableConeFriction 1)",
    }
    engine = _engine_parameters(settings, shape_kind)
    for k in ENGINE_KEYS:
        out[k] = engine[k] if k in engine else f"pybullet's default ({PYBULLET_DEFAULTS[k]})"
    for k in (*BODY_KEYS, "sleeping"):
        out[k] = settings[k] if settings.get(k) is not None else f"pybullet's default ({PYBULLET_DEFAULTS[k]})"
    for k in _PLANE:
        out[k] = settings[k]
    read = p.getPhysicsEngineParameters(physicsClientId=cid)
    for k in ("numSolverIterations", "numSubSteps", "numNonContactInnerIterations", "fixedTimeStep"):
        out[f"{k} (read back)"] = read[k]
    info = p.getDynamicsInfo(bodies[0], -1, physicsClientId=cid)
    out["body lateralFriction (read back)"] = info[1]
    out["body moment (read back)"] = info[2][0]
    out["body restitution (read back)"] = info[5]
    out["body rollingFriction (read back)"] = info[6]
    out["body spinningFriction (read back)"] = info[7]
    out["restitution combining"] = "product: plane 1 x body's"
    out["friction combining"] = "product: plane 1 x body's"
    if settings.get("contact") == "default":
        out["sources"] = {"guide": f"{QUICKSTART}, {QUICKSTART_URL}", **DEFAULT_SOURCES}
    return out


MODES = {
    "pybullet:sequential_impulse": ContactMode(
        "pybullet",
        "sequential_impulse",
        "pybullet",
        run,
        poses=POSES,
        settings=SETTINGS,
        own_process=True,
        doc="Bullet's multibody sequential-impulse contact solver, controlled: the friction pyramid, contacts "
        "solved once touching, no restitution threshold, contactERP 0 on the bouncing ball and 0.2 on the "
        "others, damping 0, restitution and friction combined by product",
    ),
    "pybullet:sequential_impulse?contact=default": ContactMode(
        "pybullet",
        "sequential_impulse?contact=default",
        "pybullet",
        run,
        poses=POSES,
        settings=DEFAULT_SETTINGS,
        own_process=True,
        doc="Bullet's multibody sequential-impulse contact solver as the PyBullet Quickstart Guide leaves it: "
        "the friction cone, every solver setting at pybullet's default (contactERP 0.08, restitution "
        "threshold 0.2 m/s, 50 iterations, contacts solved from 0.02 m apart), damping 0 (the scenes' "
        "bodies move in no air), restitution and friction combined by product",
    ),
}
