"""Compiled driver: the same step functions and force kernels, compiled by numba.

Used for timing (``harness bench``, the cost measurement), so that the measured cost is
the scheme's and not the interpreter's. Each (scheme, scene) pair compiles once per
process (2-7 s of CPU on this project's 2-core machine): numba cannot cache functions
passed as arguments to disk, and its cache would not notice a change to a scheme's file
(a callee in another file), so a stale kernel could be timed.
"""
from __future__ import annotations

import time

import numpy as np

from scenarios import Scene

from ._integrate import iterations_for, newton_max

_DRIVERS: dict[tuple[str, str, bool], object] = {}
_JITTED: dict[object, object] = {}


def _jit(fn):
    """One numba dispatcher per Python function, shared by every driver of this process: a
    scene's ``accel`` compiled for one scheme serves the next, and the ``start``/``observe``
    most schemes share compile once per scene."""
    if fn not in _JITTED:
        import numba

        _JITTED[fn] = numba.njit(fn)
    return _JITTED[fn]


def _build(scheme, scene_cls, record=False):
    import numba

    jit = numba.njit
    step, start, observe = _jit(scheme.step), _jit(scheme.start), _jit(scheme.observe)
    accel, solve, project = _jit(scene_cls.accel), _jit(scene_cls.solve), _jit(scene_cls.project)

    # ``k`` is the one integer a scheme takes besides the state: Newton iterations allowed
    # (implicit) or projection passes (constrained); explicit schemes ignore it. The loop is
    # written out once per calling convention rather than through a shared ``advance``
    # wrapper: each compiled layer is optimised again with everything it calls. This and the
    # shared dispatchers took the compile of 18 pairs (6 schemes x spring, pendulum, Kepler,
    # one process) from 109 to 66 CPU seconds.
    if scheme.constrained:
        @jit
        def drive(q, v, t0, h, n, p, k):
            state = start(accel, q, v, t0, h, p)
            for i in range(n):
                state = step(accel, project, k, state, t0 + i * h, h, p)
            return observe(accel, state, t0 + n * h, h, p)

        @jit
        def drive_recording(q, v, t0, h, n, every, p, k):
            nrec = n // every + 1 + (1 if n % every else 0)
            qs = np.empty((nrec, q.shape[0], q.shape[1]))
            vs = np.empty((nrec, q.shape[0], q.shape[1]))
            state = start(accel, q, v, t0, h, p)
            qs[0], vs[0] = observe(accel, state, t0, h, p)
            r = 1
            for i in range(n):
                state = step(accel, project, k, state, t0 + i * h, h, p)
                if (i + 1) % every == 0 or i + 1 == n:
                    qs[r], vs[r] = observe(accel, state, t0 + (i + 1) * h, h, p)
                    r += 1
            return qs, vs
    elif scheme.implicit:
        @jit
        def drive(q, v, t0, h, n, p, k):
            state = start(accel, q, v, t0, h, p)
            for i in range(n):
                state = step(accel, solve, k, state, t0 + i * h, h, p)
            return observe(accel, state, t0 + n * h, h, p)

        @jit
        def drive_recording(q, v, t0, h, n, every, p, k):
            nrec = n // every + 1 + (1 if n % every else 0)
            qs = np.empty((nrec, q.shape[0], q.shape[1]))
            vs = np.empty((nrec, q.shape[0], q.shape[1]))
            state = start(accel, q, v, t0, h, p)
            qs[0], vs[0] = observe(accel, state, t0, h, p)
            r = 1
            for i in range(n):
                state = step(accel, solve, k, state, t0 + i * h, h, p)
                if (i + 1) % every == 0 or i + 1 == n:
                    qs[r], vs[r] = observe(accel, state, t0 + (i + 1) * h, h, p)
                    r += 1
            return qs, vs
    else:
        @jit
        def drive(q, v, t0, h, n, p, k):
            state = start(accel, q, v, t0, h, p)
            for i in range(n):
                state = step(accel, state, t0 + i * h, h, p)
            return observe(accel, state, t0 + n * h, h, p)

        @jit
        def drive_recording(q, v, t0, h, n, every, p, k):
            # Observed states at step 0, every ``every`` steps and step n, kernel layout (T, ndof, batch).
            nrec = n // every + 1 + (1 if n % every else 0)
            qs = np.empty((nrec, q.shape[0], q.shape[1]))
            vs = np.empty((nrec, q.shape[0], q.shape[1]))
            state = start(accel, q, v, t0, h, p)
            qs[0], vs[0] = observe(accel, state, t0, h, p)
            r = 1
            for i in range(n):
                state = step(accel, state, t0 + i * h, h, p)
                if (i + 1) % every == 0 or i + 1 == n:
                    qs[r], vs[r] = observe(accel, state, t0 + (i + 1) * h, h, p)
                    r += 1
            return qs, vs

    # numba compiles a function on its first call: the one not asked for costs nothing.
    return drive_recording if record else drive


def driver(scheme, scene: Scene, record: bool = False):
    """The compiled loop: ``drive(q, v, t0, h, n, p, k) -> (q, v)`` at step n, or with ``record``
    ``drive(q, v, t0, h, n, every, p, k) -> (qs, vs)`` (a separate compile, only when asked for)."""
    key = (scheme.id, scene.id, record)
    if key not in _DRIVERS:
        _DRIVERS[key] = _build(scheme, type(scene), record)
    return _DRIVERS[key]


def _k(scheme, scene: Scene, iterations: int | None) -> int:
    return iterations_for(scheme, iterations) if scheme.constrained else newton_max(scene)


def run_compiled_every(scheme, scene: Scene, dt: float, steps: int, every: int, q0=None, v0=None,
                       iterations: int | None = None):
    """(steps recorded, q, v) of a compiled run, recorded as ``integrate`` records (step 0, every
    ``every`` steps and the last); q, v in API layout (T, batch, ndof). No instability check:
    for stable runs where the interpreted path would be too slow."""
    if q0 is None or v0 is None:
        q0, v0 = scene.batch_state(1)
    q = np.ascontiguousarray(np.atleast_2d(q0).T, dtype=np.float64)
    v = np.ascontiguousarray(np.atleast_2d(v0).T, dtype=np.float64)
    steps, every = int(steps), int(every)
    qs, vs = driver(scheme, scene, record=True)(q, v, 0.0, float(dt), steps, every, scene.pvec,
                                                _k(scheme, scene, iterations))
    recorded = np.unique(np.append(np.arange(0, steps + 1, every), steps))
    return recorded, qs.transpose(0, 2, 1).copy(), vs.transpose(0, 2, 1).copy()


def run_compiled(scheme, scene: Scene, dt: float, steps: int, q0=None, v0=None, iterations: int | None = None):
    """Final (q, v) after ``steps`` compiled steps, API layout (batch, ndof)."""
    if q0 is None or v0 is None:
        q0, v0 = scene.batch_state(1)
    q = np.ascontiguousarray(np.atleast_2d(q0).T, dtype=np.float64)
    v = np.ascontiguousarray(np.atleast_2d(v0).T, dtype=np.float64)
    qf, vf = driver(scheme, scene)(q, v, 0.0, float(dt), int(steps), scene.pvec, _k(scheme, scene, iterations))
    return qf.T.copy(), vf.T.copy()


#: The clocks a timing can read: wall time, or the CPU time of this process (which a core
#: shared with other processes does not inflate: what the step itself costs).
CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def step_timer(scheme, scene: Scene, dt: float, steps: int, batch: int = 1, iterations: int | None = None,
               clock: str = "wall"):
    """``(warm-up seconds, once)``: the compiled loop called once to compile it, and ``once()``
    timing one call of ``steps`` steps on ``clock`` ("wall" or "cpu"), in seconds per step."""
    now = CLOCKS[clock]
    q0, v0 = scene.batch_state(batch)
    q = np.ascontiguousarray(q0.T)
    v = np.ascontiguousarray(v0.T)
    fn = driver(scheme, scene)
    p, k = scene.pvec, _k(scheme, scene, iterations)
    t_compile = now()
    fn(q, v, 0.0, float(dt), 2, p, k)
    t_compile = now() - t_compile

    def once() -> float:
        t = now()
        fn(q, v, 0.0, float(dt), int(steps), p, k)
        return (now() - t) / steps

    return t_compile, once


def time_per_step(scheme, scene: Scene, dt: float, steps: int, batch: int = 1, repeats: int = 5,
                  iterations: int | None = None, clock: str = "wall") -> dict:
    """Time per step of the compiled loop on ``clock`` ("wall" or "cpu"): one warm-up call
    (compiles), then the minimum over ``repeats`` timed calls (the least-disturbed run; asv
    and timeit do the same)."""
    t_compile, once = step_timer(scheme, scene, dt, steps, batch, iterations, clock)
    times = [once() for _ in range(repeats)]
    return {"s_per_step": min(times), "median_s_per_step": float(np.median(times)),
            "repeats": times, "warmup_s": t_compile, "batch": batch, "steps": steps, "clock": clock}
