"""High-accuracy reference solutions where no closed form exists: scipy DOP853, cached.

The solution is built in fixed segments [k L, (k + 1) L], each a DOP853 solve with dense
output started from the end of the previous one, and kept for the life of the process. A
value at time t therefore does not depend on how far earlier calls reached (a single solve to
a larger horizon would take different steps and differ at the tolerance level).

A segment's dense output holds every step's interpolant (8 numbers per unknown a step): the 16 x 16
cloth at k = 1e6 needs about 39,000 steps to reach t = 2, 3.5 GB of them, and a 32 x 32 sheet four
times that. A solution therefore keeps dense output up to ``KEPT_VALUES`` numbers and, past that,
only each segment's start: a segment not kept is solved again from its start when asked for (the
same solve, so the same values), and the values last asked for are kept by their times (``RECENT``
sets of times), so that the many runs measured against one reference at the same times (the advice's
frames) solve it once.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from collections.abc import Callable

import numpy as np

#: One cache per (scene id, parameter values, what is solved): scenes are cheap to construct.
_CACHE: dict[tuple, SegmentedSolution] = {}
#: Dense output a solution keeps (numbers: 2^24 is 128 MB); a segment past it is solved again when asked for.
KEPT_VALUES = 1 << 24
#: Sets of times whose values a solution keeps (the most recently asked for), each of at most
#: RECENT_VALUES numbers.
RECENT = 8
RECENT_VALUES = 1 << 20


class SegmentedSolution:
    def __init__(self, rhs: Callable, y0: np.ndarray, segment: float, rtol: float, atol: float):
        self.rhs, self.segment, self.rtol, self.atol = rhs, float(segment), rtol, atol
        self.starts = [np.array(y0, dtype=float)]  # y at each segment's start (and the last one's end)
        self.pieces: dict[int, object] = {}  # segment -> its dense output, while within KEPT_VALUES
        self.kept = 0
        self.recent: OrderedDict = OrderedDict()
        self.nfev = 0
        self.solves = 0  # segment solves, those solved again included

    @property
    def y_end(self) -> np.ndarray:
        return self.starts[-1]

    def _solve(self, k: int):
        t0 = k * self.segment
        from scipy.integrate import solve_ivp  # here: a process that never solves a reference need not import it

        sol = solve_ivp(
            self.rhs,
            (t0, t0 + self.segment),
            self.starts[k],
            method="DOP853",
            rtol=self.rtol,
            atol=self.atol,
            dense_output=True,
        )
        if not sol.success:  # pragma: no cover - a failed reference must never pass silently
            raise RuntimeError(f"reference solve failed on [{t0:g}, {t0 + self.segment:g}]: {sol.message}")
        self.nfev += sol.nfev
        self.solves += 1
        if k + 1 == len(self.starts):
            self.starts.append(sol.y[:, -1].copy())
        size = len(sol.t) * 8 * self.starts[0].size
        if self.kept + size <= KEPT_VALUES:
            self.pieces[k] = sol.sol
            self.kept += size
        return sol.sol

    def _piece(self, k: int):
        while len(self.starts) <= k:
            self._solve(len(self.starts) - 1)
        piece = self.pieces.get(k)
        return piece if piece is not None else self._solve(k)

    def __call__(self, t) -> np.ndarray:
        """y at times t (t >= 0), shape (len(t), len(y0))."""
        t = np.ascontiguousarray(np.atleast_1d(np.asarray(t, dtype=float)))
        if t.size == 0:
            return np.zeros((0, self.y_end.size))
        if np.min(t) < 0:
            raise ValueError("the reference solution starts at t = 0")
        key = hashlib.sha1(t.tobytes()).hexdigest()
        if key in self.recent:
            self.recent.move_to_end(key)
            return self.recent[key].copy()
        out = np.empty((t.size, self.y_end.size))
        # A time on a segment's boundary is read at the end of the segment before it, whichever
        # segments exist: a value never depends on how far earlier calls reached.
        idx = np.maximum(np.ceil(t / self.segment).astype(int) - 1, 0)
        for k in np.unique(idx):
            sel = idx == k
            out[sel] = self._piece(int(k))(t[sel]).T
        if out.size <= RECENT_VALUES:
            self.recent[key] = out.copy()
            while len(self.recent) > RECENT:
                self.recent.popitem(last=False)
        return out


def cached(key: tuple, build: Callable[[], SegmentedSolution]) -> SegmentedSolution:
    if key not in _CACHE:
        _CACHE[key] = build()
    return _CACHE[key]


__all__ = ["SegmentedSolution", "cached"]
