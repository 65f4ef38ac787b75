"""A (scheme, scene) pair's kernel file as source (``reference._kernels`` writes, caches and loads
it): the pair's functions copied from their source files, the loop ``advance_n`` written around the
unchanged step, and what the copy found (``KernelFile``)."""
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
            params = tree.args.args[:len(bind)]
            if len(params) < len(bind) or tree.args.posonlyargs:
                raise SourceUnavailable(f"{fn.__qualname__} does not take the kernels {bind} first")
            renames = {a.arg: kernel for a, kernel in zip(params, bind)}
            tree.args.args = tree.args.args[len(bind):]
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
            if (isinstance(node, ast.For) and isinstance(node.iter, ast.Call)
                    and getattr(node.iter.func, "id", None) == "range" and len(node.iter.args) == 1
                    and getattr(node.iter.args[0], "id", None) == iterations and node.body
                    and isinstance(node.body[-1], ast.If) and not node.body[-1].orelse
                    and [type(b) for b in node.body[-1].body] == [ast.Break]):
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
        for new_name, fn, what in ((setup, head, "the statements before the state is read"),
                                   (given, tail, "the rest, given those")):
            fn = ast.fix_missing_locations(fn)
            self.origins[new_name] = f"{self.origins[name]}, {what}"
            self.functions[new_name] = ast.unparse(fn)
            self._trees[new_name] = fn
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
        parts = [header, "import numba", *sorted(set(self.imports.values())), "",
                 '_jit = numba.njit(cache=True, error_model="numpy")', ""]
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
        return "\n".join([
            "@_jit",
            "def advance_n(state, t0, h, i0, n, p, k):",
            *(["    " + setup] if setup else []),
            "    for i in range(i0, i0 + n):",
            "        state = " + step,
            "    return state", ""])
    s = [f"s{j}" for j in range(nstate)]

    def entries(r, b):
        return "(" + ", ".join(f"{x}[{r}, {b}]" for x in s) + ",)"

    def loops(step_call, indent):
        body = ["if nb == 1:",
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
                *[f"                {x}[r, b] = x[{j}]" for j, x in enumerate(s)]]
        return [indent + line for line in body]

    lines = ["@_jit", "def advance_n(state, t0, h, i0, n, p, k):"]
    lines += [f"    {x} = state[{j}].copy()" for j, x in enumerate(s)]
    lines += ["    ndof, nb = s0.shape"]
    if once:
        # One Newton iteration (every linear scene: exact) runs the step copied without the
        # iteration loop's exit, which leaves the batch loop straight-line code that vectorises.
        lines += ["    if k == 1:", *loops(kind.step_call("{x}", "{t}", "scheme_step_once", "1"), "        "),
                  "    else:", *loops(call, "        ")]
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
    return (f"_given = {kind.step_call(x, t_first, SETUP)}",
            kind.step_call(x, t, GIVEN, lead="_given, "))


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


_FILES: dict[tuple, "KernelFile | SourceUnavailable"] = {}


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
    loops = _loop_source(kind, nstate, pointwise, once, hoisted)
    bitwise, libm = src.bitwise_why()
    header = (f'"""Kernels of ref:{scheme.id} on {scene_cls.__name__} ({kind.name}, '
              f'{"pointwise" if pointwise else "array"} loop), generated by reference._kernels."""')
    return KernelFile(src.text(header, loops), pointwise, bitwise, libm)
