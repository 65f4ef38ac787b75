"""A worker's time limit in CPU seconds, not wall seconds: what a method spends, not what its
neighbours on a shared machine take from it.

On a machine whose load is five times its cores, a worker gets a fifth of a core and its
computation takes five times as long by the wall clock; a wall-clock limit then measures the
neighbours. The limit
here is the CPU (user and system) the worker's process tree spent since the call began: the
worker, its live descendants, and the children it reaped. A worker that spends no CPU at all (a
hang on a lock, a sleep, a lost child) is still stopped, after ``WALL_FACTOR`` times its limit of
wall time. Where ``/proc`` is not there to read, the limit falls back to wall time.
"""

from __future__ import annotations

import os
import time

#: A worker that has not answered after this many times its CPU limit of wall time is stopped as
#: hung, whatever CPU it spent: policy, well above the slowdown a load of ten times the cores gives.
WALL_FACTOR = 10.0
#: How often the parent reads the worker's CPU while it waits (s).
POLL_S = 0.25

_TICK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") and "SC_CLK_TCK" in os.sysconf_names else 100


def _stat(pid: int) -> tuple[int, float, float] | None:
    """(ppid, own CPU s, reaped children's CPU s) from /proc/PID/stat, or None where unreadable."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            text = f.read().decode("ascii", "replace")
    except OSError:
        return None
    fields = text[text.rindex(")") + 2 :].split()  # after "pid (comm) ": state, ppid, ...
    ppid = int(fields[1])
    utime, stime, cutime, cstime = (int(x) for x in fields[11:15])
    return ppid, (utime + stime) / _TICK, (cutime + cstime) / _TICK


def tree_cpu_seconds(pid: int) -> float | None:
    """CPU seconds (user + system) spent by process ``pid``, its live descendants and every child
    any of them reaped; None where ``/proc`` cannot be read (then no CPU limit applies)."""
    root = _stat(pid)
    if root is None:
        return None
    children: dict[int, list[int]] = {}
    stats: dict[int, tuple[int, float, float]] = {pid: root}
    try:
        entries = os.listdir("/proc")
    except OSError:
        return root[1] + root[2]
    for name in entries:
        if not name.isdigit() or int(name) == pid:
            continue
        st = _stat(int(name))
        if st is not None:
            stats[int(name)] = st
            children.setdefault(st[0], []).append(int(name))
    total, todo = 0.0, [pid]
    while todo:
        p = todo.pop()
        _, own, reaped = stats[p]
        total += own + reaped
        todo.extend(children.get(p, ()))
    return total


def wait_within(conn, pid: int, limit: float | None, cpu0: float | None = None) -> str | None:
    """Wait for ``conn`` to have something to read (a result, or EOF: the worker died) while the
    worker ``pid`` spends under ``limit`` CPU seconds beyond ``cpu0`` (its tree's CPU when the call
    began) and under ``WALL_FACTOR`` times ``limit`` of wall time. None where ``conn`` is ready;
    else why the worker is over its limit, in words (the caller kills it)."""
    if limit is None:
        conn.poll(None)
        return None
    started = time.monotonic()
    base = cpu0 if cpu0 is not None else (tree_cpu_seconds(pid) or 0.0)
    while True:
        wall = time.monotonic() - started
        if conn.poll(max(0.0, min(POLL_S, WALL_FACTOR * limit - wall))):
            return None
        wall = time.monotonic() - started
        now = tree_cpu_seconds(pid)
        if now is None:  # no /proc: the wall clock is all there is
            if wall >= limit:
                return f"no result within {limit:g} s of wall time (CPU time unreadable here); worker killed"
            continue
        used = now - base
        if used >= limit:
            return f"spent {used:.1f} CPU s, its limit {limit:g} ({wall:.1f} s of wall time); worker killed"
        if wall >= WALL_FACTOR * limit:
            return (
                f"no result within {wall:.0f} s of wall time ({WALL_FACTOR:g} x its {limit:g} CPU s limit) having "
                f"spent {used:.1f} CPU s: hung; worker killed"
            )
