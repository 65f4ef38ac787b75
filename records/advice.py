"""The advice's records: one (method, substeps) row measured, and one method's search over
substeps (``harness.measures.advise`` measures them; the nightly stores them in its advice cells,
the report and ``harness advise`` print them)."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field


@dataclass
class Row:
    """One (method, substeps) measured. ``meets`` the tolerances, else ``why`` not."""

    substeps: int
    h: float
    homega: float
    stable: bool
    status: str                     # ok, unstable, crashed, timed_out (of the horizon run, or "skipped")
    rho: float | None = None        # spectral radius of the one-step map at h (linear scenes)
    energy_error: float | None = None
    energy_gained: bool | None = None
    energy_class: str | None = None
    position_error: float | None = None
    evals_per_frame: float | None = None
    cost_per_frame_s: float | None = None
    meets: bool = False
    why: str = ""
    detail: str = ""


@dataclass
class MethodAdvice:
    """One method's search: its rows (in the order measured), the row that meets the
    tolerances with the fewest substeps (``best``, an index into ``rows``), or ``reason``."""

    method: str
    status: str = "ok"              # ok, or crashed / timed_out where the search itself died
    homega_limit: float | None = None
    limit_verdict: str = "not measured"   # limited, unbounded (stable at every h*omega searched), unstable
    limit_searched: float | None = None   # the largest h*omega the limit search tried
    cost_per_step_s: float | None = None
    cost_timing: str = ""
    evals_reason: str = ""
    rows: list[Row] = field(default_factory=list)
    best: int | None = None
    reason: str = ""

    @property
    def best_row(self) -> Row | None:
        return None if self.best is None else self.rows[self.best]

    def as_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "MethodAdvice":
        d = dict(d)
        rows = [Row(**r) for r in d.pop("rows", [])]
        return cls(rows=rows, **d)
