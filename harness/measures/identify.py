"""Which reference scheme does a method integrate? Step it and every reference scheme on the
same scene, from the same state, with the same dt, and rank the schemes by the largest
difference in (q, v) over every step.

A scheme *matches* when that difference is within roundoff: ``MATCH_RTOL`` of the largest
state component seen. Different schemes of the same order differ by a power of dt times the
state (1e-4 and up at the default ~100 steps per period), roundoff by 1e-16 per operation,
so the gap between a match and the runner-up is many orders of magnitude; both are reported.
Several schemes can match when a scene cannot tell them apart (on a force that depends on
the velocity only, position-first Euler and explicit Euler are the same update). A scheme that
differs from another only in how it treats velocity-dependent forces
(``Scheme.same_without_velocity``) is not a candidate on a scene without them.

Most schemes part from the method within a step or two by far more than roundoff, and the max
over a run is at least its max over any first steps, so a short interpreted run rules them out
(``screen``): each candidate is stepped 1, 2, 4, ... up to ``screen_length`` steps (nothing
compiled) until its difference exceeds the tolerance. Only those that stay within it, and the
runner-up, run in full, on the backend a full run takes (a compiled loop on a large scene): the
matches and their max |diff| are the same as from full runs of every scheme. The runner-up is
the scheme that stays within roundoff of the method longest among those that do not match
(then the smaller difference where it parts), with its max |diff| over the whole run; the others
show their difference at the step where they part. Where nothing matches, every scheme runs in
full and the closest is the one of smallest max |diff|.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from records import REFERENCE, MethodId, Trajectory

from scenarios import Scene
from records.result import Result
from records.trajectory import OK, UNSTABLE

from harness.measures.common import resolve
from harness.methods import all_methods
from harness.execution.simulate import simulate

#: A difference this small relative to the state is roundoff: measured matches are 0 to
#: 1e-12 relative over 10^4 steps (MuJoCo RK4 1.2e-14, the revolute pendulum 3e-12).
MATCH_RTOL = 1e-9

#: A float32 method (``Method.precision``; Newton on Warp) is compared with each scheme's run from
#: its inputs rounded to float32 (dt, the scene's parameters), the scheme's states rounded to
#: float32, within this fraction of the state's size. Its roundoff is 2^-24 of the state per
#: operation, more where the velocity is recovered from positions, (x_new - x) / h, or a position
#: sits far from the origin: measured float32 matches over 1000 steps at 100 a period (newton
#: 1.8.0) 1.6e-7 to 6.3e-6 on the springs, 5.5e-6 on the pendulum, 1.8e-5 on the chain of 32 (its
#: particles up to 33 from the origin), where the nearest other scheme, leapfrog, is 1.0e-4 away.
#: 5e-5 keeps a factor of 2 to 3 on each side there; at fewer steps a period the schemes part further.
FLOAT32_MATCH_RTOL = 5e-5

#: The precisions ``identify`` compares a method at; a reference scheme computes in float64.
PRECISIONS = ("float64", "float32")

#: The longest screen (``screen``): a scheme still within the tolerance after this many steps (or
#: half the run, if less) runs in full. Schemes of another update part at the first step (on the
#: default cloth at dt = period / 100, explicit and second-order schemes 1e2 to 1e3 times the
#: tolerance away after one step); implicit Euler and the position-based schemes, beside
#: semi-implicit Euler on the stiff cloth, part at the eighth. Schemes of the same order as the
#: method part later: beside MuJoCo's RK4 on the 4 x 4 sheet at 100 steps a period, two-stage
#: Radau IIA, the implicit midpoint, Heun and the third-order schemes stay within 1e-9 of the
#: state for 16 steps and part before 128, where only Dormand-Prince and Forest-Ruth (fourth
#: order and up) are left to run in full beside RK4. Each screen's runs are kept on disk
#: (``_stored``), so a longer screen costs only the first run on a machine.
SCREEN_STEPS = 128
#: A run of this many steps or fewer is not screened: every scheme runs in full.
UNSCREENED_STEPS = 32


def screen_length(steps: int) -> int:
    """The longest screen of a run of ``steps`` steps: ``SCREEN_STEPS``, or half the run."""
    return min(SCREEN_STEPS, steps // 2)


#: Default run: 100 steps per period over 10 periods.
STEPS_PER_PERIOD = 100
PERIODS = 10


def default_dt(scene: Scene) -> float:
    run = scene.identification_run()
    return run[0] if run is not None else scene.period / STEPS_PER_PERIOD


def default_steps(scene: Scene | None = None) -> int:
    run = scene.identification_run() if scene is not None else None
    return run[1] if run is not None else STEPS_PER_PERIOD * PERIODS


def precision_of(method) -> str:
    """``method.precision`` (a reference scheme's is float64; a plugin's that declares none is
    float64). A precision not in PRECISIONS is a ValueError naming the valid ones."""
    precision = getattr(method, "precision", "float64")
    if precision not in PRECISIONS:
        raise ValueError(f"precision: {precision!r} of {method.id} is not one of {', '.join(PRECISIONS)}")
    return precision


def float32_inputs(scene: Scene, dt: float) -> tuple[Scene, float]:
    """The scene with each real parameter rounded to float32, and dt rounded: what a float32
    engine is given. A scene that cannot be rebuilt from its values (a model file's) keeps them."""
    rounded = {
        name: float(np.float32(value)) if isinstance(value, float) else value for name, value in scene.values.items()
    }
    if rounded != dict(scene.values):
        try:
            scene = scene.copy_with(**rounded)
        except Exception:  # compared as it is: the deviation then carries the parameters' rounding
            pass
    return scene, float(np.float32(dt))


def rounded_to_float32(traj: Trajectory) -> Trajectory:
    """The run with its states rounded to float32 (what a float32 engine can hold)."""
    import dataclasses

    return dataclasses.replace(
        traj, q=np.asarray(traj.q, dtype=np.float32).astype(float), v=np.asarray(traj.v, dtype=np.float32).astype(float)
    )


def max_deviation(a: Trajectory, b: Trajectory) -> float:
    """Largest |difference| in q and v over the recorded steps; inf when the two runs did not
    record the same steps (one stopped earlier: they are not the same scheme)."""
    if a.step.shape != b.step.shape or not np.array_equal(a.step, b.step):
        return math.inf
    if len(a.step) == 0:
        return math.inf
    with np.errstate(invalid="ignore"):
        return float(max(np.max(np.abs(a.q - b.q)), np.max(np.abs(a.v - b.v))))


#: Candidate runs kept in this process, by what determines them: every engine mode identified
#: on a scene at the same dt is compared with the same reference runs (the nightly identifies
#: four to ten modes per scene, one task each, in two worker processes).
_CANDIDATES: dict[tuple, Trajectory] = {}
CANDIDATES_KEPT = 64
#: The screen's runs likewise (a few states each: up to five lengths of every scheme on a scene).
_SCREENS: dict[tuple, Trajectory] = {}
SCREENS_KEPT = 512


def candidate_run(ref, scene: Scene, dt: float, steps: int, interpreted: bool = False) -> Trajectory:
    """``ref.simulate(scene, dt, steps, 1)`` (``interpreted``: ``reference.integrate``, which
    compiles nothing: the screen's runs, and a full run whose loop is not compiled already:
    ``_loop_compiled``), or the same run made before in this process, or
    by any process of this code on this machine (``_stored``): the key holds the scheme and its
    options, the scene's id, parameters and initial state, dt, steps and the backend reference
    runs take (``reference.RefMethod.compiled_where_bitwise``: the same bits either way)."""
    q0, v0 = scene.batch_state(1)
    if not interpreted and ref.compiled_where_bitwise and not _loop_compiled(ref, scene):
        interpreted = True  # a candidate's run never compiles a loop: the same bits, interpreted
    backend = "interpreted" if interpreted else ref.compiled_where_bitwise
    key = (
        ref.id,
        tuple(sorted(ref.options.items())),
        scene.id,
        tuple(sorted(scene.values.items())),
        q0.tobytes(),
        v0.tobytes(),
        float(dt),
        int(steps),
        backend,
    )
    kept, bound = (_SCREENS, SCREENS_KEPT) if interpreted else (_CANDIDATES, CANDIDATES_KEPT)
    if key not in kept:
        if len(kept) >= bound:
            del kept[next(iter(kept))]
        if interpreted:
            from reference import integrate

            run = lambda: integrate(ref.scheme, scene, dt, steps, 1, **ref.options)  # noqa: E731
        else:
            run = lambda: ref.simulate(scene, dt, steps, 1)  # noqa: E731
        kept[key] = _stored(key, run)
    return kept[key]


def _loop_compiled(ref, scene: Scene) -> bool:
    """Whether the pair's compiled loop is in the disk cache (or compiled in this process): an
    identity's candidate run is one run of up to a few thousand steps, which costs less
    interpreted than compiling its loop would, where the loop is not there already."""
    from reference import cache_state

    try:
        return cache_state(ref.scheme, scene).compiled
    except Exception:  # noqa: BLE001 - a pair without a compiled form: interpreted
        return False


def _code_digest() -> str:
    """A hash of everything a reference run's bits depend on: the source of the packages that
    compute it (the schemes, the scenes' forces, the step loop), numpy's and Python's versions."""
    global _DIGEST
    if _DIGEST is None:
        import hashlib
        import sys
        from pathlib import Path

        import records
        import reference
        import scenarios

        h = hashlib.sha256(f"{np.__version__} {sys.version}".encode())
        for package in (records, reference, scenarios):
            root = Path(package.__file__).parent
            for path in sorted(root.rglob("*.py")):
                h.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
        _DIGEST = h.hexdigest()
    return _DIGEST


_DIGEST: str | None = None


def _stored(key: tuple, run) -> Trajectory:
    """The candidate run of ``key`` from the disk cache (``$HARNESS_CACHE/candidates``, beside the
    kernels), else ``run()`` stored there. The file's name hashes the key with ``_code_digest``, so
    a run of other code is never read: an edit to a scheme or a scene is a new file. Written to a
    temporary name and renamed, so a reader never sees half a file; one that cannot be read or
    written costs only the run."""
    import hashlib
    import os
    import pickle

    from reference import kernel_cache_dir

    folder = kernel_cache_dir().parent / "candidates"
    name = hashlib.sha256(repr(key).encode() + _code_digest().encode()).hexdigest()[:32]
    path = folder / f"{name}.pickle"
    try:
        with open(path, "rb") as fh:
            return pickle.load(fh)
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError, ImportError):
        pass
    traj = run()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        with open(tmp, "wb") as fh:
            pickle.dump(traj, fh, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(tmp, path)
    except OSError:
        pass
    return traj


@dataclass(frozen=True)
class Candidate(Result):
    """One reference scheme against the method: its largest deviation over the run, or where the
    screen ruled it out, over its first ``steps`` steps, the last the first beyond the tolerance."""

    method: str
    max_deviation: float
    status: str
    matches: bool
    steps: int | None = None  # the steps its deviation is over (the run's where it ran in full)
    within: int | None = None  # the last step up to which it stays within the tolerance (None: all)


@dataclass(frozen=True)
class IdentityResult(Result):
    """Which reference schemes ``method`` integrates on ``scene`` (``identify``)."""

    method: str
    scene: str
    params: dict
    dt: float
    steps: int
    status: str  # the method's run
    detail: str
    engine_version: str | None
    settings: dict | None
    tolerance: float | None = None  # a deviation within it is a match
    precision: str = "float64"  # the method's; float32: compared at float32 inputs
    matches: list = field(default_factory=list)  # every scheme matched, closest first
    match: str | None = None
    max_deviation: float | None = None  # the closest scheme's
    runner_up: Candidate | None = None  # the closest scheme that is not the answer
    candidates: list = field(default_factory=list)  # every Candidate, closest first
    why_no_match: str | None = None  # what the engine mode records, where nothing matches
    screen_steps: int | None = None  # the screen's longest run (None: every scheme ran in full)

    @property
    def closest(self) -> Candidate | None:
        return self.candidates[0] if self.candidates else None


def candidate_methods(scene: Scene, compiled_where_bitwise: bool = False) -> dict:
    """The reference schemes ``identify`` compares a method with on ``scene``, by id: each that runs
    there, but a scheme that is another there, update for update (``same_without_velocity``): that
    one is the candidate."""
    return {
        mid: ref
        for mid, ref in all_methods(compiled_where_bitwise).items()
        if ref.family == REFERENCE
        and ref.supports(scene)[0]
        and (scene.velocity_dependent or not ref.scheme.same_without_velocity)
    }


def identify(
    method,
    scene: Scene,
    dt: float | None = None,
    steps: int | None = None,
    timeout: float | None = None,
    compiled_where_bitwise: bool = False,
    progress=None,
) -> IdentityResult:
    """Rank every reference scheme by its deviation from ``method`` on ``scene``;
    ``compiled_where_bitwise``: the candidates step on their compiled loops wherever those compute
    the interpreted bits (else interpreted); ``progress``: told a line before each run (a
    command's progress)."""
    method = resolve(method, scene)
    dt = default_dt(scene) if dt is None else dt
    steps = default_steps(scene) if steps is None else steps
    say = progress or (lambda line: None)
    where = " in a worker process" if method.isolated else ""
    say(f"identify: stepping {method.id}, {steps} steps at dt {dt:.6g}{where}")
    run = simulate(method, scene, dt, steps, 1, timeout=timeout)
    precision = precision_of(method)
    out = {
        "method": method.id,
        "scene": scene.id,
        "params": dict(scene.values),
        "dt": dt,
        "steps": steps,
        "status": run.status,
        "detail": run.detail,
        "engine_version": run.meta.engine_version,
        "settings": run.meta.settings,
        "precision": precision,
    }
    if run.status not in (OK, UNSTABLE):
        return IdentityResult(**out)
    scale = max(1.0, float(np.max(np.abs(run.q), initial=0.0)), float(np.max(np.abs(run.v), initial=0.0)))
    tolerance = (FLOAT32_MATCH_RTOL if precision == "float32" else MATCH_RTOL) * scale
    # The candidates run on what the method was given: a float32 engine's inputs rounded.
    c_scene, c_dt = float32_inputs(scene, dt) if precision == "float32" else (scene, dt)
    as_held = rounded_to_float32 if precision == "float32" else (lambda traj: traj)
    refs = [(mid, ref) for mid, ref in candidate_methods(scene, compiled_where_bitwise).items() if mid != method.id]
    order = {mid: i for i, (mid, _) in enumerate(refs)}
    # The screen needs the method's every step from 0 on, and a run long enough to shorten.
    screening = run.status == OK and steps > UNSCREENED_STEPS and np.array_equal(run.step, np.arange(steps + 1))
    longest = screen_length(steps)
    parted: dict[str, Candidate] = {}
    if screening:
        for i, (mid, ref) in enumerate(refs, 1):
            say(f"identify: screening {mid}, {i} of {len(refs)}")
            ruled_out = _screen(run, mid, ref, c_scene, c_dt, tolerance, as_held, longest)
            if ruled_out is not None:
                parted[mid] = ruled_out
    full: dict[str, Candidate] = {}

    def run_in_full(chosen):
        for i, (mid, ref) in enumerate(chosen, 1):
            say(f"identify: candidate {mid}, {i} of {len(chosen)}")
            traj = as_held(candidate_run(ref, c_scene, c_dt, steps))
            dev = max_deviation(run, traj)
            full[mid] = Candidate(mid, dev, traj.status, dev <= tolerance, steps, _within(run, traj, tolerance))
            parted.pop(mid, None)

    run_in_full([(mid, ref) for mid, ref in refs if mid not in parted])
    if parted and not any(c.matches for c in full.values()):
        # Nothing matches: every scheme in full, the closest the one of smallest max |diff| over the run.
        run_in_full([(mid, ref) for mid, ref in refs if mid in parted])
    elif parted and all(c.matches for c in full.values()):
        # The runner-up, in full: of the schemes that do not match, the one that stays within longest.
        runner = min(parted.values(), key=lambda c: (-c.within, c.max_deviation, order[c.method]))
        run_in_full([(runner.method, dict(refs)[runner.method])])
    candidates = sorted(full.values(), key=lambda c: (c.max_deviation, order[c.method])) + sorted(
        parted.values(), key=lambda c: (-c.within, c.max_deviation, order[c.method])
    )
    matches = [c.method for c in candidates if c.matches]
    if not matches:
        # What the engine mode itself records, measured, about why nothing can match here.
        out["why_no_match"] = method.no_match.get(scene.id)
    best = candidates[0] if candidates else None
    # The runner-up is the closest scheme that is not the answer: the first non-match after
    # a match, the second-closest when nothing matches.
    others = [c for c in candidates[0 if matches else 1 :] if not c.matches]
    return IdentityResult(
        **out,
        tolerance=tolerance,
        matches=matches,
        match=matches[0] if matches else None,
        max_deviation=best.max_deviation if best else None,
        runner_up=others[0] if others else None,
        candidates=candidates,
        screen_steps=longest if screening else None,
    )


def _deviations(run: Trajectory, traj: Trajectory, n: int) -> np.ndarray:
    """max |difference| in q and v at each step 0 .. n of two runs recorded at every step; inf
    at the steps either did not record (it stopped earlier)."""
    d = np.full(n + 1, np.inf)
    m = min(len(traj.step), len(run.step), n + 1)
    if not (np.array_equal(traj.step[:m], np.arange(m)) and np.array_equal(run.step[:m], np.arange(m))):
        return d
    with np.errstate(invalid="ignore"):
        d[:m] = np.maximum(
            np.max(np.abs(run.q[:m] - traj.q[:m]), axis=(1, 2)), np.max(np.abs(run.v[:m] - traj.v[:m]), axis=(1, 2))
        )
    return d


def _within(run: Trajectory, traj: Trajectory, tolerance: float) -> int | None:
    """The last step up to which ``traj`` stays within ``tolerance`` of ``run`` (None: every step)."""
    beyond = _first_beyond(_deviations(run, traj, max(len(run.step), len(traj.step)) - 1), tolerance)
    return None if beyond is None else beyond - 1


def _first_beyond(d: np.ndarray, tolerance: float) -> int | None:
    """The first step whose deviation is not within ``tolerance`` (NaN is not), else None."""
    beyond = np.flatnonzero(~(d <= tolerance))
    return int(beyond[0]) if beyond.size else None


def _screen(
    run: Trajectory, mid: str, ref, scene: Scene, dt: float, tolerance: float, as_held, longest: int
) -> Candidate | None:
    """``mid`` as the screen rules it out: its interpreted runs of 1, 2, 4, ... up to ``longest``
    steps held against the method's first steps, stopped at the first run that
    parts from it beyond ``tolerance``; its deviation up to that step (the first beyond). None:
    within the tolerance throughout, it runs in full."""
    n = 1
    while True:
        traj = as_held(candidate_run(ref, scene, dt, n, interpreted=True))
        d = _deviations(run, traj, n)
        k = _first_beyond(d, tolerance)
        if k is not None:
            return Candidate(mid, float(np.max(d[: k + 1])), traj.status, False, k, k - 1)
        if n >= longest:
            return None
        n = min(2 * n, longest)


def format_report(result: IdentityResult) -> str:
    """The identification as text: the verdict first, then every candidate."""
    family = MethodId.parse(result.method).family
    version = f", {family} {result.engine_version}" if result.engine_version else ""
    at = (
        ", float32: the schemes run from its inputs rounded to float32, their states rounded"
        if result.precision == "float32"
        else ""
    )
    lines = [f"{result.method} on {result.scene}: dt = {result.dt:.6g}, {result.steps} steps{version}{at}"]
    if result.status not in (OK, UNSTABLE):
        lines.append(f"  the run {result.status}: {result.detail}")
        return "\n".join(lines)
    if result.status == UNSTABLE:
        lines.append(f"  (the run went unstable: {result.detail}; compared up to there)")
    if result.matches:
        dev = result.max_deviation
        kind = "bitwise" if dev == 0 else "float32 rounding" if result.precision == "float32" else "roundoff"
        lines.append(f"  matches {' = '.join(result.matches)}: max |diff| = {dev:.3g} ({kind})")
    else:
        best = result.closest
        closest = f"; closest {best.method} at max |diff| = {best.max_deviation:.3g}" if best else ""
        lines.append(f"  matches no reference scheme within {result.tolerance:.3g}{closest}")
        if result.why_no_match:
            lines.append(f"  why: {result.why_no_match}")
    if result.runner_up is not None:
        lines.append(f"  runner-up {result.runner_up.method}: max |diff| = {result.runner_up.max_deviation:.3g}")
    lines.append(
        "  all schemes, max |diff| in (q, v) over every step"
        + (
            f" (over the steps up to where it parts, for a scheme that parts within the first {result.screen_steps})"
            if result.screen_steps
            else ""
        )
        + ":"
    )
    for c in result.candidates:
        mark = "  <- match" if c.matches else ""
        if c.steps is not None and c.steps < result.steps:
            mark = f"  (parts at step {c.steps})"
        lines.append(f"    {c.method:42s} {c.max_deviation:10.3g}{mark}")
    return "\n".join(lines)
