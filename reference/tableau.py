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

A tableau may carry an embedded row ``b_hat``, the weights of a lower-order solution: the step with
its error estimate (``error_step``, the same form) and a step-size controller on it
(``error_controlled``) follow; the fixed step never reads it.
"""

from __future__ import annotations

import linecache
import math
from fractions import Fraction
from collections.abc import Callable, Sequence

import numpy as np

from ._scheme import Floor, Scheme
from .kinds import EXPLICIT

Number = int | float | str | Fraction


def _fraction(x: Number) -> Fraction:
    return x if isinstance(x, Fraction) else Fraction(x)


class Tableau:
    """A Butcher tableau of an explicit scheme: ``A`` strictly lower triangular (s x s), ``b``
    and ``c`` of length s, entries exact (int, Fraction, or a string such as "1/6")."""

    def __init__(
        self,
        A: Sequence[Sequence[Number]],
        b: Sequence[Number],
        c: Sequence[Number],
        b_hat: Sequence[Number] | None = None,
    ):
        self.A = tuple(tuple(_fraction(x) for x in row) for row in A)
        self.b = tuple(_fraction(x) for x in b)
        self.c = tuple(_fraction(x) for x in c)
        s = len(self.b)
        if len(self.A) != s or len(self.c) != s or any(len(row) != s for row in self.A):
            raise ValueError(f"a tableau of {s} stages needs A s x s and c of length s")
        if any(self.A[i][j] for i in range(s) for j in range(i, s)):
            raise ValueError("A is not strictly lower triangular: the scheme would be implicit")
        #: The embedded row (``error_step``): weights of a lower-order solution over the s stages, or
        #: over s + 1 where its last stage is the force at the new state (first same as last).
        self.b_hat = None if b_hat is None else tuple(_fraction(x) for x in b_hat)
        if self.b_hat is not None and len(self.b_hat) not in (s, s + 1):
            raise ValueError(f"the embedded row of a tableau of {s} stages has {s} or {s + 1} weights")

    @property
    def stages(self) -> int:
        return len(self.b)

    # ------------------------------------------------------------------ the step as source
    def step_source(
        self, name: str, force: Callable[[str, str, str], str], params: str, state: str, x: str = "q"
    ) -> str:
        """The step function's source: ``def name(params): state-line; ...; return (x_1, v_1)``,
        the force of stage i written by ``force(x_i, v_i, t_i)``."""
        lines, xs, accs = self._stages(name, force, params, state, x)
        lines.append(f"    return ({_plus(x, self.b, xs)}, {_plus('v', self.b, accs)})")
        return "\n".join(lines) + "\n"

    def _stages(self, name: str, force: Callable[[str, str, str], str], params: str, state: str, x: str):
        """(the lines through the last stage's force, the stages' velocities, their forces)."""
        lines = [f"def {name}({params}):", f"    {state}"]
        xs, accs = [], []
        for i in range(self.stages):
            xi, vi = (x, "v") if i == 0 else (f"{x}{i + 1}", f"v{i + 1}")
            if i:
                lines.append(f"    {xi}, {vi} = {_plus(x, self.A[i][:i], xs)}, {_plus('v', self.A[i][:i], accs)}")
            ti = "t" if self.c[i] == 0 else f"t + {_scaled_h(self.c[i])}"
            ai = f"a{i + 1}"
            lines.append(f"    {ai} = {force(xi, vi, ti)}")
            xs.append(vi)
            accs.append(ai)
        return lines, xs, accs

    # ------------------------------------------------------------------ the embedded error estimate
    def error_step_source(
        self, name: str, force: Callable[[str, str, str], str], params: str, state: str, x: str = "q"
    ) -> str:
        """The step with its embedded error estimate: ``return (x_1, v_1, ex, ev)``, (x_1, v_1) the
        step's own (``step_source``'s bits) and (ex, ev) = (x_1, v_1) - (x^_1, v^_1) =
        h sum_i (b_i - b^_i) (v_i, a_i), the first-same-as-last stage's term, -h b^_{s+1} (v_1,
        a(x_1, v_1, t + h)), where the row has one (evaluated once more: not carried to the next step)."""
        if self.b_hat is None:
            raise ValueError("the tableau declares no embedded row (b_hat)")
        lines, xs, accs = self._stages(name, force, params, state, x)
        lines.append(f"    {x}_1, v_1 = {_plus(x, self.b, xs)}, {_plus('v', self.b, accs)}")
        weights = [bi - bh for bi, bh in zip(self.b, self.b_hat)]
        if len(self.b_hat) > self.stages:
            lines.append(f"    a_1 = {force(f'{x}_1', 'v_1', 't + h')}")
            weights.append(-self.b_hat[-1])
            xs, accs = xs + ["v_1"], accs + ["a_1"]
        lines.append(f"    return ({x}_1, v_1, {_weighted(weights, xs)}, {_weighted(weights, accs)})")
        return "\n".join(lines) + "\n"

    @property
    def error_evals(self) -> int:
        """Force evaluations of ``error_step``: the stages, and the first-same-as-last one where the row has it."""
        return self.stages + (len(self.b_hat) > self.stages if self.b_hat is not None else 0)

    def embedded_order(self) -> int:
        """The order of the embedded solution (its order conditions, written out to 4): the estimate
        is O(h^(q+1)), q this order, as the controller takes it."""
        if self.b_hat is None:
            raise ValueError("the tableau declares no embedded row (b_hat)")
        A, c = [list(row) for row in self.A], list(self.c)
        if len(self.b_hat) > self.stages:  # the last stage is the force at the new state: A's row b, c = 1
            A = [row + [Fraction(0)] for row in A] + [list(self.b) + [Fraction(0)]]
            c = c + [Fraction(1)]
        embedded = Tableau(A, self.b_hat, c)
        return max((q for q in range(1, 5) if embedded.order_conditions(q)), default=0)

    def floor_step(self, name: str) -> Callable:
        """The floor's step (``reference._scheme.Floor``): the stages written out for the unit spring,
        a = (-k x)/m at each stage, in the generated step's order of operations. It checks the kernel
        files and the scene's force, not the tableau, which its order conditions check."""
        source = self.step_source(name, lambda x, v, t: f"-k * {x} / m", "s, h, k, m", "x, v = s", x="x")
        return _compile(source, name, f"<tableau floor {name}>", __name__)

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
        conds = [
            (sum(b), 1),
            (sum(b[i] * c[i] for i in range(s)), Fraction(1, 2)),
            (sum(b[i] * c[i] ** 2 for i in range(s)), Fraction(1, 3)),
            (sum(b[i] * Ac[i] for i in range(s)), Fraction(1, 6)),
            (sum(b[i] * c[i] ** 3 for i in range(s)), Fraction(1, 4)),
            (sum(b[i] * c[i] * Ac[i] for i in range(s)), Fraction(1, 8)),
            (sum(b[i] * Ac2[i] for i in range(s)), Fraction(1, 12)),
            (sum(b[i] * AAc[i] for i in range(s)), Fraction(1, 24)),
        ]
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
        return _first_crossing(P)

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


def _first_crossing(P) -> float | None:
    """For P(y) (coefficients lowest first, P(0) = 0), the largest y with P <= 0 on all of (0, y]:
    None where P > 0 just above 0, inf where P never turns positive. Its root is found by
    ``np.roots`` and bisected until the two ends round to one float, in the coefficients' own
    arithmetic (exact on Fractions, else to adjacent floats)."""
    P = list(P)
    while P and P[-1] == 0:
        P.pop()
    if not P:
        return math.inf
    lowest = next(x for x in P if x != 0)
    if lowest > 0:
        return None
    roots = sorted(
        r.real
        for r in np.roots([float(x) for x in reversed(P)])
        if abs(r.imag) <= 1e-9 * max(1.0, abs(r)) and r.real > 0
    )
    exact = all(isinstance(x, (int, Fraction)) for x in P)
    for r in roots:  # the first root past which P turns positive
        lo, hi = (Fraction(r * (1 - 1e-6)), Fraction(r * (1 + 1e-6))) if exact else (r * (1 - 1e-6), r * (1 + 1e-6))
        if _poly_eval(P, lo) <= 0 < _poly_eval(P, hi):
            while float(lo) != float(hi):
                mid = (lo + hi) / 2
                if not exact and mid in (lo, hi):  # in floats: the two ends are adjacent floats
                    break
                lo, hi = (mid, hi) if _poly_eval(P, mid) <= 0 else (lo, mid)
            return float(lo)
    return math.inf


def _scaled_h(r: Fraction, h: str = "h") -> str:
    """r h as written: ``h``, ``0.5 * h`` (r = 1/2^k: an exact product), ``h / 3.0`` (r = 1/n),
    else ``r * h`` (``h``: the name multiplied)."""
    if r == 1:
        return h
    if r.numerator == 1 and r.denominator & (r.denominator - 1) == 0:
        return f"{float(r)!r} * {h}"
    if r.numerator == 1:
        return f"{h} / {float(r.denominator)!r}"
    return f"{float(r)!r} * {h}"


def _plus(base: str, weights: Sequence[Fraction], names: Sequence[str]) -> str:
    """``base + (h sum_j w_j names_j)`` in the tableau's one written form (module docstring)."""
    if not any(w != 0 for w in weights):
        return base
    return f"{base} + {_weighted(weights, names)}"


def _weighted(weights: Sequence[Fraction], names: Sequence[str]) -> str:
    """``h sum_j w_j names_j`` in the tableau's one written form (module docstring); ``0.0 * h`` where
    every weight is 0."""
    terms = [(w, n) for w, n in zip(weights, names) if w != 0]
    if not terms:
        return "0.0 * h"
    if len(terms) == 1:
        w, n = terms[0]
        return f"{_scaled_h(w)} * {n}"
    d = math.lcm(*(w.denominator for w, _ in terms))
    parts = [n if w * d == 1 else f"{float(w * d)!r} * {n}" for w, n in terms]
    return f"{_scaled_h(Fraction(1, d))} * ({' + '.join(parts)})"


def _compile(source: str, name: str, filename: str, module: str, namespace: dict | None = None) -> Callable:
    """The function ``name`` of ``source``, its source kept in ``linecache`` under ``filename``
    (as the interpreter keeps a file's), so that ``inspect.getsource`` finds it and the kernel
    files copy it as they copy a hand-written step; ``namespace``: the globals it reads, if any."""
    linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
    namespace = {**(namespace or {}), "__name__": module}
    exec(compile(source, filename, "exec"), namespace)
    return namespace[name]


def tableau_scheme(
    id: str,
    A,
    b,
    c,
    *,
    order: int,
    energy_claim: str,
    doc: str,
    module: str = "reference.tableau",
    b_hat=None,
    **declared,
) -> Scheme:
    """The explicit scheme of a tableau: its step generated (``Tableau.step_source``), its force
    evaluations the stages, its stability limit derived (``Tableau.homega_max``), its floor
    (``Tableau.floor_step``) and its recurrence on the damped oscillator (``Tableau.damping_matrix``),
    never symplectic (no explicit Runge-Kutta scheme is); ``order`` and ``energy_claim`` declared (a
    test checks the order against the tableau's order conditions); ``declared``: the rest of
    ``Scheme``'s declarations (``suites``, a closed-form ``damping_limit``); ``b_hat``: the tableau's
    embedded row, where it has one (``error_controlled``; the fixed step never reads it)."""
    tab = Tableau(A, b, c, b_hat)
    source = tab.step_source(id, lambda x, v, t: f"accel({x}, {v}, {t}, p)", "accel, state, t, h, p", "q, v = state")
    step = _compile(source, id, f"<tableau {module}.{id}>", module)
    step.__doc__ = doc
    return Scheme(
        id=id,
        step=step,
        order=order,
        force_evals=tab.stages,
        symplectic=False,
        kind=EXPLICIT,
        energy_claim=energy_claim,
        homega_max=tab.homega_max(),
        doc=doc,
        tableau=tab,
        floor=Floor(tab.floor_step(f"floor_{id}")),
        amplification=tab.damping_matrix,
        **declared,
    )


# ---------------------------------------------------------------------- the step-size controller
#: The controller's safety factor and the bounds on one step's change of h (Hairer, Norsett and
#: Wanner I, II.4: 0.9, 0.2, 5; no growth right after a rejected step).
SAFETY, SHRINK_MOST, GROW_MOST = 0.9, 0.2, 5.0


def error_step(tab: Tableau, name: str = "error_step") -> Callable:
    """``error_step(accel, state, t, h, p) -> (q_1, v_1, eq, ev)`` of the tableau (``error_step_source``),
    generated once per tableau."""
    if getattr(tab, "_error_step", None) is None:
        source = tab.error_step_source(
            name, lambda x, v, t: f"accel({x}, {v}, {t}, p)", "accel, state, t, h, p", "q, v = state"
        )
        tab._error_step = _compile(source, name, f"<tableau error step {name} {id(tab)}>", __name__)
    return tab._error_step


def error_controlled(
    scheme: Scheme,
    scene,
    t_end: float,
    *,
    rtol: float,
    atol: float | None = None,
    h0: float | None = None,
    max_steps: int = 1_000_000,
) -> dict:
    """The scene's state at ``t_end`` from its initial state, the step chosen by the tableau's embedded
    error estimate (``scheme.tableau.b_hat``): a step is accepted where the estimate's RMS over (q, v),
    each entry scaled by atol + rtol max(|y_n|, |y_n+1|), is at most 1, and the next h is
    h min(GROW_MOST, max(SHRINK_MOST, SAFETY err^(-1/(q+1)))), q the embedded order; the last step
    ends at t_end. ``atol`` defaults to ``rtol``; ``h0`` to t_end / 100. Returns ``{"t", "q", "v"}``
    (kernel layout, (ndof, 1)) with the steps accepted and rejected and the force evaluations."""
    tab = scheme.tableau
    if tab is None or tab.b_hat is None:
        raise ValueError(f"ref:{scheme.id} declares no embedded row to control its step with")
    step, exponent = error_step(tab, f"error_step_{scheme.id}"), -1.0 / (tab.embedded_order() + 1)
    atol = rtol if atol is None else atol
    q0, v0 = scene.batch_state(1)
    q = np.ascontiguousarray(np.atleast_2d(q0).T, dtype=np.float64)
    v = np.ascontiguousarray(np.atleast_2d(v0).T, dtype=np.float64)
    t, h, p = 0.0, (t_end / 100.0 if h0 is None else h0), scene.pvec
    accepted = rejected = 0
    grow = GROW_MOST
    while t < t_end:
        if accepted + rejected >= max_steps:
            raise ValueError(f"ref:{scheme.id}: no step to {t_end} within {max_steps} tries (reached t = {t})")
        last = h >= t_end - t
        h = t_end - t if last else h
        q1, v1, eq, ev = step(scene.accel, (q, v), t, h, p)
        scale_q = atol + rtol * np.maximum(np.abs(q), np.abs(q1))
        scale_v = atol + rtol * np.maximum(np.abs(v), np.abs(v1))
        err = math.sqrt((np.sum((eq / scale_q) ** 2) + np.sum((ev / scale_v) ** 2)) / (eq.size + ev.size))
        if err <= 1.0:
            t, q, v = (t_end if last else t + h), q1, v1
            accepted += 1
            h *= min(grow, SAFETY * err**exponent) if err > 0.0 else grow
            grow = GROW_MOST
        else:
            rejected += 1
            h *= max(SHRINK_MOST, SAFETY * err**exponent)
            grow = 1.0
    return {
        "t": t,
        "q": q,
        "v": v,
        "accepted": accepted,
        "rejected": rejected,
        "force_evals": (accepted + rejected) * tab.error_evals,
    }
