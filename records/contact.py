"""What an engine's contact run hands back (``ContactRun``) and what the harness measured of it
(``ContactFigures``, the ``contact`` cell's figures)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .figures import Figures
from .trajectory import CRASHED, OK, TIMED_OUT, UNSTABLE

STATUSES = (OK, UNSTABLE, CRASHED, TIMED_OUT)

#: The three steps every contact mode is reported at (s): the harness's runs and the report's tables.
REPORT_DTS = (1 / 1000, 1 / 240, 1 / 60)


@dataclass
class ContactRun:
    """One engine mode's run of a contact scene at one step.

    ``t`` (n,) the recorded times, from 0 (the initial state) at every step; ``centres`` and
    ``velocities`` (n, bodies, 3): each body's centre and linear velocity, z up (a 2-D pose fills
    y with 0). ``loop_cpu_s``: the process CPU time of the engine's own stepping loop over the
    same steps with nothing recorded (a second pass), so that the cost is the engine's and not
    the recording's; ``loop`` says what that loop is. ``settings``: every contact setting the
    pose chose or read back (restitution and its combining rule, friction, damping, the contact
    model's parameters, speculative margins), stated with the results. ``status``: ``ok``, or
    ``unstable`` (a non-finite or runaway state, at ``failed_step``), ``crashed``, ``timed_out``,
    with ``detail`` saying where and why.
    """

    scene: str
    method: str
    dt: float
    t: np.ndarray
    centres: np.ndarray
    velocities: np.ndarray
    loop_cpu_s: float | None = None
    loop: str = ""
    settings: dict = field(default_factory=dict)
    status: str = OK
    detail: str = ""
    failed_step: int | None = None
    engine_version: str | None = None

    @property
    def steps(self) -> int:
        return max(len(self.t) - 1, 0)

    @classmethod
    def failed(cls, scene: str, method: str, dt: float, status: str, detail: str, **kw) -> "ContactRun":
        empty = np.zeros((0, 1, 3))
        return cls(scene, method, dt, np.zeros(0), empty, empty, status=status, detail=detail, **kw)


@dataclass(frozen=True)
class ContactFigures(Figures):
    """A contact run measured against its scene's truth (``harness.contact.figures``). Each figure
    is None where the scene does not pose it; ``passes`` names each judged figure's ✓ (True) or ✗.

    ball: ``restitution`` (per bounce, sqrt(H_n / H_(n-1)) from the recorded apexes),
    ``apex_ratio`` (H_bounces / H0), ``gained`` (the bounces whose apex exceeds the one before),
    ``intervals`` (the flights between impacts, s); slide: ``stop`` (the distance to where it
    stopped, m), ``stop_time`` (s), ``creep`` (what it moved after, m); rest and stack:
    ``penetration``, ``drift`` (m), ``kinetic`` (J, at the end). ``cpu_per_s``: the engine loop's
    CPU seconds per simulated second. ``truth``: the scene's analytic figures; ``settings``: the
    engine's contact settings as the pose stated them; ``status`` the run's (``detail`` says where
    and why a run failed) and ``engine_version`` the engine release that ran."""

    scene: str = ""
    params: dict = field(default_factory=dict)
    dt: float | None = None
    status: str = OK
    restitution: list | None = None
    apex_ratio: float | None = None
    gained: list | None = None
    intervals: list | None = None
    stop: float | None = None
    stop_time: float | None = None
    creep: float | None = None
    penetration: float | None = None
    drift: float | None = None
    kinetic: float | None = None
    cpu_per_s: float | None = None
    loop: str | None = None
    truth: dict = field(default_factory=dict)
    tolerances: dict = field(default_factory=dict)
    passes: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    detail: str | None = None
    engine_version: str | None = None


@dataclass(frozen=True)
class ContactCellFigures(Figures):
    """The nightly's ``contact`` cell: one engine mode on one contact scene (``scene_params`` its
    parameters) at every step of the ladder (``harness.contact.run.LADDER``). ``runs``: each step's
    ``ContactFigures`` as stored (``to_data``), with its ``status``; ``largest``: for each judged figure, the largest step of the
    ladder at which it and every shorter step is ✓ (None: not even the shortest); the cell's value
    is the largest step at which every figure is. ``settings`` and ``doc``: the mode's contact
    settings and what it is."""

    scene: str = ""
    scene_params: dict = field(default_factory=dict)
    runs: list = field(default_factory=list)
    largest: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    doc: str | None = None
    engine_version: str | None = None


@dataclass(frozen=True)
class PenaltyFigures(Figures):
    """The nightly's ``penalty`` cell: one reference scheme on the penalty ball
    (``harness.contact.penalty``), a row per (e, h*omega_c); the cell's value is the largest
    h*omega_c of the grid up to which a perfectly elastic bounce stays within the tolerance."""

    rows: list = field(default_factory=list)
    grid: list = field(default_factory=list)
    omega_c: float | None = None
    tolerance: float | None = None
    gain: float | None = None
