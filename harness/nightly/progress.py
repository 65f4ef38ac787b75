"""The nightly's progress: a bar on a terminal, plain lines otherwise (logs, CI), each task's
numba compile seconds beside its own, and before and after the run what it compiles; and a
single-scene command's (``Lines``): what it is doing, once it has run a few seconds."""

from __future__ import annotations

import sys
import time

from records.run import RunTiming


class Progress:
    """A bar on a terminal, plain lines otherwise (logs, CI)."""

    def __init__(self, total: int, stream=None):
        # Looked up at call time: a stream bound at import can be closed by then (pytest capture).
        stream = stream or sys.stderr
        self.total, self.done, self.stream = total, 0, stream
        self.tty = hasattr(stream, "isatty") and stream.isatty()
        self.t0 = time.perf_counter()
        self.compile_s = 0.0

    def say(self, line: str) -> None:
        """A line of its own (nothing where ``line`` is empty)."""
        if line:
            self.stream.write(line + "\n")
            self.stream.flush()

    def update(self, task, status: str, seconds: float, cells=()):
        self.done += 1
        compiling = sum((c.kernels or {}).get("compile_s", 0.0) for c in cells)
        self.compile_s += compiling
        if self.tty:
            width = 30
            filled = int(width * self.done / max(self.total, 1))
            self.stream.write(
                f"\r[{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total} "
                f"{time.perf_counter() - self.t0:6.1f}s (compiling {self.compile_s:.0f}s) "
                f"{task.scene} {task.method}"[:110].ljust(110)
            )
            if self.done == self.total:
                self.stream.write("\n")
        else:
            spent = f", {compiling:.1f}s of it compiling, {self.compile_s:.1f}s so far" if compiling else ""
            self.stream.write(f"[{self.done}/{self.total}] {task.label}: {status} ({seconds:.1f}s{spent})\n")
        self.stream.flush()


def compile_line(timing: RunTiming) -> str:
    """After the cells: what compiling took of the workers' CPU and what a kept cache would have
    saved ("" where nothing was compiled)."""
    if not timing.kernels_compiled:
        return f"kernels: {timing.kernels_loaded or 0} loaded from the disk cache, none compiled"
    share = f" ({timing.compile_share:.0%} of the workers' CPU)" if timing.compile_share is not None else ""
    return (
        f"compiling: {timing.numba_compile_s:.1f} CPU-s for {timing.kernels_compiled} kernels{share}; "
        f"a kept kernel cache would have saved about {timing.cache_would_save_s:.0f} CPU-s"
    )


#: Seconds a single-scene command runs before it says what it is doing: a command that answers
#: within them prints nothing but its answer. ``$HARNESS_PROGRESS_AFTER`` sets another (``inf``:
#: never, for a caller that reads stderr whole).
QUIET_S = 3.0
QUIET_ENV = "HARNESS_PROGRESS_AFTER"


def quiet_seconds() -> float:
    """The seconds before a command's progress begins: ``$HARNESS_PROGRESS_AFTER``, else ``QUIET_S``."""
    import math
    import os

    from records import InvalidInput

    value = os.environ.get(QUIET_ENV)
    if value is None:
        return QUIET_S
    try:
        x = float(value)
    except ValueError:
        x = math.nan
    if not x >= 0.0:
        raise InvalidInput(f"{QUIET_ENV}={value!r} is out of range (allowed: seconds >= 0, or inf)")
    return x


class Lines:
    """A single-scene command's progress on stderr: what it is doing, a plain line each (logs, CI;
    on a terminal one line rewritten in place, cleared when the command ends), once the command
    has run ``quiet_s`` seconds. A line said before then is held, and the latest held line is
    printed when that moment comes (a timer thread): a long compile begun early is still named.
    ``clock``: the clock ``quiet_s`` is read on (a test injects its own)."""

    def __init__(self, stream=None, quiet_s: float | None = None, clock=time.monotonic):
        import threading

        self.stream = stream or sys.stderr
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.quiet_s = quiet_seconds() if quiet_s is None else quiet_s
        self.clock = clock
        self.t0 = clock()
        self.said = 0  # lines written
        self._held = ""
        self._loud = self.quiet_s <= 0
        self._closed = False
        self._lock = threading.Lock()
        self._timer = None
        if not self._loud and self.quiet_s < float("inf"):
            self._timer = threading.Timer(self.quiet_s, self._wake)
            self._timer.daemon = True
            self._timer.start()

    def __call__(self, line: str) -> None:
        with self._lock:
            if not (self._loud or self._closed) and self.clock() - self.t0 >= self.quiet_s:
                self._loud, self._held = True, ""  # this line is newer than the one held
            if self._loud:
                self._write(line)
            else:
                self._held = line

    def _wake(self) -> None:
        """The threshold passed (the timer; it waits while a compile holds the interpreter)."""
        with self._lock:
            if self._loud or self._closed:
                return
            self._loud = True
            if self._held:
                self._write(self._held)
                self._held = ""

    def _write(self, line: str) -> None:
        if self.tty:
            self.stream.write("\r" + line[:110].ljust(110))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()
        self.said += 1

    def close(self) -> None:
        """Stop the timer; on a terminal, clear the line (the answer follows on stdout)."""
        with self._lock:
            if self._timer is not None:
                self._timer.cancel()
            self._closed, self._loud, self._held = True, False, ""
            if self.tty and self.said:
                self.stream.write("\r" + " " * 110 + "\r")
                self.stream.flush()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
