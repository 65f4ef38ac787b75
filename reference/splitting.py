"""Splitting schemes as data: a composition of drifts (x += c h v) and kicks (v += d h a(x, v, t)),
declared once as its sequence of coefficients (``Splitting``), as a tableau declares an explicit
Runge-Kutta scheme (``reference.tableau``). One declaration gives the step, its force evaluations,
its floor, its recurrence on the damped oscillator and its stability limit on the spring
(``splitting_scheme``).

A kick evaluates the force at the position and velocity it finds, at the time t + tau h, tau the
sum of the drifts before it. With ``fsal`` (first same as last: the sequence starts and ends with a
kick) the last kick's force is carried to the next step, whose first kick takes it instead of
evaluating it: one evaluation fewer a step, the state carried (x, v, a) as velocity Verlet's.

The step is generated as source (``Splitting.step_source``), so it runs interpreted and is copied
into the kernel files like a hand-written step. Its arithmetic is fixed by the declaration, in one
written form:

* each coefficient other than 1 is multiplied into h once, in order of first use, before the
  first update (``c1 = 0.5 * h``); a rational one as the tableau writes it (``0.5 * h``,
  ``h / 3.0``, ``r * h``), one with a constant as its value's float (``0.6756035959798289 * h``:
  the float of its expression over the declared constants, as the declaration writes it);
  a coefficient of 1 is ``h`` itself;
* a drift is ``q = q + c * v``, a kick ``v = v + d * accel(q, v, t_i, p)``; the last update is
  written in the return;
* a kick's time is ``t`` (tau = 0), ``t + h`` (tau = 1), ``t + c`` where tau h is one of the
  step's coefficients, ``t + h - c`` where (1 - tau) h is (the mirror of a symmetric splitting's
  earlier kick), else tau h as a rational coefficient is written.

Coefficients are exact: an int, a ``Fraction``, or a string expression of numbers and the names in
``constants`` (``"(1 - THETA)/2"``), linear in those names; the times and the consistency check
(the drifts and the kicks each sum to 1) are exact on them.
"""

from __future__ import annotations

import ast
import math
from fractions import Fraction
from functools import reduce
from collections.abc import Callable

import numpy as np

from ._scheme import Floor, Scheme
from .kinds import EXPLICIT
from .oscillator import drift as drift_matrix
from .oscillator import kick as kick_matrix
from .tableau import _compile, _first_crossing, _poly_add, _poly_mul, _scaled_h

DRIFT, KICK = "drift", "kick"


def start_with_force(accel, q, v, t, h, p):
    """The carried state of a first-same-as-last splitting: (q, v) and the force there."""
    return (q, v, accel(q, v, t, p))


def floor_start_with_force(x, v, h, k, m):
    return (x, v, -k * x / m)


# ---------------------------------------------------------------------- exact coefficients
def _linear(node: ast.AST, constants: dict) -> dict[str, Fraction]:
    """The exact value of an expression as a linear form: name -> rational weight ("" the number)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        return {"": Fraction(node.value)}
    if isinstance(node, ast.Name):
        if node.id not in constants:
            raise ValueError(f"coefficient names {node.id!r}, which is not among the declared constants")
        return {node.id: Fraction(1)}
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        inner = _linear(node.operand, constants)
        return inner if isinstance(node.op, ast.UAdd) else _scale(inner, Fraction(-1))
    if isinstance(node, ast.BinOp):
        a, b = _linear(node.left, constants), _linear(node.right, constants)
        if isinstance(node.op, ast.Add):
            return _add(a, b)
        if isinstance(node.op, ast.Sub):
            return _add(a, _scale(b, Fraction(-1)))
        if isinstance(node.op, ast.Mult) and (_rational(a) is not None or _rational(b) is not None):
            return _scale(b, _rational(a)) if _rational(a) is not None else _scale(a, _rational(b))
        if isinstance(node.op, ast.Div) and _rational(b):
            return _scale(a, 1 / _rational(b))
    raise ValueError(f"coefficient {ast.unparse(node)!r} is not linear in the declared constants")


def _add(a: dict, b: dict) -> dict:
    out = dict(a)
    for name, w in b.items():
        out[name] = out.get(name, Fraction(0)) + w
    return {name: w for name, w in out.items() if w != 0}


def _scale(a: dict, r: Fraction) -> dict:
    return {name: w * r for name, w in a.items() if w * r != 0}


def _rational(a: dict) -> Fraction | None:
    """The form's value where it names no constant, else None."""
    return None if set(a) - {""} else a.get("", Fraction(0))


class Coefficient:
    """One coefficient of a splitting: ``exact`` (a linear form, name -> weight, "" the number),
    ``value`` its float (the declared expression evaluated in floats) and ``times(h)``, the source
    of its product with ``h`` in the splitting's written form."""

    def __init__(self, declared, constants: dict):
        self.text = str(declared)
        if isinstance(declared, (int, Fraction)) and not isinstance(declared, bool):
            self.exact = {"": Fraction(declared)} if declared else {}
        else:
            tree = ast.parse(self.text, mode="eval").body
            self.exact = _linear(tree, constants)
        rational = _rational(self.exact)
        if rational is not None:
            self.value = float(rational)
        else:  # the float of the expression as declared, each operation rounded as Python rounds it
            self.value = float(
                eval(compile(ast.Expression(tree), "<coefficient>", "eval"), {"__builtins__": {}}, dict(constants))
            )
        self.key = tuple(sorted(self.exact.items()))

    @property
    def rational(self) -> Fraction | None:
        return _rational(self.exact)

    def times(self, h: str) -> str:
        r = self.rational
        if r is not None:
            return _scaled_h(r, h)
        return f"{self.value!r} * {h}"

    def __repr__(self) -> str:
        return self.text


# ---------------------------------------------------------------------- the splitting
class Splitting:
    """A splitting: ``ops`` in the order they act, each ``("drift", c)`` (x += c h v) or
    ``("kick", d)`` (v += d h a); ``fsal``: the last kick's force carried to the next step's first
    kick (the module docstring); ``constants``: the names a coefficient's
    expression may use, with their float values."""

    def __init__(self, *ops: tuple[str, object], fsal: bool = False, constants: dict | None = None):
        self.constants = dict(constants or {})
        if not ops:
            raise ValueError("a splitting needs at least one drift and one kick")
        self.ops = []
        for op in ops:
            if len(op) != 2 or op[0] not in (DRIFT, KICK):
                raise ValueError(f"each step of a splitting is ('drift', c) or ('kick', d), not {op!r}")
            c = Coefficient(op[1], self.constants)
            if not c.exact:
                raise ValueError(f"a {op[0]} of coefficient {op[1]!r} is no update")
            self.ops.append((op[0], c))
        self.ops = tuple(self.ops)
        self.fsal = bool(fsal)
        for what in (DRIFT, KICK):  # consistency: first order needs the drifts and the kicks each to make one step
            total = reduce(_add, (c.exact for kind, c in self.ops if kind == what), {})
            if total != {"": Fraction(1)}:
                raise ValueError(f"the {what}s of a splitting must sum to 1 (they sum to {total or 0})")
        if self.fsal and not (self.ops[0][0] == KICK and self.ops[-1][0] == KICK and len(self.ops) > 2):
            raise ValueError("a first-same-as-last splitting starts and ends with a kick, a drift between")
        # The coefficient lines: each distinct coefficient other than 1, named in order of first use.
        self.names: dict[tuple, str] = {}
        for _, c in self.ops:
            if c.rational != 1 and c.key not in self.names:
                self.names[c.key] = f"c{len(self.names) + 1}"
        self._first = {}
        for _, c in self.ops:
            self._first.setdefault(c.key, c)

    @property
    def kicks(self) -> int:
        return sum(kind == KICK for kind, _ in self.ops)

    @property
    def force_evals(self) -> int:
        """Force evaluations a step: one a kick, the carried one not counted (``fsal``)."""
        return self.kicks - (1 if self.fsal else 0)

    @property
    def carries(self) -> tuple[str, ...]:
        return ("q", "v", "a") if self.fsal else ("q", "v")

    # ------------------------------------------------------------------ the step as source
    def _h(self, c: Coefficient) -> str:
        return self.names.get(c.key, "h")

    def _time(self, tau: dict) -> str:
        """Source of t + tau h (module docstring's written form)."""
        if not tau:
            return "t"
        if tau == {"": Fraction(1)}:
            return "t + h"
        if tuple(sorted(tau.items())) in self.names:
            return f"t + {self.names[tuple(sorted(tau.items()))]}"
        mirror = tuple(sorted(_add({"": Fraction(1)}, _scale(tau, Fraction(-1))).items()))
        if mirror in self.names:
            return f"t + h - {self.names[mirror]}"
        r = _rational(tau)
        if r is not None:
            return f"t + {_scaled_h(r)}"
        value = sum(float(w) * (1.0 if name == "" else float(self.constants[name])) for name, w in tau.items())
        return f"t + {value!r} * h"

    def step_source(
        self, name: str, force: Callable[[str, str, str], str], params: str, state: str, x: str = "q"
    ) -> str:
        """The step function's source: ``def name(params): state-line; coefficient lines; updates;
        return (x_1, v_1[, a_1])``, the force of a kick written by ``force(x, v, t)``."""
        lines = [f"def {name}({params}):", f"    {state}"]
        for key, cname in self.names.items():
            lines.append(f"    {cname} = {self._first[key].times('h')}")
        tau: dict = {}
        last = len(self.ops) - 1
        for i, (kind, c) in enumerate(self.ops):
            if kind == DRIFT:
                update = f"{x} + {self._h(c)} * v"
                if i == last:
                    lines.append(f"    return ({update}, v)")
                else:
                    lines.append(f"    {x} = {update}")
                tau = _add(tau, c.exact)
                continue
            if self.fsal and i == 0:
                lines.append(f"    v = v + {self._h(c)} * a")
            elif self.fsal and i == last:
                lines.append(f"    a = {force(x, 'v', self._time(tau))}")
                lines.append(f"    return ({x}, v + {self._h(c)} * a, a)")
            elif i == last:
                lines.append(f"    return ({x}, v + {self._h(c)} * {force(x, 'v', self._time(tau))})")
            else:
                lines.append(f"    v = v + {self._h(c)} * {force(x, 'v', self._time(tau))}")
        return "\n".join(lines) + "\n"

    def floor(self, name: str, module: str = __name__) -> Floor:
        """The floor (``reference._scheme.Floor``): the step written for the unit spring, a = (-k x)/m
        read from the floor's arguments k and m at each kick, in the generated step's order of
        operations (the kernel on the spring computes its bits)."""
        state = "x, v, a = s" if self.fsal else "x, v = s"
        source = self.step_source(name, lambda x, v, t: f"(-k * {x} / m)", "s, h, k, m", state, x="x")
        step = _compile(source, name, f"<splitting {module}.{name}>", module)
        return Floor(step, floor_start_with_force) if self.fsal else Floor(step)

    # ------------------------------------------------------------------ what it derives
    def amplification(self, y: float, zeta: float) -> np.ndarray:
        """One step on the damped oscillator x'' = -x - 2 zeta x' at y = h omega
        (``reference.oscillator``), on the state the step carries: the product of the drifts' and
        the kicks' matrices, the last on the left; with ``fsal``, on (x, v, a), the first kick
        taking the carried a and the last carrying its own."""
        factors = {c.key: eval(c.times("y"), {"__builtins__": {}}, {"y": y}) for _, c in self.ops}
        if not self.fsal:
            mats = [
                drift_matrix(factors[c.key]) if kind == DRIFT else kick_matrix(factors[c.key], zeta)
                for kind, c in self.ops
            ]
            return reduce(np.matmul, reversed(mats))
        # Each of x, v, a as a row: its linear map of the carried (x, v, a).
        x, v, a = np.eye(3)
        for i, (kind, c) in enumerate(self.ops):
            f = factors[c.key]
            if kind == DRIFT:
                x = x + f * v
            else:
                if i:
                    a = -x - 2.0 * zeta * v
                v = v + f * a
        return np.vstack([x, v, a])

    def spring_polynomial(self) -> list:
        """|tr M(y)|^2 - 4 on the undamped spring (M the (x, v) map, det M = 1): the map is stable
        where it is <= 0. Exact (Fractions) where every coefficient is rational, else in floats."""
        exact = all(c.rational is not None for _, c in self.ops)
        one, zero = ([Fraction(1)], [Fraction(0)]) if exact else ([1.0], [0.0])
        M = [[one, zero], [zero, one]]
        for kind, c in self.ops:
            w = c.rational if exact else c.value
            op = [[one, [0, w]], [zero, one]] if kind == DRIFT else [[one, zero], [[0, -w], one]]
            M = [
                [_poly_add(_poly_mul(op[i][0], M[0][j]), _poly_mul(op[i][1], M[1][j])) for j in range(2)]
                for i in range(2)
            ]
        trace = _poly_add(M[0][0], M[1][1])
        P = _poly_mul(trace, trace)
        P[0] -= 4
        return P

    def homega_max(self) -> float | None:
        """The largest y = h omega at which every y' in (0, y] is stable on the undamped spring
        (None: unstable for every small y; inf: never), from ``spring_polynomial``."""
        return _first_crossing(self.spring_polynomial())


def splitting_scheme(
    id: str,
    splitting: Splitting,
    *,
    order: int,
    doc: str,
    energy_claim: str = "bounded",
    homega_max: float | None = None,
    module: str = __name__,
    **declared,
) -> Scheme:
    """The explicit scheme of a splitting: its step generated (``Splitting.step_source``), its force
    evaluations (``Splitting.force_evals``), the carried state and its start where ``fsal``, its
    floor (``Splitting.floor``), its recurrence on the damped oscillator (``Splitting.amplification``)
    and its stability limit on the spring (``Splitting.homega_max``); always symplectic (every
    drift and kick is), its energy bounded unless declared otherwise. ``order`` declared, and the
    order where the force depends on the velocity 1 where ``order`` is higher (a kick takes a(x, v)
    at the velocity before it, without a solve: the symmetry that made it higher is lost), unless
    declared. ``homega_max``: a declared value (a textbook's rounding, the claim the records hold)
    checked against the derived one to 1e-4; else the derived one. ``declared``: the rest of
    ``Scheme``'s declarations (``suites``, a closed-form ``damping_limit``)."""
    derived = splitting.homega_max()
    if homega_max is None:
        homega_max = derived
    elif derived is None or not math.isclose(homega_max, derived, rel_tol=1e-4):
        raise ValueError(f"{id}: declared stability limit {homega_max} is not the splitting's {derived}")
    state = "q, v, a = state" if splitting.fsal else "q, v = state"
    source = splitting.step_source(id, lambda x, v, t: f"accel({x}, {v}, {t}, p)", "accel, state, t, h, p", state)
    step = _compile(source, id, f"<splitting {module}.{id}>", module)
    step.__doc__ = doc
    declared.setdefault("order_velocity_dependent", 1 if order > 1 else None)
    if splitting.fsal:
        declared.setdefault("start", start_with_force)
    return Scheme(
        id=id,
        step=step,
        order=order,
        force_evals=splitting.force_evals,
        symplectic=True,
        kind=EXPLICIT,
        energy_claim=energy_claim,
        homega_max=homega_max,
        doc=doc,
        carries=splitting.carries,
        splitting=splitting,
        floor=splitting.floor(f"floor_{id}", module),
        amplification=splitting.amplification,
        **declared,
    )
