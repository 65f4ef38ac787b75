"""Runs one method on one scene: in-process for reference schemes, in a worker process
for engines (an engine abort, segfault or hang becomes a recorded result)."""
from __future__ import annotations

from records import Method, Trajectory

from scenarios import Scene

from harness import validate


def simulate(method: Method, scene: Scene, dt: float, steps: int, every: int = 1, timeout: float | None = None) -> Trajectory:
    """Validate the inputs (InvalidInput, one line), then step ``method`` on ``scene``.
    Nothing reaches an engine that validation would refuse: some engines abort the whole
    process on bad input (pymunk on a negative mass) or never return (REBOUND with dt = 0)."""
    dt = validate.positive_finite("dt", dt)
    steps = validate.count("steps", steps, 0)
    every = validate.count("every", every, 1)
    validate.scene_values(scene)
    if method.isolated:
        from harness.execution import isolation

        if not isolation.IN_WORKER:
            return isolation.simulate_isolated(method, scene, dt, steps, every, timeout=timeout)
    return method.simulate(scene, dt, steps, every)
