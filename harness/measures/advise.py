"""Advice at a frame rate: the cheapest method, with the fewest substeps, that keeps a scene
stable and within a user's tolerances over a horizon. Every figure is measured here, by the
harness's own measures.

At ``hz`` frames a second and ``s`` substeps a frame the step is h = 1 / (hz s), s one of the
levels 1, 2, 4, ... <= ``max_substeps``. For each candidate method the most substeps are
measured first: a method that misses the tolerances there misses them at every coarser step
(a convergent method's error falls with h), and is judged by that one run. Where it meets
them, a bisection over the levels finds the fewest substeps that still do: that method's
cheapest frame (cost per frame = s x cost per step). At each level, one rule for every method:

* **stable**: on a linear scene, the spectral radius of the method's one-step map at h
  (``harness.measures.stability``: rho <= 1 + RHO_TOL), measured before anything is run; a step with
  rho > 1 grows without bound, so its horizon run is skipped. On every scene the run itself
  must finish within ``stability.GROWTH`` times the size of the true solution. Beside it,
  the method's largest stable h*omega on that scene (linear scenes; its own damping
  included, as the one-step map includes it), searched over the h*omega the advice can use.
* **energy error**: ``max_n |E_n - E_exact(t_n)| / max_n |E_exact(t_n)|`` over the horizon,
  relative to the largest exact energy (the initial one where the scene dissipates: relative
  to a damped spring's decaying energy itself the error would grow without meaning), and its
  class by ``harness.measures.energy.classify``.
* **position error**: ``max_n max_i |q_i(t_n) - q_i,true(t_n)|``, absolute, in the scene's
  units, against the exact solution or the scene's reference (``harness.measures.error.true_state``),
  at the frames (t_n = n / hz, the states a viewer sees) up to the scene's reference horizon. The
  true state is asked for at every frame of that horizon whatever the substeps, the same times for
  every level and method, so a reference solve (a stiff cloth's DOP853, dearer than the whole
  search on a large sheet) is solved once per scene and frame rate and read from its cache after;
  the run's size, which ``stability.GROWTH`` bounds, is held against the true state's at the same
  frames. Judged by default: within ERROR_REL (5%) of the scene's
  length scale (``Scene.length_scale``: the 4 x 4 cloth's 0.3 width, the spring's amplitude), or an
  absolute ``error_tol``; a request with neither (``error_rel`` None) judges the energy alone,
  and its verdict says so first. An energy tolerance alone is kept by a method that damps as the
  true motion does while ending far from it (XPBD's one substep on a stiff cloth: 0.233 off on a
  sheet 0.3 wide).
* **converged or not**: a method whose options declare a convergence knob (``Option.tighten``: a
  projection's passes, an iterative solve's tolerance) is run again where it meets the tolerances,
  at the same substeps, its knob tightened (``harness.methods.tightened``: ten times the passes, a
  tolerance a hundred times tighter). Where that run misses them, the row says its win rests on
  the solve's own error (``Row.converged``): XPBD's ten passes at one substep keep 53% of a stiff
  cloth's energy, its hundred 49%, implicit Euler's 48.7%.
* **force evaluations per frame**: counted over the horizon run (s x evaluations per step;
  None, with the reason, where an engine mode cannot be counted).
* **cost per frame**: s x the method's measured time per step (``harness.measures.cost``: the compiled
  kernel of a reference scheme, the engine mode's step for an engine), on the CPU clock,
  measured once, at the step of the row that meets the tolerances (a nightly passes its cost
  cell's figure instead, and every row then has one).

A method that meets the tolerances at no level is listed with why, from its most substeps;
where none meets them the closest is named. The search measures only what it must: one run
for a method that cannot meet the tolerances, a bisection over the levels for one that can,
no run for a step already known unstable, each method's limit measured once and its time per
step only where it is advised (timing a reference scheme compiles its kernel).
"""

from __future__ import annotations

import fnmatch
import math
from dataclasses import asdict, dataclass, field

import numpy as np

from records import InvalidInput
from records.advice import MethodAdvice, Row, tie

from scenarios import Scene

from harness import validate
from harness.measures.common import resolve

#: Default horizon, in the scene's time unit (seconds for the animation scenes).
HORIZON = 10.0
#: The position tolerance asked unless the user gives another or none: this share of the scene's
#: length scale (``Scene.length_scale``), an error an animation's viewer does not see.
ERROR_REL = 0.05
MAX_SUBSTEPS = 16
#: Recorded states per horizon run, at most, where a frame holds more than one (the energy
#: classification wants >= 100): every ``frame_stride`` steps, a divisor of the substeps, so that
#: every frame is among them.
RECORDED = 2000
#: The limit search goes at least this far in h*omega (past every explicit scheme's limit),
#: so that a method stable at every step the advice uses still shows where it would fail.
LIMIT_SEARCH_HI = 10.0
#: Relative bracket of the stability-limit search (three digits are all the advice prints).
LIMIT_RTOL = 1e-4
#: Timing of the cost per step: repeats and steps per repeat (compiled kernel / engine).
COST_REPEATS = 3
#: Steps a mode that counts its force evaluations only in a counting run is counted over
#: (``harness.measures.cost.counted_evaluations``; a step's count does not vary with the horizon).
COUNT_STEPS = 100


@dataclass(frozen=True)
class Request:
    """What the user asks: a scene at ``hz`` frames per unit time, over ``horizon``, within
    ``energy_tol`` (relative) and a position error of ``error_tol`` (absolute, in the scene's
    units) or else ``error_rel`` of the scene's length scale (by default ERROR_REL; None and no
    ``error_tol``: no accuracy tolerance, the energy alone judged)."""

    hz: float
    horizon: float = HORIZON
    energy_tol: float | None = None
    error_tol: float | None = None
    max_substeps: int = MAX_SUBSTEPS
    error_rel: float | None = ERROR_REL

    def checked(self) -> Request:
        """The request validated field by field (InvalidInput, one line, before anything runs); an
        absolute position tolerance replaces the relative one."""
        hz = validate.positive_finite("--hz", self.hz)
        horizon = validate.positive_finite("--horizon", self.horizon)
        energy = None if self.energy_tol is None else validate.positive_finite("--energy-tol", self.energy_tol)
        error = None if self.error_tol is None else validate.positive_finite("--error-tol", self.error_tol)
        rel = (
            None
            if self.error_rel is None or error is not None
            else validate.positive_finite("--error-tol", self.error_rel)
        )
        if energy is None and error is None and rel is None:
            raise InvalidInput("no tolerance given (allowed: --energy-tol REL and/or --error-tol ABS or P%, each > 0)")
        if horizon < 1.0 / hz:
            raise InvalidInput(
                f"--horizon={self.horizon} is shorter than one frame at {hz:g} Hz (allowed: >= {1.0 / hz:g})"
            )
        substeps = validate.count("--max-substeps", self.max_substeps, 1)
        return Request(hz, horizon, energy, error, substeps, rel)

    @property
    def accuracy(self) -> bool:
        """Whether a position tolerance is asked (absolute or relative to the scene's size)."""
        return self.error_tol is not None or self.error_rel is not None

    def position_tolerance(self, scene: Scene) -> float | None:
        """The position tolerance on ``scene``, absolute: ``error_tol``, else ``error_rel`` of its length
        scale, except on a scene with no reference to hold a run against (a model file only one
        engine loads: ``Scene.own_run_reference``), where the default judges the energy alone."""
        if self.error_tol is not None:
            return self.error_tol
        if self.error_rel is None or scene.own_run_reference:
            return None
        return self.error_rel * scene.length_scale

    @property
    def substeps(self) -> list[int]:
        """1, 2, 4, ... up to ``max_substeps``."""
        return [2**i for i in range(int(math.log2(self.max_substeps)) + 1)]

    def tolerances_text(self, length_scale: float | None = None, judged: bool = True) -> str:
        """The tolerances in words; ``length_scale`` the scene's, where the position tolerance is a
        share of it; ``judged`` False: the scene has no reference for the positions to be judged against."""
        if self.accuracy and not judged:
            return (
                f"{Request(self.hz, self.horizon, self.energy_tol, None, self.max_substeps, None).tolerances_text()}"
                " (the scene has no reference solution)"
            )
        parts = []
        if self.energy_tol is not None:
            parts.append(f"energy error <= {self.energy_tol:g}")
        if self.error_tol is not None:
            parts.append(f"position error <= {self.error_tol:g}")
        elif self.error_rel is not None:
            of = (
                f"{self.error_rel * length_scale:.3g} ({100 * self.error_rel:g}% of the scene's length scale "
                f"{length_scale:.3g})"
                if length_scale is not None
                else f"{100 * self.error_rel:g}% of the scene's length scale"
            )
            parts.append(f"position error <= {of}")
        text = " and ".join(parts)
        return text if self.accuracy else f"{text}; no accuracy tolerance (positions not judged)"


# ----------------------------------------------------------------------------- one method
def _limit(method, scene: Scene, request: Request, timeout) -> tuple[float | None, str, float | None]:
    """(largest stable h*omega, verdict, largest h*omega searched) on a linear scene, by the
    spectral radius, from a hundredth of the smallest step the advice uses to its largest or
    LIMIT_SEARCH_HI, whichever is further; (None, "not measured: ...", None) elsewhere."""
    from harness.measures.stability import largest_stable_dt

    if not scene.linear:
        return None, "not measured (nonlinear scene: each run is judged by its growth)", None
    hi = max(scene.omega / request.hz, LIMIT_SEARCH_HI)
    lo = min(1e-4, scene.omega / request.hz / request.max_substeps / 100.0)
    res = largest_stable_dt(method, scene, criterion="spectral_radius", lo=lo, hi=hi, rtol=LIMIT_RTOL, timeout=timeout)
    return res.omega_dt_max, res.verdict, hi


def _energies(traj, scene: Scene, frames=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, the run's energy, the exact energy) the energy figures read: at every recorded state; on a
    dissipating scene whose exact energy is its DOP853 reference's (the damped cloth,
    ``harness.measures.horizon.supported``), at the frames (``frames``), where the reference is read
    once per frame rate: at every recorded time a large sheet's reference, whose dense output is
    not all kept, would be solved again for every run."""
    from harness.measures.horizon import supported

    e = np.asarray(traj.energy[:, 0], dtype=float)
    if frames is not None and not scene.conservative and supported(scene):
        q, v = frames.truth()
        rows = frames.frame_rows()[: len(q)]
        return traj.t[rows], e[rows], np.asarray(scene.energy(q[: len(rows)], v[: len(rows)]), dtype=float)
    return traj.t, e, np.asarray(scene.exact_energy(traj.t), dtype=float)


def _energy_error(traj, scene: Scene, frames=None) -> tuple[float | None, bool | None, str | None]:
    """The largest energy error relative to the largest exact energy (``_energies``), whether the
    run gained energy, and the word for its way: ``grows`` / ``falls`` against a kept energy; on a
    dissipating scene ``grows`` only where the energy ends above its start (``RISE``), else
    ``damps less`` / ``damps more`` than the exact motion by where it ends (``harness.measures.energy``'s
    rule 7)."""
    from harness.measures.energy import RISE, dissipative

    _, e, exact = _energies(traj, scene, frames)
    scale = float(np.max(np.abs(exact)))
    if scale == 0.0 or not np.all(np.isfinite(e)):
        return None, None, None
    dev = e - exact
    i = int(np.argmax(np.abs(dev)))
    error = float(abs(dev[i]) / scale)
    if dissipative(exact):
        gained = bool(e[-1] > e[0] + RISE * abs(float(e[0])))  # rule 7: ends above its start
        return error, gained, "grows" if gained else "damps less" if e[-1] > exact[-1] else "damps more"
    return error, bool(dev[i] > 0.0), "grows" if dev[i] > 0.0 else "falls"


def _built_differently(method, scene: Scene, out) -> list[str]:
    """What another engine built differently from MuJoCo's model of a model file
    (``harness.measures.cross_engine.built_differently``), asked once per method's advice."""
    if not getattr(scene, "file", None):
        return []
    if not hasattr(out, "_differs"):
        from harness.measures.cross_engine import built_differently

        out._differs = built_differently(method, scene, 1.0 / 60.0) or []
    return out._differs


def frame_stride(substeps: int, steps: int) -> int:
    """Steps between recorded states: a divisor of ``substeps``, so that every frame is recorded and
    no figure skips one; the smallest that keeps at most RECORDED of the run's ``steps`` (the start
    and RECORDED states after it), else one state a frame (a large sheet's energy, taken state by
    state, holds every spring of every state)."""
    return next(d for d in range(1, substeps + 1) if substeps % d == 0 and (steps // d <= RECORDED or d == substeps))


def judged_tolerance(request: Request, scene: Scene) -> float:
    """The position tolerance a horizon and a convergence check are measured against: the request's,
    else the default share of the scene's length scale (a request on the energy alone still asks
    whether its solve's motion has converged)."""
    tol = request.position_tolerance(scene)
    return tol if tol is not None else ERROR_REL * scene.length_scale


class _Frames:
    """A run held against the true state at the frames (module docstring), asked for once and
    only where a figure needs it."""

    def __init__(self, traj, scene: Scene, request: Request, substeps: int):
        self.traj, self.scene, self.request, self.substeps = traj, scene, request, substeps

    def truth(self) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) true at every frame t = n / hz within the horizon and the scene's reference horizon."""
        from harness.measures.horizon import truth

        return truth(self.scene, self.request.hz, self.request.horizon)

    def horizon(self):
        """The scene's predictable horizon (``harness.measures.horizon``; None: judged at every frame)."""
        from harness.measures.horizon import measure

        r = self.request
        return measure(self.scene, r.hz, r.horizon, judged_tolerance(r, self.scene))

    def true_size(self) -> float:
        from harness.measures.common import scaled_state

        q, v = self.truth()
        return float(np.max(np.linalg.norm(scaled_state(self.scene, q, v), axis=-1)))

    def frame_rows(self) -> np.ndarray:
        """The recorded states at frames 0, 1, ... as far as the run reached (every frame is recorded)."""
        step = self.traj.step
        rows = np.flatnonzero(step % self.substeps == 0)
        return rows[step[rows] // self.substeps == np.arange(len(rows))]  # frames in order, none skipped

    def positions(self) -> np.ndarray:
        """The run's positions at every frame it reached."""
        return self.traj.q[self.frame_rows(), 0, :]

    def judged(self):
        """The run against the truth at the frames, inside the horizon and past it
        (``harness.measures.horizon.judge_frames``); None where the scene has no reference."""
        from harness.measures.horizon import judge_frames

        if self.scene.own_run_reference:
            return None  # no reference to hold the run against (a file only one engine loads)
        q_true, _ = self.truth()
        return judge_frames(self.scene, self.positions(), q_true, self.horizon())


def _pct(x: float) -> str:
    return f"{x:.3g}" if x < 1e-3 else f"{100 * x:.3g}%"


def _judge(row: Row, request: Request, scene: Scene, method=None) -> None:
    """Fill ``meets`` and ``why`` of a row whose run finished stably. The default position tolerance
    is not held against a reference that is another engine's model of a file (``error.measured_against_own_run``:
    pybullet on a file whose reference is MuJoCo's run): that difference is the models', not the method's."""
    from harness.measures.error import measured_against_own_run
    from harness.measures.horizon import STRAIN_TOL

    whys = []
    if request.energy_tol is not None:
        if row.energy_error is None:
            said = next((w for w in ("model differs", "model unchecked") if w in (row.detail or "")), None)
            whys.append(row.detail[row.detail.index(said) :] if said else "energy error undefined")
        elif row.energy_error > request.energy_tol:
            way = row.energy_way or ("grows" if row.energy_gained else "falls")
            what = f"energy {way}" if way in ("grows", "falls") else f"{way} than the exact motion: energy off"
            whys.append(
                f"{what} {_pct(row.energy_error)} over {request.horizon:g} s (tolerance {request.energy_tol:g})"
            )
    tol = request.position_tolerance(scene)
    if request.error_tol is None and method is not None and measured_against_own_run(method, scene):
        tol = None
    if tol is not None:
        inside = f" (to {row.judged_until:.3g} s, the predictable horizon)" if row.judged_until is not None else ""
        if row.judged_until == 0.0:
            whys.append(
                "positions not judged: at this tolerance the scene is unpredictable from the first frame "
                "(its two references part by a tenth of it at once)"
            )
        elif row.position_error is None:
            whys.append("position error not measurable")
        elif row.position_error > tol:
            whys.append(f"position error {row.position_error:.3g} > {tol:.3g}{inside}")
        if row.com_error is not None and row.com_error > tol:
            whys.append(f"centre of mass {row.com_error:.3g} > {tol:.3g} past the predictable horizon")
        if row.strain_excess is not None and row.strain_excess > STRAIN_TOL:
            whys.append(
                f"a spring family's largest strain {row.strain_excess:.1%} above the reference's "
                f"(tolerance {STRAIN_TOL:.0%})"
            )
    row.meets = not whys
    row.why = "; ".join(whys)


def _cost_per_step(
    method, scene: Scene, h: float, injected: dict | None = None
) -> tuple[float | None, str, float | None]:
    """(seconds per step, the fastest repeat; how timed; the repeats' relative spread)."""
    from harness.measures.cost import wall_time_per_step

    res = wall_time_per_step(method, scene, h, repeats=COST_REPEATS, clock="cpu", injected=injected)
    timing = f"{res['timing']}; {res['clock']} clock, {res['time_steps']} steps a repeat"
    return res["s_per_step"], timing, res.get("rel_spread")


def advise_method(
    method,
    scene: Scene,
    request: Request,
    *,
    timeout: float | None = None,
    cost_per_step: tuple[float, str] | None = None,
    injected: dict | None = None,
    reference: bool = True,
) -> MethodAdvice:
    """The search over substeps for one method, in this process (the caller isolates engines).
    ``cost_per_step`` = (seconds, how timed) reuses a measured figure (a nightly's cost cell);
    ``injected``: timings to read instead of the clock's (``harness.measures.cost``); ``reference``
    False: where no position tolerance is asked, nothing is held against the scene's reference
    solution (no position error; a run that finishes is judged by its energy, which a run that
    blows up fails): a stiff 32 x 32 cloth's DOP853 reference costs more than the whole search."""
    method = resolve(method, scene)
    out = MethodAdvice(method.id)
    try:
        out.homega_limit, out.limit_verdict, out.limit_searched = _limit(method, scene, request, timeout)
    except InvalidInput as exc:  # the one-step map cannot be measured: each step is judged by its run
        out.limit_verdict = f"not measured ({exc})"
    if cost_per_step is not None:
        out.cost_per_step_s, out.cost_timing = cost_per_step
    levels = request.substeps
    rows: dict[int, Row] = {}

    def measure(s: int) -> Row:
        if s not in rows:
            rows[s] = _row(method, scene, request, s, out, timeout, reference)
        return rows[s]

    # The most substeps first: a method that misses the tolerances there misses them at every
    # coarser step too (a convergent method's error falls with h), and is judged by one run.
    # Where it meets them, bisect over the levels for the fewest substeps that still do.
    if measure(levels[-1]).meets:
        fails, meets = -1, len(levels) - 1
        while meets - fails > 1:
            mid = (fails + meets) // 2
            if measure(levels[mid]).meets:
                meets = mid
            else:
                fails = mid
        best = levels[meets]
    else:
        best = None
    out.rows = [rows[s] for s in sorted(rows)]
    if best is not None:
        out.best = sorted(rows).index(best)
        out.best_row.converged = convergence(method, scene, request, out.best_row, out, timeout, reference)
        if out.cost_per_step_s is None:
            out.cost_per_step_s, out.cost_timing, out.cost_rel_spread = _cost_per_step(
                method, scene, out.best_row.h, injected
            )
    for row in out.rows:
        release(row)
        if out.cost_per_step_s is not None:
            row.cost_per_frame_s = row.substeps * out.cost_per_step_s
    if out.best is None:
        out.reason = _reason(out, request)
    return out


def _row(
    method,
    scene: Scene,
    request: Request,
    s: int,
    out: MethodAdvice,
    timeout,
    reference: bool = True,
    count: bool = True,
) -> Row:
    """One substep count measured: stability first (no run for a step known unstable), then the
    horizon run's energy, position error and counted evaluations, judged against the request.
    ``count`` False: no evaluations counted where the run did not count them (a sweep, which
    prints none, skips the interpreted counting run: on a large cloth its Python conjugate
    gradients are dearer than the whole search)."""
    from harness.execution.simulate import simulate
    from harness.measures.stability import blew_up, spectral_test

    h = 1.0 / (request.hz * s)
    row = Row(substeps=s, h=h, homega=h * scene.omega, stable=False, status="skipped")
    if scene.linear and not out.limit_verdict.startswith("not measured"):
        stable, info = spectral_test(method, scene, h, timeout=timeout)
        row.rho = info["rho"]
        if not stable:
            row.why = (
                f"unstable: spectral radius {row.rho:.6g} > 1 at h*omega = {row.homega:.3g}"
                if row.rho is not None
                else f"unstable: {info.get('reason')}"
            )
            return row
    steps = max(1, int(round(request.horizon * request.hz * s)))
    traj = simulate(method, scene, h, steps, frame_stride(s, steps), timeout=timeout)
    row.status, row.detail = traj.status, traj.detail
    if traj.status in ("crashed", "timed_out"):
        row.why = f"{traj.status}: {traj.detail}"
        return row
    reference = reference or request.accuracy
    frames = _Frames(traj, scene, request, s)
    if reference:
        blown, _, what = blew_up(traj, scene, frames.true_size) if traj.ok else (True, math.inf, "")
    else:  # judged by its energy alone (advise_method's ``reference``)
        blown, what = not traj.ok, ""
    if blown:
        row.why = (
            f"unstable: blew up at step {traj.failed_step} of {steps} (h*omega = {row.homega:.3g})"
            if not traj.ok
            else f"unstable: {what}"
        )
        return row
    row.stable = True
    row.energy_error, row.energy_gained, row.energy_way = _energy_error(traj, scene, frames)
    differs = _built_differently(method, scene, out)
    if differs:  # the file's energy is MuJoCo's function of MuJoCo's model: not this engine's
        row.energy_error = row.energy_gained = row.energy_way = None
        from harness.measures.cross_engine import differs_word

        row.detail = (row.detail + "; " if row.detail else "") + f"{differs_word(differs)}: " + "; ".join(differs[:3])
    row.energy_class = _energy_class(traj, scene, frames)
    # What a convergence check holds the tightened run against (not recorded: ``release`` drops it).
    row._at_frames = frames.positions().copy()
    if reference:
        judged = frames.judged()
        if judged is not None:
            row.position_error, row.com_error, row.strain_excess = (
                judged.position_error,
                judged.com_error,
                judged.strain_excess,
            )
            predictable = frames.horizon()
            row.judged_until = predictable.until if predictable is not None and predictable.short else None
    if traj.force_evals is not None:
        row.evals_per_frame = traj.force_evals / steps * s
    elif count:  # counted as the cost measure counts them: a counting run where the mode has one
        from harness.measures.cost import counted_evaluations

        counted = counted_evaluations(method, scene, h, steps=min(steps, COUNT_STEPS), timeout=timeout)
        if counted["force_evals_per_step"] is not None:
            row.evals_per_frame = counted["force_evals_per_step"] * s
        else:
            out.evals_reason = counted["force_evals_reason"]
    _judge(row, request, scene, method)
    return row


def classed(scene: Scene, horizon: float) -> bool:
    """Whether the horizon holds the periods the energy classification needs
    (``harness.measures.energy.MIN_PERIODS``): over fewer a bounded band reads as a drift."""
    from harness.measures.energy import MIN_PERIODS

    return horizon >= MIN_PERIODS * scene.period


def convergence(
    method,
    scene: Scene,
    request: Request,
    row: Row,
    advice: MethodAdvice,
    timeout=None,
    reference: bool = True,
    count: bool = True,
) -> dict | None:
    """The row's method run again at the row's substeps with its convergence knob tightened
    (``harness.methods.tightened``), judged as the row was, and its motion against the row's: its
    positions at every frame inside the predictable horizon and its centre of mass past it
    (``harness.measures.horizon.moved``), within the position tolerance (the request's, else the
    default share of the length scale): ``{"method", "meets", "why", "energy_error", "position_error",
    "com_error", "strain_excess", "energy_within", "moved", "com_moved", "tol", "until", "motion"}``;
    "meets" False where the tightened run misses the tolerances or its motion moves past them (the
    row's win then rests on its solve's own error); None for a method with no knob (nothing
    iterates short of its answer)."""
    from harness.methods import tightened

    from harness.measures.horizon import measure, moved

    tight = tightened(method)
    if tight is None:
        short = newton_shortfall(row)
        if not short:
            return None
        # No knob to tighten, but the run's own Newton iteration said it stopped short: the win
        # rests on steps that were not solved.
        return {
            "method": method.id,
            "meets": False,
            "unconverged": True,
            "why": short,
            "energy_error": row.energy_error,
            "position_error": row.position_error,
            "com_error": row.com_error,
            "strain_excess": row.strain_excess,
            "energy_within": True,
            "moved": None,
            "com_moved": None,
            "tol": None,
            "until": None,
            "motion": False,
        }
    probe = MethodAdvice(tight.id, limit_verdict=advice.limit_verdict)
    r = _row(tight, scene, request, row.substeps, probe, timeout, reference, count)
    out = {
        "method": tight.id,
        "meets": r.meets,
        "why": r.why or ("" if r.meets else r.status),
        "energy_error": r.energy_error,
        "position_error": r.position_error,
        "com_error": r.com_error,
        "strain_excess": r.strain_excess,
    }
    out["energy_within"] = bool(
        r.stable
        and (request.energy_tol is None or (r.energy_error is not None and r.energy_error <= request.energy_tol))
    )
    mine, theirs = getattr(row, "_at_frames", None), getattr(r, "_at_frames", None)
    release(r)
    if mine is None or theirs is None or not r.stable:
        out["motion"] = False if not r.stable else None
        return out
    # Every figure the row's verdict rests on, and the motion itself: the tightened run's positions
    # at the frames against the row's, inside the predictable horizon, its centre of mass past it.
    tol = judged_tolerance(request, scene)
    # Two runs that stay within the tolerance over the whole horizon have converged wherever the
    # horizon falls: the two references are solved only where they part by more.
    h = None
    apart, com = moved(scene, mine, theirs, None)
    if apart > tol:
        h = measure(scene, request.hz, request.horizon, tol)
        apart, com = moved(scene, mine, theirs, h)
    out.update(moved=apart, com_moved=com, tol=tol, until=None if h is None or not h.short else h.until)
    whys = [out["why"]] if out["why"] else []
    if apart > tol:
        whys.append(
            f"its positions move {apart:.3g} > {tol:.3g}"
            + (f" within the predictable horizon ({h.until:.3g} s)" if h is not None and h.short else "")
        )
    if com is not None and com > tol:
        whys.append(f"its centre of mass moves {com:.3g} > {tol:.3g} past the horizon")
    out["motion"] = bool(apart <= tol and (com is None or com <= tol))
    out["meets"] = bool(r.meets and out["motion"])
    out["why"] = "; ".join(whys)
    return out


def release(row: Row | None) -> Row | None:
    """The row without the run's positions a convergence check reads (what goes back to a caller)."""
    if row is not None:
        row.__dict__.pop("_at_frames", None)
    return row


#: How a run says its Newton iteration stopped short at some steps (``reference.solvers``).
UNCONVERGED = "ended their Newton iteration unconverged"


def newton_shortfall(row: Row) -> str:
    """The run's own account of its unconverged Newton steps ("" where none)."""
    for part in (row.detail or "").split("; "):
        if UNCONVERGED in part:
            return part
    return ""


def rests_on_solve(row: Row | None) -> bool:
    """Whether a row that meets the tolerances misses them once its solve converges further."""
    return row is not None and row.converged is not None and not row.converged["meets"]


def solve_note(row: Row) -> str:
    """Why a row's win rests on its solve's own error, in a few words."""
    c = row.converged
    if c.get("unconverged"):
        return f"its win rests on steps its solve did not converge: {c['why']}"
    return (
        f"its win rests on the solve's own error: {c['method']} at {row.substeps} substep"
        f"{'s' if row.substeps > 1 else ''} misses them ({c['why']})"
    )


def _energy_class(traj, scene: Scene, frames=None) -> str | None:
    from harness.measures.energy import classify

    if not classed(scene, float(traj.t[-1] - traj.t[0])):
        return None  # too few periods to tell a band from a drift (the command says so under its table)
    t, e, exact = _energies(traj, scene, frames)
    return classify(e, exact, t)["classification"]


def _reason(advice: MethodAdvice, request: Request) -> str:
    """Why a method meets the tolerances at no substep count tried, in a few words: what its
    most substeps measured."""
    last = advice.rows[-1]
    if last.stable:
        return f"{last.why} at {last.substeps} substep{'s' if last.substeps > 1 else ''}"
    if last.status in ("crashed", "timed_out"):
        return last.why
    if advice.limit_verdict in ("unstable", "unresolved"):
        every = "at every h" if advice.limit_verdict == "unstable" else "at every h (no stable step resolved)"
        return (
            f"unstable: spectral radius > 1 {every} (h*omega = {last.homega:.3g} at {last.substeps} substeps): "
            "its error grows without bound, so no run over the horizon makes it advisable"
        )
    if advice.homega_limit is not None:
        return f"unstable: h*omega = {last.homega:.3g} > {advice.homega_limit:.3g} at {last.substeps} substeps"
    return f"{last.why} at {last.substeps} substeps"


# ----------------------------------------------------------------------------- the advice
@dataclass
class Advice:
    scene: str
    params: dict
    request: Request
    methods: list[MethodAdvice]
    left_out: list[dict] = field(default_factory=list)
    length_scale: float | None = None  # the scene's (``Scene.length_scale``)
    position_tol: float | None = None  # the position tolerance on the scene, absolute (None: not judged)
    periods: float | None = None  # the horizon in periods of the scene's omega
    horizon: dict | None = None  # the scene's predictable horizon (``harness.measures.horizon``), where measured

    @property
    def meeting(self) -> list[MethodAdvice]:
        """Methods that meet the tolerances, cheapest frame first (fewest evaluations, then
        the id, where a cost is missing)."""
        ok = [m for m in self.methods if m.best is not None]
        return sorted(ok, key=lambda m: (_inf(m.best_row.cost_per_frame_s), m.method))

    @property
    def failing(self) -> list[MethodAdvice]:
        return sorted((m for m in self.methods if m.best is None), key=lambda m: m.method)

    @property
    def closest(self) -> tuple[MethodAdvice, Row] | None:
        """Where no method meets the tolerances: the stable row nearest them (the smallest
        largest ratio of a measured error to its tolerance)."""
        best, score = None, math.inf
        for m in self.methods:
            for r in m.rows:
                if not r.stable:
                    continue
                x = _excess(r, self.request, self.position_tol)
                if x < score:
                    best, score = (m, r), x
        return best

    @property
    def tied(self) -> list[MethodAdvice]:
        """The methods that meet the tolerances at a frame cost within the cheapest's timing spread
        (``tie``), the cheapest first: more than one, and the pick is a tie."""
        meeting = self.meeting
        if not meeting:
            return []
        first = meeting[0]
        return [first] + [
            m
            for m in meeting[1:]
            if tie(
                first.best_row.cost_per_frame_s,
                first.cost_rel_spread,
                m.best_row.cost_per_frame_s,
                m.cost_rel_spread,
            )
        ]

    def horizon_text(self) -> str:
        """The predictable horizon and what was judged past it, where one was measured."""
        from harness.measures.horizon import Horizon

        h = Horizon.from_dict(self.horizon)
        if h is None or self.position_tol is None:
            return ""
        past = h.past_text()
        return f"; the scene is {h.text()}" + (f": {past}" if past else "")

    def verdict(self) -> str:
        """The verdict in a line; without an accuracy tolerance it says so first. Methods whose frames
        cost the same within their timing spread are a tie, each named."""
        first = "" if self.position_tol is not None else "no accuracy tolerance (the energy alone judged): "
        meeting = self.meeting
        if meeting:
            m = meeting[0]
            r = m.best_row
            rests = f"; {solve_note(r)}" if rests_on_solve(r) else ""
            tied = self.tied
            if len(tied) > 1:
                names = " and ".join(
                    f"{t.method} ({t.best_row.substeps} substep{'s' if t.best_row.substeps > 1 else ''}, "
                    f"{_us(t.best_row.cost_per_frame_s)} per frame)"
                    for t in tied
                )
                return (
                    f"{first}cheapest that meets the tolerances: a tie within the timing spread, {names}"
                    f"{rests}{self.horizon_text()}"
                )
            return (
                f"{first}cheapest that meets the tolerances: {m.method}, {r.substeps} substep"
                f"{'s' if r.substeps > 1 else ''}, {_us(r.cost_per_frame_s)} per frame{rests}{self.horizon_text()}"
            )
        near = self.closest
        if near is None:
            return f"{first}no method meets the tolerances, and none ran stably at any substep count tried"
        m, r = near
        return (
            f"{first}no method meets the tolerances; closest: {m.method} at {r.substeps} substep"
            f"{'s' if r.substeps > 1 else ''} ({r.why}){self.horizon_text()}"
        )

    def advice(self) -> dict | None:
        """The advice as data: the cheapest method that meets the tolerances, its substeps, h,
        cost per frame, errors and evaluations, and the runner-up alike; None where none meets
        them (``closest`` then says what came nearest)."""
        meeting = self.meeting
        if not meeting:
            return None
        return {
            **_choice(meeting[0]),
            "runner_up": _choice(meeting[1]) if len(meeting) > 1 else None,
            "tie": [m.method for m in self.tied] if len(self.tied) > 1 else None,
        }

    def as_dict(self) -> dict:
        near = self.closest
        return {
            "scene": self.scene,
            "params": self.params,
            "request": asdict(self.request),
            "length_scale": self.length_scale,
            "position_tol": self.position_tol,
            "periods": self.periods,
            "horizon": self.horizon,
            "advice": self.advice(),
            "verdict": self.verdict(),
            "closest": None if self.meeting or near is None else {**_choice(near[0], near[1]), "why": near[1].why},
            "meeting": [m.method for m in self.meeting],
            "methods": [m.as_dict() for m in self.methods],
            "left_out": self.left_out,
        }


def _choice(m: MethodAdvice, row: Row | None = None) -> dict:
    r = row or m.best_row
    return {
        "method": m.method,
        "substeps": r.substeps,
        "h": r.h,
        "h_omega": r.homega,
        "cost_per_frame_s": r.cost_per_frame_s,
        "cost_timing": m.cost_timing or None,
        "energy_error": r.energy_error,
        "energy_class": r.energy_class,
        "position_error": r.position_error,
        "judged_until": r.judged_until,
        "com_error": r.com_error,
        "strain_excess": r.strain_excess,
        "evals_per_frame": r.evals_per_frame,
        "evals_reason": None if r.evals_per_frame is not None else (m.evals_reason or None),
        "converged": r.converged,
    }


def _inf(x):
    return math.inf if x is None else x


def _excess(row: Row, request: Request, position_tol: float | None) -> float:
    ratios = []
    if request.energy_tol is not None:
        ratios.append(_inf(row.energy_error) / request.energy_tol)
    if position_tol is not None:
        ratios.append(_inf(row.position_error) / position_tol)
    return max(ratios)


def _us(seconds: float | None) -> str:
    return "cost not measured" if seconds is None else f"{seconds * 1e6:.3g} µs"


def candidates(scene: Scene, patterns: list[str] | None) -> tuple[list[str], list[dict]]:
    """Method ids matching ``patterns`` (fnmatch, e.g. ``ref:*``; default every method) that can
    be advised on ``scene``, and those left out with why. A pattern with an option in it is one
    method at those options (``ref:xpbd?iterations=1``, checked as every id is). A pattern
    matching no method id is bad input."""
    from harness.methods import all_methods, get_method

    methods = dict(all_methods())
    ids = list(methods)
    if patterns:
        chosen = []
        for pat in patterns:
            if "=" in pat or "@" in pat:  # a method at options of its own, not a wildcard
                m = get_method(pat)
                methods[m.id] = m
                chosen.append(m.id)
                continue
            hit = [m for m in ids if fnmatch.fnmatchcase(m, pat)]
            if not hit:
                raise InvalidInput(
                    f"--methods pattern {pat!r} matches no method (valid: {', '.join(ids)}, "
                    "or a pattern such as ref:* or mujoco:*)"
                )
            chosen += hit
        ids = list(dict.fromkeys(chosen))
    keep, left = [], []
    for mid in ids:
        m = methods[mid]
        ok, why = m.available()
        if ok:
            ok, why = m.supports(scene)
        if ok and m.adaptive:
            ok, why = False, "chooses its own steps: substeps do not apply"
        (keep.append(mid) if ok else left.append({"method": mid, "reason": why}))
    return keep, left


def _advise_in_worker(
    method_id: str, scene: Scene, request: Request, timeout, plugins, injected: dict | None = None
) -> MethodAdvice:
    from harness.methods import get_method, use_plugins

    use_plugins(plugins)
    # A reference scheme's runs on its compiled loop where that computes the interpreted bits (as
    # the nightly's advice cells): the same figures; backward Euler's Newton iterations over the
    # cloth's solve, interpreted, do not finish within the command's limit at 4 x 4.
    method = get_method(method_id, compiled_where_bitwise=True)
    return advise_method(method, scene, request, timeout=timeout, injected=injected)


def _found(res: MethodAdvice) -> str:
    """What a method's search found, in a progress line's words."""
    if res.status != "ok":
        return res.status
    if res.best is None:
        return "misses the tolerances"
    n = res.best_row.substeps
    return f"{n} substep{'s' if n != 1 else ''}"


def _as_they_end(futures: dict):
    """(key, future) pairs of ``futures`` in the order they finish."""
    from concurrent.futures import as_completed

    keys = {fut: key for key, fut in futures.items()}
    for fut in as_completed(keys):
        yield keys[fut], fut


def advise(
    scene: Scene,
    request: Request,
    patterns: list[str] | None = None,
    *,
    jobs: int = 1,
    timeout: float = 120.0,
    progress=None,
) -> Advice:
    """Advice for ``scene``: every candidate method searched in ``jobs`` reused worker processes
    (an engine that aborts or hangs costs its method a ``crashed`` / ``timed_out`` entry), then
    ranked. Timings injected by ``$HARNESS_INJECT_TIMINGS`` are read here and handed to the workers.
    ``progress``: told a line as each method's search ends (a command's progress)."""
    from concurrent.futures import ThreadPoolExecutor

    from harness.measures.injected import load_injected
    from harness.execution.isolation import WorkerFailure, engine_modules, preload_engines
    from harness.execution.pool import WorkerPool
    from harness.methods import active_plugins

    from harness.measures.horizon import measure

    request = request.checked()
    validate.scene_values(scene)
    ids, left = candidates(scene, patterns)
    plugins = active_plugins()
    injected = load_injected()
    # Both references once, here: the scene carries them to every worker (``harness.measures.horizon``).
    tol = request.position_tolerance(scene)
    # The workers' server imports the engines these methods step, not every installed one (Drake's
    # and Warp's imports are seconds a spring's advice need not wait for).
    preload_engines(engine_modules(ids))
    say = progress or (lambda line: None)
    if tol is not None and ids:
        say(f"advise: the predictable horizon (two references of {scene.id})")
    horizon = measure(scene, request.hz, request.horizon, tol) if tol is not None and ids else None
    results: dict[str, MethodAdvice] = {}
    with WorkerPool(max(1, min(jobs, len(ids) or 1))) as pool, ThreadPoolExecutor(max(1, jobs)) as threads:
        futures = {
            mid: threads.submit(
                pool.call, _advise_in_worker, (mid, scene, request, timeout, plugins, injected), timeout=timeout
            )
            for mid in ids
        }
        say(f"advise: {len(ids)} methods searched in {max(1, min(jobs, len(ids)))} workers")
        for done, (mid, fut) in enumerate(_as_they_end(futures), start=1):
            res = fut.result()
            if isinstance(res, WorkerFailure):
                res = MethodAdvice(mid, status=res.status, reason=f"{res.status}: {res.detail}")
            results[mid] = res
            say(f"advise: {done} of {len(ids)} methods searched ({mid}: {_found(res)})")
    return Advice(
        scene.id,
        dict(scene.values),
        request,
        [results[m] for m in ids],
        left,
        scene.length_scale,
        request.position_tolerance(scene),
        request.horizon / scene.period,
        horizon.as_dict() if horizon is not None else None,
    )
