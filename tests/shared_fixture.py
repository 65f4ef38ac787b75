"""A module fixture's costly result, built once per test run however many pytest-xdist workers
ask for it.

pytest builds a module-scoped fixture once in each worker that runs one of the module's tests, and
``--dist worksteal`` hands a module's tests to both workers: a fixture of three nightlies ran
twice. ``built_once`` builds it in the first worker that asks, under a lock in the run's shared
temporary folder, and hands the other the same result (pickled) and the same folder. The fixture's
tests must only read what it built (a test that changes a database copies it first).
"""

from __future__ import annotations

import fcntl
import os
import pickle
from pathlib import Path


def built_once(tmp_path_factory, name: str, build):
    """``build(folder)``, run once per test run in a folder of its own; its result as built."""
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # every worker's base folder lies in the run's
    folder, done = root / f"shared-{name}", root / f"shared-{name}.pickle"
    with open(root / f"shared-{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if done.exists():
            return pickle.loads(done.read_bytes())
        folder.mkdir()
        value = build(Path(folder))
        tmp = done.with_suffix(".tmp")
        tmp.write_bytes(pickle.dumps(value))
        os.replace(tmp, done)
        return value
