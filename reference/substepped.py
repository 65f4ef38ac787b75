"""A scheme taken n times at h/n, as a scheme of its own: ``substepped(scheme, n, id=...)``.

Its step is generated as source (so it runs interpreted and is copied into the kernel files like a
hand-written step): the scheme's own step's statements, copied into a loop of n substeps, with
h/n for h (written once, as a tableau writes a coefficient: ``h_sub = 0.5 * h``, ``h / 3.0``).
Substep j starts at ``t_sub = t + j h_sub`` and ends at ``t_end = t + (j + 1) h_sub``, both from
the step's t (not summed substep by substep, so the last ends at t + h where n h_sub is h: n a power
of 2); the copied step's t is ``t_sub`` and its end ``t + h`` is ``t_end``. Its start, observe and
floor are the scheme's where they do not read h, else the same statements with h/n for h; its
floor steps the scheme's floor n times at h/n alike.

What follows of it: n times the force evaluations and the stability limit (on the spring and,
``damping_limit``, on the damped spring: the scheme is stable at y = h omega where the scheme is
at y/n), the n-th power of the recurrence at y/n, and the rest of the scheme's claims as they
are (its order, symplecticity, energy behaviour, kind and options).
"""

from __future__ import annotations

import ast
import inspect
import textwrap
from fractions import Fraction
from collections.abc import Callable

from ._scheme import Floor, Scheme
from .tableau import _compile, _scaled_h

#: The names the generated source binds, which the copied functions must not use.
_OWN = ("h_sub", "t_sub", "t_end", "sub")


def _body(fn: Callable) -> tuple[ast.FunctionDef, list[ast.stmt]]:
    """The function's tree and its statements (its docstring dropped). Raises ValueError where
    its source cannot be read or copied into a loop (a return before its last statement)."""
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(fn))).body[0]
    except (OSError, TypeError) as exc:
        raise ValueError(f"substepped needs the source of {fn.__qualname__}: {exc}") from None
    if not isinstance(tree, ast.FunctionDef):
        raise ValueError(f"{fn.__qualname__} is not a plain function")
    body = tree.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
        body = body[1:]
    returns = [n for stmt in body for n in ast.walk(stmt) if isinstance(n, ast.Return)]
    if not body or not isinstance(body[-1], ast.Return) or len(returns) != 1 or body[-1].value is None:
        raise ValueError(f"{fn.__qualname__} must end in its one return of a value to be substepped")
    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} | {a.arg for a in tree.args.args}
    if names & set(_OWN) or any(isinstance(n, (ast.FunctionDef, ast.Lambda)) for stmt in body for n in ast.walk(stmt)):
        raise ValueError(f"{fn.__qualname__} binds one of {_OWN} or defines a function: it cannot be substepped")
    return tree, body


class _Substep(ast.NodeTransformer):
    """h -> h_sub; where ``t`` is given, t + h -> t_end and t -> t_sub."""

    def __init__(self, h: str, t: str | None):
        self.h, self.t = h, t

    def visit_BinOp(self, node):
        if (
            self.t
            and isinstance(node.op, ast.Add)
            and isinstance(node.left, ast.Name)
            and node.left.id == self.t
            and isinstance(node.right, ast.Name)
            and node.right.id == self.h
        ):
            return ast.copy_location(ast.Name("t_end", ast.Load()), node)
        return self.generic_visit(node)

    def visit_Name(self, node):
        if node.id in (self.h, self.t):
            if not isinstance(node.ctx, ast.Load):
                raise ValueError(f"a substepped function assigns to its {node.id}")
            return ast.copy_location(ast.Name({self.h: "h_sub", self.t: "t_sub"}[node.id], ast.Load()), node)
        return node


def _rewritten(
    fn: Callable, name: str, n: int, h_at: int, t_at: int | None, state_at: int | None, module: str, what: str
) -> Callable:
    """``fn`` as ``name`` with h/n for its h (parameter ``h_at``); with ``state_at``, its statements
    in a loop of n substeps carrying the parameter ``state_at`` from one to the next (the return's
    value assigned to it), its time (parameter ``t_at``) each substep's."""
    tree, body = _body(fn)
    params = [a.arg for a in tree.args.args]
    h, t = params[h_at], params[t_at] if t_at is not None else None
    stmts = [_Substep(h, t if state_at is not None else None).visit(stmt) for stmt in body]
    text = [ast.unparse(ast.fix_missing_locations(stmt)) for stmt in stmts]
    lines = [f"def {name}({', '.join(params)}):", f"    h_sub = {_scaled_h(Fraction(1, n), h)}"]
    if state_at is None:
        lines += [textwrap.indent(s, "    ") for s in text]
    else:
        state = params[state_at]
        used = {n_.id for stmt in stmts for n_ in ast.walk(stmt) if isinstance(n_, ast.Name)}
        lines.append(f"    for sub in range({n}):")
        if "t_sub" in used:
            lines.append(f"        t_sub = {t} + sub * h_sub")
        if "t_end" in used:
            lines.append(f"        t_end = {t} + (sub + 1) * h_sub")
        lines += [textwrap.indent(s, "        ") for s in text[:-1]]
        lines.append(f"        {state} = {ast.unparse(stmts[-1].value)}")
        lines.append(f"    return {state}")
    source = "\n".join(lines) + "\n"
    return _compile(source, name, f"<substepped {module}.{name} {what}>", module, fn.__globals__)


def _reads(fn: Callable, at: int) -> bool:
    """Whether ``fn`` reads its parameter ``at`` (a default start or observe does not read h)."""
    tree, _ = _body(fn)
    name = tree.args.args[at].arg
    return any(isinstance(n, ast.Name) and n.id == name for n in ast.walk(tree))


def substepped(scheme: Scheme, n: int, *, id: str, doc: str, module: str = __name__, **declared) -> Scheme:
    """``scheme`` as n steps of h/n a step (module docstring): the step, start, observe, floor,
    recurrence and claims it follows with; ``declared``: what it declares itself (``suites``) or
    declares otherwise than it follows."""
    if not isinstance(n, int) or n < 2:
        raise ValueError(f"substepped takes n >= 2 substeps, not {n!r}")
    step = _rewritten(scheme.step, id, n, -2, -3, -4, module, "step")
    step.__doc__ = doc
    start = (
        scheme.start
        if not _reads(scheme.start, -2)
        else _rewritten(scheme.start, "start", n, -2, None, None, module, "start")
    )
    observe = (
        scheme.observe
        if not _reads(scheme.observe, -2)
        else _rewritten(scheme.observe, "observe", n, -2, None, None, module, "observe")
    )
    floor = None
    if scheme.floor is not None:
        f = scheme.floor
        floor = Floor(
            _rewritten(f.step, f"floor_{id}", n, 1, None, 0, module, "floor"),
            f.start
            if not _reads(f.start, 2)
            else _rewritten(f.start, f"floor_start_{id}", n, 2, None, None, module, "floor start"),
            f.observe
            if not _reads(f.observe, 1)
            else _rewritten(f.observe, f"floor_observe_{id}", n, 1, None, None, module, "floor observe"),
            f.scene_data,
        )
    scale = _scaled_h(Fraction(1, n), "y")
    amplification = damping_limit = None
    if scheme.amplification is not None:
        inner = scheme.amplification

        def amplification(y, zeta):
            """The scheme's recurrence at y/n, to the n-th power (products on the right)."""
            m = inner(eval(scale, {"__builtins__": {}}, {"y": y}), zeta)
            out = m
            for _ in range(n - 1):
                out = out @ m
            return out

    if scheme.damping_limit is not None:
        limit = scheme.damping_limit

        def damping_limit(zeta):
            """n times the scheme's (None: unstable for every y)."""
            at = limit(zeta)
            return None if at is None else n * at

    fields = dict(
        order=scheme.order,
        force_evals=n * scheme.force_evals,
        symplectic=scheme.symplectic,
        energy_claim=scheme.energy_claim,
        homega_max=None if scheme.homega_max is None else n * scheme.homega_max,
        kind=scheme.kind,
        start=start,
        observe=observe,
        iterations=scheme.iterations,
        substeps=scheme.substeps,
        order_velocity_dependent=scheme.order_velocity_dependent,
        one_pass_on_linear=scheme.one_pass_on_linear,
        carries=scheme.carries,
        floor=floor,
        amplification=amplification,
        damping_limit=damping_limit,
        substepped_from=(scheme, n),
    )
    fields.update(declared)
    return Scheme(id=id, step=step, doc=doc, **fields)
