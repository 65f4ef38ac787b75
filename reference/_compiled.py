"""Compiled driver: the same step functions and force kernels, compiled by numba, one loop per
(scheme, scene) pair for both its timings and its accuracy runs.

The timings (``harness bench``, the cost measurement) time the loop, so that the measured cost is
the scheme's and not the interpreter's; the accuracy runs (:func:`integrate_compiled`) record it
as the interpreted driver records. Where the loop computes the interpreted run's bits
(:func:`bitwise_why`, the one rule), a run on it is the interpreted run, its force evaluations,
solves and projections those the scheme declares (``reference._counts``; where they vary, an
interpreted counting run's); elsewhere the run is interpreted. The kernels of a pair come from
``reference._kernels``: generated from the scheme's and scene's source, cached on disk (a
pair compiles once per machine and source, then loads at a small fraction of that cost) and, on a
pointwise scene, run as a loop of scalars without array temporaries.
"""

from __future__ import annotations

import time

import numpy as np

from records import Trajectory

from scenarios import Scene, no_velocity_dependence
from records.trajectory import OK, UNSTABLE, RunMeta, divergence_detail, diverged, step_loop

from . import _codegen, _counts, _kernels
from ._scheme import observe_qv

#: One driver per (scheme, scene class) in this process: the Scheme object (a frozen dataclass
#: holding its functions), so a scheme re-imported from an edited file is a new key.
_DRIVERS: dict[tuple, _Compiled] = {}


class _Compiled:
    """The compiled pieces of one pair: ``start``, ``advance_n`` (the loop, called from Python)
    and ``observe``; ``warmup_s`` is the CPU time their first call took (compiling them, or
    loading them from the disk cache; ``reference._kernels.STATS`` says which)."""

    def __init__(self, kernels: _kernels.Kernels, scheme, scene: Scene):
        self.kernels = kernels
        self.advance_n = kernels.advance_n
        self.observes_qv = scheme.observe is observe_qv
        q, v = _kernel_layout(scene, None, None)
        h, p, k = 0.01 / scene.omega, scene.pvec, _k(scheme, scene, None)
        self.warmup_s = _kernels.warm(
            kernels, lambda: self.drive(q, v, 0.0, h, 2, p, k), label=f"{scheme.id} on {scene.id}"
        )

    def first_state(self, q, v, t0, h, p):
        return self.kernels.start(q, v, t0, h, p)

    def observe(self, state, t, h, p):
        """(q, v) a user sees of ``state`` at time t, kernel layout: the carried (q, v) themselves
        where the scheme observes those (``observe_qv``, what its compiled ``observe`` returns,
        without a call into it at every recorded step)."""
        if self.observes_qv:
            return state[0], state[1]
        return self.kernels.observe(state, t, h, p)

    def drive(self, q, v, t0, h, n, p, k):
        """Observed (q, v) at step n, kernel layout."""
        state = self.advance_n(self.first_state(q, v, t0, h, p), t0, h, 0, int(n), p, int(k))
        return self.observe(state, t0 + n * h, h, p)


def compiled_as(scheme, scene_cls):
    """The scheme whose kernel a pair compiles. A scheme that is, update for update, another
    where the force has no velocity dependence (``Scheme.same_without_velocity``: the velocity-
    implicit and the decaying kicks) compiles as that one on a scene class whose force never
    depends on the velocity (its damping rate is ``no_velocity_dependence``): the same bits (its
    solve divides by 1 + h 0 = 1, its decay multiplies by e^0 = 1, both exact; where a second
    Newton pass follows, on a nonlinear scene, its residual v + h a - w is w - w = 0 and its update
    an exact zero), without the solve or the exponential that a loop written for that scene would
    not have. Its counts are still its own (``reference._counts``)."""
    if scheme.same_without_velocity and scene_cls.damping_rate is no_velocity_dependence:
        return scheme.same_without_velocity
    return scheme


def _nstate(scheme, scene: Scene) -> int:
    q, v = _kernel_layout(scene, None, None)
    with np.errstate(all="ignore"):
        return len(scheme.start(scene.accel, q, v, 0.0, 0.01, scene.pvec))


def _parts(scheme, scene: Scene) -> _Compiled:
    key = (scheme, type(scene))
    if key not in _DRIVERS:
        scheme = compiled_as(scheme, type(scene))
        _DRIVERS[key] = _Compiled(_kernels.load(scheme, type(scene), _nstate(scheme, scene)), scheme, scene)
    return _DRIVERS[key]


def cache_state(scheme, scene: Scene) -> _kernels.Cached:
    """What this machine's disk cache holds of a pair's loop (of the file it comes from:
    ``compiled_as``) before anything loads it (``_kernels.Cached``); nothing is written or compiled."""
    loop = compiled_as(scheme, type(scene))
    return _kernels.cached(loop, type(scene), _nstate(loop, scene))


def driver(scheme, scene: Scene):
    """``drive(q, v, t0, h, n, p, k) -> (q, v)``: the observed state at step n, kernel layout."""
    return _parts(scheme, scene).drive


def _k(scheme, scene: Scene, iterations: int | None, substeps: int | None = None) -> int:
    """The integer the step takes (``Kind.count``), which every compiled loop passes."""
    return scheme.kind.count(scheme, scene, iterations, substeps)


def _kernel_layout(scene: Scene, q0, v0):
    if q0 is None or v0 is None:
        q0, v0 = scene.batch_state(1)
    q = np.ascontiguousarray(np.atleast_2d(q0).T, dtype=np.float64)
    v = np.ascontiguousarray(np.atleast_2d(v0).T, dtype=np.float64)
    return q, v


def _within(state) -> bool:
    return not diverged(state[0], state[1])


#: The kernels a scene gives a scheme, which a compiled loop takes from the scene's class.
_SCENE_KERNELS = ("accel", "solve", "project", "damping_rate", "constraints")


def bitwise_why(scheme, scene: Scene, q0=None, iterations: int | None = None, substeps: int | None = None) -> str:
    """Why the pair's compiled loop might compute other bits than the interpreted driver on a run
    from ``q0`` (default: the scene's state), or "" where it computes the same: the one rule that
    sends a reference run to the interpreter. The loop's source is judged operation by operation
    (``reference._bitwise``: a reduction, ``**``, a call not known to round alike), the library
    functions it calls are checked against numpy on this machine (``reference._libm``), the scene
    must not override its kernels on the instance (the loop takes its class's), and the pointwise
    loop, which ends each entry's Newton iteration on that entry's own update, must have one entry
    or one iteration (the interpreted step ends it on the largest update over every entry).
    Nothing is compiled."""
    for name in _SCENE_KERNELS:
        if name in vars(scene):
            return f"scene {scene.id} overrides its {name} on the instance: the kernels are the class's"
    loop = compiled_as(scheme, type(scene))
    try:
        made = _codegen.kernel_file(loop, type(scene), _nstate(loop, scene))
    except _codegen.SourceUnavailable as exc:
        return f"its loop is compiled in memory from the function objects, not checked: {exc}"
    if made.bitwise_why:
        return made.bitwise_why
    from . import _libm

    for f in made.libm:
        if not _libm.agrees(f):
            return f"numba's {f} gives other bits than numpy's on this machine"
    entries = scene.ndof if q0 is None else np.size(q0)
    if made.pointwise and loop.kind.implicit and entries > 1 and _k(loop, scene, iterations, substeps) > 1:
        return (
            "the pointwise loop ends each entry's Newton iteration on its own update, the interpreted step "
            f"on the largest over all {entries} entries"
        )
    return ""


def run_compiled_every(
    scheme,
    scene: Scene,
    dt: float,
    steps: int,
    every: int,
    q0=None,
    v0=None,
    t0: float = 0.0,
    iterations: int | None = None,
    substeps: int | None = None,
):
    """(steps recorded, q, v, failed step or None) of a compiled run, recorded as ``integrate``
    records (step 0, every ``every`` steps and the last) and stopped as it stops, at the first
    step whose state diverged; q, v in API layout (T, batch, ndof).

    The compiled loop runs from one recorded step to the next (``step_loop``'s spans); only where a
    span ends diverged is it replayed one step at a time from its start, to find the step (a state
    that passed the bound and came back within one span would go unseen: blow-ups do not come back)."""
    q, v = _kernel_layout(scene, q0, v0)
    steps, every, t0 = int(steps), int(every), float(t0)
    parts = _parts(scheme, scene)
    p, k, h = scene.pvec, _k(scheme, scene, iterations, substeps), float(dt)
    now = {"state": parts.first_state(q, v, t0, h, p)}
    now["good"] = now["state"]  # the state at the last recorded step, where a failed span restarts
    recorded, qs, vs = [], [], []

    def advance(a, b):
        now["state"] = parts.advance_n(now["state"], t0, h, a, b - a, p, k)

    def record(n):
        # The loop never writes into a state it was given or returned, so a record keeps the
        # observed arrays as they are; they are laid out as the interpreted driver's once, at the end.
        now["good"] = now["state"]
        qo, vo = parts.observe(now["state"], t0 + n * h, h, p)
        recorded.append(n)
        qs.append(qo)
        vs.append(vo)

    def rewind():
        now["state"] = now["good"]

    with np.errstate(all="ignore"):
        failed, _ = step_loop(
            advance,
            lambda n: "" if _within(now["state"]) else "diverged",
            record,
            steps,
            every,
            spans=True,
            rewind=rewind,
        )
    return (
        np.array(recorded, dtype=np.int64),
        np.ascontiguousarray(np.array(qs).transpose(0, 2, 1)),
        np.ascontiguousarray(np.array(vs).transpose(0, 2, 1)),
        failed,
    )


def integrate_compiled(
    scheme,
    scene: Scene,
    dt: float,
    steps: int,
    every: int = 1,
    q0=None,
    v0=None,
    t0: float = 0.0,
    iterations: int | None = None,
    substeps: int | None = None,
    counted: bool = False,
) -> Trajectory:
    """``integrate`` on the pair's compiled loop: the same step functions and kernels, the same
    recording and the same divergence stop; the same states, bit for bit, where
    :func:`bitwise_why` finds nothing (the caller asks). ``counted``: with the force evaluations,
    solves and projections the interpreted run counts, where the scheme declares them (``reference._counts``:
    where they vary, ``force_evals`` None and the reason); else none (``force_evals`` None), for
    runs too long to interpret whatever their bits."""
    steps, every, t0 = int(steps), int(every), float(t0)
    recorded, q, v, failed = run_compiled_every(scheme, scene, dt, steps, every, q0, v0, t0, iterations, substeps)
    status, detail = (UNSTABLE, divergence_detail(failed, t0 + failed * dt)) if failed else (OK, "")
    with np.errstate(over="ignore", invalid="ignore"):
        energy = scene.energy(q, v)
    meta = RunMeta(
        backend="compiled",
        steps_run=(failed - 1) if failed else steps,
        params=dict(scene.values),
        iterations=scheme.kind.run_iterations(scheme, iterations),
        force_evals_reason="compiled run: not counted (the interpreted driver counts them)",
    )
    counts = _counts.of_run(scheme, scene, failed or steps, iterations, substeps) if counted else None
    if counted:
        meta.start_force_evals = _counts.start_evaluations(scheme, scene, *_kernel_layout(scene, q0, v0), t0, dt)
        meta.force_evals_reason = None if counts is not None else _counts.VARYING
    if counts is not None and "project" in scheme.kind.kernels:
        meta.projections = counts.projections
    return Trajectory(
        scene=scene.id,
        method=f"ref:{scheme.id}",
        dt=dt,
        steps=steps,
        every=every,
        step=recorded,
        t=t0 + recorded * dt,
        q=q,
        v=v,
        energy=energy,
        status=status,
        detail=detail,
        failed_step=failed,
        force_evals=counts.force_evals if counts else None,
        solves=counts.solves if counts else None,
        meta=meta,
    )


def run_compiled(
    scheme,
    scene: Scene,
    dt: float,
    steps: int,
    q0=None,
    v0=None,
    iterations: int | None = None,
    substeps: int | None = None,
):
    """Final (q, v) after ``steps`` compiled steps, API layout (batch, ndof)."""
    q, v = _kernel_layout(scene, q0, v0)
    qf, vf = driver(scheme, scene)(
        q, v, 0.0, float(dt), int(steps), scene.pvec, _k(scheme, scene, iterations, substeps)
    )
    return qf.T.copy(), vf.T.copy()


#: The clocks a timing can read: wall time, or the CPU time of this process (which a core
#: shared with other processes does not inflate: what the step itself costs).
CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def step_timer(
    scheme,
    scene: Scene,
    dt: float,
    steps: int,
    batch: int = 1,
    iterations: int | None = None,
    clock: str = "wall",
    substeps: int | None = None,
):
    """``(warm-up seconds, once)``: the compiled loop (``advance_n`` from the first state) called
    once to compile it, and ``once(n=steps)`` timing one call of n steps on ``clock`` ("wall" or
    "cpu"), in seconds per step."""
    now = CLOCKS[clock]
    q0, v0 = scene.batch_state(batch)
    q = np.ascontiguousarray(q0.T)
    v = np.ascontiguousarray(v0.T)
    t_compile = now()
    parts = _parts(scheme, scene)
    p, k, h = scene.pvec, _k(scheme, scene, iterations, substeps), float(dt)
    state = parts.first_state(q, v, 0.0, h, p)
    parts.observe(parts.advance_n(state, 0.0, h, 0, 2, p, k), 2 * h, h, p)
    t_compile = now() - t_compile

    def once(n: int = steps) -> float:
        t = now()
        parts.advance_n(state, 0.0, h, 0, int(n), p, k)
        return (now() - t) / n

    return t_compile, once


def time_per_step(
    scheme,
    scene: Scene,
    dt: float,
    steps: int,
    batch: int = 1,
    repeats: int = 5,
    iterations: int | None = None,
    clock: str = "wall",
    substeps: int | None = None,
) -> dict:
    """Time per step of the compiled loop on ``clock`` ("wall" or "cpu"): one warm-up call
    (compiles), then the minimum over ``repeats`` timed calls (the least-disturbed run; asv
    and timeit do the same)."""
    t_compile, once = step_timer(scheme, scene, dt, steps, batch, iterations, clock, substeps)
    times = [once() for _ in range(repeats)]
    return {
        "s_per_step": min(times),
        "median_s_per_step": float(np.median(times)),
        "repeats": times,
        "warmup_s": t_compile,
        "batch": batch,
        "steps": steps,
        "clock": clock,
    }
