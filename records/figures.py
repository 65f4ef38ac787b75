"""Each measure's figures as a typed record (``records.cell.FIGURES`` names each measure's), and
the typed rows a report reads of them; the textbook claims a cell is
judged against (``Claims``), and ``Record``, the frozen-dataclass-as-flat-dict they share: a
field ``name`` is stored under ``KEYS.get(name, name)`` and a None figure is not written
(``records.cell`` stores them in a cell's ``data``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any, ClassVar


class Record:
    """A frozen record stored as a flat dict: field ``name`` under its ``KEYS.get(name, name)``,
    None figures left out; a field named in ``NESTED`` holds a record of that class."""

    KEYS: ClassVar[dict[str, str]] = {}
    NESTED: ClassVar[dict[str, type]] = {}

    @classmethod
    def stored_keys(cls) -> dict[str, str]:
        """{stored key: field name}."""
        return {cls.KEYS.get(f.name, f.name): f.name for f in fields(cls)}

    @classmethod
    def from_data(cls, data: dict) -> tuple[Record, dict]:
        """(the record, the keys of ``data`` that are none of its fields)."""
        keys = cls.stored_keys()
        mine = {keys[k]: v for k, v in data.items() if k in keys}
        for name, kind in cls.NESTED.items():
            if isinstance(mine.get(name), dict):
                mine[name] = kind.from_data(mine[name])[0]
        return cls(**mine), {k: v for k, v in data.items() if k not in keys}

    @classmethod
    def pick(cls, result: dict, **given) -> Record:
        """The record of the entries of ``result`` (a measure's result) named as its fields are
        stored, and of ``given``; the rest of ``result`` is not taken."""
        keys = cls.stored_keys()
        taken = {name: result[key] for key, name in keys.items() if key in result and name not in given}
        return cls(**taken, **given)

    def to_data(self) -> dict:
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None:
                continue
            out[self.KEYS.get(f.name, f.name)] = v.to_data() if isinstance(v, Record) else v
        return out


@dataclass(frozen=True)
class Claims(Record):
    """The textbook claims of a scheme, as a cell is judged by them: its order (on this scene),
    counted force evaluations per step, energy behaviour, largest stable h*omega (None: none is
    stable; inf: every one is). ``scheme`` is None where no scheme is known (an engine mode that
    matches none)."""

    scheme: str | None = None
    order: float | None = None
    order_note: str | None = None
    force_evals: float | None = None
    force_evals_text: str | None = None
    energy: str | None = None
    homega_max: float | None = None
    #: The evaluations are per Newton pass, the passes as many as the iteration takes (coupled
    #: stages that iterate even on a linear scene: two-stage Radau IIA): a step counts whole passes.
    evals_per_pass: bool = False

    @property
    def known(self) -> bool:
        return self.scheme is not None

    def to_data(self) -> dict:
        """{} where no scheme is known; else every claim, None included (a None ``homega_max``
        is a claim: no h is stable), the order note only where there is one."""
        if not self.known:
            return {}
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        if self.order_note is None:
            del out["order_note"]
        if not self.evals_per_pass:
            del out["evals_per_pass"]
        return out


@dataclass(frozen=True)
class Figures(Record):
    """The figures of one measure (a subclass per measure)."""


@dataclass(frozen=True)
class EnergyFigures(Figures):
    """``energy``: max |dE/E| (the cell's value) and its classification over the energy run."""

    KEYS: ClassVar[dict[str, str]] = {"energy_class": "class"}
    energy_class: str | None = None  # bounded, grows, decays, drifts, ... (stored as "class")
    rule: str | None = None
    rel_error_defined: bool | None = None  # False where the exact energy crosses zero
    final_rel_error: float | None = None
    failed_step: int | None = None
    series: dict | None = None  # {"t", "energy", "exact"}, downsampled, for the chart
    numbers: dict | None = None  # the classification's figures (envelopes, secular rate)
    events: list | None = None  # what the bodies did (Scene.events): ejected, spiralled in
    settings: Any = None  # what an engine adapter recorded of its settings
    engine_version: str | None = None
    backend: str | None = None


@dataclass(frozen=True)
class ErrorFigures(Figures):
    """``error``: max global error (the value) over the energy run."""

    error_final: float | None = None
    source: str | None = None
    t_compared: float | None = None
    horizon: float | None = None
    t_final: float | None = None
    reference_error: float | None = None  # the true state's own estimated error (0: exact)
    below_reference: bool | None = None  # the error is at or below it: no number (the value None)


@dataclass(frozen=True)
class OrderFigures(Figures):
    """``order``: the observed order (the value) of the dt sweep."""

    points: list | None = None  # [{"dt", "error", ...}] used in the fit
    excluded: list | None = None
    rvalue: float | None = None
    range: dict | None = None  # the dt range the sweep chose


@dataclass(frozen=True)
class NominalRun(Record):
    """The stability measure's finite horizon run once more at the suite's nominal dt
    (``harness.nightly.cells._nominal_run``): where it failed, and its energy against time
    (``series``: t, energy, e0; absent where the run recorded no state)."""

    dt: float | None = None
    homega: float | None = None
    steps: int | None = None
    status: str | None = None
    failed_step: int | None = None
    detail: str | None = None
    series: dict | None = None

    @property
    def has_series(self) -> bool:
        return bool(self.series and len(self.series["t"]))


#: Significant digits of every stability limit the report prints, measured or declared: the nightly's
#: coarsest search bisects to 1e-4 relative, its limit the last stable step, up to 1e-4 below the
#: boundary, so a fourth digit could print 0.9971 in one table and 0.9972 in another for one limit
#: (Dormand-Prince's 0.997188). Three digits are what every search resolves.
LIMIT_DIGITS = 3


def limit_text(x, none: str = "none") -> str:
    """A largest stable h*omega as every table prints it (``LIMIT_DIGITS``), the report and the commands alike: None
    -> ``none``, inf -> ``unbounded``."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return none
    if math.isinf(x):
        return "unbounded"
    return format(x, f".{LIMIT_DIGITS}g")


@dataclass(frozen=True)
class StabilityFigures(Figures):
    """``stability``: the largest stable h*omega (the value; inf where unbounded)."""

    NESTED: ClassVar[dict[str, type]] = {"nominal": NominalRun}

    criterion: str | None = None
    criterion_rule: str | None = None
    verdict: str | None = None  # limited, unbounded, unstable, unresolved
    dt_max: float | None = None
    unbounded: bool | None = None
    unstable_everywhere: bool | None = None
    unresolved: bool | None = None  # no stable step resolved (``harness.measures.stability``)
    homega_searched: float | None = None
    rho_above_dt_max: float | None = None
    nominal: NominalRun | None = None  # the finite horizon's run at the suite's nominal dt
    horizon_steps: int | None = None  # the finite horizon's steps: a limit found over it holds over it alone


@dataclass(frozen=True)
class CostFigures(Figures):
    """``cost``: CPU seconds per step (the value), counted evaluations, the ratio to explicit Euler."""

    force_evals_per_step: float | None = None
    force_evals_reason: str | None = None  # why they are not counted, where they are not
    solves_per_step: float | None = None
    timing: str | None = None
    clock: str | None = None
    repeats_s_per_step: list | None = None
    spread: float | None = None
    ratio_to_explicit_euler: float | None = None
    ratio_spread: float | None = None
    ratio_repeats: list | None = None
    baseline_s_per_step: float | None = None
    baseline_repeats_s_per_step: list | None = None
    loop: str | None = None
    engine_loop: str | None = None
    as_stepped_s_per_step: float | None = None
    as_stepped_repeats_s_per_step: list | None = None
    as_stepped_timing: str | None = None
    calibration: float | None = None  # the machine's calibration ratio, timed beside
    calibration_spread: float | None = None  # (harness.measures.calibration)
    first_ratio: float | None = None  # a slowdown measured again in fresh processes
    remeasured_ratios: list | None = None  # (harness.nightly.run.remeasure_slowdowns): the first
    process_noise: float | None = None  # figure, the others, their noise (log units)

    @property
    def noise(self) -> float:
        """The relative spread its point in a series carries: the ratio's where timed against
        explicit Euler, else the seconds'."""
        return (self.ratio_spread if self.ratio_spread is not None else self.spread) or 0.0


@dataclass(frozen=True)
class IdentityFigures(Figures):
    """``identity``: which reference scheme an engine mode integrates (value: the max deviation)."""

    NESTED: ClassVar[dict[str, type]] = {"match_claims": Claims}
    match: str | None = None
    matches: list | None = None
    closest: str | None = None
    runner_up: str | None = None
    runner_up_deviation: float | None = None
    name_suggests: str | None = None
    match_claims: Claims | None = None
    note: str | None = None
    precision: str | None = None  # the mode's arithmetic: float32 is matched at float32 rounding

    @property
    def all_matches(self) -> list[str]:
        """Every scheme matched (several where the scene cannot tell them apart)."""
        return list(self.matches or ([self.match] if self.match else []))


@dataclass(frozen=True)
class AdviceFigures(Figures):
    """``advise``: one frame rate's search over substeps (value: the best cost per frame). ``rows``
    are the measured (substeps, h*omega, errors, cost per frame ...) rows, ``best`` an index."""

    hz: float | None = None
    request: dict | None = None
    length_scale: float | None = None  # the scene's, that a relative position tolerance is a share of
    position_tol: float | None = None  # the position tolerance on the scene (None: positions not judged)
    method: str | None = None
    status: str | None = None
    homega_limit: float | None = None
    limit_verdict: str | None = None
    limit_searched: float | None = None
    cost_per_step_s: float | None = None
    cost_timing: str | None = None
    evals_reason: str | None = None
    rows: list | None = None
    best: int | None = None
    reason: str | None = None


@dataclass(frozen=True)
class BoundFigures(Figures):
    """``bound``: a reviewed energy bound (the value: the measured max |dE/E|)."""

    bound: float | None = None


@dataclass(frozen=True)
class ConstraintFigures(Figures):
    """``constraint``: the largest relative link stretch (the value) over the energy run."""

    final_stretch: float | None = None
    energy_change: float | None = None
    max_energy_change: float | None = None
    t_final: float | None = None
    iterations: int | None = None
    failed_step: int | None = None
    by_iterations: list | None = None


@dataclass(frozen=True)
class DampingFigures(Figures):
    """``damping``: far beyond the explicit limit (the value: energy kept after one step)."""

    factor: float | None = None
    omega_dt: float | None = None
    energy_kept: float | None = None
    rho: float | None = None
    stable: bool | None = None
    reason: str | None = None
    modal_leak: float | None = None
    linearity_residual: float | None = None
    highest: dict | None = None  # the highest mode: rho, energy_factor, zeta
    lowest: dict | None = None
    failed_step: int | None = None
    run_status: str | None = None


@dataclass(frozen=True)
class StabilityVsDampingFigures(Figures):
    """``stability_vs_damping``: the limit at each damping ratio beside the theory (value: agreeing)."""

    scheme: str | None = None
    rows: list | None = None  # [{"zeta", "measured", "theory", "agrees"}]
    tolerance: float | None = None
    judged_by: str | None = None
    theory_curve: dict | None = None


@dataclass(frozen=True)
class ScalingFigures(Figures):
    """``scaling``: compiled cost per step against N (the value: the log-log slope)."""

    rows: list | None = None
    rvalue: float | None = None
    intercept: float | None = None
    settings: dict | None = None


@dataclass(frozen=True)
class BrouwerFigures(Figures):
    """``brouwer``: the energy error's growth over an ensemble (the value: the log-log slope of
    its RMS against t; Brouwer's law for roundoff, 0.5), with its 95% bootstrap interval."""

    ci95: list | None = None
    contains_brouwer: bool | None = None
    expected_slope: float | None = None
    realizations: int | None = None
    perturbation: float | None = None
    horizon: float | None = None
    periods: float | None = None
    every: int | None = None
    failed: int | None = None
    t: list | None = None
    rms: list | None = None
    error_slope: float | None = None
    error_ci95: list | None = None
    error_fit_until: float | None = None  # the position error's slope is fitted up to this t
    reason: str | None = None


@dataclass(frozen=True)
class CrossEngineFigures(Figures):
    """``cross_engine`` (a model file's conservative variant): two engine modes run from the same
    state at a step where each one's own error is at most a tenth of what is reported
    (``harness.measures.cross_engine``; the value: how far apart, relative), the verdict (agree,
    differ, models differ, not resolved), each step tried, and every quantity that differs in the
    models the two engines built, read back from each engine."""

    methods: list | None = None
    statuses: list | None = None
    errors: list | None = None
    reference_error: float | None = None
    verdict: str | None = None
    disagree: bool | None = None
    resolved: bool | None = None
    horizon: float | None = None
    levels: list | None = None
    differences: list | None = None
    notes: list | None = None


@dataclass(frozen=True)
class ToleranceFigures(Figures):
    """``tolerance``: per tolerance, the run's error, steps taken and rejected, evaluations and cost."""

    rows: list | None = None
    ended: str | None = None
    settings: dict | None = None


@dataclass(frozen=True)
class SmallStepsRow(Record):
    """One configuration of the small-steps study (``harness.measures.small_steps``): its label,
    scheme and options, and at the study's frame rate the energy retained E(end) / E(0), the
    largest stretch, the error against the reference and the CPU cost per frame (None where it did
    not run or was not timed: ``status``, ``detail``)."""

    config: str = ""
    scene: str | None = None
    method: str | None = None
    substeps: int | None = None
    iterations: int | None = None
    steps_per_frame: int | None = None
    hz: float | None = None
    status: str = "ok"
    detail: str | None = ""
    energy_retained: float | None = None
    stretch: float | None = None
    error: float | None = None
    cost_per_frame_s: float | None = None


@dataclass(frozen=True)
class PaperClaim(Record):
    """One claim of the paper judged from the small-steps rows: ✓, ✗ or – where it could not be
    judged, with the figures that decide it."""

    scene: str = ""
    claim: str = ""
    verdict: str = "–"
    figures: str = ""


@dataclass(frozen=True)
class SmallStepsSettings(Record):
    """How the small-steps study ran: the scene and its parameters, the frame rate and horizon,
    the passes compared, the timing's clock, frames and repeats, and the reference solution's own
    stretch over the same frames."""

    scene: str | None = None
    params: dict | None = None
    hz: float | None = None
    t_end: float | None = None
    passes: list | None = None
    clock: str | None = None
    timing_frames: int | None = None
    repeats: int | None = None
    cpu_s: float | None = None
    reference_stretch: float | None = None
    label: str | None = None  # the study's title where it is not its scene's id (a stiffened scene)


@dataclass(frozen=True)
class SmallStepsFigures(Figures):
    """``small_steps``: the study's rows, the paper's claims judged from them, its settings (stored
    as the study's dicts; read as ``SmallStepsRow``, ``PaperClaim``, ``SmallStepsSettings``)."""

    rows: list | None = None
    paper_claims: list | None = None  # the paper's claims judged (not "claims": a cell's own key)
    settings: dict | None = None
    #: Where the scene is not the paper's case (its reference stretches its soft springs), the study
    #: on the scene with every spring stiff: {"rows", "paper_claims", "settings"} as above.
    stiff: dict | None = None

    def studies(self) -> list[tuple[list[SmallStepsRow], list[PaperClaim], SmallStepsSettings]]:
        """Each study the cell holds (the scene's, then the stiffened scene's where there is one):
        its rows, its judged claims and its settings."""
        stiff = self.stiff or {}
        return [
            (
                [SmallStepsRow.from_data(r)[0] for r in rows or []],
                [PaperClaim.from_data(r)[0] for r in claims or []],
                SmallStepsSettings.from_data(settings or {})[0],
            )
            for rows, claims, settings in (
                (self.rows, self.paper_claims, self.settings),
                (stiff.get("rows"), stiff.get("paper_claims"), stiff.get("settings")),
            )
            if rows
        ]

    def study_rows(self) -> list[SmallStepsRow]:
        return [SmallStepsRow.from_data(r)[0] for r in self.rows or []]

    def judged_claims(self) -> list[PaperClaim]:
        return [PaperClaim.from_data(r)[0] for r in self.paper_claims or []]

    def study_settings(self) -> SmallStepsSettings:
        return SmallStepsSettings.from_data(self.settings or {})[0]
