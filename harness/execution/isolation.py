"""Engine runs in worker processes: an abort, a segfault or a hang becomes a recorded result.

:func:`run_in_worker` is the general tool (the nightly runner uses it for whole measurement
cells): it calls a module-level function in a fresh worker process and returns its result, or
a :class:`WorkerFailure` saying how the worker died (``crashed`` with the signal, ``timed_out``
after the limit, the worker then killed). :func:`simulate_isolated` uses it to step one engine
mode and always returns a :class:`Trajectory`.

Workers come from a ``forkserver``: safe when the parent has threads (a plain ``fork`` is
not), and cheaper than ``spawn`` because the server has already imported numpy, the scenes
and the adapters (and the engines, silently) when it forks a worker. Each worker runs in its
own temporary directory, with its file descriptors 1 and 2 sent to files there, so engine
banners, warnings and MUJOCO_LOG.TXT never reach the caller's output or working directory;
the tail of what the engine said is kept for the failure's detail.

:class:`WorkerPool` keeps such workers for call after call (the nightly's cells): a worker
that dies or hangs costs its call and is replaced, and what a worker compiled stays compiled.

The isolation layer does not validate inputs (``runner.simulate`` does, before calling it),
so tests can hand an engine through it what validation would refuse.
"""
from __future__ import annotations

import faulthandler
import math
import multiprocessing
import multiprocessing.forkserver
import os
import shutil
import signal
import tempfile
import threading
import time
import traceback
from dataclasses import asdict, dataclass, field

from records import Trajectory

from scenarios import Scene
from records.trajectory import CRASHED, TIMED_OUT

#: Seconds an engine run may take when the caller gives no limit.
DEFAULT_TIMEOUT_S = 60.0

#: Modules the forkserver imports once, so that a worker starts without importing them.
PRELOAD = ["numpy", "records", "scenarios", "reference", "adapters", "harness.methods", "harness.execution.isolation",
           "harness.execution.preload"]

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
        saved = os.environ.get("PYTHONPATH")
        os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (_PROJECT_ROOT, saved) if p)
        try:
            multiprocessing.forkserver.ensure_running()
        finally:
            if saved is None:
                del os.environ["PYTHONPATH"]
            else:
                os.environ["PYTHONPATH"] = saved
    return _CONTEXT


#: Seconds past its limit after which a worker ends itself (SIGALRM). Its parent kills it at the
#: limit; this backstop is for a parent that died first (a Dask worker killed mid-cell), whose
#: hung worker would otherwise outlive it for good.
ORPHAN_GRACE_S = 2.0

#: True inside a worker: the process is already the isolation, so engines run in it directly
#: (a worker may not start children of its own, and needs none).
IN_WORKER = False


def _worker(conn, workdir: str, fn, args, kwargs, limit: float | None = None) -> None:
    global IN_WORKER
    IN_WORKER = True
    if limit is not None:  # SIGALRM's default action ends the process, even inside an engine's C loop
        signal.signal(signal.SIGALRM, signal.SIG_DFL)
        signal.setitimer(signal.ITIMER_REAL, limit + ORPHAN_GRACE_S)
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
    traceback in ``output``. ``timeout`` (seconds, None or inf for no limit) counts from the
    worker's start; past it the worker is killed and the failure is ``timed_out``.

    As with any start method but ``fork``, a script that calls this at import time needs the
    ``if __name__ == "__main__":`` guard (the worker imports the caller's main module).
    """
    ctx = _context()
    limit = None if timeout is None or math.isinf(timeout) else float(timeout)
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="harness-worker-") as workdir:
        receiver, sender = ctx.Pipe(duplex=False)
        proc = ctx.Process(target=_worker, args=(sender, workdir, fn, args, kwargs or {}, limit),
                           daemon=True)
        proc.start()
        sender.close()  # only the worker holds the sending end: its death reads as EOF here
        try:
            if not receiver.poll(limit):  # neither a result nor EOF in time
                proc.kill()
                proc.join()
                return WorkerFailure(TIMED_OUT, f"no result within {limit:g} s; worker killed",
                                     output=_tail(workdir), seconds=time.monotonic() - started)
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
            return WorkerFailure(TIMED_OUT, f"no result within {limit:g} s; worker stopped itself",
                                 output=output, seconds=seconds)
        if code is not None and code < 0:
            name = signal.Signals(-code).name
            said = _complaint(workdir)
            detail = f"worker killed by {name}" + (f" ({said})" if said else "")
            return WorkerFailure(CRASHED, detail, signal=name, exitcode=code, output=output, seconds=seconds)
        return WorkerFailure(CRASHED, f"worker exited with code {code} without a result",
                             exitcode=code, output=output, seconds=seconds)


# ----------------------------------------------------------------------------- reused workers
_PARTIAL_TO = None  # in a pool worker, while a call runs: the connection to its caller


def report_partial(obj) -> None:
    """Send ``obj`` (picklable) to the caller now, from inside a :class:`WorkerPool` call: should
    the call then kill its worker or time out, the failure carries what was sent
    (``WorkerFailure.partial``). Anywhere else it does nothing."""
    if _PARTIAL_TO is not None:
        _PARTIAL_TO.send(("partial", obj))


def _serve(conn, workdir: str) -> None:
    """A pool worker's loop: receive ``(fn, args, kwargs)``, answer with the result and the
    CPU seconds the call took; ``None`` or a closed pipe ends it."""
    global IN_WORKER, _PARTIAL_TO
    IN_WORKER = True
    os.chdir(workdir)
    for fd, name in ((1, "stdout.txt"), (2, "stderr.txt")):
        out = os.open(os.path.join(workdir, name), os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        os.dup2(out, fd)
        os.close(out)
    faulthandler.enable()
    import sys

    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        fn, args, kwargs = job
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        for fd in (1, 2):  # each call's output alone: a failure's tail is this call's
            os.ftruncate(fd, 0)
            os.lseek(fd, 0, os.SEEK_SET)
        cpu = time.process_time()
        _PARTIAL_TO = conn
        try:
            message = ("ok", fn(*args, **kwargs))
        except BaseException as exc:  # noqa: BLE001 - every failure must come back as a result
            message = ("error", f"{type(exc).__name__}: {exc}", traceback.format_exc())
        finally:
            _PARTIAL_TO = None
        cpu = time.process_time() - cpu
        try:
            conn.send((*message, cpu))
        except Exception as exc:  # an unpicklable result
            conn.send(("error", f"result could not be sent back: {type(exc).__name__}: {exc}", "", cpu))


class _PooledWorker:
    def __init__(self, ctx):
        self.workdir = tempfile.mkdtemp(prefix="harness-worker-")
        self.conn, child = ctx.Pipe(duplex=True)
        self.proc = ctx.Process(target=_serve, args=(child, self.workdir), daemon=True)
        self.proc.start()
        child.close()  # only the worker holds its end: its death reads as EOF here
        self.calls = 0

    def alive(self) -> bool:
        return self.proc.is_alive()

    def close(self, kill: bool = False) -> None:
        if kill:
            self.proc.kill()
        else:
            try:
                self.conn.send(None)
            except OSError:
                pass
        self.proc.join(timeout=10.0)
        if self.proc.exitcode is None:
            self.proc.kill()
            self.proc.join()
        self.conn.close()
        shutil.rmtree(self.workdir, ignore_errors=True)


@dataclass
class CallStats:
    """What one pool call cost: wall seconds in the parent, CPU seconds in the worker (None when
    the worker died or was killed before it could say), and which worker process ran it."""

    wall_s: float
    cpu_s: float | None
    worker_pid: int | None


class WorkerPool:
    """Up to ``size`` long-lived worker processes, each running one call at a time.

    The same isolation as :func:`run_in_worker` (a forkserver child in its own temporary
    directory, file descriptors 1 and 2 sent to files there), but a worker serves call after
    call, so what it imported and compiled (numba kernels) is paid for once, not per call.
    A call that raises comes back as a ``crashed`` :class:`WorkerFailure` and its worker goes
    on; a call that kills its worker (abort, segfault) or outlives its ``timeout`` (the worker
    is then killed) is a ``crashed`` / ``timed_out`` failure and the worker is replaced by a
    fresh one for the next call. Thread-safe: call :meth:`call` from up to ``size`` threads.
    """

    def __init__(self, size: int):
        self.size = max(1, int(size))
        self._idle: list[_PooledWorker] = []
        self._all: set[_PooledWorker] = set()
        self._cond = threading.Condition()
        self._closed = False
        self.started = 0  # worker processes started, replacements included

    def _take(self) -> _PooledWorker:
        with self._cond:
            while True:
                if self._closed:
                    raise RuntimeError("the worker pool is closed")
                while self._idle:
                    w = self._idle.pop()
                    if w.alive():
                        return w
                    self._all.discard(w)
                    w.close(kill=True)
                if len(self._all) < self.size:
                    w = _PooledWorker(_context())
                    self._all.add(w)
                    self.started += 1
                    return w
                self._cond.wait()

    def _give_back(self, w: _PooledWorker, keep: bool) -> None:
        with self._cond:
            if keep and not self._closed:
                self._idle.append(w)
            else:
                self._all.discard(w)
            self._cond.notify()
        if not keep or self._closed:
            w.close(kill=not keep)

    def call(self, fn, args: tuple = (), kwargs: dict | None = None, timeout: float | None = None):
        """``fn(*args, **kwargs)`` in a pool worker: its result, or a :class:`WorkerFailure`."""
        return self.call_with_stats(fn, args, kwargs, timeout)[0]

    def call_with_stats(self, fn, args: tuple = (), kwargs: dict | None = None,
                        timeout: float | None = None) -> tuple[object, CallStats]:
        limit = None if timeout is None or math.isinf(timeout) else float(timeout)
        w = self._take()
        started = time.monotonic()
        pid = w.proc.pid
        try:
            w.conn.send((fn, args, kwargs or {}))
        except (OSError, ValueError):  # the worker died while idle: a fresh one takes the call
            self._give_back(w, keep=False)
            return self.call_with_stats(fn, args, kwargs, timeout)
        w.calls += 1
        partial = []
        while True:
            left = None if limit is None else max(0.0, started + limit - time.monotonic())
            if not w.conn.poll(left):  # neither a result nor EOF in time
                w.proc.kill()
                w.proc.join()
                output = _tail(w.workdir)
                self._give_back(w, keep=False)
                seconds = time.monotonic() - started
                return (WorkerFailure(TIMED_OUT, f"no result within {limit:g} s; worker killed", output=output,
                                      seconds=seconds, partial=partial), CallStats(seconds, None, pid))
            try:
                message = w.conn.recv()
            except (EOFError, OSError):  # the worker died without answering
                message = None
            if message is None or message[0] != "partial":
                break
            partial.append(message[1])
        seconds = time.monotonic() - started
        if message is not None:
            self._give_back(w, keep=True)
            if message[0] == "ok":
                return message[1], CallStats(seconds, message[2], pid)
            return (WorkerFailure(CRASHED, f"raised {message[1]}", output=message[2] or _tail(w.workdir),
                                  seconds=seconds, partial=partial), CallStats(seconds, message[3], pid))
        w.proc.join(timeout=10.0)
        code = w.proc.exitcode
        output, said = _tail(w.workdir), _complaint(w.workdir)
        self._give_back(w, keep=False)
        if code is not None and code < 0:
            name = signal.Signals(-code).name
            detail = f"worker killed by {name}" + (f" ({said})" if said else "")
            failure = WorkerFailure(CRASHED, detail, signal=name, exitcode=code, output=output, seconds=seconds,
                                    partial=partial)
        else:
            failure = WorkerFailure(CRASHED, f"worker exited with code {code} without a result",
                                    exitcode=code, output=output, seconds=seconds, partial=partial)
        return failure, CallStats(seconds, None, pid)

    def close(self) -> None:
        with self._cond:
            self._closed = True
            workers, self._idle = list(self._all), []
            self._all.clear()
            self._cond.notify_all()
        for w in workers:
            w.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _simulate(method_id: str, scene: Scene, dt: float, steps: int, every: int) -> Trajectory:
    from harness.methods import get_method

    return get_method(method_id).simulate(scene, dt, steps, every)


def simulate_isolated(method, scene: Scene, dt: float, steps: int, every: int = 1,
                      timeout: float | None = None) -> Trajectory:
    """Step an engine mode (a method, or its id) in a worker, which looks it up again by its id;
    a crash or a hang comes back as a failed Trajectory."""
    if isinstance(method, str):
        from harness.methods import get_method

        method = get_method(method)
    limit = DEFAULT_TIMEOUT_S if timeout is None else timeout
    out = run_in_worker(_simulate, (method.id, scene, dt, steps, every), timeout=limit)
    if isinstance(out, WorkerFailure):
        info = method.describe()  # a failed run, too, says which engine and settings
        meta = {"backend": "engine", "engine": info.get("engine"), "engine_version": info.get("engine_version"),
                "settings": info.get("settings"), "worker": out.as_dict(), "params": dict(scene.values)}
        return Trajectory.failed(scene.id, method.id, dt, steps, out.status, out.detail, every=every,
                                 ndof=scene.ndof, meta=meta)
    return out
