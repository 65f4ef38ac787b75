"""What an engine's contact run hands back (a ``Trajectory``: ``ContactTrajectory``) and what the
harness measured of it (``ContactFigures``, one run's; ``ContactCellFigures``, the ``contact``
cell's figures)."""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from .figures import Figures
from .trajectory import CRASHED, OK, TIMED_OUT, UNSTABLE, RunMeta, Trajectory

STATUSES = (OK, UNSTABLE, CRASHED, TIMED_OUT)

#: The three steps every contact mode is reported at (s): the harness's runs and the report's tables.
REPORT_DTS = (1 / 1000, 1 / 240, 1 / 60)
#: The step each tolerance profile (``scenarios.contact.PROFILES``) is advised at: a game's frame at
#: 60 Hz, a robot's control step at 1 kHz.
PROFILE_DT = {"game": 1 / 60, "robotics": 1 / 1000}


@dataclass
class ContactTrajectory(Trajectory):
    """One engine mode's run of a contact scene at one step: a ``Trajectory`` whose state is the
    scene's (``scenarios.contact``): q every body's centre, v its linear velocity, flattened
    (body i's x, y, z at q[..., 3 i : 3 i + 3]), z up (a 2-D pose fills y with 0), recorded at
    every step from t = 0. ``meta.settings``: every contact setting the pose chose or read back
    (restitution and its combining rule, friction, damping, the contact model's parameters,
    speculative margins), stated with the results; ``meta.loop`` what the engine's loop is;
    ``loop_cpu_s``: the process CPU time of that loop over the same steps with nothing recorded
    (a second pass), so that the cost is the engine's and not the recording's. ``status``:
    ``ok``, or ``unstable`` (a non-finite or runaway state, at ``failed_step``), ``crashed``,
    ``timed_out``, with ``detail`` saying where and why."""

    loop_cpu_s: float | None = None
    #: (n, bodies, 4): each body's orientation (w, x, y, z, body to world) at each recorded step,
    #: and (n, bodies, 3) its angular velocity in world axes; None where the pose keeps its bodies
    #: from turning (the ball on its joint, the boxes that only slide and rest).
    orientations: np.ndarray | None = None
    angular: np.ndarray | None = None

    @classmethod
    def of(
        cls,
        scene,
        method: str,
        dt: float,
        t,
        centres,
        velocities,
        *,
        loop: str = "",
        settings=None,
        status: str = OK,
        detail: str = "",
        failed_step: int | None = None,
        engine_version: str | None = None,
        steps: int | None = None,
        loop_cpu_s: float | None = None,
        orientations=None,
        angular=None,
    ) -> ContactTrajectory:
        """The run of ``scene`` (a contact scene, or its id: then its energy is not computed) from
        each body's recorded centres and velocities, (n, bodies, 3) each, and where the bodies
        turn, their orientations (n, bodies, 4) and angular velocities (n, bodies, 3)."""
        t = np.asarray(t, dtype=float)
        centres, velocities = np.asarray(centres, dtype=float), np.asarray(velocities, dtype=float)
        n = len(t)
        q = centres.reshape(n, 1, int(np.prod(centres.shape[1:])))
        v = velocities.reshape(n, 1, int(np.prod(velocities.shape[1:])))
        if orientations is not None:
            orientations = np.asarray(orientations, dtype=float).reshape(n, -1, 4)
            angular = np.asarray(angular, dtype=float).reshape(n, -1, 3)
        spin = None if angular is None else angular.reshape(n, 1, -1)
        energy = (
            np.asarray(scene.energy(q, v, spin), dtype=float).reshape(n, 1)
            if hasattr(scene, "energy") and n
            else np.zeros((n, 1))
        )
        scene_id = scene if isinstance(scene, str) else scene.id
        meta = RunMeta(
            backend="engine",
            steps_run=max(n - 1, 0),
            loop=loop or None,
            engine_version=engine_version,
            settings=dict(settings or {}),
            params={} if isinstance(scene, str) else dict(scene.values),
        )
        return cls(
            scene_id,
            method,
            dt,
            max(n - 1, 0) if steps is None else steps,
            1,
            np.arange(n),
            t,
            q,
            v,
            energy,
            status=status,
            detail=detail,
            failed_step=failed_step,
            meta=meta,
            loop_cpu_s=loop_cpu_s,
            orientations=orientations,
            angular=angular,
        )

    @classmethod
    def failed(cls, scene: str, method: str, dt: float, status: str, detail: str, **kw) -> ContactTrajectory:
        empty = np.zeros((0, 1, 3))
        return cls.of(scene, method, dt, np.zeros(0), empty, empty, status=status, detail=detail, **kw)

    @property
    def centres(self) -> np.ndarray:
        """(n, bodies, 3): each body's centre at each recorded step."""
        return self.q.reshape(len(self.t), self.q.shape[-1] // 3, 3)

    @property
    def velocities(self) -> np.ndarray:
        """(n, bodies, 3): each body's linear velocity at each recorded step."""
        return self.v.reshape(len(self.t), self.v.shape[-1] // 3, 3)

    @property
    def settings(self) -> dict:
        if self.meta.settings is None:
            self.meta.settings = {}
        return self.meta.settings

    @property
    def loop(self) -> str:
        return self.meta.loop or ""

    @property
    def engine_version(self) -> str | None:
        return self.meta.engine_version

    @property
    def steps_recorded(self) -> int:
        """The steps the recorded states span (all of them where the run ended well)."""
        return max(len(self.t) - 1, 0)


def _figure_keys() -> set[str]:
    return {f.name for f in fields(ContactFigures)}


@dataclass(frozen=True)
class ContactFigures(Figures):
    """A contact run measured against its scene's truth (``harness.contact.figures``): ``values``
    the figures the scene's judge gives ({name: value}, the scene's ``FIGURES``; stored each
    under its own name beside the other fields, and read as attributes, ``f.restitution``);
    ``passes`` names each judged figure's ✓ (True) or ✗; ``cpu_per_s`` the engine loop's CPU
    seconds per simulated second; ``truth`` the scene's analytic figures; ``tolerances`` the
    tolerances it was judged by (the profile ``profile``); ``settings`` the engine's contact settings as the pose stated
    them; ``status`` the run's (``detail`` says where and why a run failed, or why a figure is
    missing) and ``engine_version`` the engine release that ran."""

    scene: str = ""
    params: dict = field(default_factory=dict)
    dt: float | None = None
    status: str = OK
    values: dict = field(default_factory=dict)
    cpu_per_s: float | None = None
    loop: str | None = None
    truth: dict = field(default_factory=dict)
    tolerances: dict = field(default_factory=dict)
    passes: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    detail: str | None = None
    engine_version: str | None = None
    #: The tolerance profile ``passes`` judges by (``scenarios.contact.PROFILES``), and the ✓/✗ of
    #: every judged figure under each profile ({profile: {figure: bool}}): an advice at another
    #: step reads its own profile's.
    profile: str | None = None
    by_profile: dict = field(default_factory=dict)

    def __getattr__(self, name):
        values = self.__dict__.get("values") or {}
        if name in values:
            return values[name]
        raise AttributeError(name)

    def to_data(self) -> dict:
        """Flat: each figure under its own name beside the other fields (None figures left out)."""
        out = {k: v for k, v in super().to_data().items() if k != "values"}
        out.update({k: v for k, v in self.values.items() if v is not None})
        return out

    @classmethod
    def from_data(cls, data: dict):
        keys = _figure_keys() - {"values"}
        mine = {k: v for k, v in data.items() if k in keys}
        return cls(**mine, values={k: v for k, v in data.items() if k not in keys}), {}


@dataclass(frozen=True)
class ContactCellFigures(Figures):
    """The nightly's ``contact`` cell: one engine mode on one contact scene (``scene`` its id,
    ``scene_params`` its parameters) at every step of the ladder (``harness.contact.run.LADDER``).
    ``runs``: each step's ``ContactFigures`` as stored (``to_data``), with its ``status``;
    ``largest``: for each judged figure, the largest step of the ladder at which it and every
    shorter step is ✓ (None: not even the shortest); the cell's value is the largest step at which
    every figure is. ``settings`` and ``doc``: the mode's contact settings and what it is.
    What the report and the charts show of it is the scene's own declaration, carried here so
    that the report reads records alone: ``declared`` its figures (``scenarios.contact.Figure``
    as a dict each: name, column header and format, the truth it is compared with, the chart's
    label), ``truth_text`` and ``tolerance_text`` its truth and tolerances in words."""

    scene: str = ""
    scene_params: dict = field(default_factory=dict)
    runs: list = field(default_factory=list)
    largest: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    doc: str | None = None
    engine_version: str | None = None
    declared: list = field(default_factory=list)
    truth_text: str | None = None
    tolerance_text: str | None = None
    #: The tolerance profile ``largest`` and the tables judge by (each run also carries its ✓/✗
    #: under every profile, ``by_profile``).
    profile: str | None = None


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
