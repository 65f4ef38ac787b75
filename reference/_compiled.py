"""Compiled driver: the same step functions and force kernels, compiled by numba.

Used for timing (``harness bench``, the cost measurement), so that the measured cost is
the scheme's and not the interpreter's, and for runs too long to interpret
(:func:`integrate_compiled`). The kernels of a (scheme, scene) pair come from
``reference._kernels``: generated from the scheme's and scene's source, cached on disk (a
pair compiles once per machine and source, then loads at a small fraction of that cost) and, on a
pointwise scene, run as a loop of scalars without array temporaries.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from records import Trajectory

from scenarios import Scene, no_velocity_dependence
from records.trajectory import OK, UNSTABLE, RunMeta, divergence_detail, diverged, output_marks, step_loop

from . import _kernels

#: One driver per (scheme, scene class) in this process: the Scheme object (a frozen dataclass
#: holding its functions), so a scheme re-imported from an edited file is a new key.
_DRIVERS: dict[tuple, "_Compiled"] = {}


class _Compiled:
    """The compiled pieces of one pair: ``start``, ``advance_n`` (the loop, called from Python)
    and ``observe``; ``warmup_s`` is the CPU time their first call took (compiling them, or
    loading them from the disk cache; ``reference._kernels.STATS`` says which)."""

    def __init__(self, kernels: _kernels.Kernels, scheme, scene: Scene):
        self.kernels = kernels
        self.advance_n = kernels.advance_n
        q, v = _kernel_layout(scene, None, None)
        h, p, k = 0.01 / scene.omega, scene.pvec, _k(scheme, scene, None)
        self.warmup_s = _kernels.warm(kernels, lambda: self.drive(q, v, 0.0, h, 2, p, k),
                                      label=f"{scheme.id} on {scene.id}")

    def first_state(self, q, v, t0, h, p):
        return self.kernels.start(q, v, t0, h, p)

    def observe(self, state, t, h, p):
        """(q, v) a user sees of ``state`` at time t, kernel layout."""
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
    solve divides by 1 + h 0 = 1, its decay multiplies by e^0 = 1, both exact), without the
    solve or the exponential that a loop written for that scene would not have."""
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


def cache_state(scheme, scene: Scene) -> tuple[_kernels.Cached, _kernels.Cached]:
    """What this machine's disk cache holds of a pair before anything loads it
    (``_kernels.Cached``): of the file its timing loop comes from (``compiled_as``), and of the
    file its counted run comes from; nothing is written or compiled."""
    timing = compiled_as(scheme, type(scene))
    return (_kernels.cached(timing, type(scene), _nstate(timing, scene)),
            _kernels.cached(scheme, type(scene), _nstate(scheme, scene)))


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


def run_compiled_every(scheme, scene: Scene, dt: float, steps: int, every: int, q0=None, v0=None,
                       iterations: int | None = None, substeps: int | None = None):
    """(steps recorded, q, v, failed step or None) of a compiled run, recorded as ``integrate``
    records (step 0, every ``every`` steps and the last) and stopped as it stops, at the first
    step whose state diverged; q, v in API layout (T, batch, ndof).

    The compiled loop runs from one recorded step to the next (``step_loop``'s spans); only where a
    span ends diverged is it replayed one step at a time from its start, to find the step."""
    q, v = _kernel_layout(scene, q0, v0)
    steps, every = int(steps), int(every)
    parts = _parts(scheme, scene)
    p, k, h = scene.pvec, _k(scheme, scene, iterations, substeps), float(dt)
    now = {"state": parts.first_state(q, v, 0.0, h, p)}
    now["good"] = now["state"]  # the state at the last recorded step, where a failed span restarts
    recorded, qs, vs = [], [], []

    def advance(a, b):
        now["state"] = parts.advance_n(now["state"], 0.0, h, a, b - a, p, k)

    def record(n):
        now["good"] = now["state"]
        qo, vo = parts.observe(now["state"], n * h, h, p)
        recorded.append(n)
        qs.append(qo.T.copy())
        vs.append(vo.T.copy())

    def rewind():
        now["state"] = now["good"]

    with np.errstate(all="ignore"):
        failed, _ = step_loop(advance, lambda n: "" if _within(now["state"]) else "diverged", record, steps, every,
                              spans=True, rewind=rewind)
    return np.array(recorded, dtype=np.int64), np.array(qs), np.array(vs), failed


def integrate_compiled(scheme, scene: Scene, dt: float, steps: int, every: int = 1,
                       iterations: int | None = None, substeps: int | None = None) -> Trajectory:
    """``integrate`` on the compiled path: the same step functions and kernels, so the same
    states (bitwise, or within FMA contraction), the same recording and the same divergence
    stop, for runs too long to interpret (1e6 steps of a 6-body force). Force evaluations are
    not counted here (``force_evals`` None): the interpreted driver counts them."""
    recorded, q, v, failed = run_compiled_every(scheme, scene, dt, steps, every, iterations=iterations,
                                                  substeps=substeps)
    status, detail = (UNSTABLE, divergence_detail(failed, failed * dt)) if failed else (OK, "")
    with np.errstate(over="ignore", invalid="ignore"):
        energy = scene.energy(q, v)
    meta = RunMeta(backend="compiled", steps_run=(failed - 1) if failed else steps, params=dict(scene.values),
                   force_evals_reason="compiled run: not counted (the interpreted driver counts them)",
                   iterations=scheme.kind.run_iterations(scheme, iterations))
    return Trajectory(scene=scene.id, method=f"ref:{scheme.id}", dt=dt, steps=steps, every=every,
                      step=recorded.astype(np.int64), t=recorded * dt, q=q, v=v, energy=energy,
                      status=status, detail=detail, failed_step=failed, meta=meta)


# ------------------------------------------------------------------ the exact compiled run
#: (scheme, scene class) -> (its kernels, why its counted run might not compute the interpreted
#: bits, "" where it does), for this process.
_COUNTED: dict[tuple, tuple] = {}
#: (scheme, scene class) -> its kernel file, loaded (not compiled), for this process.
_LOADED: dict[tuple, _kernels.Kernels] = {}
NOT_YET = "its counted kernel is not compiled on this machine yet"


#: (scheme, scene class) -> [CPU seconds, steps] this process spent interpreting the pair's runs
#: where its counted kernel was not compiled (``Exact.interpreted``): what the pair has cost so far,
#: and its rate, seconds per step.
_INTERPRETED: dict[tuple, list] = {}
#: CPU seconds compiling a pair's counted run is expected to take, by its loop (``reference._kernels``),
#: at the kernels' optimisation level (``reference._numba_config``): estimates from measured compiles
#: (docs/performance.md), an array loop about three times a pointwise one.
COUNTED_COMPILE_S = {"pointwise": 0.5, "array": 1.5}
#: Steps of the interpreted run that measures a pair's rate before its first run is decided
#: (``Exact.wants_rate``): its seconds per step come within about 30% of a long run's, at a small
#: share of a run's cost (a larger one on the cloth, whose interpreted step is the slowest).
PROBE_STEPS = 32


def counted_compile_s(scheme, scene: Scene) -> float:
    """What compiling the pair's counted run is expected to cost, CPU seconds."""
    return COUNTED_COMPILE_S["pointwise" if scheme.kind.pointwise(type(scene)) else "array"]


@dataclass(frozen=True)
class Exact:
    """The reference backend that steps on :func:`integrate_exact` wherever it computes the
    interpreted run's bits, and interpreted elsewhere: the same numbers in a fraction of the
    time (``RefMethod(..., exact=Exact(...))``). ``compile_for``: the scheme ids whose counted
    kernels may be compiled here (a few seconds each, once per machine; None: any); the others
    take theirs only where an earlier run compiled them, and are interpreted until then (the
    nightly's task for a scheme compiles its own, not the engine tasks that compare with every
    scheme). ``after_interpreting``: those of them whose pair is new to the disk cache, and
    whose compile may never be used again (a machine that keeps no cache): such a pair compiles
    before the run that would bring what interpreting it has cost, with that run, to what
    compiling would cost (``counted_compile_s``), the run's cost predicted from the pair's rate
    so far (a short run measures it first: ``wants_rate``). So it costs at most about twice the
    cheaper of the two (the ski-rental rule), and compiles at once where its first run alone
    would cost more interpreted than compiling."""

    compile_for: frozenset | None = None
    after_interpreting: frozenset = frozenset()
    #: Also defer every pair that is new to the disk cache, asked pair by pair when it first runs
    #: here (the nightly's rule, ``harness.nightly.kernels.plan``, for a command that cannot know
    #: its pairs before it starts: ``harness identify`` steps every scheme).
    new_to_cache: bool = False
    #: Steps of the interpreted run that measures a deferred pair's rate (``wants_rate``).
    probe_steps: int = PROBE_STEPS

    def _allowed(self, scheme) -> bool:
        return self.compile_for is None or scheme.id in self.compile_for

    def _deferred(self, scheme, scene: Scene | None) -> bool:
        if scene is None or not self._allowed(scheme):
            return False
        return scheme.id in self.after_interpreting or (self.new_to_cache and _new_to_cache(scheme, scene))

    def may_compile(self, scheme, scene: Scene | None = None, steps: int = 0) -> bool:
        """Whether the pair's counted run may compile before a run of ``steps`` steps."""
        if not self._deferred(scheme, scene):
            return self._allowed(scheme)
        spent, done = _INTERPRETED.get((scheme, type(scene)), (0.0, 0))
        ahead = spent / done * steps if done else 0.0
        return spent + ahead >= counted_compile_s(scheme, scene)

    def wants_rate(self, scheme, scene: Scene) -> bool:
        """Whether the pair's next run is to be decided (``may_compile``) with no rate yet: its
        compile is deferred, it has neither run interpreted nor compiled its counted run here."""
        key = (scheme, type(scene))
        return self._deferred(scheme, scene) and key not in _INTERPRETED and key not in _COUNTED

    @staticmethod
    def interpreted(scheme, scene: Scene, seconds: float, steps: int = 0) -> None:
        """Count ``seconds`` of CPU spent interpreting ``steps`` steps of the pair (``may_compile``)."""
        spent = _INTERPRETED.setdefault((scheme, type(scene)), [0.0, 0])
        spent[0] += seconds
        spent[1] += steps


#: (scheme, scene class) -> whether its kernel file was missing from the disk cache when this
#: process first asked (``Exact.new_to_cache``): an interpreted run writes the file, which must not
#: turn the pair into one "in the cache" halfway through a command.
_NEW: dict[tuple, bool] = {}


def _new_to_cache(scheme, scene: Scene) -> bool:
    key = (scheme, type(scene))
    if key not in _NEW:
        _NEW[key] = not cache_state(scheme, scene)[1].file
    return _NEW[key]


def _counted_parts(scheme, scene: Scene, may_compile: bool = True) -> tuple:
    """(kernels, why not) of a pair, its counted run warmed (compiled, or loaded from the disk
    cache) where it is exact; NOT_YET, not remembered, where it would have to be compiled
    and ``may_compile`` is False (``Exact.may_compile``)."""
    key = (scheme, type(scene))
    if key in _COUNTED:
        return _COUNTED[key]
    q, v = _kernel_layout(scene, None, None)
    if key not in _LOADED:  # written and imported once: a NOT_YET pair is asked again at every run
        _LOADED[key] = _kernels.load(scheme, type(scene), _nstate(scheme, scene))
    kernels = _LOADED[key]
    why = kernels.exact_why
    if not why:
        from . import _libm

        why = next((f"numba's {f} gives other bits than numpy's on this machine"
                    for f in kernels.libm if not _libm.agrees(f)), "")
    if not why:
        if not (may_compile or kernels.counted_compiled()):
            return kernels, NOT_YET
        k = _k(scheme, scene, None)
        out = np.empty((3,) + q.shape)
        with np.errstate(all="ignore"):  # two steps, in the variant batch-one runs take
            _kernels.warm(kernels, lambda: _counted_run(kernels, q, v, 0.0, 0.01 / scene.omega, 2, 1, scene.pvec,
                                                        int(k), out, out.copy()),
                          kernels.counted_dispatchers(), counted=True, label=f"{scheme.id} on {scene.id}")
        kernels.mark_counted()
    _COUNTED[key] = (kernels, why)
    return _COUNTED[key]


def _counted_run(kernels, q, v, t0, h, n, every, p, k, out_q, out_v) -> tuple[int, int, int, np.ndarray]:
    """(force evaluations of the start, rows recorded, failing step or 0, the run's counts) of
    ``run_counted`` from (q, v) (kernel layout), on floats (``run_counted_one``) where the
    scene is pointwise and the run has one entry."""
    cnt = np.zeros(3, np.int64)
    one = kernels.run_counted_one is not None and q.size == 1
    state = kernels.start_counted(cnt, *((q[0, 0], v[0, 0]) if one else (q, v)), t0, h, p)
    start_evals = int(cnt[0])
    cnt[:] = 0
    if one:
        recorded, failed = kernels.run_counted_one(state, t0, h, n, every, p, k, out_q, out_v, cnt)
    else:
        _, recorded, failed = kernels.run_counted(state, t0, h, n, every, p, k, out_q, out_v, cnt)
    return start_evals, int(recorded), int(failed), cnt


def exact_why(scheme, scene: Scene, may_compile: bool = True) -> str:
    """Why :func:`integrate_exact` does not run ``scheme`` on ``scene`` here ("" where it does;
    ``may_compile`` False: NOT_YET where its counted kernel would have to be compiled first)."""
    for name in ("accel", "solve", "project", "damping_rate", "constraints"):
        if name in vars(scene):
            return f"scene {scene.id} overrides its {name} on the instance: the kernels are the class's"
    return _counted_parts(scheme, scene, may_compile)[1]


def integrate_exact(scheme, scene: Scene, dt: float, steps: int, every: int = 1, q0=None, v0=None,
                    t0: float = 0.0, iterations: int | None = None, may_compile: bool = True,
                    substeps: int | None = None) -> Trajectory | None:
    """``reference.integrate`` compiled: the same trajectory, bit for bit, with the same force
    evaluations, solves and projections counted, the same recording and the same divergence
    stop, from the pair's ``run_counted`` kernel (``reference._kernels``; on a pointwise scene
    with one entry, ``run_counted_one``); None where the pair has none that computes the
    interpreted bits (:func:`exact_why` says why), for the caller to interpret instead.
    ``meta.backend`` says "compiled, counted"."""
    steps, every = int(steps), int(every)
    if every < 1 or steps < 0 or exact_why(scheme, scene, may_compile):
        return None
    kernels = _counted_parts(scheme, scene, may_compile)[0]
    q, v = _kernel_layout(scene, q0, v0)
    p, k, h, t0 = scene.pvec, int(_k(scheme, scene, iterations, substeps)), float(dt), float(t0)
    marks = output_marks(steps, every)
    out_q, out_v = np.empty((len(marks),) + q.shape), np.empty((len(marks),) + v.shape)
    with np.errstate(all="ignore"):
        start_evals, recorded, failed, cnt = _counted_run(kernels, q, v, t0, h, steps, every, p, k, out_q, out_v)
    failed = failed or None
    step_arr = marks[:recorded]
    q_arr = np.ascontiguousarray(out_q[:recorded].transpose(0, 2, 1))
    v_arr = np.ascontiguousarray(out_v[:recorded].transpose(0, 2, 1))
    with np.errstate(over="ignore", invalid="ignore"):
        energy = scene.energy(q_arr, v_arr)
    meta = RunMeta(backend="compiled, counted", start_force_evals=start_evals,
                   steps_run=(failed - 1) if failed else steps, params=dict(scene.values),
                   iterations=scheme.kind.run_iterations(scheme, iterations),
                   projections=int(cnt[2]) if "project" in scheme.kind.kernels else None)
    return Trajectory(
        scene=scene.id, method=f"ref:{scheme.id}", dt=dt, steps=steps, every=every,
        step=step_arr, t=t0 + step_arr * dt, q=q_arr, v=v_arr, energy=energy,
        status=UNSTABLE if failed else OK, detail=divergence_detail(failed, t0 + failed * dt) if failed else "",
        failed_step=failed, force_evals=int(cnt[0]), solves=int(cnt[1]), meta=meta)


def run_compiled(scheme, scene: Scene, dt: float, steps: int, q0=None, v0=None, iterations: int | None = None,
                 substeps: int | None = None):
    """Final (q, v) after ``steps`` compiled steps, API layout (batch, ndof)."""
    q, v = _kernel_layout(scene, q0, v0)
    qf, vf = driver(scheme, scene)(q, v, 0.0, float(dt), int(steps), scene.pvec,
                                   _k(scheme, scene, iterations, substeps))
    return qf.T.copy(), vf.T.copy()


#: The clocks a timing can read: wall time, or the CPU time of this process (which a core
#: shared with other processes does not inflate: what the step itself costs).
CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def step_timer(scheme, scene: Scene, dt: float, steps: int, batch: int = 1, iterations: int | None = None,
               clock: str = "wall", substeps: int | None = None):
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


def time_per_step(scheme, scene: Scene, dt: float, steps: int, batch: int = 1, repeats: int = 5,
                  iterations: int | None = None, clock: str = "wall", substeps: int | None = None) -> dict:
    """Time per step of the compiled loop on ``clock`` ("wall" or "cpu"): one warm-up call
    (compiles), then the minimum over ``repeats`` timed calls (the least-disturbed run; asv
    and timeit do the same)."""
    t_compile, once = step_timer(scheme, scene, dt, steps, batch, iterations, clock, substeps)
    times = [once() for _ in range(repeats)]
    return {"s_per_step": min(times), "median_s_per_step": float(np.median(times)),
            "repeats": times, "warmup_s": t_compile, "batch": batch, "steps": steps, "clock": clock}
