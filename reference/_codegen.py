"""A (scheme, scene) pair's kernel file as source (``reference._kernels`` writes, caches and loads
it): the pair's functions copied from their source files, the loop ``advance_n`` written around the
unchanged step (or, where the step's kind asks, with the step's statements in it), and what the copy
found (``KernelFile``)."""

from __future__ import annotations

import ast
import builtins
import inspect
import math
import sys
import textwrap
import types
from dataclasses import dataclass

import numpy as np

from ._scheme import largest_magnitude

# The step split where it first reads the state (``_Source.add_hoisted``): what comes before, run
# once by a loop, and the rest, run every step; the kinds name the two in their calls.
from .kinds import GIVEN, SETUP

from ._bitwise import bitwise_why

#: Modules a copied function may name, and the import line that gives them.
_MODULE_IMPORTS = {np: "import numpy as {name}", math: "import math as {name}"}
#: Packages whose functions may be copied into a kernel file.
_OWN_PACKAGES = ("reference", "scenarios")
#: Functions the kernel file imports rather than copies (numba compiles them through the
#: overloads registered below).
_IMPORTED = {largest_magnitude: "from reference._scheme import largest_magnitude"}


class SourceUnavailable(Exception):
    """A function's source cannot be copied into a kernel file (the reason is the message)."""


def _free_globals(tree: ast.FunctionDef) -> list[str]:
    """Names a function reads that it does not bind (its parameters, assignments, loops)."""
    bound = {a.arg for a in tree.args.args + tree.args.kwonlyargs + tree.args.posonlyargs}
    loads = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            if isinstance(node.ctx, ast.Store):
                bound.add(node.id)
            elif node.id not in loads:
                loads.append(node.id)
    return [n for n in loads if n not in bound and not hasattr(builtins, n)]


def _reads(stmt) -> set[str]:
    return {n.id for n in ast.walk(stmt) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)}


def _returns(stmt) -> bool:
    return any(isinstance(n, (ast.Return, ast.Yield, ast.YieldFrom)) for n in ast.walk(stmt))


def _stores(stmts) -> list[str]:
    """The names the statements assign, once for each assignment."""
    return [n.id for stmt in stmts for n in ast.walk(stmt) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)]


def _makes_empty_array(stmt, numpy: set[str]) -> bool:
    """Whether ``stmt`` is ``X = np.empty(...)`` (``numpy``: the names numpy is imported as)."""
    return (
        isinstance(stmt, ast.Assign)
        and len(stmt.targets) == 1
        and isinstance(stmt.targets[0], ast.Name)
        and isinstance(stmt.value, ast.Call)
        and isinstance(stmt.value.func, ast.Attribute)
        and stmt.value.func.attr == "empty"
        and isinstance(stmt.value.func.value, ast.Name)
        and stmt.value.func.value.id in numpy
    )


def _binds_without_call(stmt) -> bool:
    """Whether ``stmt`` only binds names (or tuples of names) to a value computed without a call."""
    return (
        isinstance(stmt, ast.Assign)
        and all(
            isinstance(n, (ast.Name, ast.Tuple))
            for target in stmt.targets
            for n in ast.walk(target)
            if not isinstance(n, (ast.Store, ast.Load))
        )
        and not any(isinstance(n, ast.Call) for n in ast.walk(stmt.value))
    )


def _reads_only_shape(stmt, names) -> bool:
    """Whether ``stmt`` reads each of ``names`` only for its ``.shape``."""
    shapes = {id(n.value) for n in ast.walk(stmt) if isinstance(n, ast.Attribute) and n.attr == "shape"}
    return all(
        id(n) in shapes
        for n in ast.walk(stmt)
        if isinstance(n, ast.Name) and n.id in names and isinstance(n.ctx, ast.Load)
    )


def _copy_into(stmt, array: str) -> tuple[str, str] | None:
    """(the rows, the name) where ``stmt`` is ``array[rows] = name``, else None."""
    if (
        isinstance(stmt, ast.Assign)
        and len(stmt.targets) == 1
        and isinstance(stmt.targets[0], ast.Subscript)
        and isinstance(stmt.targets[0].value, ast.Name)
        and stmt.targets[0].value.id == array
        and isinstance(stmt.value, ast.Name)
    ):
        return ast.unparse(stmt.targets[0].slice), stmt.value.id
    return None


def _function_tree(fn, name: str) -> ast.FunctionDef:
    try:
        src = textwrap.dedent(inspect.getsource(fn))
    except (OSError, TypeError) as exc:
        raise SourceUnavailable(f"no source for {fn!r}: {exc}") from None
    tree = ast.parse(src).body[0]
    if not isinstance(tree, ast.FunctionDef):
        raise SourceUnavailable(f"{fn!r} is not a plain function")
    tree.decorator_list = []
    tree.name = name
    return tree


class _Source:
    """The text of one kernel file, built function by function."""

    def __init__(self):
        self.imports: dict[str, str] = {}
        self.constants: dict[str, str] = {}
        self.functions: dict[str, str] = {}
        self.origins: dict[str, str] = {}
        self._copied: dict[str, object] = {}
        self._trees: dict[str, ast.FunctionDef] = {}
        #: The loop's source where ``add_loop_in_place`` wrote it, else "" (``_loop_source`` writes it).
        self.loop = ""

    def add(self, fn, name: str, bind: tuple[str, ...] = ()) -> None:
        """Copy ``fn`` as ``name``, with the globals it reads. ``bind`` names the kernels its
        first parameters receive (``scene_accel``, ...): those parameters are dropped and the
        kernels called as globals of the file, since numba caches no function that takes a
        function as an argument or passes one on."""
        if name in self._copied:
            if self._copied[name] is not fn:
                raise SourceUnavailable(f"two functions named {name}")
            return
        self._copied[name] = fn
        tree = _function_tree(fn, name)
        if bind:
            params = tree.args.args[: len(bind)]
            if len(params) < len(bind) or tree.args.posonlyargs:
                raise SourceUnavailable(f"{fn.__qualname__} does not take the kernels {bind} first")
            renames = {a.arg: kernel for a, kernel in zip(params, bind)}
            tree.args.args = tree.args.args[len(bind) :]
            for node in ast.walk(tree):
                if isinstance(node, ast.Name) and node.id in renames:
                    if isinstance(node.ctx, ast.Store):
                        raise SourceUnavailable(f"{fn.__qualname__} assigns to its kernel {node.id}")
                    node.id = renames[node.id]
        module = sys.modules.get(fn.__module__)
        self.origins[name] = f"{fn.__module__}.{fn.__qualname__}"
        for gname in _free_globals(tree):
            if gname in bind:
                continue
            if gname not in fn.__globals__:
                raise SourceUnavailable(f"{fn.__qualname__} reads an undefined global {gname}")
            self._global(gname, fn.__globals__[gname], module)
        self.functions[name] = ast.unparse(tree)
        self._trees[name] = tree

    def parameters(self, name: str) -> list[str]:
        """The parameters of the copied function ``name`` (its bound kernels dropped)."""
        return [a.arg for a in self._trees[name].args.args]

    def add_one_iteration(self, name: str, new_name: str, iterations: str) -> bool:
        """Copy the already copied ``name`` as ``new_name`` for exactly one iteration: each loop
        ``for _ in range(<iterations>)`` whose body ends ``if ...: break`` becomes one pass
        without that exit (a break that ends the last pass changes nothing). Unlike a loop with
        an exit, straight-line code vectorises over a batch. False if there is no such loop."""
        tree = ast.parse(self.functions[name]).body[0]
        found = False
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.For)
                and isinstance(node.iter, ast.Call)
                and getattr(node.iter.func, "id", None) == "range"
                and len(node.iter.args) == 1
                and getattr(node.iter.args[0], "id", None) == iterations
                and node.body
                and isinstance(node.body[-1], ast.If)
                and not node.body[-1].orelse
                and [type(b) for b in node.body[-1].body] == [ast.Break]
            ):
                node.body = node.body[:-1] or [ast.Pass()]
                node.iter.args = [ast.Constant(1)]
                found = True
        if found:
            tree.name = new_name
            self.origins[new_name] = self.origins[name] + ", one iteration"
            self.functions[new_name] = ast.unparse(ast.fix_missing_locations(tree))
        return found

    def add_hoisted(self, name: str, setup: str, given: str, varying: tuple[str, ...]) -> bool:
        """Split the already copied ``name`` where it first reads a name in ``varying`` (the state,
        the time, the scene's force): ``setup`` (the same parameters) runs the
        statements before that and returns the names they bind that the rest reads; ``given``
        takes that tuple first and runs the rest. A compiled loop calls ``setup`` once and
        ``given`` every step: what the statements compute depends on nothing a step changes, so
        each step sees the values it would have computed itself (the step must not modify them:
        the scheme's kind says so). False, and nothing added, where no statement comes first."""
        tree = ast.parse(self.functions[name]).body[0]
        first = 0
        for stmt in tree.body:
            reads = {n.id for n in ast.walk(stmt) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)}
            if reads & set(varying) or any(isinstance(n, (ast.Return, ast.Yield)) for n in ast.walk(stmt)):
                break
            first += 1
        prefix, rest = tree.body[:first], tree.body[first:]
        bound, counters = [], set()  # a loop's counter means nothing after it (nor is bound if it ran no pass)
        for stmt in prefix:
            for n in ast.walk(stmt):
                if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store) and n.id not in bound:
                    bound.append(n.id)
                if isinstance(n, ast.For):
                    counters |= {t.id for t in ast.walk(n.target) if isinstance(t, ast.Name)}
        read_later = {n.id for stmt in rest for n in ast.walk(stmt) if isinstance(n, ast.Name)}
        names = [n for n in bound if n in read_later and n not in counters]
        if not prefix or not rest or not names:
            return False

        def tuple_of(ctx):
            return ast.Tuple([ast.Name(n, ctx()) for n in names], ctx())

        head = ast.parse(self.functions[name]).body[0]
        head.name, head.body = setup, prefix + [ast.Return(tuple_of(ast.Load))]
        tail = ast.parse(self.functions[name]).body[0]
        tail.name = given
        tail.args.args.insert(0, ast.arg("_given"))
        tail.body = [ast.Assign([tuple_of(ast.Store)], ast.Name("_given", ast.Load()))] + rest
        for new_name, fn, what in (
            (setup, head, "the statements before the state is read"),
            (given, tail, "the rest, given those"),
        ):
            fn = ast.fix_missing_locations(fn)
            self.origins[new_name] = f"{self.origins[name]}, {what}"
            self.functions[new_name] = ast.unparse(fn)
            self._trees[new_name] = fn
        return True

    def add_loop_in_place(self, name: str, varying: tuple[str, ...], counts: list[str]) -> bool:
        """Write the compiled loop ``advance_n(state, t0, h, i0, n, p, k)`` (``_loop_source``'s
        signature) with the statements of the already copied step ``name`` in it, one array
        carrying the state from step to step, where the step has this form::

            <setup: the statements before the first read of a name in ``varying``>
            q, v = state                      # the state unpacked (any names, any count)
            <names bound to values computed without a call, reading q, v only for their .shape>
            work = np.empty(...)              # the step's one array
            work[<rows of q>] = q             # the state copied into it, each part once
            work[<rows of v>] = v
            <the rest, reading neither the state nor q, v: only the array>
            return (work[<rows of q>], work[<rows of v>])

        The loop runs the setup and the statements through the copies once, then the rest every
        step. The views a step returns are the rows its copies write, so each step begins with its
        state in those rows, as the copies would leave it: the copies are made once, and a step
        makes no array, passes none in a call and takes no reference to one (the step's statements
        are in the loop, not called; a compiled call takes and drops a reference to every array it
        passes). The step must not modify what the setup computes (as for ``add_hoisted``), and
        must write every other entry of its array before it reads it (an ``np.empty`` array holds
        nothing to read), so it computes the bits it computes with an array of its own.
        ``counts``: the expressions of ``k`` the step's parameters before the state take
        (``Kind.count_args``). False, and nothing added, where the step has another form, the rest
        assigns a name bound before it, or a name of the loop's own would shadow one of the step's."""
        tree = ast.parse(self.functions[name]).body[0]
        params = [a.arg for a in tree.args.args]
        if len(params) != len(counts) + 4:
            return False
        *count_params, state, t, h, p = params
        body = tree.body
        if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
            body = body[1:]  # the docstring
        first = 0
        for stmt in body:
            if _reads(stmt) & set(varying) or _returns(stmt):
                break
            first += 1
        prefix, rest = body[:first], body[first:]
        # The state unpacked into names, first.
        if not rest or not (
            isinstance(rest[0], ast.Assign)
            and len(rest[0].targets) == 1
            and isinstance(rest[0].targets[0], ast.Tuple)
            and all(isinstance(e, ast.Name) for e in rest[0].targets[0].elts)
            and isinstance(rest[0].value, ast.Name)
            and rest[0].value.id == state
        ):
            return False
        parts = [e.id for e in rest[0].targets[0].elts]
        # The return: views of one array, one a part.
        last = rest[-1]
        if not (
            isinstance(last, ast.Return)
            and isinstance(last.value, ast.Tuple)
            and len(last.value.elts) == len(parts)
            and all(isinstance(e, ast.Subscript) and isinstance(e.value, ast.Name) for e in last.value.elts)
        ):
            return False
        array = last.value.elts[0].value.id
        rows = [ast.unparse(e.slice) for e in last.value.elts]
        if any(e.value.id != array for e in last.value.elts) or any(_returns(stmt) for stmt in rest[:-1]):
            return False
        numpy = {alias for alias, line in self.imports.items() if line.startswith("import numpy")}
        made = [i for i, stmt in enumerate(rest) if _makes_empty_array(stmt, numpy)]
        if len(made) != 1 or rest[made[0]].targets[0].id != array:
            return False
        at = made[0]
        shape = rest[1:at]
        if not all(
            _binds_without_call(stmt) and t not in _reads(stmt) and _reads_only_shape(stmt, [*parts, state])
            for stmt in shape
        ):
            return False
        copies = rest[at + 1 : at + 1 + len(parts)]
        if [_copy_into(stmt, array) for stmt in copies] != list(zip(rows, parts)):
            return False
        steps = rest[at + 1 + len(parts) : -1]
        bound = set(params) | set(parts) | set(_stores(shape)) | {array}
        counters = {
            n.id
            for stmt in prefix
            for loop_ in ast.walk(stmt)
            if isinstance(loop_, ast.For)
            for n in ast.walk(loop_.target)
            if isinstance(n, ast.Name)
        }
        if (
            any((_reads(stmt) & (set(parts) | {state})) for stmt in steps)
            or set(_stores(steps)) & (bound | (set(_stores(prefix)) - counters))
            or _stores(body).count(array) != 1
        ):
            return False
        loop = "advance_n"
        own = {loop, "_t0", "_i0", "_steps", "_k", "_i"}
        if own & ({n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} | set(params) | set(self.functions)):
            return False

        def lines(stmts, indent):
            return [textwrap.indent(ast.unparse(stmt), indent) for stmt in stmts]

        reads_time = any(t in _reads(stmt) for stmt in steps)
        text = [
            f"def {loop}({state}, _t0, {h}, _i0, _steps, {p}, _k):",
            *[f"    {param} = {value}" for param, value in zip(count_params, counts)],
            *lines(prefix, "    "),
            *lines(rest[: at + 1 + len(parts)], "    "),
            "    for _i in range(_i0, _i0 + _steps):",
            *([f"        {t} = _t0 + _i * {h}"] if reads_time else []),
            *lines(steps, "        "),
            f"    return {ast.unparse(last.value)}",
        ]
        self._trees[loop] = ast.parse("\n".join(text)).body[0]
        self.loop = "\n".join(
            [
                f"# from {self.origins[name]}: its statements in the loop, the state carried in its array",
                "@_jit",
                *text,
                "",
            ]
        )
        return True

    def bitwise_why(self) -> tuple[str, tuple[str, ...]]:
        """(why numba may compute other bits than numpy, or "", the libm functions the kernels
        call) by ``reference._bitwise``, over every function copied."""
        modules = {}
        for alias, line in self.imports.items():
            if line.startswith("import numpy"):
                modules[alias] = "np"
            elif line.startswith("import math"):
                modules[alias] = "math"
        libm = set()
        for name, tree in self._trees.items():
            why = bitwise_why(tree, modules, set(self.functions) | set(self.imports), libm)
            if why:
                return f"{self.origins[name]}: {why}", ()
        return "", tuple(sorted(libm))

    def _global(self, name: str, value, module) -> None:
        if isinstance(value, types.ModuleType):
            for mod, line in _MODULE_IMPORTS.items():
                if value is mod:
                    self._put(self.imports, name, line.format(name=name))
                    return
            raise SourceUnavailable(f"module {value.__name__} (as {name}) cannot be named in a kernel")
        if isinstance(value, (bool, int, float)):
            self._put(self.constants, name, f"{name} = {value!r}")
            return
        if value in _IMPORTED:
            self._put(self.imports, name, _IMPORTED[value])
            return
        if isinstance(value, types.FunctionType) and value.__module__.split(".")[0] in _OWN_PACKAGES:
            self.add(value, name)
            return
        raise SourceUnavailable(f"global {name} = {value!r} cannot be copied into a kernel")

    def _put(self, table: dict, name: str, line: str) -> None:
        if table.get(name, line) != line:
            raise SourceUnavailable(f"two different globals named {name}")
        table[name] = line

    def text(self, header: str, loop: str) -> str:
        # error_model="numpy": a division by zero gives inf/nan, as on the interpreted (numpy)
        # path, instead of raising, and the loops skip the zero checks (~15% of a spring step).
        parts = [
            header,
            "import numba",
            *sorted(set(self.imports.values())),
            "",
            '_jit = numba.njit(cache=True, error_model="numpy")',
            "",
        ]
        parts += sorted(self.constants.values()) + [""]
        for name, body in self.functions.items():
            parts += [f"# from {self.origins[name]}", "@_jit", body, ""]
        return "\n".join(parts + [loop])


def _loop_source(kind, nstate: int, pointwise: bool, once: bool = False, hoisted: bool = False) -> str:
    """``advance_n(state, t0, h, i0, n, p, k) -> state``: steps i0 .. i0 + n - 1 of a run
    started at t0 (step i starts at t0 + i h, as in the interpreted driver, so a run cut into
    pieces is the same run). ``k`` is the one integer a scheme takes besides the state: Newton
    iterations allowed (implicit) or projection passes (constrained). The state passed in is
    not modified. ``once``: the file has ``scheme_step_once``, the step for one Newton iteration;
    ``hoisted``: it has ``scheme_setup`` and ``scheme_step_given`` (``_Source.add_hoisted``), which
    the array loop runs instead of the step: the setup once, before its steps."""
    call = kind.step_call("{x}", "{t}")
    if not pointwise:
        setup, step = _hoisted_calls(kind, hoisted, "state", "t0 + i * h", "t0 + i0 * h")
        return "\n".join(
            [
                "@_jit",
                "def advance_n(state, t0, h, i0, n, p, k):",
                *(["    " + setup] if setup else []),
                "    for i in range(i0, i0 + n):",
                "        state = " + step,
                "    return state",
                "",
            ]
        )
    s = [f"s{j}" for j in range(nstate)]

    def entries(r, b):
        return "(" + ", ".join(f"{x}[{r}, {b}]" for x in s) + ",)"

    def loops(step_call, indent):
        body = [
            "if nb == 1:",
            "    for r in range(ndof):",
            f"        x = {entries('r', 0)}",
            "        for i in range(i0, i0 + n):",
            "            x = " + step_call.format(x="x", t="t0 + i * h"),
            *[f"        {x}[r, 0] = x[{j}]" for j, x in enumerate(s)],
            "else:",
            "    for i in range(i0, i0 + n):",
            "        t = t0 + i * h",
            "        for r in range(ndof):",
            "            for b in range(nb):",
            "                x = " + step_call.format(x=entries("r", "b"), t="t"),
            *[f"                {x}[r, b] = x[{j}]" for j, x in enumerate(s)],
        ]
        return [indent + line for line in body]

    lines = ["@_jit", "def advance_n(state, t0, h, i0, n, p, k):"]
    lines += [f"    {x} = state[{j}].copy()" for j, x in enumerate(s)]
    lines += ["    ndof, nb = s0.shape"]
    if once:
        # One Newton iteration (every linear scene: exact) runs the step copied without the
        # iteration loop's exit, which leaves the batch loop straight-line code that vectorises.
        lines += [
            "    if k == 1:",
            *loops(kind.step_call("{x}", "{t}", "scheme_step_once", "1"), "        "),
            "    else:",
            *loops(call, "        "),
        ]
    else:
        lines += loops(call, "    ")
    lines += ["    return (" + ", ".join(s) + ",)", ""]
    return "\n".join(lines)


def _hoisted_calls(kind, hoisted: bool, x: str, t: str, t_first: str) -> tuple[str, str]:
    """(the setup line or "", the step's call) of an array loop over ``x``: the step itself, or
    where the file has them (``hoisted``) the setup assigned to ``_given`` once and the step
    given it."""
    if not hoisted:
        return "", kind.step_call(x, t)
    return (f"_given = {kind.step_call(x, t_first, SETUP)}", kind.step_call(x, t, GIVEN, lead="_given, "))


@dataclass(frozen=True)
class KernelFile:
    """The text of a pair's kernel file and what it holds. ``bitwise_why``: why its loop might
    compute other bits than the interpreted driver ("" where it computes the same, given the
    library functions ``libm`` it calls agree: ``reference._bitwise``)."""

    text: str
    pointwise: bool
    bitwise_why: str
    libm: tuple[str, ...]


def kernel_source(scheme, scene_cls, nstate: int) -> tuple[str, bool]:
    """(text of the kernel file, pointwise?) for a pair. Raises SourceUnavailable."""
    f = kernel_file(scheme, scene_cls, nstate)
    return f.text, f.pointwise


def kernel_file(scheme, scene_cls, nstate: int) -> KernelFile:
    """The kernel file of a pair (``KernelFile``), generated once per process (the functions'
    source does not change while it runs; the nightly's plan asks for every pair's before its
    workers load them). Raises SourceUnavailable."""
    key = (scheme, scene_cls, nstate)
    if key not in _FILES:
        try:
            _FILES[key] = _kernel_file(scheme, scene_cls, nstate)
        except SourceUnavailable as exc:
            _FILES[key] = exc
    made = _FILES[key]
    if isinstance(made, SourceUnavailable):
        raise made
    return made


_FILES: dict[tuple, KernelFile | SourceUnavailable] = {}


def _kernel_file(scheme, scene_cls, nstate: int) -> KernelFile:
    kind = scheme.kind
    pointwise = kind.pointwise(scene_cls)
    src = _Source()
    kernels = ("scene_accel", *(f"scene_{name}" for name in kind.kernels))
    src.add(scheme.step, "scheme_step", kernels)
    src.add(scheme.start, "start", ("scene_accel",))
    src.add(scheme.observe, "observe", ("scene_accel",))
    src.add(scene_cls.accel, "scene_accel")
    for name in kind.kernels:
        src.add(getattr(scene_cls, name), f"scene_{name}")
    once = kind.variants(src, pointwise)
    hoisted = GIVEN in src.functions and not pointwise
    loops = src.loop or _loop_source(kind, nstate, pointwise, once, hoisted)
    bitwise, libm = src.bitwise_why()
    header = (
        f'"""Kernels of ref:{scheme.id} on {scene_cls.__name__} ({kind.name}, '
        f'{"pointwise" if pointwise else "array"} loop), generated by reference._kernels."""'
    )
    return KernelFile(src.text(header, loops), pointwise, bitwise, libm)
