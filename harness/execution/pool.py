"""Reused workers: :class:`WorkerPool` keeps forkserver workers (``isolation``'s, the same
isolation: own temporary directory, output kept for a failure's detail) for call after call (the
nightly's cells): a worker that dies or hangs costs its call and is replaced, and what a worker
compiled stays compiled. Inside a call, :func:`report_partial` sends results ahead to the caller,
so a call that then crashes or hangs keeps what it measured before (``WorkerFailure.partial``)."""

from __future__ import annotations

import faulthandler
import math
import os
import shutil
import signal
import tempfile
import threading
import time
import traceback
from dataclasses import dataclass

from records.trajectory import CRASHED, TIMED_OUT

from harness.execution import isolation
from harness.execution.cpu_limit import tree_cpu_seconds, wait_within
from harness.execution.isolation import WorkerFailure, _complaint, _context, _tail

_PARTIAL_TO = None  # in a pool worker, while a call runs: the connection to its caller


def report_partial(obj) -> None:
    """Send ``obj`` (picklable) to the caller now, from inside a :class:`WorkerPool` call: should
    the call then kill its worker or time out, the failure carries what was sent
    (``WorkerFailure.partial``). Anywhere else it does nothing."""
    if _PARTIAL_TO is not None:
        _PARTIAL_TO.send(("partial", obj))


def _serve(conn, workdir: str) -> None:
    """A pool worker: receive ``(fn, args, kwargs)``, answer with the result and the CPU seconds
    the call took; ``None`` or a closed pipe ends it. Its folder goes with it: a worker that ends
    here was let go, or its caller is gone (a nightly killed with SIGKILL) and nothing will read
    the folder again; one that dies of a signal leaves it for the caller to read and remove."""
    try:
        _serve_calls(conn, workdir)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


def _serve_calls(conn, workdir: str) -> None:
    global _PARTIAL_TO
    isolation.IN_WORKER = True
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
        fn, args, kwargs, limit = job
        isolation.arm_backstop(limit)  # this call's own timers (none where it has no limit)
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
            isolation.arm_backstop(None)  # an idle worker waits for its next call for as long as it takes
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

    def call_with_stats(
        self, fn, args: tuple = (), kwargs: dict | None = None, timeout: float | None = None
    ) -> tuple[object, CallStats]:
        limit = None if timeout is None or math.isinf(timeout) else float(timeout)
        w = self._take()
        started = time.monotonic()
        pid = w.proc.pid
        cpu0 = tree_cpu_seconds(pid)  # the worker's CPU so far: its earlier calls are not this one's
        try:
            w.conn.send((fn, args, kwargs or {}, limit))
        except (OSError, ValueError):  # the worker died while idle: a fresh one takes the call
            self._give_back(w, keep=False)
            return self.call_with_stats(fn, args, kwargs, timeout)
        w.calls += 1
        partial = []
        while True:
            over = wait_within(w.conn, pid, limit, cpu0)
            if over is not None:  # neither a result nor EOF within the limit
                w.proc.kill()
                w.proc.join()
                output = _tail(w.workdir)
                self._give_back(w, keep=False)
                seconds = time.monotonic() - started
                return (
                    WorkerFailure(TIMED_OUT, over, output=output, seconds=seconds, partial=partial),
                    CallStats(seconds, None, pid),
                )
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
            return (
                WorkerFailure(
                    CRASHED,
                    f"raised {message[1]}",
                    output=message[2] or _tail(w.workdir),
                    seconds=seconds,
                    partial=partial,
                ),
                CallStats(seconds, message[3], pid),
            )
        w.proc.join(timeout=10.0)
        code = w.proc.exitcode
        output, said = _tail(w.workdir), _complaint(w.workdir)
        self._give_back(w, keep=False)
        if code is not None and code < 0:
            name = signal.Signals(-code).name
            detail = f"worker killed by {name}" + (f" ({said})" if said else "")
            failure = WorkerFailure(
                CRASHED, detail, signal=name, exitcode=code, output=output, seconds=seconds, partial=partial
            )
        else:
            failure = WorkerFailure(
                CRASHED,
                f"worker exited with code {code} without a result",
                exitcode=code,
                output=output,
                seconds=seconds,
                partial=partial,
            )
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
