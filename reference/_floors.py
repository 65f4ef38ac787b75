"""The floor: each unconstrained scheme on the unit spring as a hand-written loop of scalars.

What a compiled step can cost at best on this machine: the scheme's updates written out by
hand for the spring, a = (-k x)/m as the scene spells it, every value a float (no array, no
temporary, no call the compiler does not inline), the state carried in registers on one
spring and stepped over contiguous arrays, innermost, on a batch. ``harness bench`` times
each scheme's compiled kernel beside its floor in the same run; the ratio is what the
generated kernels still pay over a loop written by hand. Written independently of the
schemes' and the scene's source, the floors also check them: the states agree to roundoff
(tests/test_reference.py). An explicit Runge-Kutta scheme's floor is generated from its tableau
(``reference.tableau``) with the spring's force written in: it checks the kernel files and the
scene's force, not the tableau, which tests/test_tableau.py checks against its order conditions.

A floor is ``step(state, h, k, m) -> state`` over a tuple of floats, with ``start(x, v, h,
k, m) -> state`` and ``observe(state, h, k, m) -> (x, v)`` where the scheme carries more than
(x, v); ``single`` and ``batch`` below drive one (``FLOORS[scheme id]``).
"""
from __future__ import annotations

import math
import time
from collections.abc import Mapping

import numba
import numpy as np

from . import _numba_config

_numba_config.configure()  # before the first floor compiles: at the kernels' level
_jit = numba.njit(error_model="numpy")

#: Forest-Ruth's theta = 1/(2 - 2^(1/3)), written out again here on purpose.
_THETA = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))


@_jit
def semi_implicit_euler(s, h, k, m):
    x, v = s
    v = v + h * (-k * x / m)
    return (x + h * v, v)


@_jit
def semi_implicit_euler_position_first(s, h, k, m):
    x, v = s
    x = x + h * v
    return (x, v + h * (-k * x / m))


@_jit
def leapfrog(s, h, k, m):
    x, v = s
    x = x + 0.5 * h * v
    v = v + h * (-k * x / m)
    return (x + 0.5 * h * v, v)


@_jit
def velocity_verlet(s, h, k, m):
    x, v, a = s
    v = v + 0.5 * h * a
    x = x + h * v
    a = -k * x / m
    return (x, v + 0.5 * h * a, a)


@_jit
def verlet(s, h, k, m):
    x, x_prev, a = s
    x_next = 2.0 * x - x_prev + h * h * a
    return (x_next, x, -k * x_next / m)


@_jit
def forest_ruth(s, h, k, m):
    x, v = s
    x = x + 0.5 * _THETA * h * v
    v = v + _THETA * h * (-k * x / m)
    x = x + 0.5 * (1.0 - _THETA) * h * v
    v = v + (1.0 - 2.0 * _THETA) * h * (-k * x / m)
    x = x + 0.5 * (1.0 - _THETA) * h * v
    v = v + _THETA * h * (-k * x / m)
    return (x + 0.5 * _THETA * h * v, v)


@_jit
def implicit_euler(s, h, k, m):
    # The spring is linear: one Newton iteration from w = v_n solves for v_{n+1} exactly, and
    # the harness takes one (newton_max = 1 on a linear scene).
    x, v = s
    dw = (h * (-k * (x + h * v) / m)) / (1.0 + h * h * (k / m))
    w = v + dw
    return (x + h * w, w)


@_jit
def implicit_euler_doubled(s, h, k, m):
    # Two implicit Euler steps of h/2, each one Newton iteration from w = v (exact on the linear spring).
    x, v = s
    half = 0.5 * h
    for _ in range(2):
        dw = (half * (-k * (x + half * v) / m)) / (1.0 + half * half * (k / m))
        w = v + dw
        x, v = x + half * w, w
    return (x, v)


@_jit
def linearly_implicit_euler(s, h, k, m):
    # One solve of (1 + h^2 k/m) v_{n+1} = v_n + h a(x_n, 0).
    x, v = s
    w = (v + h * (-k * x / m)) / (1.0 + h * h * (k / m))
    return (x + h * w, w)


@_jit
def implicit_midpoint(s, h, k, m):
    x, v = s
    dw = (h * (-k * (x + 0.5 * h * v) / m)) / (1.0 + 0.25 * h * h * (k / m))
    w = v + dw
    return (x + h * (0.5 * (v + w)), w)


#: Two-stage Radau IIA's passes allowed and its stopping tolerances, written out again here
#: (``reference.schemes.radau_iia2``, ``implicit_euler.NEWTON_RTOL``, ``kinds.NEWTON_MAX``).
_RADAU_PASSES = 50
_RADAU_RTOL = 1e-13


@_jit
def radau_iia2(s, h, k, m):
    # The scheme's own algorithm, not the closed form its stages converge to: the simplified
    # Newton passes on the stage velocities W1, W2 (the spring's solve divides by 1 + beta k/m
    # for each real shift), each pass two forces and two solves, until the passes stall in
    # roundoff below the tolerance. Same operations in the same order, so the same bits.
    x, v = s
    w1 = v
    w2 = v
    d_prev = math.inf
    for _ in range(_RADAU_PASSES):
        a1 = -k * (x + (h / 12.0) * (5.0 * w1 - w2)) / m
        a2 = -k * (x + (0.25 * h) * (3.0 * w1 + w2)) / m
        r1 = v + (h / 12.0) * (5.0 * a1 - a2) - w1
        r2 = v + (0.25 * h) * (3.0 * a1 + a2) - w2
        u1 = ((35.0 * r1 + 7.0 * r2) / 33.0) / (1.0 + 0.09 * (h * h) * (k / m))
        u2 = ((10.0 * r1 + 35.0 * r2) / 33.0) / (1.0 + 0.25 * (h * h) * (k / m))
        dw1 = u1 - 0.2 * u2
        dw2 = u2 - (2.0 / 7.0) * u1
        w1 = w1 + dw1
        w2 = w2 + dw2
        d = max(abs(dw1), abs(dw2))
        scale = 1.0 + max(abs(w1), abs(w2))
        stalled = d >= 0.5 * d_prev or d <= 1e-16 * scale
        d_prev = d
        if d <= _RADAU_RTOL * scale and stalled:
            break
    return (x + (0.25 * h) * (3.0 * w1 + w2), w2)


@_jit
def semi_implicit_euler_velocity_implicit(s, h, k, m):
    # The spring's force does not depend on v: the implicit velocity solve divides by 1, and
    # the step is semi-implicit Euler's.
    x, v = s
    v = v + h * (-k * x / m)
    return (x + h * v, v)


@_jit
def position_first_euler_decay_after_kick(s, h, k, m):
    # The spring's damping rate is 0: the decay factor e^{-0 h} is 1.
    x, v = s
    x = x + h * v
    return (x, math.exp(-0.0 * h) * (v + h * (-k * x / m)))


@_jit
def position_first_euler_decay_before_kick(s, h, k, m):
    x, v = s
    x = x + h * v
    return (x, math.exp(-0.0 * h) * v + h * (-k * x / m))


#: The position-based floors' passes over the one constraint, one substep a step: the schemes'
#: defaults (``reference.schemes.pbd``/``xpbd``), written out again here.
_PASSES = 10


@_jit
def xpbd(s, h, k, m):
    # The spring as XPBD sees it: C = x (a wall anchor at 0, rest length 0), compliance 1/k.
    x, v = s
    x_old = x
    x = x + h * v
    w = 1.0 / m
    tilde = (1.0 / k) / (h * h)
    lam = 0.0
    for _ in range(_PASSES):
        dl = (-x - tilde * lam) / (w + tilde)
        lam = lam + dl
        x = x + w * dl
    return (x, (x - x_old) / h)


#: The Jacobi XPBD floor's passes: the scheme's default (``reference.schemes.xpbd_jacobi``, Newton's).
_JACOBI_PASSES = 2


@_jit
def xpbd_jacobi(s, h, k, m):
    # One constraint: a Jacobi pass is its correction, summed from 0 and then applied, at
    # relaxation 1 (1000 thousandths, as the scheme divides it), gradient 1.
    x, v = s
    x_old = x
    x = x + h * v
    w = 1.0 / m
    tilde = (1.0 / k) / (h * h)
    lam = 0.0
    for _ in range(_JACOBI_PASSES):
        dl = (1000 / 1000.0) * ((-(x - 0.0 - 0.0) - tilde * lam) / (0.0 + w + tilde))
        lam = lam + dl
        x = x + (0.0 + w * dl * 1.0)
    return (x, (x - x_old) / h)


@_jit
def pbd(s, h, k, m):
    # Each pass removes the share s' = 1 - (1 - s)^(1/passes) of C = x, s = w / (w + (1/k)/h^2),
    # computed once before the loop (``_start_pbd``, as the kernel's loop computes it once) and
    # carried in the state; the share divided by w as the scheme keeps it, then times w.
    x, v, share = s
    x_old = x
    x = x + h * v
    w = 1.0 / m
    for _ in range(_PASSES):
        x = x + w * (-share * (x - 0.0 - 0.0))  # C = x - anchor - rest, both 0, as the scheme forms it
    return (x, (x - x_old) / h, share)


def _root(a, n):
    # a^(1/n) by Newton's method from 1 with integer powers by squaring, as the scheme takes it.
    if n == 1 or a == 0.0 or a == 1.0:
        return a
    y = 1.0
    for _ in range(200):
        power, base, e = 1.0, y, n - 1
        while e > 0:
            if e % 2 == 1:
                power = power * base
            base = base * base
            e = e // 2
        y_new = y - (power * y - a) / (n * power)
        if not y_new < y:
            break
        y = y_new
    return y


def _start_pbd(x, v, h, k, m):
    w = 0.0 + 1.0 / m
    return (x, v, (1.0 - _root(1.0 - w / (w + (1.0 / k) / (h * h)), _PASSES)) / w)


def _start_qv(x, v, h, k, m):
    return (x, v)


def _observe_qv(s, h, k, m):
    return s[0], s[1]


def _start_velocity_verlet(x, v, h, k, m):
    return (x, v, -k * x / m)


def _start_verlet(x, v, h, k, m):
    a = -k * x / m
    return (x, x - h * v + 0.5 * h * h * a, a)


def _observe_verlet(s, h, k, m):
    x, x_prev, a = s
    return x, (x - x_prev) / h + 0.5 * h * a


#: scheme id -> (step, start, observe), the schemes written here by hand; an explicit Runge-Kutta
#: scheme's floor is generated from its tableau (``_tableau_floor``).
_HAND_WRITTEN = {
    "semi_implicit_euler": (semi_implicit_euler, _start_qv, _observe_qv),
    "semi_implicit_euler_position_first": (semi_implicit_euler_position_first, _start_qv, _observe_qv),
    "leapfrog": (leapfrog, _start_qv, _observe_qv),
    "velocity_verlet": (velocity_verlet, _start_velocity_verlet, _observe_qv),
    "verlet": (verlet, _start_verlet, _observe_verlet),
    "forest_ruth": (forest_ruth, _start_qv, _observe_qv),
    "implicit_euler": (implicit_euler, _start_qv, _observe_qv),
    "implicit_euler_doubled": (implicit_euler_doubled, _start_qv, _observe_qv),
    "linearly_implicit_euler": (linearly_implicit_euler, _start_qv, _observe_qv),
    "implicit_midpoint": (implicit_midpoint, _start_qv, _observe_qv),
    "radau_iia2": (radau_iia2, _start_qv, _observe_qv),
    "pbd": (pbd, _start_pbd, _observe_qv),
    "xpbd": (xpbd, _start_qv, _observe_qv),
    "xpbd_jacobi": (xpbd_jacobi, _start_qv, _observe_qv),
    "semi_implicit_euler_velocity_implicit": (semi_implicit_euler_velocity_implicit, _start_qv, _observe_qv),
    "position_first_euler_decay_after_kick": (position_first_euler_decay_after_kick, _start_qv, _observe_qv),
    "position_first_euler_decay_before_kick": (position_first_euler_decay_before_kick, _start_qv, _observe_qv),
}


def _tableau_floor(scheme):
    """The floor of a tableau scheme: the tableau's stages written out for the spring, a = (-k x)/m
    at each stage, in the generated step's order of operations (``reference.tableau``)."""
    source = scheme.tableau.step_source(f"floor_{scheme.id}", lambda x, v, t: f"-k * {x} / m", "s, h, k, m",
                                        "x, v = s", x="x")
    namespace: dict = {}
    exec(source, namespace)
    return (_jit(namespace[f"floor_{scheme.id}"]), _start_qv, _observe_qv)


class _Floors(Mapping):
    """scheme id -> (step, start, observe) of every unconstrained scheme in ``reference.METHODS``
    that has one: written here, or generated from its tableau on first use (a tableau registered
    later, by a test, has its floor too)."""

    def __init__(self):
        self._generated: dict = {}

    def _ids(self) -> list[str]:
        from . import METHODS

        return [sid for sid, s in METHODS.items()
                if not s.constrained and (sid in _HAND_WRITTEN or s.tableau is not None)]

    def __getitem__(self, scheme_id: str):
        if scheme_id in _HAND_WRITTEN:
            return _HAND_WRITTEN[scheme_id]
        from . import METHODS

        scheme = METHODS.get(scheme_id)
        if scheme is None or scheme.tableau is None:
            raise KeyError(scheme_id)
        key = (scheme_id, scheme)
        if key not in self._generated:
            self._generated[key] = _tableau_floor(scheme)
        return self._generated[key]

    def __iter__(self):
        return iter(self._ids())

    def __len__(self) -> int:
        return len(self._ids())


#: scheme id -> (step, start, observe), every unconstrained scheme.
FLOORS = _Floors()

_LOOPS: dict = {}


def _loops(scheme_id: str):
    """(single, batch) compiled loops of a floor: ``single(state, h, k, m, n) -> state`` in
    registers, ``batch(states (nstate, nb), h, k, m, n)`` in place, the batch innermost."""
    step = FLOORS[scheme_id][0]
    if step not in _LOOPS:
        jit = numba.njit(error_model="numpy")

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

        _LOOPS[step] = (single, batch2, batch3)
    return _LOOPS[step]


def run_floor(scheme_id: str, x0: float, v0: float, h: float, k: float, m: float, n: int) -> tuple[float, float]:
    """(x, v) after n steps of the floor from (x0, v0)."""
    _, start, observe = FLOORS[scheme_id]
    single = _loops(scheme_id)[0]
    return observe(single(start(x0, v0, h, k, m), h, k, m, n), h, k, m)


def floor_timer(scheme_id: str, h: float, steps: int, batch: int = 1, k: float = 1.0, m: float = 1.0,
                x0: float = 1.0, v0: float = 0.0, clock=time.perf_counter):
    """``(warm-up seconds, once)`` as ``reference._compiled.step_timer``: ``once()`` times one
    call of ``steps`` steps of the floor (one spring in registers, or a batch of springs) and
    returns seconds per step."""
    _, start, _ = FLOORS[scheme_id]
    single, batch2, batch3 = _loops(scheme_id)
    s0 = start(x0, v0, h, k, m)
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
