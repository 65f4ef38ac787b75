"""pybullet's bare loops for ``harness bench --engines``: a loop of ``stepSimulation``, and on the
undamped spring the same with the spring force read and applied before each step (``bare loop +
force``: the least Python can do where Bullet has no spring)."""

from __future__ import annotations


def bare_loops(mode, p, model, scene, dt: float):
    """([(name, once(n)), ...], what they are): the step-only loop first."""
    cid, body = model.cid, model.body
    k = model.k

    def stepped(n):
        step = p.stepSimulation
        for _ in range(n):
            step(physicsClientId=cid)

    def forced(n):
        step, get, apply, frame = p.stepSimulation, p.getBasePositionAndOrientation, p.applyExternalForce, p.WORLD_FRAME
        for _ in range(n):
            pos = get(body, physicsClientId=cid)[0]
            apply(body, -1, [-k * pos[0], 0.0, 0.0], pos, frame, physicsClientId=cid)
            step(physicsClientId=cid)

    loops = [("stepSimulation loop", stepped)]
    if getattr(model, "spring_alone", False):  # the force -k x alone, as the spring pose applies it
        loops.append(("bare loop + force", forced))
    return loops, "a Python loop of stepSimulation; the same with the spring force read and applied"
