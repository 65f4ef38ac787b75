"""High-accuracy reference solutions where no closed form exists: scipy DOP853, cached.

The solution is built in fixed segments [k L, (k + 1) L], each a DOP853 solve with dense
output started from the end of the previous one, and kept for the life of the process. A
value at time t therefore does not depend on how far earlier calls reached (a single solve to
a larger horizon would take different steps and differ at the tolerance level).
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp

#: One cache per (scene id, parameter values, what is solved): scenes are cheap to construct.
_CACHE: dict[tuple, "SegmentedSolution"] = {}


class SegmentedSolution:
    def __init__(self, rhs: Callable, y0: np.ndarray, segment: float, rtol: float, atol: float):
        self.rhs, self.segment, self.rtol, self.atol = rhs, float(segment), rtol, atol
        self.pieces = []
        self.y_end = np.array(y0, dtype=float)
        self.nfev = 0

    def _extend_to(self, t_max: float) -> None:
        while not self.pieces or len(self.pieces) * self.segment < t_max:
            t0 = len(self.pieces) * self.segment
            sol = solve_ivp(self.rhs, (t0, t0 + self.segment), self.y_end, method="DOP853",
                            rtol=self.rtol, atol=self.atol, dense_output=True)
            if not sol.success:  # pragma: no cover - a failed reference must never pass silently
                raise RuntimeError(f"reference solve failed on [{t0:g}, {t0 + self.segment:g}]: {sol.message}")
            self.nfev += sol.nfev
            self.pieces.append(sol.sol)
            self.y_end = sol.y[:, -1].copy()

    def __call__(self, t) -> np.ndarray:
        """y at times t (t >= 0), shape (len(t), len(y0))."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.size == 0:
            return np.zeros((0, self.y_end.size))
        if np.min(t) < 0:
            raise ValueError("the reference solution starts at t = 0")
        self._extend_to(float(np.max(t)))
        out = np.empty((t.size, self.y_end.size))
        idx = np.minimum((t // self.segment).astype(int), len(self.pieces) - 1)
        for k in np.unique(idx):
            sel = idx == k
            out[sel] = self.pieces[k](t[sel]).T
        return out


def cached(key: tuple, build: Callable[[], SegmentedSolution]) -> SegmentedSolution:
    if key not in _CACHE:
        _CACHE[key] = build()
    return _CACHE[key]


__all__ = ["SegmentedSolution", "cached"]
