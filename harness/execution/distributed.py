"""Cells on a Dask cluster: ``harness nightly --scheduler ADDRESS`` (or ``$HARNESS_SCHEDULER``).

``local:N`` starts a ``LocalCluster`` of N single-threaded worker processes on this machine
(how the tests exercise it); anything else is the address of a running scheduler
(``tcp://host:8786``, ``host:8786``) for ``dask.distributed.Client``.

Isolation. Each task is self-contained (a ``Task`` -> its list of cell records) and runs,
inside the Dask worker, through ``isolation.run_in_worker``: in a fresh child process of the
worker, exactly as a local run does. So an engine that aborts, segfaults or hangs costs that
child only: the cell comes back ``crashed`` (with the signal) or ``timed_out`` (the child
killed at the suite's cell timeout), the same records a local run stores, and the Dask worker
goes on; should the Dask worker itself die first, the child ends itself just past its limit
(``isolation.ORPHAN_GRACE_S``) rather than outlive it. The Dask task is *not* the isolation:
a worker cannot kill a hung thread of its own, and a segfault there would cost the worker, a
restart and every retry. This is why the workers must be non-daemonic (a daemonic process may not start children); a
cluster we start is, and a cluster we join is checked before anything runs.

Lost workers. The Dask task dies only if its worker process does (killed, out of memory, the
machine gone). The scheduler then runs it again on another worker; if that one dies too, the
client gets ``KilledWorker`` and records every measure of the task ``crashed`` with that
detail. A cluster we start allows exactly one retry (``ALLOWED_FAILURES``); a cluster we join
applies its own ``distributed.scheduler.allowed-failures`` (Dask's default is 3), which the
run's executor description records. The scheduler charges a death to every task the worker
held, so the client keeps at most one task per worker thread in flight: a dying worker
charges only the cells it was running. (Measured on ``local:2`` with the 25 smoke bound tasks
and one task killing its worker on every attempt: submitted all at once, 9 and then 3
innocent tasks were recorded crashed in two trials; throttled, only the killer.)

One writer. Workers return records; the client stores them (it alone opens the database),
each task exactly once: a task is submitted once and its future read once. The client never
waits blindly: it polls, and a lost scheduler or a cluster without workers for
``WORKER_WAIT_S`` raises :class:`ClusterLost`; the run is then left incomplete, never
compared, and the previous report stays as it was.

Before anything runs, every worker must run the same code as the client (a digest of the
project's packages), the same package versions, and be non-daemonic; otherwise a one-line
error names the worker and the difference.
"""

from __future__ import annotations

import logging
import os
import re
import time
import uuid

from records import InvalidInput

from harness.execution.environment import environment

#: The environment variable read when ``--scheduler`` is not given.
ENV_VAR = "HARNESS_SCHEDULER"

#: How often a task may lose its worker before it is recorded crashed, on a cluster we start
#: (1: one retry on another worker).
ALLOWED_FAILURES = 1

#: Seconds to reach a scheduler before giving up.
CONNECT_TIMEOUT_S = 30.0

#: Seconds the cluster may have no worker at all (at the start, or mid-run) before the run stops.
WORKER_WAIT_S = 60.0

#: Seconds between the client's checks on the cluster while it waits for results.
POLL_S = 1.0

#: Address schemes a Dask scheduler listens on.
SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")

_ADDRESS = re.compile(r"^(?:(?P<scheme>[a-z]+)://)?(?P<host>\[[0-9a-fA-F:]+\]|[A-Za-z0-9_.-]+):(?P<port>\d+)/?$")
_FORMS = (
    f"local:N (N >= 1 worker processes) or a scheduler address [SCHEME://]HOST:PORT (schemes: {', '.join(SCHEMES)})"
)


class ClusterLost(RuntimeError):
    """The scheduler, or every worker, went away mid-run: the run cannot finish."""


def parse_scheduler(spec: str, source: str = "--scheduler") -> tuple[str, int | str]:
    """``("local", N)`` or ``("address", spec)``; InvalidInput naming ``source`` otherwise."""
    spec = spec.strip()
    if spec.startswith("local:"):
        n = spec.split(":", 1)[1]
        if not n.isdigit() or int(n) < 1:
            raise InvalidInput(f"{source}={spec}: local:N needs N >= 1 worker processes")
        return "local", int(n)
    m = _ADDRESS.match(spec)
    if m is None:
        raise InvalidInput(f"{source}={spec}: expected {_FORMS}")
    if m["scheme"] and m["scheme"] not in SCHEMES:
        raise InvalidInput(f"{source}={spec}: unknown scheme {m['scheme']!r} (valid: {', '.join(SCHEMES)})")
    if not 1 <= int(m["port"]) <= 65535:
        raise InvalidInput(f"{source}={spec}: port {m['port']} is not in 1..65535")
    return "address", spec


def resolve_scheduler(option: str | None, jobs_given: bool) -> tuple[str, str] | None:
    """Which scheduler the nightly uses: ``(spec, source)``, or None for local processes.

    ``--scheduler`` wins over ``$HARNESS_SCHEDULER``; an explicit ``--jobs`` asks for local
    processes and so wins over the environment, but contradicts an explicit ``--scheduler``.
    """
    if option is not None:
        if jobs_given:
            raise InvalidInput(
                "--jobs: sets the local worker processes; with --scheduler the cluster's "
                "workers set the parallelism (local:N starts N)"
            )
        source, spec = "--scheduler", option
    else:
        spec = os.environ.get(ENV_VAR, "").strip()
        if not spec or jobs_given:
            return None
        source = f"${ENV_VAR}"
    parse_scheduler(spec, source)
    return spec.strip(), source


# ----------------------------------------------------------------------------- worker side
def run_cell_task(task, timeout, run_task, engines=None):
    """Runs in the Dask worker: ``run_task(task)`` (the nightly's ``harness.nightly.cells.run_task``,
    pickled by name) in an isolated child process, as a local run does; the worker's forkserver
    imports ``engines``, the run's (``isolation.preload_engines``; None: every installed one)."""
    from harness.execution.isolation import preload_engines, run_in_worker

    if engines is not None:
        preload_engines(engines)
    return run_in_worker(run_task, (task,), timeout=timeout)


def _allowed_failures(dask_scheduler=None):
    return dask_scheduler.allowed_failures


# ----------------------------------------------------------------------------- client side
def _plural(n: int, noun: str) -> str:
    return f"{n} {noun}" if n == 1 else f"{n} {noun}{'es' if noun.endswith('s') else 's'}"


def _times(n: int) -> str:
    return {0: "never", 1: "once"}.get(n, f"{n} times")


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}"[:300]


class DaskExecutor:
    """Runs nightly tasks on a Dask cluster; the same ``describe/run/close`` as ``LocalExecutor``.
    ``run_task`` is what a worker runs for one task (the nightly passes ``harness.nightly.cells.run_task``:
    this layer runs tasks, it does not know what they measure)."""

    def __init__(self, spec: str, source: str = "--scheduler", *, run_task):
        try:
            import dask
            from dask.distributed import Client, LocalCluster
        except ImportError as exc:  # the [distributed] extra is missing
            raise InvalidInput(
                f"{source} needs the [distributed] extra (pip install 'integrator-harness[distributed]'): {exc}"
            ) from None
        kind, arg = parse_scheduler(spec, source)
        self.spec, self.source, self.run_task = spec, source, run_task
        self.cluster = self.client = None
        try:
            if kind == "local":
                # Each cell runs in a child of its Dask worker, and a daemonic process may not
                # start children. The nanny reads this setting every time it (re)starts a worker,
                # including after a worker died mid-run, so it is set for the process, not scoped.
                dask.config.set({"distributed.worker.daemon": False})
                self.cluster = LocalCluster(
                    n_workers=arg,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    silence_logs=logging.CRITICAL,
                    scheduler_kwargs={"allowed_failures": ALLOWED_FAILURES},
                )
                self.client = Client(self.cluster)
            else:
                try:
                    self.client = Client(arg, timeout=CONNECT_TIMEOUT_S)
                except (OSError, TimeoutError) as exc:
                    raise InvalidInput(
                        f"{source}={spec}: no Dask scheduler reachable within "
                        f"{CONNECT_TIMEOUT_S:g} s ({_one_line(exc)})"
                    ) from None
            self._check_workers()
            self._description = self._describe(kind)
        except BaseException:
            self.close()
            raise

    # ---------------------------------------------------------------- start
    def _check_workers(self) -> None:
        from distributed.utils import TimeoutError as DaskTimeout

        try:
            self.client.wait_for_workers(1, timeout=WORKER_WAIT_S)
        except (DaskTimeout, TimeoutError):
            raise InvalidInput(
                f"{self.source}={self.spec}: the scheduler has no workers (none joined within {WORKER_WAIT_S:g} s)"
            ) from None
        mine = environment()
        for address, theirs in self.client.run(environment).items():
            if theirs.get("daemon"):
                raise InvalidInput(
                    f"{self.source}={self.spec}: worker {address} is a daemonic process and cannot "
                    f"start the child process each cell is isolated in; start the workers with "
                    f"DASK_DISTRIBUTED__WORKER__DAEMON=False"
                )
            for key, value in mine.items():
                if key != "daemon" and theirs.get(key) != value:
                    raise InvalidInput(
                        f"{self.source}={self.spec}: worker {address} has {key} {theirs.get(key)} "
                        f"where this client has {value}; every worker must compute with the same "
                        f"code and packages"
                    )

    def _describe(self, kind: str) -> str:
        threads = self.client.nthreads()
        n, total = len(threads), sum(threads.values())
        try:
            retries = self.client.run_on_scheduler(_allowed_failures)
            policy = f"a cell whose worker dies is retried {_times(retries)}"
        except Exception:  # a scheduler that refuses run_on_scheduler: say we do not know
            policy = "retries when a worker dies: unknown"
        if kind == "local":
            return (
                f"Dask LocalCluster at {self.cluster.scheduler_address} ({_plural(n, 'worker process')}, "
                f"1 thread each; {policy})"
            )
        return f"Dask scheduler {self.spec} ({_plural(n, 'worker')}, {_plural(total, 'thread')}; {policy})"

    def describe(self) -> str:
        """Where the cells run, as measured when the executor connected (also valid after close)."""
        return self._description

    # ---------------------------------------------------------------- run
    def _slots(self) -> int:
        """Worker threads connected now; raises ClusterLost when the scheduler is gone."""
        if self.client.status != "running":
            raise ClusterLost(f"lost the connection to the Dask scheduler {self.spec} (client {self.client.status})")
        try:
            return sum(self.client.nthreads().values())
        except Exception as exc:
            raise ClusterLost(f"lost the connection to the Dask scheduler {self.spec} ({_one_line(exc)})") from None

    def run(self, tasks, timeout: float):
        """Yield ``(task, result)`` as tasks finish, each task exactly once; ``result`` is the task's
        cells, or a ``WorkerFailure`` (the child crashed or hung, or the worker died twice)."""
        from distributed import wait
        from distributed.utils import CancelledError
        from distributed.utils import TimeoutError as DaskTimeout

        from harness.execution.isolation import engine_modules

        token = uuid.uuid4().hex[:8]
        engines = sorted(engine_modules(t.method for t in tasks))
        queue = list(enumerate(tasks))[::-1]
        in_flight = {}
        no_workers_since = None
        while queue or in_flight:
            slots = self._slots()
            if slots:
                no_workers_since = None
            else:
                no_workers_since = no_workers_since or time.monotonic()
                if time.monotonic() - no_workers_since > WORKER_WAIT_S:
                    raise ClusterLost(
                        f"the Dask scheduler {self.spec} has had no workers for {WORKER_WAIT_S:g} s "
                        f"with {len(queue) + len(in_flight)} task(s) left"
                    )
            # At most one task per worker thread, so a dying worker is charged only its own cell.
            while queue and len(in_flight) < max(slots, 1):
                i, task = queue.pop()
                fut = self.client.submit(
                    run_cell_task, task, timeout, self.run_task, engines, pure=False, key=f"{task.label} [{token}-{i}]"
                )
                in_flight[fut] = task
            try:
                done = wait(list(in_flight), timeout=POLL_S, return_when="FIRST_COMPLETED").done
            except (DaskTimeout, TimeoutError):
                continue
            except CancelledError as exc:  # the client cancels every future when it loses the scheduler
                raise ClusterLost(f"lost the connection to the Dask scheduler {self.spec} ({_one_line(exc)})") from None
            for fut in done:
                task = in_flight.pop(fut)
                result = self._result(fut)
                fut.release()  # the worker may drop it: the client now holds the only copy
                yield task, result

    def _result(self, fut):
        from distributed import KilledWorker

        from harness.execution.isolation import WorkerFailure

        try:
            return fut.result()
        except KilledWorker as exc:
            last = getattr(getattr(exc, "last_worker", None), "address", "?")
            return WorkerFailure(
                "crashed",
                f"its Dask worker died on each of {exc.allowed_failures + 1} attempts "
                f"(KilledWorker; the last on {last})",
            )
        except Exception as exc:  # run_cell_task returns failures; this is the task itself failing
            return WorkerFailure("crashed", f"the Dask task raised {_one_line(exc)}")

    def close(self):
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()
