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
    rounded = {name: float(np.float32(value)) if isinstance(value, float) else value
               for name, value in scene.values.items()}
    if rounded != dict(scene.values):
        try:
            scene = scene.copy_with(**rounded)
        except Exception:  # compared as it is: the deviation then carries the parameters' rounding
            pass
    return scene, float(np.float32(dt))


def rounded_to_float32(traj: Trajectory) -> Trajectory:
    """The run with its states rounded to float32 (what a float32 engine can hold)."""
    import dataclasses

    return dataclasses.replace(traj, q=np.asarray(traj.q, dtype=np.float32).astype(float),
                               v=np.asarray(traj.v, dtype=np.float32).astype(float))


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


def candidate_run(ref, scene: Scene, dt: float, steps: int) -> Trajectory:
    """``ref.simulate(scene, dt, steps, 1)``, or the same run made before in this process, or
    by any process of this code on this machine (``_stored``): the key holds the scheme and its
    options, the scene's id, parameters and initial state, dt, steps and the backend reference
    runs take (``reference.Exact``: the same bits either way)."""
    q0, v0 = scene.batch_state(1)
    key = (ref.id, tuple(sorted(ref.options.items())), scene.id, tuple(sorted(scene.values.items())),
           q0.tobytes(), v0.tobytes(), float(dt), int(steps), ref.exact is not None)
    if key not in _CANDIDATES:
        if len(_CANDIDATES) >= CANDIDATES_KEPT:
            del _CANDIDATES[next(iter(_CANDIDATES))]
        _CANDIDATES[key] = _stored(key, lambda: ref.simulate(scene, dt, steps, 1))
    return _CANDIDATES[key]


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
    """One reference scheme against the method: its largest deviation over the run."""

    method: str
    max_deviation: float
    status: str
    matches: bool


@dataclass(frozen=True)
class IdentityResult(Result):
    """Which reference schemes ``method`` integrates on ``scene`` (``identify``)."""

    method: str
    scene: str
    params: dict
    dt: float
    steps: int
    status: str                                # the method's run
    detail: str
    engine_version: str | None
    settings: dict | None
    tolerance: float | None = None             # a deviation within it is a match
    precision: str = "float64"                 # the method's; float32: compared at float32 inputs
    matches: list = field(default_factory=list)    # every scheme matched, closest first
    match: str | None = None
    max_deviation: float | None = None         # the closest scheme's
    runner_up: Candidate | None = None         # the closest scheme that is not the answer
    candidates: list = field(default_factory=list)  # every Candidate, closest first
    why_no_match: str | None = None            # what the engine mode records, where nothing matches

    @property
    def closest(self) -> Candidate | None:
        return self.candidates[0] if self.candidates else None


def identify(method, scene: Scene, dt: float | None = None, steps: int | None = None,
             timeout: float | None = None, exact=None, progress=None) -> IdentityResult:
    """Rank every reference scheme by its deviation from ``method`` on ``scene``; ``exact``: the
    candidates' backend (``reference.Exact``; None: interpreted); ``progress``: told a line
    before each run (a command's progress)."""
    method = resolve(method, scene)
    dt = default_dt(scene) if dt is None else dt
    steps = default_steps(scene) if steps is None else steps
    say = progress or (lambda line: None)
    where = " in a worker process" if method.isolated else ""
    say(f"identify: stepping {method.id}, {steps} steps at dt {dt:.6g}{where}")
    run = simulate(method, scene, dt, steps, 1, timeout=timeout)
    precision = precision_of(method)
    out = {"method": method.id, "scene": scene.id, "params": dict(scene.values), "dt": dt, "steps": steps,
           "status": run.status, "detail": run.detail,
           "engine_version": run.meta.engine_version, "settings": run.meta.settings, "precision": precision}
    if run.status not in (OK, UNSTABLE):
        return IdentityResult(**out)
    scale = max(1.0, float(np.max(np.abs(run.q), initial=0.0)), float(np.max(np.abs(run.v), initial=0.0)))
    tolerance = (FLOAT32_MATCH_RTOL if precision == "float32" else MATCH_RTOL) * scale
    # The candidates run on what the method was given: a float32 engine's inputs rounded.
    c_scene, c_dt = float32_inputs(scene, dt) if precision == "float32" else (scene, dt)
    as_held = rounded_to_float32 if precision == "float32" else (lambda traj: traj)
    candidates = []
    refs = [(mid, ref) for mid, ref in all_methods(exact).items()
            if ref.family == REFERENCE and mid != method.id and ref.supports(scene)[0]
            # a scheme that is here another, update for update (same_without_velocity): that one is the candidate
            and (scene.velocity_dependent or not ref.scheme.same_without_velocity)]
    for i, (mid, ref) in enumerate(refs, 1):
        say(f"identify: candidate {mid}, {i} of {len(refs)}")
        traj = as_held(candidate_run(ref, c_scene, c_dt, steps))
        dev = max_deviation(run, traj)
        candidates.append(Candidate(mid, dev, traj.status, dev <= tolerance))
    candidates.sort(key=lambda c: c.max_deviation)
    matches = [c.method for c in candidates if c.matches]
    if not matches:
        # What the engine mode itself records, measured, about why nothing can match here.
        out["why_no_match"] = method.no_match.get(scene.id)
    best = candidates[0] if candidates else None
    # The runner-up is the closest scheme that is not the answer: the first non-match after
    # a match, the second-closest when nothing matches.
    others = [c for c in candidates[0 if matches else 1:] if not c.matches]
    return IdentityResult(**out, tolerance=tolerance, matches=matches, match=matches[0] if matches else None,
                          max_deviation=best.max_deviation if best else None,
                          runner_up=others[0] if others else None, candidates=candidates)


def format_report(result: IdentityResult) -> str:
    """The identification as text: the verdict first, then every candidate."""
    family = MethodId.parse(result.method).family
    version = f", {family} {result.engine_version}" if result.engine_version else ""
    at = (", float32: the schemes run from its inputs rounded to float32, their states rounded"
          if result.precision == "float32" else "")
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
    lines.append("  all schemes, max |diff| in (q, v) over every step:")
    for c in result.candidates:
        mark = "  <- match" if c.matches else ""
        lines.append(f"    {c.method:42s} {c.max_deviation:10.3g}{mark}")
    return "\n".join(lines)
