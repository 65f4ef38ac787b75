"""The floors, compiled and driven: each scheme's hand-written loop of scalars on the unit spring
(``Scheme.floor``, a ``reference._scheme.Floor``, declared in the scheme's file or, for a tableau, a
splitting or a substepped scheme, generated from its declaration, the spring's k and m read from the
floor's arguments as the kernel reads them from the scene's).

What a compiled step can cost at best on this machine: the scheme's updates written out by hand
for the spring, the state carried in registers on one spring and stepped over contiguous arrays,
innermost, on a batch. ``harness bench`` times each scheme's compiled kernel beside its floor in
the same run; the ratio is what the generated kernels still pay over a loop written by hand.
``run_floor`` and ``floor_timer`` below drive one.
"""

from __future__ import annotations

import time

import numba
import numpy as np

from . import _numba_config

_numba_config.configure()  # before the first floor compiles: at the kernels' level

#: Floor step (a plain function) -> (step, single, batch2, batch3), compiled on first use.
_LOOPS: dict = {}


def _loops(floor):
    """(single, batch2, batch3) compiled loops of a floor: ``single(state, h, k, m, n) -> state`` in
    registers, ``batch(states (nstate, nb), h, k, m, n)`` in place, the batch innermost."""
    if floor.step not in _LOOPS:
        jit = numba.njit(error_model="numpy")
        step = jit(floor.step)

        @jit
        def single(s, h, k, m, n):
            for _ in range(n):
                s = step(s, h, k, m)
            return s

        @jit
        def batch2(a, h, k, m, n):
            for _ in range(n):
                for b in range(a.shape[1]):
                    s = step((a[0, b], a[1, b]), h, k, m)
                    a[0, b] = s[0]
                    a[1, b] = s[1]

        @jit
        def batch3(a, h, k, m, n):
            for _ in range(n):
                for b in range(a.shape[1]):
                    s = step((a[0, b], a[1, b], a[2, b]), h, k, m)
                    a[0, b] = s[0]
                    a[1, b] = s[1]
                    a[2, b] = s[2]

        _LOOPS[floor.step] = (single, batch2, batch3)
    return _LOOPS[floor.step]


def run_floor(floor, x0: float, v0: float, h: float, k: float, m: float, n: int) -> tuple[float, float]:
    """(x, v) after n steps of ``floor`` (a scheme's ``Floor``) from (x0, v0)."""
    single = _loops(floor)[0]
    return floor.observe(single(floor.start(x0, v0, h, k, m), h, k, m, n), h, k, m)


def floor_timer(
    floor,
    h: float,
    steps: int,
    batch: int = 1,
    k: float = 1.0,
    m: float = 1.0,
    x0: float = 1.0,
    v0: float = 0.0,
    clock=time.perf_counter,
):
    """``(warm-up seconds, once)`` as ``reference._compiled.step_timer``: ``once()`` times one
    call of ``steps`` steps of ``floor`` (one spring in registers, or a batch of springs) and
    returns seconds per step."""
    single, batch2, batch3 = _loops(floor)
    s0 = floor.start(x0, v0, h, k, m)
    states = np.repeat(np.array(s0, dtype=np.float64)[:, None], batch, axis=1)
    loop = batch2 if len(s0) == 2 else batch3
    t = clock()
    single(s0, h, k, m, 2)
    loop(states.copy(), h, k, m, 2)
    warm = clock() - t

    def once() -> float:
        if batch == 1:
            t0 = clock()
            single(s0, h, k, m, steps)
        else:
            work = states.copy()
            t0 = clock()
            loop(work, h, k, m, steps)
        return (clock() - t0) / steps

    return warm, once
