"""Explicit Runge-Kutta schemes as a Butcher tableau (A, b, c, as ``scipy.integrate``'s
``RungeKutta`` declares them): one declaration gives the step, its force evaluations, its
stability limit on the spring, its recurrence on the damped oscillator and its floor (the
scheme's ``floor`` and ``amplification``, ``reference._scheme``).

On y = (x, v), y' = (v, a(x, v, t)), stage i is evaluated at
x_i = x + h sum_j A_ij v_j, v_i = v + h sum_j A_ij a_j, t + c_i h (stage 1 at (x, v, t)), and
x_{n+1} = x + h sum_j b_j v_j, v_{n+1} = v + h sum_j b_j a_j: one force evaluation a stage.

The step is generated as source (``step_source``), so it runs interpreted and is copied into the
kernel files like a hand-written step. Each weighted sum is written in one fixed form, so a
tableau's arithmetic is fixed by its entries: a single weight r as ``r h`` (``0.5 * h``, ``h``,
``h / 3.0``), several as their common factor 1/d times integer weights, summed left to right in
stage order (RK4's h/6 (v + 2 v2 + 2 v3 + v4)); ``c_i h`` likewise.
"""
from __future__ import annotations

import linecache
import math
from fractions import Fraction
from typing import Callable, Sequence

import numpy as np

from ._scheme import Floor, Scheme
from .kinds import EXPLICIT

Number = int | float | str | Fraction


def _fraction(x: Number) -> Fraction:
    return x if isinstance(x, Fraction) else Fraction(x)


class Tableau:
    """A Butcher tableau of an explicit scheme: ``A`` strictly lower triangular (s x s), ``b``
    and ``c`` of length s, entries exact (int, Fraction, or a string such as "1/6")."""

    def __init__(self, A: Sequence[Sequence[Number]], b: Sequence[Number], c: Sequence[Number]):
        self.A = tuple(tuple(_fraction(x) for x in row) for row in A)
        self.b = tuple(_fraction(x) for x in b)
        self.c = tuple(_fraction(x) for x in c)
        s = len(self.b)
        if len(self.A) != s or len(self.c) != s or any(len(row) != s for row in self.A):
            raise ValueError(f"a tableau of {s} stages needs A s x s and c of length s")
        if any(self.A[i][j] for i in range(s) for j in range(i, s)):
            raise ValueError("A is not strictly lower triangular: the scheme would be implicit")

    @property
    def stages(self) -> int:
        return len(self.b)

    # ------------------------------------------------------------------ the step as source
    def step_source(self, name: str, force: Callable[[str, str, str], str], params: str, state: str,
                    x: str = "q") -> str:
        """The step function's source: ``def name(params): state-line; ...; return (x_1, v_1)``,
        the force of stage i written by ``force(x_i, v_i, t_i)``."""
        lines = [f"def {name}({params}):", f"    {state}"]
        xs, vs, accs = [], [], []
        for i in range(self.stages):
            xi, vi = (x, "v") if i == 0 else (f"{x}{i + 1}", f"v{i + 1}")
            if i:
                lines.append(f"    {xi}, {vi} = {_plus(x, self.A[i][:i], xs)}, {_plus('v', self.A[i][:i], accs)}")
            ti = "t" if self.c[i] == 0 else f"t + {_scaled_h(self.c[i])}"
            ai = f"a{i + 1}"
            lines.append(f"    {ai} = {force(xi, vi, ti)}")
            xs.append(vi)
            accs.append(ai)
        lines.append(f"    return ({_plus(x, self.b, xs)}, {_plus('v', self.b, accs)})")
        return "\n".join(lines) + "\n"

    def floor_step(self, name: str) -> Callable:
        """The floor's step (``reference._scheme.Floor``): the stages written out for the unit spring,
        a = (-k x)/m at each stage, in the generated step's order of operations. It checks the kernel
        files and the scene's force, not the tableau, which its order conditions check."""
        source = self.step_source(name, lambda x, v, t: f"-k * {x} / m", "s, h, k, m", "x, v = s", x="x")
        namespace: dict = {}
        exec(source, namespace)
        return namespace[name]

    # ------------------------------------------------------------------ what it derives
    def stability_coefficients(self) -> tuple[Fraction, ...]:
        """gamma_k of the stability polynomial R(z) = sum_k gamma_k z^k: gamma_0 = 1,
        gamma_k = b^T A^(k-1) 1 (what one step does to y' = lambda y, z = h lambda)."""
        s = self.stages
        vec = [Fraction(1)] * s
        out = [Fraction(1)]
        for _ in range(s):
            out.append(sum((bi * vi for bi, vi in zip(self.b, vec)), Fraction(0)))
            vec = [sum((self.A[i][j] * vec[j] for j in range(s)), Fraction(0)) for i in range(s)]
        while len(out) > 1 and out[-1] == 0:
            out.pop()
        return tuple(out)

    def order_conditions(self, order: int) -> bool:
        """Whether the tableau meets the order conditions up to ``order`` (at most 4; beyond it the
        rooted trees are not written out here) for a general (non-autonomous) force: the row sums
        of A are c, and the elementary weights of every tree of order <= ``order`` are 1/gamma."""
        if order > 4:
            raise ValueError("order conditions are written out to order 4")
        s, A, b, c = self.stages, self.A, self.b, self.c
        if any(sum(A[i]) != c[i] for i in range(s)):
            return False
        Ac = [sum(A[i][j] * c[j] for j in range(s)) for i in range(s)]
        AAc = [sum(A[i][j] * Ac[j] for j in range(s)) for i in range(s)]
        Ac2 = [sum(A[i][j] * c[j] ** 2 for j in range(s)) for i in range(s)]
        conds = [(sum(b), 1),
                 (sum(b[i] * c[i] for i in range(s)), Fraction(1, 2)),
                 (sum(b[i] * c[i] ** 2 for i in range(s)), Fraction(1, 3)),
                 (sum(b[i] * Ac[i] for i in range(s)), Fraction(1, 6)),
                 (sum(b[i] * c[i] ** 3 for i in range(s)), Fraction(1, 4)),
                 (sum(b[i] * c[i] * Ac[i] for i in range(s)), Fraction(1, 8)),
                 (sum(b[i] * Ac2[i] for i in range(s)), Fraction(1, 12)),
                 (sum(b[i] * AAc[i] for i in range(s)), Fraction(1, 24))]
        needed = {1: 1, 2: 2, 3: 4, 4: 8}[order] if order >= 1 else 0
        return all(value == target for value, target in conds[:needed])

    def homega_max(self) -> float | None:
        """The largest y = h omega with |R(i y')| <= 1 for every y' in (0, y]: the stability limit on
        the undamped spring (eigenvalues +-i omega). None: |R(i y)| > 1 for every small y > 0
        (unstable for every h); inf: never. Exact on the polynomial |R(i y)|^2 - 1, its root
        bisected in rationals until the two ends round to one float."""
        gamma = self.stability_coefficients()
        re = [Fraction(0)] * len(gamma)
        im = [Fraction(0)] * len(gamma)
        for k, g in enumerate(gamma):  # i^k: 1, i, -1, -i
            (re if k % 2 == 0 else im)[k] = g * (-1 if k % 4 in (2, 3) else 1)
        P = _poly_add(_poly_mul(re, re), _poly_mul(im, im))
        P[0] -= 1
        while P and P[-1] == 0:
            P.pop()
        if not P:
            return math.inf
        lowest = next(x for x in P if x != 0)
        if lowest > 0:
            return None
        roots = sorted(r.real for r in np.roots([float(x) for x in reversed(P)])
                       if abs(r.imag) <= 1e-9 * max(1.0, abs(r)) and r.real > 0)
        for r in roots:  # the first root past which P turns positive
            lo, hi = Fraction(r * (1 - 1e-6)), Fraction(r * (1 + 1e-6))
            if _poly_eval(P, lo) <= 0 < _poly_eval(P, hi):
                while float(lo) != float(hi):
                    mid = (lo + hi) / 2
                    lo, hi = (mid, hi) if _poly_eval(P, mid) <= 0 else (lo, mid)
                return float(lo)
        return math.inf

    def damping_matrix(self, y: float, zeta: float) -> np.ndarray:
        """One step as the matrix R(y J) on (x, v) of x'' = -x - 2 zeta x' (J its 2x2 matrix): I + a
        + gamma_2 a^2 + ..., a = y J, each power one more product on the right, a term 1/k written
        as a division (RK4's I + a + a@a/2 + a@a@a/6 + a@a@a@a/24)."""
        gamma = self.stability_coefficients()
        a = y * np.array([[0.0, 1.0], [-1.0, -2.0 * zeta]])
        m = np.eye(2) + a
        power = a
        for g in gamma[2:]:
            power = power @ a
            if g:
                m = m + (power / float(1 / g) if g.numerator == 1 else float(g) * power)
        return m


def _poly_mul(p, q):
    out = [Fraction(0)] * (len(p) + len(q) - 1)
    for i, x in enumerate(p):
        for j, y in enumerate(q):
            out[i + j] += x * y
    return out


def _poly_add(p, q):
    n = max(len(p), len(q))
    return [(p[i] if i < len(p) else 0) + (q[i] if i < len(q) else 0) for i in range(n)]


def _poly_eval(p, x):
    out = Fraction(0)
    for coef in reversed(p):
        out = out * x + coef
    return out


def _scaled_h(r: Fraction) -> str:
    """r h as written: ``h``, ``0.5 * h`` (r = 1/2^k: an exact product), ``h / 3.0`` (r = 1/n),
    else ``r * h``."""
    if r == 1:
        return "h"
    if r.numerator == 1 and r.denominator & (r.denominator - 1) == 0:
        return f"{float(r)!r} * h"
    if r.numerator == 1:
        return f"h / {float(r.denominator)!r}"
    return f"{float(r)!r} * h"


def _plus(base: str, weights: Sequence[Fraction], names: Sequence[str]) -> str:
    """``base + (h sum_j w_j names_j)`` in the tableau's one written form (module docstring)."""
    terms = [(w, n) for w, n in zip(weights, names) if w != 0]
    if not terms:
        return base
    if len(terms) == 1:
        w, n = terms[0]
        return f"{base} + {_scaled_h(w)} * {n}"
    d = math.lcm(*(w.denominator for w, _ in terms))
    parts = [n if w * d == 1 else f"{float(w * d)!r} * {n}" for w, n in terms]
    return f"{base} + {_scaled_h(Fraction(1, d))} * ({' + '.join(parts)})"


def _compile(source: str, name: str, filename: str, module: str) -> Callable:
    """The function ``name`` of ``source``, its source kept in ``linecache`` under ``filename``
    (as the interpreter keeps a file's), so that ``inspect.getsource`` finds it and the kernel
    files copy it as they copy a hand-written step."""
    linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
    namespace = {"__name__": module}
    exec(compile(source, filename, "exec"), namespace)
    return namespace[name]


def tableau_scheme(id: str, A, b, c, *, order: int, energy_claim: str, doc: str,
                   module: str = "reference.tableau", **declared) -> Scheme:
    """The explicit scheme of a tableau: its step generated (``Tableau.step_source``), its force
    evaluations the stages, its stability limit derived (``Tableau.homega_max``), its floor
    (``Tableau.floor_step``) and its recurrence on the damped oscillator (``Tableau.damping_matrix``),
    never symplectic (no explicit Runge-Kutta scheme is); ``order`` and ``energy_claim`` declared (a
    test checks the order against the tableau's order conditions); ``declared``: the rest of
    ``Scheme``'s declarations (``suites``, a closed-form ``damping_limit``)."""
    tab = Tableau(A, b, c)
    source = tab.step_source(id, lambda x, v, t: f"accel({x}, {v}, {t}, p)", "accel, state, t, h, p", "q, v = state")
    step = _compile(source, id, f"<tableau {module}.{id}>", module)
    step.__doc__ = doc
    return Scheme(id=id, step=step, order=order, force_evals=tab.stages, symplectic=False, kind=EXPLICIT,
                  energy_claim=energy_claim, homega_max=tab.homega_max(), doc=doc, tableau=tab,
                  floor=Floor(tab.floor_step(f"floor_{id}")), amplification=tab.damping_matrix, **declared)
