"""Runs one method on one scene: in-process for reference schemes, in a worker process
for engines (an engine abort, segfault or hang becomes a recorded result)."""
from __future__ import annotations

from scenarios import Scene, Trajectory


def simulate(method, scene: Scene, dt: float, steps: int, every: int = 1, timeout: float | None = None) -> Trajectory:
    if getattr(method, "isolated", False):
        from .isolation import simulate_isolated

        return simulate_isolated(method.id, scene, dt, steps, every, timeout=timeout)
    return method.simulate(scene, dt, steps, every)
