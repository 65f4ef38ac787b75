"""pymunk's bare loops for ``harness bench --engines``: a loop of ``space.step`` (a mode's
``velocity_func`` runs inside it) and, where the mode sets the force from Python before every step,
the same with that done first (``bare loop + force``)."""

from __future__ import annotations


def bare_loops(mode, pymunk, model, scene, dt: float):
    """([(name, once(n)), ...], what they are): the step-only loop first."""
    space = model.space

    def stepped(n):
        step = space.step
        for _ in range(n):
            step(dt)

    loops = [("space.step loop", stepped)]
    if model.apply_before_step is not None:
        apply = model.apply_before_step

        def forced(n):
            step = space.step
            for _ in range(n):
                apply()
                step(dt)

        loops.append(("bare loop + force", forced))
    return loops, "a Python loop of space.step (velocity_func runs inside it); with the force set first"
