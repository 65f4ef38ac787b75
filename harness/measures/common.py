"""What every measurement shares: resolving a method and a scene, stepping through the
runner, and turning results into JSON-ready dicts and tidy DataFrames.

Every measure is a plain function ``measure(method, scene, **settings) -> dict``: the
method is an id (``ref:rk4``, ``mujoco:euler``) or a method object (a ``records.Method``, or
anything with ``id``, ``available()``, ``supports(scene)``, ``simulate(scene, dt, steps, every)``
and ``describe()``, its other capabilities then defaulted by ``harness.methods.as_method``),
the scene is a :class:`scenarios.Scene`. Methods are always stepped through
:func:`harness.execution.simulate.simulate`, so engine modes run isolated exactly as in ``harness run``.
Results are plain dicts; :mod:`harness.measures.frames` turns them into JSON and DataFrames.
"""

from __future__ import annotations

import copy

import numpy as np

from records import InvalidInput, Method, Trajectory

from scenarios import Scene, make_scene

from harness.methods import as_method, check_supported, get_method
from harness.execution.simulate import simulate


def resolve(method, scene: Scene) -> Method:
    """The method object for ``method`` (an id or an object), checked against ``scene``."""
    method = get_method(method) if isinstance(method, str) else as_method(method)
    check_supported(method, scene)
    return method


def require_fixed_step(method: Method, measure: str) -> None:
    """An adaptive method (IAS15) picks its own steps and takes dt as its output interval, so
    a measure of behaviour against dt does not apply: say so before stepping anything."""
    if method.adaptive:
        raise InvalidInput(
            f"method {method.id} chooses its own steps (dt is only its output interval): "
            f"{measure} against dt does not apply"
        )


def step(method, scene: Scene, dt: float, steps: int, every: int = 1, timeout: float | None = None) -> Trajectory:
    return simulate(method, scene, float(dt), int(steps), int(every), timeout=timeout)


def declared_order(method: Method, scene: Scene | None = None) -> int | None:
    """The order a method declares (a reference scheme's ``order``, or on a ``scene`` whose force
    depends on the velocity its ``order_velocity_dependent``; ``order`` in an engine mode's
    ``describe()``), or None."""
    scheme = method.scheme
    if scheme is not None:
        return int(scheme.order_for(scene is not None and scene.velocity_dependent))
    order = method.describe().get("order")
    return int(order) if isinstance(order, (int, float)) and not isinstance(order, bool) else None


def scaled_state(scene: Scene, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``y = (q, v/omega)``: positions and velocities in the same units, so one norm measures both."""
    return np.concatenate([q, v / scene.omega], axis=-1)


def started_at(scene: Scene, q0, v0) -> Scene:
    """A copy of ``scene`` that starts from ``(q0, v0)`` (each of shape (ndof,)).

    Where the scene's own parameters encode its initial state (``x0``/``v0`` of the 1-DOF
    springs) the copy is made through them, so it survives an engine worker re-creating
    the scene from ``(id, values)``. Otherwise ``initial_state`` is overridden on a copy,
    which only an in-process method sees; ``state_in_params`` says which.
    """
    q0 = np.asarray(q0, dtype=float).reshape(-1)
    v0 = np.asarray(v0, dtype=float).reshape(-1)
    if scene.ndof == 1 and {"x0", "v0"} <= set(scene.params):
        try:
            moved = make_scene(scene.id, **{**scene.values, "x0": float(q0[0]), "v0": float(v0[0])})
        except InvalidInput:
            moved = None
        if moved is not None:
            q, v = moved.initial_state()
            if np.array_equal(q, q0) and np.array_equal(v, v0):
                moved.state_in_params = True
                return moved
    moved = copy.copy(scene)
    moved.initial_state = lambda: (q0.copy(), v0.copy())
    moved.state_in_params = False
    return moved
