"""pybullet's contact poses: ``pybullet:sequential_impulse``, Bullet's one multibody contact solver.

The contact is a velocity-level constraint solved by sequential impulses (projected Gauss-Seidel,
``btMultiBodyConstraintSolver``): each contact point's normal impulse is the one that turns the
approach speed u into the rebound ``e u`` (restitution, applied at impact speeds above
``restitutionVelocityThreshold``), less what the gap d still allows (``d / h``), with any
penetration corrected by ``contactERP``; friction is two tangent rows per point bounded by
``mu`` times the normal impulse (the pyramid), or a cone where ``enableConeFriction``.

Each scene is the smallest model: a sphere or box base-only multibody (6 DOF) on a static
``GEOM_PLANE``. Every setting that changes the answer is set on every run and stated
(``SETTINGS``, read back where pybullet reads it back; docs/engines.md has each default's
measured effect):

* restitution: Bullet combines the two bodies' by product: the plane 1, the ball e;
* lateral friction: by product too: the plane 1, each box mu (1 for rest and stack); rolling and
  spinning friction 0;
* linear and angular damping 0 (default 0.04, quadratic), the velocity clamp raised, sleeping off;
* ``contactBreakingThreshold``: how far apart two shapes are still in contact (default 0.02 m):
  a contact found before touching is solved with its gap allowed for, which takes part of each
  rebound away; it is a process-wide global of Bullet (``gContactBreakingThreshold``), kept from
  whatever ran before in the process, so every run sets it and runs in a process of its own;
* ``restitutionVelocityThreshold``, ``contactERP`` / ``erp`` / ``frictionERP``, split impulse and
  its penetration threshold, ``numSolverIterations``, ``numSubSteps`` 0, ``enableConeFriction``,
  ``allowedCcdPenetration`` (CCD stays off: no swept sphere radius), ``contactProcessingThreshold``.

The engine's loop is a Python loop of ``stepSimulation`` alone (Bullet has none of its own to call).
"""

from __future__ import annotations

import numpy as np

from .._contact import BOX, SPHERE, ContactMode, record_loop, timed_loop
from .._engine import engine_version, import_engine

#: How pybullet poses each contact scene (the scene's kind -> its ``ContactPose``): the ball a sphere,
#: each box a box, base-only multibodies. A new contact scene is one entry here.
POSES = {"ball": SPHERE, "slide": BOX, "rest": BOX, "stack": BOX}

#: ``setPhysicsEngineParameter`` settings of every run (the process-wide threshold among them).
ENGINE_PARAMETERS = {
    "contactBreakingThreshold": 0.02,
    "restitutionVelocityThreshold": 0.0,
    "erp": 0.2,
    "contactERP": 0.2,
    "frictionERP": 0.2,
    "useSplitImpulse": 1,
    "splitImpulsePenetrationThreshold": -0.04,
    "numSolverIterations": 50,
    "numSubSteps": 0,
    "enableConeFriction": 0,
    "allowedCcdPenetration": 0.04,
}
#: The ball's ``contactERP``: a bounce's penetration is left to its rebound, since the correction adds
#: the energy of pushing it out to every bounce (the boxes keep ``ENGINE_PARAMETERS["contactERP"]``).
BALL_CONTACT_ERP = 0.0
#: ``changeDynamics`` settings of every body.
BODY_DYNAMICS = {
    "linearDamping": 0.0,
    "angularDamping": 0.0,
    "rollingFriction": 0.0,
    "spinningFriction": 0.0,
    "maxJointVelocity": 1e6,
    "contactProcessingThreshold": 0.0,
}
#: The plane's restitution and friction: Bullet multiplies them into each body's.
PLANE = {"restitution": 1.0, "lateralFriction": 1.0}


def _pose(p, cid, scene, dt: float, settings: dict) -> list[int]:
    engine = {k: settings[k] for k in ENGINE_PARAMETERS if settings[k] is not None}
    sphere = POSES[scene.kind] is SPHERE
    if sphere and settings["ball contactERP"] is not None:
        engine["contactERP"] = settings["ball contactERP"]
    p.setPhysicsEngineParameter(fixedTimeStep=dt, physicsClientId=cid, **engine)
    p.setGravity(*(float(x) for x in scene.gravity), physicsClientId=cid)
    plane = p.createMultiBody(0.0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)
    p.changeDynamics(plane, -1, physicsClientId=cid, **{k: settings[f"plane {k}"] for k in PLANE})
    dynamics = {k: settings[k] for k in BODY_DYNAMICS if settings[k] is not None}
    dynamics["activationState"] = p.ACTIVATION_STATE_DISABLE_SLEEPING
    if sphere:
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=scene.radius, physicsClientId=cid)
        own = {"restitution": scene.e, "lateralFriction": 0.0}
    else:
        h = scene.half
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[h, h, h], physicsClientId=cid)
        own = {"restitution": 0.0, "lateralFriction": getattr(scene, "mu", 1.0)}
    bodies = []
    for centre in scene.initial_centres():
        b = p.createMultiBody(scene.mass, shape, basePosition=list(centre), physicsClientId=cid)
        p.changeDynamics(b, -1, physicsClientId=cid, **dynamics, **own)
        bodies.append(b)
    for b, v in zip(bodies, scene.initial_velocities()):
        if any(v):
            p.resetBaseVelocity(b, list(v), [0.0, 0.0, 0.0], physicsClientId=cid)
    return bodies


def run(mode: ContactMode, scene, dt: float):
    p = import_engine("pybullet")
    settings = dict(mode.settings)

    def fresh():
        cid = p.connect(p.DIRECT)
        return cid, _pose(p, cid, scene, dt, settings)

    cid, bodies = fresh()

    def step():
        p.stepSimulation(physicsClientId=cid)

    def read():
        c = np.array([p.getBasePositionAndOrientation(b, physicsClientId=cid)[0] for b in bodies])
        v = np.array([p.getBaseVelocity(b, physicsClientId=cid)[0] for b in bodies])
        return c, v

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
    """The settings as the run used them, with what pybullet reads back."""
    out = {
        "solver": "btMultiBodyConstraintSolver (sequential impulse)",
        "pybullet": engine_version("pybullet"),
        "bodies": "base-only multibodies (6 DOF) on a static GEOM_PLANE",
    }
    out.update(settings)
    info = p.getDynamicsInfo(bodies[0], -1, physicsClientId=cid)
    out["body restitution (read back)"] = info[5]
    out["body lateralFriction (read back)"] = info[1]
    out["restitution combining"] = "product: plane 1 x body's"
    out["friction combining"] = "product: plane 1 x body's"
    out["numSolverIterations (read back)"] = p.getPhysicsEngineParameters(physicsClientId=cid)["numSolverIterations"]
    return out


SETTINGS = {
    **ENGINE_PARAMETERS,
    "ball contactERP": BALL_CONTACT_ERP,
    **BODY_DYNAMICS,
    **{f"plane {k}": v for k, v in PLANE.items()},
}

MODES = {
    "pybullet:sequential_impulse": ContactMode(
        "pybullet",
        "sequential_impulse",
        "pybullet",
        run,
        poses=POSES,
        settings=SETTINGS,
        own_process=True,
        doc="Bullet's multibody sequential-impulse contact solver; restitution and friction combined by product, "
        "damping 0, contacts only once touching",
    ),
}
