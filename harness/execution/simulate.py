"""Runs one method on one scene: in-process for reference schemes, in a worker process
for engines (an engine abort, segfault or hang becomes a recorded result)."""

from __future__ import annotations

from records import Method, Trajectory
from records.trajectory import RunMeta

from scenarios import Scene

from harness import validate


def simulate(
    method: Method, scene: Scene, dt: float, steps: int, every: int = 1, timeout: float | None = None
) -> Trajectory:
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
            return simulate_isolated(method, scene, dt, steps, every, timeout=timeout)
    return method.simulate(scene, dt, steps, every)


def _simulate(method_id: str, scene: Scene, dt: float, steps: int, every: int) -> Trajectory:
    from harness.methods import get_method

    return get_method(method_id).simulate(scene, dt, steps, every)


def simulate_isolated(
    method: Method | str, scene: Scene, dt: float, steps: int, every: int = 1, timeout: float | None = None
) -> Trajectory:
    """Step an engine mode (a method, or its id) in a worker, which looks it up again by its id;
    a crash or a hang comes back as a failed Trajectory."""
    from harness.execution.isolation import DEFAULT_TIMEOUT_S, WorkerFailure, run_in_worker

    if isinstance(method, str):
        from harness.methods import get_method

        method = get_method(method)
    limit = DEFAULT_TIMEOUT_S if timeout is None else timeout
    out = run_in_worker(_simulate, (method.id, scene, dt, steps, every), timeout=limit)
    if isinstance(out, WorkerFailure):
        # A failed run, too, says which engine and settings (a plugin's method may leave them out).
        info = {"engine": None, "engine_version": None, "settings": None, **method.describe()}
        meta = RunMeta(
            backend="engine",
            engine=info["engine"],
            engine_version=info["engine_version"],
            settings=info["settings"],
            worker=out.as_dict(),
            params=dict(scene.values),
        )
        return Trajectory.failed(
            scene.id, method.id, dt, steps, out.status, out.detail, every=every, ndof=scene.ndof, meta=meta
        )
    return out
