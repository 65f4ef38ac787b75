"""The nightly's progress: a bar on a terminal, plain lines otherwise (logs, CI), each task's
numba compile seconds beside its own, and before and after the run what it compiles."""
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
            self.stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total} "
                              f"{time.perf_counter() - self.t0:6.1f}s (compiling {self.compile_s:.0f}s) "
                              f"{task.scene} {task.method}"[:110].ljust(110))
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
    return (f"compiling: {timing.numba_compile_s:.1f} CPU-s for {timing.kernels_compiled} kernels{share}; "
            f"a kept kernel cache would have saved about {timing.cache_would_save_s:.0f} CPU-s")
