"""Kill points for the crash tests: a nightly that is SIGKILLed at a named point of its work.

``HARNESS_KILL_AT=POINT[:N]`` makes the N-th (default first) pass through ``checkpoint(POINT)``
kill the process, its whole process group where it leads one (its workers with it), by SIGKILL:
what an OOM killer or a lost machine does, with no handler run and nothing flushed. The points:

* ``store``: inside a task's store, its cells written and their transaction not yet committed
  (the nightly passes ``checkpoint("store")`` as ``History.add_task_cells``'s ``before_commit``);
* ``report``: the report's charts drawn, its markdown not yet written (``reports.markdown``'s
  ``before_write``).

A kill during a task needs no point: the tests kill the process group from outside once the
first cells are stored. Unset (every real run), ``checkpoint`` is one dictionary lookup.
"""

from __future__ import annotations

import os
import signal

KILL_VAR = "HARNESS_KILL_AT"
_passes: dict[str, int] = {}


def checkpoint(point: str) -> None:
    spec = os.environ.get(KILL_VAR)
    if not spec:
        return
    name, _, nth = spec.partition(":")
    if name != point:
        return
    _passes[point] = _passes.get(point, 0) + 1
    if _passes[point] < int(nth or 1):
        return
    if os.getpgid(0) == os.getpid():
        os.killpg(os.getpid(), signal.SIGKILL)
    os.kill(os.getpid(), signal.SIGKILL)
