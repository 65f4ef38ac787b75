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

#: (floor step, state length, scene data) -> (single, batch), compiled on first use.
_LOOPS: dict = {}


def _batch_source(length: int, scene_data: int) -> str:
    """The batch loop of a state of ``length`` floats, its last ``scene_data`` the scene's data
    (``Floor.scene_data``): each spring's own entries read from its column and stored back, the
    data passed to every spring as the tuple ``data``."""
    own = length - scene_data
    entries = [f"a[{i}, b]" for i in range(own)] + [f"data[{j}]" for j in range(scene_data)]
    lines = [
        "def batch(a, data, h, k, m, n):",
        "    for _ in range(n):",
        "        for b in range(a.shape[1]):",
        f"            s = step(({', '.join(entries)},), h, k, m)",
    ]
    lines += [f"            a[{i}, b] = s[{i}]" for i in range(own)]
    return "\n".join(lines) + "\n"


def _loops(floor, length: int):
    """(single, batch) compiled loops of a floor whose state has ``length`` floats:
    ``single(state, h, k, m, n) -> state`` in registers, ``batch(states (own, nb), data, h, k, m,
    n)`` in place over the springs' own entries, the batch innermost, the scene's data a tuple."""
    key = (floor.step, length, floor.scene_data)
    if key not in _LOOPS:
        jit = numba.njit(error_model="numpy")
        # Inlined by numba before LLVM sees it, as the kernel's statements are written into its
        # loop: a step LLVM declines to inline (its passes unrolled make it large) is a call a
        # spring, and the batch loop around a call does not vectorise.
        step = numba.njit(error_model="numpy", inline="always")(floor.step)

        @jit
        def single(s, h, k, m, n):
            for _ in range(n):
                s = step(s, h, k, m)
            return s

        namespace = {"step": step}
        exec(compile(_batch_source(length, floor.scene_data), f"<floor batch {length}>", "exec"), namespace)
        _LOOPS[key] = (single, jit(namespace["batch"]))
    return _LOOPS[key]


def run_floor(floor, x0: float, v0: float, h: float, k: float, m: float, n: int) -> tuple[float, float]:
    """(x, v) after n steps of ``floor`` (a scheme's ``Floor``) from (x0, v0)."""
    s0 = floor.start(x0, v0, h, k, m)
    single = _loops(floor, len(s0))[0]
    return floor.observe(single(s0, h, k, m, n), h, k, m)


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
    s0 = floor.start(x0, v0, h, k, m)
    single, loop = _loops(floor, len(s0))
    own = len(s0) - floor.scene_data
    data = tuple(float(e) for e in s0[own:])
    states = np.repeat(np.array(s0[:own], dtype=np.float64)[:, None], batch, axis=1)
    t = clock()
    single(s0, h, k, m, 2)
    loop(states.copy(), data, h, k, m, 2)
    warm = clock() - t

    def once() -> float:
        if batch == 1:
            t0 = clock()
            single(s0, h, k, m, steps)
        else:
            work = states.copy()
            t0 = clock()
            loop(work, data, h, k, m, steps)
        return (clock() - t0) / steps

    return warm, once
