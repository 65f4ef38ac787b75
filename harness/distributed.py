"""Cells on a Dask cluster: ``harness nightly --scheduler ADDRESS`` (or ``$HARNESS_SCHEDULER``).

``local:N`` starts a ``LocalCluster`` of N worker processes on this machine (how the tests
exercise it); anything else is a scheduler address for ``dask.distributed.Client``.

Each task is self-contained (scene, method, settings -> list of cell records) and runs,
inside the Dask worker, in the same isolated child process as a local run, so an engine
abort or hang is a recorded ``crashed``/``timed_out`` cell there too. Results flow back to
the client, the database's one writer; no worker writes the database. A worker that dies
mid-cell costs that cell one retry elsewhere (the scheduler's ``allowed-failures`` is 1 for a
cluster we start); if it dies again the cell is recorded ``crashed``: never lost, never twice.
"""
from __future__ import annotations

from scenarios import InvalidInput

#: How often a task may lose its worker before it is recorded as crashed (1 = one retry).
ALLOWED_FAILURES = 1


def parse_scheduler(spec: str) -> tuple[str, int | str]:
    if spec.startswith("local:"):
        n = spec.split(":", 1)[1]
        if not n.isdigit() or int(n) < 1:
            raise InvalidInput(f"--scheduler={spec}: local:N needs N >= 1 worker processes")
        return "local", int(n)
    if "://" not in spec and ":" not in spec:
        raise InvalidInput(f"--scheduler={spec}: expected local:N or a scheduler address such as tcp://host:8786")
    return "address", spec


def run_cell_task(task, timeout):
    """Runs in the Dask worker: the cell in an isolated child process, as locally."""
    from .cells import run_task
    from .isolation import run_in_worker

    return run_in_worker(run_task, (task,), timeout=timeout)


class DaskExecutor:
    def __init__(self, spec: str):
        try:
            import dask
            from dask.distributed import Client, LocalCluster
        except ImportError as exc:  # the [distributed] extra is missing
            raise InvalidInput(f"--scheduler needs the [distributed] extra (pip install "
                               f"'integrator-harness[distributed]'): {exc}") from None
        kind, arg = parse_scheduler(spec)
        self.cluster = None
        # Child processes inside Dask workers need non-daemonic workers.
        dask.config.set({"distributed.worker.daemon": False,
                         "distributed.scheduler.allowed-failures": ALLOWED_FAILURES})
        if kind == "local":
            self.cluster = LocalCluster(n_workers=arg, threads_per_worker=1, processes=True,
                                        dashboard_address=None, silence_logs=40)
            self.client = Client(self.cluster)
            self.address = f"LocalCluster {self.cluster.scheduler_address}"
        else:
            self.client = Client(arg, timeout="30s")
            self.address = arg

    def describe(self) -> str:
        n = len(self.client.scheduler_info().get("workers", {}))
        return f"Dask scheduler {self.address} with {n} worker(s)"

    def run(self, tasks, timeout: float):
        from dask.distributed import as_completed

        from .isolation import WorkerFailure

        futures = {}
        for task in tasks:
            fut = self.client.submit(run_cell_task, task, timeout, pure=False, key=f"cell-{id(task)}-{task.label}")
            futures[fut] = task
        for fut in as_completed(list(futures)):
            task = futures[fut]
            try:
                result = fut.result()
            except Exception as exc:  # KilledWorker after the retry, or a task error
                result = WorkerFailure("crashed", f"Dask worker lost twice ({type(exc).__name__}: {exc})"[:500])
            yield task, result

    def close(self):
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()
