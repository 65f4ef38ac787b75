"""What several adapters' poses share: a force applied from Python in one order of operations,
and an angle made continuous.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np


def chain_force(k: float, c: float, x: np.ndarray, velocities: Callable[[], np.ndarray]) -> np.ndarray:
    """The chain's force from Python, k (x_{i-1} - 2 x_i + x_{i+1}) with the walls at 0, plus the
    dashpots' c (v_{i-1} - 2 v_i + v_{i+1}) where c != 0 (only then are the velocities read),
    in the one order of operations every adapter that applies it keeps."""
    f = (-2.0 * k) * x
    f[1:] += k * x[:-1]
    f[:-1] += k * x[1:]
    if c != 0.0:
        v = velocities()
        g = (-2.0 * c) * v
        g[1:] += c * v[:-1]
        g[:-1] += c * v[1:]
        f = f + g
    return f


def unwrap(previous: float, angle: float) -> float:
    """``angle`` plus the whole turns that bring it nearest ``previous``: a continuous angle from
    an engine that reports it modulo 2 pi. An angle already continuous is returned untouched."""
    turns = round((previous - angle) / (2.0 * math.pi))
    return angle + turns * (2.0 * math.pi) if turns else angle
