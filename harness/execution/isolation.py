"""Engine runs in worker processes: an abort, a segfault or a hang becomes a recorded result.

:func:`run_in_worker` is the general tool (the nightly runner uses it for whole measurement
cells): it calls a module-level function in a fresh worker process and returns its result, or
a :class:`WorkerFailure` saying how the worker died (``crashed`` with the signal, ``timed_out``
after the limit, the worker then killed). ``simulate.simulate_isolated`` uses it to step one
engine mode and always returns a Trajectory.

Workers come from a ``forkserver``: safe when the parent has threads (a plain ``fork`` is
not), and cheaper than ``spawn`` because the server has already imported numpy, the scenes
and the adapters (and the engines, silently) when it forks a worker. Each worker runs in its
own temporary directory, with its file descriptors 1 and 2 sent to files there, so engine
banners, warnings and MUJOCO_LOG.TXT never reach the caller's output or working directory;
the tail of what the engine said is kept for the failure's detail.

``pool.WorkerPool`` keeps such workers for call after call (the nightly's cells).

The isolation layer does not validate inputs (``simulate.simulate`` does, before calling it),
so tests can hand an engine through it what validation would refuse.
"""

from __future__ import annotations

import faulthandler
import math
import multiprocessing
import multiprocessing.forkserver
import os
import signal
import tempfile
import threading
import time
import traceback
from dataclasses import asdict, dataclass, field

from records.trajectory import CRASHED, TIMED_OUT

from .cpu_limit import wait_within

#: Seconds an engine run may take when the caller gives no limit.
DEFAULT_TIMEOUT_S = 60.0

#: Modules the forkserver imports once, so that a worker starts without importing them: the
#: harness's own, and the large libraries they import only where used (scipy's solvers and sparse
#: matrices, pandas), which a worker forked without them would import afresh, each.
PRELOAD = [
    "numpy",
    "scipy.integrate",
    "scipy.optimize",
    "scipy.sparse.linalg",
    "pandas",
    "records",
    "scenarios",
    "reference",
    "adapters",
    "harness.methods",
    "harness.execution.isolation",
    "harness.execution.preload",
]

#: How much of the worker's captured output a failure keeps.
OUTPUT_TAIL_CHARS = 2000


@dataclass
class WorkerFailure:
    """How a worker failed to return a result: ``status`` is ``crashed`` or ``timed_out``."""

    status: str
    detail: str
    signal: str | None = None
    exitcode: int | None = None
    output: str = ""
    seconds: float = 0.0
    partial: list = field(default_factory=list)  # what the call sent with report_partial before it failed

    def as_dict(self) -> dict:
        return asdict(self)


_CONTEXT = None
_LOCK = threading.Lock()
#: The engine modules the forkserver imports (``preload_engines``); None: every installed engine.
_ENGINES: tuple[str, ...] | None = None
#: How ``preload_engines`` hands its choice to the server, which reads it as it starts.
ENGINES_ENV = "HARNESS_PRELOAD_ENGINES"


def engine_modules(method_ids) -> set[str]:
    """The engine modules (``EngineMode.module``: ``pydrake`` for ``drake:``) that these method ids
    step; a reference scheme or a plug-in's mode names none."""
    from adapters import ENGINES

    modules = {e.id: e.module for e in ENGINES.values()}
    return {modules[m.split(":")[0]] for m in method_ids if m.split(":")[0] in modules}


def preload_engines(modules) -> None:
    """Have the forkserver import only these engine modules (``adapters`` modules, as
    ``EngineMode.module`` names them): a run that knows its methods (a nightly of its suite) does
    not pay an import of every installed engine in its server (Newton's is seconds). A worker still
    imports any other engine it needs, on first use, each time. The first choice in a process
    stands, and none is made once the server runs: a process whose server serves many runs of
    different engines (a test session) names them all first."""
    global _ENGINES
    with _LOCK:
        if _ENGINES is None and _CONTEXT is None:
            _ENGINES = tuple(sorted(set(modules)))


#: The directory holding this copy of the project's packages (the checkout, or site-packages).
_PROJECT_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _context():
    """The forkserver context, with the server running and importing *this* copy of the project.

    Python 3.11's forkserver is handed the caller's sys.path and drops it, so the server would
    preload whatever ``harness`` its default path finds (an installed copy instead of this
    checkout) and the workers forked from it would run that. The server is therefore started
    (and restarted, should it have died) with this copy's root first on PYTHONPATH.
    """
    global _CONTEXT
    with _LOCK:
        if _CONTEXT is None:
            _CONTEXT = multiprocessing.get_context("forkserver")
            _CONTEXT.set_forkserver_preload(PRELOAD)
        saved = {k: os.environ.get(k) for k in ("PYTHONPATH", ENGINES_ENV)}
        os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (_PROJECT_ROOT, saved["PYTHONPATH"]) if p)
        if _ENGINES is not None:
            os.environ[ENGINES_ENV] = ",".join(_ENGINES)
        try:
            multiprocessing.forkserver.ensure_running()
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
    return _CONTEXT


#: Seconds past ``cpu_limit.WALL_FACTOR`` times its limit of wall time after which a worker ends
#: itself (SIGALRM). Its parent kills it at its limit of CPU seconds; this backstop is for a parent
#: that died first (a Dask worker killed mid-cell), whose hung worker would otherwise outlive it for
#: good. (Not a process CPU timer: while one is armed, Linux reads the process CPU clock at the
#: scheduler's tick, and the cost measures' short timed runs would read as nothing.)
ORPHAN_GRACE_S = 2.0


def arm_backstop(limit: float | None) -> None:
    """The worker's own timer for a call of ``limit`` CPU seconds (none where None): SIGALRM's
    default action ends the process, even inside an engine's C loop."""
    from .cpu_limit import WALL_FACTOR

    signal.signal(signal.SIGALRM, signal.SIG_DFL)
    signal.setitimer(signal.ITIMER_REAL, 0.0 if limit is None else WALL_FACTOR * limit + ORPHAN_GRACE_S)


#: True inside a worker: the process is already the isolation, so engines run in it directly
#: (a worker may not start children of its own, and needs none).
IN_WORKER = False


def _worker(conn, workdir: str, fn, args, kwargs, limit: float | None = None) -> None:
    global IN_WORKER
    IN_WORKER = True
    if limit is not None:
        arm_backstop(limit)
    os.chdir(workdir)
    for fd, name in ((1, "stdout.txt"), (2, "stderr.txt")):
        out = os.open(os.path.join(workdir, name), os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        os.dup2(out, fd)
        os.close(out)
    faulthandler.enable()  # a segfault leaves its Python traceback in stderr.txt
    try:
        message = ("ok", fn(*args, **kwargs))
    except BaseException as exc:  # noqa: BLE001 - every failure must come back as a result
        message = ("error", f"{type(exc).__name__}: {exc}", traceback.format_exc())
    try:
        conn.send(message)
    except Exception as exc:  # an unpicklable result
        conn.send(("error", f"result could not be sent back: {type(exc).__name__}: {exc}", ""))
    conn.close()


def _read(workdir: str, name: str) -> str:
    try:
        with open(os.path.join(workdir, name), errors="replace") as f:
            return f.read()
    except OSError:
        return ""


def _tail(workdir: str) -> str:
    parts = [text.strip() for text in (_read(workdir, "stderr.txt"), _read(workdir, "stdout.txt")) if text.strip()]
    return "\n".join(parts)[-OUTPUT_TAIL_CHARS:]


def _complaint(workdir: str) -> str:
    """What the worker said on stderr before it died, on one line: the engine's message
    (pymunk: "Aborting due to Chipmunk error: Mass must be positive ..."), else the first
    line of faulthandler's dump ("Fatal Python error: Segmentation fault")."""
    text = _read(workdir, "stderr.txt")
    before, sep, after = text.partition("Fatal Python error")
    said = " ".join(before.split()) or (sep + after.splitlines()[0] if sep else "")
    return said[:200]


def run_in_worker(fn, args: tuple = (), kwargs: dict | None = None, timeout: float | None = None):
    """``fn(*args, **kwargs)`` in a worker process; its result, or a :class:`WorkerFailure`.

    ``fn`` must be a module-level function and its arguments and result picklable. A Python
    exception in the worker is a ``crashed`` failure with the exception in ``detail`` and the
    traceback in ``output``. ``timeout`` (CPU seconds of the worker's process tree, None or inf
    for no limit; ``cpu_limit``) counts from the worker's start; past it, or past
    ``cpu_limit.WALL_FACTOR`` times it of wall time, the worker is killed and the failure is
    ``timed_out``.

    As with any start method but ``fork``, a script that calls this at import time needs the
    ``if __name__ == "__main__":`` guard (the worker imports the caller's main module).
    """
    ctx = _context()
    limit = None if timeout is None or math.isinf(timeout) else float(timeout)
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="harness-worker-") as workdir:
        receiver, sender = ctx.Pipe(duplex=False)
        proc = ctx.Process(target=_worker, args=(sender, workdir, fn, args, kwargs or {}, limit), daemon=True)
        proc.start()
        sender.close()  # only the worker holds the sending end: its death reads as EOF here
        try:
            over = wait_within(receiver, proc.pid, limit, 0.0)
            if over is not None:  # neither a result nor EOF within the limit
                proc.kill()
                proc.join()
                return WorkerFailure(TIMED_OUT, over, output=_tail(workdir), seconds=time.monotonic() - started)
            try:
                message = receiver.recv()
            except EOFError:  # the worker died without sending anything
                message = None
            proc.join(timeout=10.0)
            if proc.exitcode is None:  # sent its result but will not exit
                proc.kill()
                proc.join()
        finally:
            receiver.close()
        seconds = time.monotonic() - started
        if message is not None and message[0] == "ok":
            return message[1]
        output = _tail(workdir)
        if message is not None:
            return WorkerFailure(CRASHED, f"raised {message[1]}", output=message[2] or output, seconds=seconds)
        code = proc.exitcode
        if code == -signal.SIGALRM:  # the backstop fired before this thread got to kill it
            return WorkerFailure(
                TIMED_OUT, f"hung past {limit:g} CPU s of limit; worker stopped itself", output=output, seconds=seconds
            )
        if code is not None and code < 0:
            name = signal.Signals(-code).name
            said = _complaint(workdir)
            detail = f"worker killed by {name}" + (f" ({said})" if said else "")
            return WorkerFailure(CRASHED, detail, signal=name, exitcode=code, output=output, seconds=seconds)
        return WorkerFailure(
            CRASHED, f"worker exited with code {code} without a result", exitcode=code, output=output, seconds=seconds
        )
