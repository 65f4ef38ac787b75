"""Compiled driver: the same step functions and force kernels, compiled by numba.

Used for timing (``harness bench``, the cost measurement), so that the measured cost is
the scheme's and not the interpreter's, and for runs too long to interpret
(:func:`integrate_compiled`). Each (scheme, scene) pair compiles once per process (2-15 s):
numba cannot cache functions passed as arguments to disk.
"""
from __future__ import annotations

import time

import numpy as np

from scenarios import Scene, Trajectory
from scenarios.trajectory import OK, UNSTABLE, divergence_detail, diverged

from ._integrate import iterations_for, newton_max

_DRIVERS: dict[tuple[str, str], tuple] = {}


def _build(scheme, scene_cls):
    """Both compiled loops of one (scheme, scene) pair, built on the same compiled kernels:
    numba compiles lazily per dispatcher, so whichever loop runs second reuses the step
    functions and force kernels the first one compiled, and costs only its own loop."""
    import numba

    jit = numba.njit
    step, start, observe = jit(scheme.step), jit(scheme.start), jit(scheme.observe)
    accel, solve, project = jit(scene_cls.accel), jit(scene_cls.solve), jit(scene_cls.project)

    # ``k`` is the one integer a scheme takes besides the state: Newton iterations allowed
    # (implicit) or projection passes (constrained); explicit schemes ignore it.
    if scheme.constrained:
        @jit
        def advance(state, t, h, p, k):
            return step(accel, project, k, state, t, h, p)
    elif scheme.implicit:
        @jit
        def advance(state, t, h, p, k):
            return step(accel, solve, k, state, t, h, p)
    else:
        @jit
        def advance(state, t, h, p, k):
            return step(accel, state, t, h, p)

    @jit
    def advance_n(state, t0, h, i0, n, p, k):
        # Steps i0 .. i0 + n - 1 of a run started at t0: step i starts at t0 + i h, as in the
        # interpreted driver, so a run cut into pieces is the same run.
        for i in range(i0, i0 + n):
            state = advance(state, t0 + i * h, h, p, k)
        return state

    @jit
    def drive(q, v, t0, h, n, p, k):
        state = start(accel, q, v, t0, h, p)
        # np.int64(0), not 0: a literal would compile a second advance_n for calls from Python.
        state = advance_n(state, t0, h, np.int64(0), n, p, k)
        return observe(accel, state, t0 + n * h, h, p)

    return drive, _Pieces(start, advance_n, observe, accel)


class _Pieces:
    """The compiled parts of ``drive``, callable from Python: a recorded run calls them piece by
    piece and reuses what ``drive`` compiled (a second compiled loop would cost a second compile)."""

    def __init__(self, start, advance_n, observe, accel):
        self.start, self.advance_n, self.observe, self.accel = start, advance_n, observe, accel


def _parts(scheme, scene: Scene):
    key = (scheme.id, scene.id)
    if key not in _DRIVERS:
        _DRIVERS[key] = _build(scheme, type(scene))
    return _DRIVERS[key]


def driver(scheme, scene: Scene):
    """The compiled loop ``drive(q, v, t0, h, n, p, k) -> (q, v)``: observed state at step n."""
    return _parts(scheme, scene)[0]


def _k(scheme, scene: Scene, iterations: int | None) -> int:
    return iterations_for(scheme, iterations) if scheme.constrained else newton_max(scene)


def _kernel_layout(scene: Scene, q0, v0):
    if q0 is None or v0 is None:
        q0, v0 = scene.batch_state(1)
    q = np.ascontiguousarray(np.atleast_2d(q0).T, dtype=np.float64)
    v = np.ascontiguousarray(np.atleast_2d(v0).T, dtype=np.float64)
    return q, v


def _within(state) -> bool:
    return not diverged(state[0], state[1])


def run_compiled_every(scheme, scene: Scene, dt: float, steps: int, every: int, q0=None, v0=None,
                       iterations: int | None = None):
    """(steps recorded, q, v, failed step or None) of a compiled run, recorded as ``integrate``
    records (step 0, every ``every`` steps and the last) and stopped as it stops, at the first
    step whose state diverged; q, v in API layout (T, batch, ndof).

    The compiled loop runs from one recorded step to the next; only where a piece ends
    diverged is it replayed one step at a time from its start, to find the step (a state that
    passes ``DIVERGED`` and comes back within one piece would be missed: blow-ups do not)."""
    q, v = _kernel_layout(scene, q0, v0)
    steps, every = int(steps), int(every)
    drive, parts = _parts(scheme, scene)
    drive(q, v, 0.0, float(dt), 0, scene.pvec, _k(scheme, scene, iterations))  # compiles, or is compiled
    p, k, h = scene.pvec, _k(scheme, scene, iterations), float(dt)
    state = parts.start(parts.accel, q, v, 0.0, h, p)
    marks = np.unique(np.append(np.arange(0, steps + 1, every), steps))
    recorded, qs, vs = [0], [], []

    def record(n):
        qo, vo = parts.observe(parts.accel, state, n * h, h, p)
        qs.append(qo.T.copy())
        vs.append(vo.T.copy())

    record(0)
    failed = None
    with np.errstate(all="ignore"):
        for a, b in zip(marks[:-1], marks[1:]):
            a, b = int(a), int(b)
            nxt = parts.advance_n(state, 0.0, h, a, b - a, p, k)
            if not _within(nxt):
                for i in range(a, b):
                    state = parts.advance_n(state, 0.0, h, i, 1, p, k)
                    if not _within(state):
                        failed = i + 1
                        break
                break
            state = nxt
            recorded.append(b)
            record(b)
    return np.array(recorded, dtype=np.int64), np.array(qs), np.array(vs), failed


def integrate_compiled(scheme, scene: Scene, dt: float, steps: int, every: int = 1,
                       iterations: int | None = None) -> Trajectory:
    """``integrate`` on the compiled path: the same step functions and kernels, so the same
    states (bitwise, or within FMA contraction), the same recording and the same divergence
    stop, for runs too long to interpret (1e6 steps of a 6-body force). Force evaluations are
    not counted here (``force_evals`` None): the interpreted driver counts them."""
    recorded, q, v, failed = run_compiled_every(scheme, scene, dt, steps, every, iterations=iterations)
    status, detail = (UNSTABLE, divergence_detail(failed, failed * dt)) if failed else (OK, "")
    with np.errstate(over="ignore", invalid="ignore"):
        energy = scene.energy(q, v)
    meta = {"backend": "compiled", "steps_run": (failed - 1) if failed else steps, "params": dict(scene.values),
            "force_evals_reason": "compiled run: not counted (the interpreted driver counts them)"}
    if scheme.constrained:
        meta["iterations"] = iterations_for(scheme, iterations)
    return Trajectory(scene=scene.id, method=f"ref:{scheme.id}", dt=dt, steps=steps, every=every,
                      step=recorded.astype(np.int64), t=recorded * dt, q=q, v=v, energy=energy,
                      status=status, detail=detail, failed_step=failed, meta=meta)


def run_compiled(scheme, scene: Scene, dt: float, steps: int, q0=None, v0=None, iterations: int | None = None):
    """Final (q, v) after ``steps`` compiled steps, API layout (batch, ndof)."""
    q, v = _kernel_layout(scene, q0, v0)
    qf, vf = driver(scheme, scene)(q, v, 0.0, float(dt), int(steps), scene.pvec, _k(scheme, scene, iterations))
    return qf.T.copy(), vf.T.copy()


def time_per_step(scheme, scene: Scene, dt: float, steps: int, batch: int = 1, repeats: int = 5,
                  iterations: int | None = None) -> dict:
    """Wall time per step of the compiled loop: one warm-up call (compiles), then the
    minimum over ``repeats`` timed calls (the least-disturbed run; asv and timeit do the same)."""
    q0, v0 = scene.batch_state(batch)
    q = np.ascontiguousarray(q0.T)
    v = np.ascontiguousarray(v0.T)
    fn = driver(scheme, scene)
    p, k = scene.pvec, _k(scheme, scene, iterations)
    t_compile = time.perf_counter()
    fn(q, v, 0.0, float(dt), 2, p, k)
    t_compile = time.perf_counter() - t_compile
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn(q, v, 0.0, float(dt), int(steps), p, k)
        times.append((time.perf_counter() - t) / steps)
    return {"s_per_step": min(times), "median_s_per_step": float(np.median(times)),
            "repeats": times, "warmup_s": t_compile, "batch": batch, "steps": steps}
