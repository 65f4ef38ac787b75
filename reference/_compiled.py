"""Compiled driver: the same step functions and force kernels, compiled by numba.

Used for timing (``harness bench``, the cost measurement), so that the measured cost is
the scheme's and not the interpreter's. Each (scheme, scene) pair compiles once per
process (about 2 s): numba cannot cache functions passed as arguments to disk.
"""
from __future__ import annotations

import time

import numpy as np

from scenarios import Scene

from ._integrate import newton_max

_DRIVERS: dict[tuple[str, str], object] = {}


def _build(scheme, scene_cls):
    import numba

    jit = numba.njit
    step, start, observe = jit(scheme.step), jit(scheme.start), jit(scheme.observe)
    accel, solve = jit(scene_cls.accel), jit(scene_cls.solve)

    if scheme.implicit:
        @jit
        def advance(state, t, h, p, nmax):
            return step(accel, solve, nmax, state, t, h, p)
    else:
        @jit
        def advance(state, t, h, p, nmax):
            return step(accel, state, t, h, p)

    @jit
    def drive(q, v, t0, h, n, p, nmax):
        state = start(accel, q, v, t0, h, p)
        for i in range(n):
            state = advance(state, t0 + i * h, h, p, nmax)
        return observe(accel, state, t0 + n * h, h, p)

    return drive


def driver(scheme, scene: Scene):
    key = (scheme.id, scene.id)
    if key not in _DRIVERS:
        _DRIVERS[key] = _build(scheme, type(scene))
    return _DRIVERS[key]


def run_compiled(scheme, scene: Scene, dt: float, steps: int, q0=None, v0=None):
    """Final (q, v) after ``steps`` compiled steps, API layout (batch, ndof)."""
    if q0 is None or v0 is None:
        q0, v0 = scene.batch_state(1)
    q = np.ascontiguousarray(np.atleast_2d(q0).T, dtype=np.float64)
    v = np.ascontiguousarray(np.atleast_2d(v0).T, dtype=np.float64)
    qf, vf = driver(scheme, scene)(q, v, 0.0, float(dt), int(steps), scene.pvec, newton_max(scene))
    return qf.T.copy(), vf.T.copy()


def time_per_step(scheme, scene: Scene, dt: float, steps: int, batch: int = 1, repeats: int = 5) -> dict:
    """Wall time per step of the compiled loop: one warm-up call (compiles), then the
    minimum over ``repeats`` timed calls (the least-disturbed run; asv and timeit do the same)."""
    q0, v0 = scene.batch_state(batch)
    q = np.ascontiguousarray(q0.T)
    v = np.ascontiguousarray(v0.T)
    fn = driver(scheme, scene)
    p, nmax = scene.pvec, newton_max(scene)
    t_compile = time.perf_counter()
    fn(q, v, 0.0, float(dt), 2, p, nmax)
    t_compile = time.perf_counter() - t_compile
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn(q, v, 0.0, float(dt), int(steps), p, nmax)
        times.append((time.perf_counter() - t) / steps)
    return {"s_per_step": min(times), "median_s_per_step": float(np.median(times)),
            "repeats": times, "warmup_s": t_compile, "batch": batch, "steps": steps}
