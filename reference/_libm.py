"""Do numba and the interpreted kernels compute a library function to the same bits here?

A kernel calling ``np.sin`` runs numpy's loop for it interpreted and numba's compiled. Both
call the C library's ``sin`` unless numpy brings its own vectorised version for this CPU
(numpy's AVX-512 builds of sin, cos and exp for float64 differ from glibc by an ulp on many
arguments): whether they agree is a fact of the machine and of numpy's build, so it is checked,
once per process, over arguments spread across the range a kernel sees, on each side as the
kernels call it (numpy on an array, ``math`` on a float). A disagreement on any argument
counts as a disagreement everywhere. LAPACK's dense solve likewise: numpy's bundled build
against the one numba calls, on random systems of the sizes a scene's solve has.
"""
from __future__ import annotations

import math
from functools import cache

import numba
import numpy as np

from . import _numba_config

_numba_config.configure()  # the check compiles at the kernels' level, as they call these functions


def _arguments(name: str) -> np.ndarray:
    """Where the check evaluates: a dense sweep of a few periods, wide random arguments, tiny
    ones and the special values (exp: within its finite range and across all of it)."""
    rng = np.random.default_rng(20261123)
    x = np.concatenate([np.linspace(-20.0, 20.0, 40_001), rng.standard_normal(20_000) * 1e3,
                        rng.standard_normal(5_000) * 1e-6, [0.0, -0.0, np.inf, -np.inf, np.nan]])
    if name.endswith("exp"):
        x = np.concatenate([np.clip(x, -745.0, 709.0), np.linspace(-745.0, 709.0, 20_001)])
    return x


def _interpreted(name: str, x: np.ndarray) -> np.ndarray:
    module, fn = name.split(".")
    if module == "np":
        return getattr(np, fn)(x)
    f = getattr(math, fn)
    out = np.empty_like(x)
    for i, e in enumerate(x.tolist()):
        try:
            out[i] = f(e)
        except (ValueError, OverflowError):  # math raises where numpy gives nan/inf: not a kernel's case
            out[i] = getattr(np, fn)(e)
    return out


def _compiled(name: str):
    module, fn = name.split(".")
    if module == "np":
        f = getattr(np, fn)
        return numba.njit(error_model="numpy")(lambda x: f(x))
    g = getattr(math, fn)

    def each(x):
        out = np.empty_like(x)
        for i in range(x.size):
            out[i] = g(x[i])
        return out

    return numba.njit(error_model="numpy")(each)


@numba.njit(cache=True)
def _solve(a, b):
    return np.linalg.solve(a, b)


def _solve_agrees() -> bool:
    """numba's ``np.linalg.solve`` (LAPACK's gesv through scipy) against numpy's (its own
    bundled LAPACK) on well-conditioned random systems of every size up to 24: the same bits
    for every one, or a disagreement."""
    solve = _solve
    rng = np.random.default_rng(20261123)
    for n in range(1, 25):
        for _ in range(40):
            a = np.eye(n) - rng.standard_normal((n, n)) * rng.uniform(0.01, 0.5)
            b = rng.standard_normal(n) * 10.0 ** rng.uniform(-8, 8)
            x, y = np.linalg.solve(a, b), solve(a, b)
            if x.tobytes() != y.tobytes():
                return False
    return True


@cache
def agrees(name: str) -> bool:
    """True iff numba's ``name`` ("np.sin", "math.exp", ...) gives numpy's (or math's) bits at
    every argument checked, NaN for NaN."""
    if name == "np.linalg.solve":
        return _solve_agrees()
    x = _arguments(name)
    with np.errstate(all="ignore"):
        a = _interpreted(name, x)
        b = _compiled(name)(x)
    same = (a.view(np.int64) == b.view(np.int64)) | (np.isnan(a) & np.isnan(b))
    return bool(same.all())
