"""The damped oscillator x'' = -x - 2 zeta x' (k = m = 1: omega = 1, h omega = y), on which a
scheme declares its recurrence (``Scheme.amplification``): one step as a matrix M(y, zeta) on the
state it carries, written from its update formulas applied to a = -x - 2 zeta v. The scheme is
stable at y iff the spectral radius of M is <= 1 (``harness.measures.stability_damping`` finds the
first y where it is not, where the scheme gives no closed form, ``Scheme.damping_limit``).

The pieces the schemes' matrices are products of, on (x, v): a kick, a drift and the oscillator's
own matrix (the first-order form's Jacobian).
"""

from __future__ import annotations

import math

import numpy as np


def kick(d: float, zeta: float) -> np.ndarray:
    """v += d a(x, v), a = -x - 2 zeta v, on (x, v)."""
    return np.array([[1.0, 0.0], [-d, 1.0 - 2.0 * zeta * d]])


def drift(d: float) -> np.ndarray:
    """x += d v, on (x, v)."""
    return np.array([[1.0, d], [0.0, 1.0]])


def oscillator(zeta: float) -> np.ndarray:
    """J of (x, v)' = J (x, v): [[0, 1], [-1, -2 zeta]]."""
    return np.array([[0.0, 1.0], [-1.0, -2.0 * zeta]])


def unbounded(zeta: float) -> float:
    """The limit of an A-stable scheme: stable at every y, whatever the damping."""
    return math.inf
