"""Do numba and the interpreted kernels compute a library function to the same bits here?

A kernel calling ``np.sin`` runs numpy's loop for it interpreted and numba's compiled. Both
call the C library's ``sin`` unless numpy brings its own vectorised version for this CPU
(numpy's AVX-512 builds of sin, cos and exp for float64 differ from glibc by an ulp on many
arguments): whether they agree is a fact of the machine and of numpy's build, so it is checked,
once per process, over arguments spread across the range a kernel sees, on each side as the
kernels call it (numpy on an array, ``math`` on a float). A disagreement on any argument
counts as a disagreement everywhere. LAPACK's dense solve likewise: numpy's bundled build
against the one numba calls, on random systems of the sizes a scene's solve has.

Each answer is kept beside the kernels (``$HARNESS_CACHE/kernels/libm-<key>.json``), the key a hash
of what it depends on (numpy's, numba's and Python's versions, this CPU and its features, the
kernels' optimisation level, this module's source): a later process on the machine reads it instead
of compiling the check again.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import sys
import tempfile
from functools import cache
from pathlib import Path

import numba
import numpy as np

from . import _numba_config

_numba_config.configure()  # the check compiles at the kernels' level, as they call these functions


def _arguments(name: str) -> np.ndarray:
    """Where the check evaluates: a dense sweep of a few periods, wide random arguments, tiny
    ones and the special values (exp: within its finite range and across all of it)."""
    rng = np.random.default_rng(20261123)
    x = np.concatenate(
        [
            np.linspace(-20.0, 20.0, 40_001),
            rng.standard_normal(20_000) * 1e3,
            rng.standard_normal(5_000) * 1e-6,
            [0.0, -0.0, np.inf, -np.inf, np.nan],
        ]
    )
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


def _answers_file() -> Path:
    """Where this machine's answers are kept (the module docstring)."""
    from llvmlite import binding

    from ._kernels import cache_dir

    h = hashlib.sha256(Path(__file__).read_bytes())
    h.update(
        f"numpy {np.__version__} numba {numba.__version__} python {sys.version} cpu {binding.get_host_cpu_name()} "
        f"{binding.get_host_cpu_features().flatten()} opt {_numba_config.opt_level()}".encode()
    )
    return cache_dir() / f"libm-{h.hexdigest()[:16]}.json"


def _kept() -> dict:
    try:
        return json.loads(_answers_file().read_text())
    except (OSError, ValueError):
        return {}


def _keep(name: str, answer: bool) -> None:
    """Add an answer to the file: written under a temporary name and put in place, so a process
    reading it sees a whole file (of two writing at once, one's answer may be lost, and found again
    by a later process)."""
    path = _answers_file()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".json")
        with os.fdopen(fd, "w") as f:
            json.dump({**_kept(), name: answer}, f)
        os.replace(tmp, path)
    except OSError:  # a cache that cannot be written: the answer is found again in the next process
        pass


@cache
def agrees(name: str) -> bool:
    """True iff numba's ``name`` ("np.sin", "math.exp", ...) gives numpy's (or math's) bits at
    every argument checked, NaN for NaN: as kept for this machine, else checked (and kept)."""
    kept = _kept()
    if name in kept:
        return bool(kept[name])
    answer = _check(name)
    _keep(name, answer)
    return answer


def _check(name: str) -> bool:
    if name == "np.linalg.solve":
        return _solve_agrees()
    x = _arguments(name)
    with np.errstate(all="ignore"):
        a = _interpreted(name, x)
        b = _compiled(name)(x)
    same = (a.view(np.int64) == b.view(np.int64)) | (np.isnan(a) & np.isnan(b))
    return bool(same.all())
