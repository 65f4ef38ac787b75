"""What judging a nightly run found (``harness.judge``), as plain records the report prints.

Nothing here judges: a ``Finding`` is a line of markdown and whether what it checks holds
(None where it checks nothing), ``ClaimChecks`` the agreement of one method's cells with its
textbook claims (and those claims), ``Verdict`` the run against the previous one. ``MARK`` stands in a finding's
text where its verdict mark is printed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from records.cell import Claims

#: Where a finding's text carries its verdict mark (replaced by the report's check or cross).
MARK = "{mark}"


@dataclass(frozen=True)
class Finding:
    """One line of the report's findings (markdown, no leading dash)."""

    text: str
    ok: bool | None = None  # whether what the line checks holds; None: it checks nothing
    scene: str | None = None
    method: str | None = None


@dataclass(frozen=True)
class ClaimChecks:
    """One method's cells on a scene against its ``claims``: each True / False, None where not judged."""

    claims: Claims = field(default_factory=Claims)
    evals: bool | None = None  # counted force evaluations per step = the declared number
    order: bool | None = None  # observed order within ORDER_TOL of the declared
    energy: bool | None = None  # energy class = the declared behaviour
    homega: bool | None = None  # largest stable h*omega within STABILITY_TOL of the declared


@dataclass(frozen=True)
class Change:
    """An accuracy figure that changed in this run (deterministic, so reported at once)."""

    scene: str
    method: str
    measure: str
    before: float
    after: float


@dataclass(frozen=True)
class Verdict:
    """The run against the previous complete run of its suite."""

    previous: int | None  # that run's id; None: none (bounds checked only)
    regressions: tuple[str, ...] = ()  # one line each
    judged_runs: int | None = None  # cost judged over this many runs (None: run to run)
    changed: tuple[Change, ...] = ()
    failed: tuple[tuple[str, str], ...] = ()  # (scene, method) with a crashed or timed-out cell
    not_measured: tuple[str, ...] = ()  # one line per cell that timed out this run: not a regression


@dataclass(frozen=True)
class Judgement:
    """Everything judged about one run: what the report prints beside the measured cells."""

    verdict: Verdict
    claims: dict = field(default_factory=dict)  # (scene, method) -> ClaimChecks
    bounds: dict = field(default_factory=dict)  # (scene, method, dt) -> whether within its bound
    findings: tuple[Finding, ...] = ()
