"""A stored nightly run as typed records: what the report's footer and appendix print.

``RunRecord.of`` and ``RunTiming.of`` are the one conversion from the history's run row and the
timing the nightly measured (dicts, possibly written by an older version: a field it lacks
keeps its default)."""

from __future__ import annotations

from dataclasses import MISSING, dataclass, field, fields

#: The key of ``RunRecord.versions`` under which a run records the LLVM level its kernels compiled
#: at (``reference._numba_config``), beside numba's version: a kernel's speed depends on both.
NUMBA_OPT_KEY = "numba opt level"


def _known(cls, d: dict | None) -> dict:
    """The entries of ``d`` that are fields of ``cls``, less a None where the field's default is
    not None (an older row's null list or dict keeps the empty default)."""
    out = {}
    for f in fields(cls):
        if f.name not in (d or {}):
            continue
        default = (
            f.default
            if f.default is not MISSING
            else (f.default_factory() if f.default_factory is not MISSING else None)
        )
        if d[f.name] is not None or default is None:
            out[f.name] = d[f.name]
    return out


@dataclass(frozen=True)
class RunSettings:
    """How the run was set up: the suite (``asdict(Suite)``), where its cells ran, the per-task
    time limit, plugins, and the (scene, method) pairs left out with why."""

    suite: dict = field(default_factory=dict)
    executor: str | None = None
    jobs: int | None = None
    cell_timeout: float | None = None
    plugins: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    code_digest: str | None = None  # the project's code (a dirty tree's commit says nothing of it)
    injected_timings: dict | None = None  # timings read instead of the clock's (harness.measures.injected)
    resumed: list = field(default_factory=list)  # the attempts that continued the run after a kill

    @classmethod
    def of(cls, d: dict | None) -> RunSettings:
        return cls(**_known(cls, d))


@dataclass(frozen=True)
class RunRecord:
    """One stored run: ``History.run(run_id)`` typed."""

    run_id: int
    suite: str
    started: str
    measurement_version: int
    git_commit: str | None = None
    finished: str | None = None
    complete: bool = False
    versions: dict = field(default_factory=dict)
    machine: dict = field(default_factory=dict)
    settings: RunSettings = field(default_factory=RunSettings)
    wall_s: float | None = None

    @classmethod
    def of(cls, run) -> RunRecord:
        if isinstance(run, cls):
            return run
        d = _known(cls, dict(run))
        if "git_commit" in d and not isinstance(d["git_commit"], str):  # none recorded (a DataFrame's NaN)
            d["git_commit"] = None
        return cls(**{**d, "settings": RunSettings.of(d.get("settings"))})


@dataclass(frozen=True)
class RunTiming:
    """Where a run's time went, as the nightly measured it (``harness.nightly.run``)."""

    total_s: float | None = None
    cells_s: float = 0.0
    tasks: int | None = None
    executor: str | None = None
    jobs: int | None = None
    cpus: int | None = None
    workers_started: int | None = None
    worker_cpu_s: float | None = None
    tasks_without_cpu: int = 0
    main_cpu_s: float = 0.0
    numba_compile_s: float | None = None
    kernels_compiled: int | None = None
    kernels_loaded: int | None = None
    kernel_load_s: float = 0.0
    numba_s: float | None = None  # every numba compilation in the workers (numba's compile events)
    kernel_plan: dict | None = None  # what the run expected to compile (harness.nightly.kernels.KernelPlan)
    worker_seconds_by_measure: dict = field(default_factory=dict)
    worker_seconds_by_family: dict = field(default_factory=dict)
    slowest_tasks: list = field(default_factory=list)
    task_s: dict = field(default_factory=dict)
    task_cpu_s: dict = field(default_factory=dict)
    report_s: float | None = None
    finished_s: float | None = None
    machine_busy: float | None = None  # share of the machine's CPU other processes took during the cells
    resumed: dict | None = None  # attempts, tasks carried from them, tasks run by the last

    @classmethod
    def of(cls, timing) -> RunTiming:
        return timing if isinstance(timing, cls) else cls(**_known(cls, timing))

    #: CPU seconds to load a kernel from the disk cache, where the run loaded none to measure it
    #: (an estimate from a warm standard nightly's loads: docs/performance.md).
    LOAD_S = 0.02

    @property
    def compile_share(self) -> float | None:
        """The share of the workers' CPU spent compiling kernels (None where either is unknown)."""
        if not self.worker_cpu_s or self.numba_compile_s is None:
            return None
        return self.numba_compile_s / self.worker_cpu_s

    @property
    def cache_would_save_s(self) -> float:
        """CPU seconds a disk cache holding every kernel compiled here would have saved: their
        compile time less loading them (at this run's seconds a load, else ``LOAD_S``)."""
        per_load = self.kernel_load_s / self.kernels_loaded if self.kernels_loaded else self.LOAD_S
        return max(0.0, (self.numba_compile_s or 0.0) - (self.kernels_compiled or 0) * per_load)
