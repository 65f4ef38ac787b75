"""Test-only Dask worker preload: chosen nightly tasks kill their own Dask worker process.

The tests load it into every worker through Dask's own ``distributed.worker.preload`` setting;
the harness knows nothing of it. ``$HARNESS_TEST_WORKER_KILLS`` is a JSON object mapping a
task label (``Task.label``) to how many of its attempts die; ``$HARNESS_TEST_WORKER_KILLS_DIR``
is where every attempt is logged, one line per attempt, so that the count survives the
worker it kills. An attempt that dies sends SIGKILL to its own Dask worker process, mid-task;
the later attempts run the task normally.
"""

import hashlib
import json
import os
import signal
from pathlib import Path

PLAN_VAR = "HARNESS_TEST_WORKER_KILLS"
DIR_VAR = "HARNESS_TEST_WORKER_KILLS_DIR"


def attempts_file(directory, label: str) -> Path:
    return Path(directory) / f"{hashlib.sha1(label.encode()).hexdigest()[:12]}.attempts"


def attempts(directory, label: str) -> list[str]:
    """What each attempt at ``label`` did: ``killed PID`` or ``ran PID``."""
    path = attempts_file(directory, label)
    return path.read_text().split("\n")[:-1] if path.exists() else []


def dask_setup(worker):
    import harness.execution.distributed as distributed

    plan = json.loads(os.environ.get(PLAN_VAR, "{}"))
    directory = os.environ.get(DIR_VAR)
    original = distributed.run_cell_task
    if not plan or getattr(original, "kills_worker", False):
        return

    def run_cell_task(task, timeout, run_task, *engines):
        kills = plan.get(task.label, 0)
        if kills:
            path = attempts_file(directory, task.label)
            dies = len(attempts(directory, task.label)) < kills
            with open(path, "a") as f:
                f.write(f"{'killed' if dies else 'ran'} {os.getpid()}\n")
            if dies:
                os.kill(os.getpid(), signal.SIGKILL)
        return original(task, timeout, run_task, *engines)

    run_cell_task.kills_worker = True
    # The client pickles harness.execution.distributed.run_cell_task by name, so the worker runs this one.
    distributed.run_cell_task = run_cell_task


def hang(pid_file: str) -> None:
    """Stands for an engine that never returns: records its pid, then sleeps for good."""
    import time

    Path(pid_file).write_text(str(os.getpid()))
    while True:
        time.sleep(60)
