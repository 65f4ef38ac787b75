"""Compiled kernels of a (scheme, scene) pair, generated as source and cached on disk.

For each pair this module writes one Python file: the scheme's ``step``/``start``/``observe``
and the scene's ``accel``/``solve``/``project``, copied verbatim from their source files
(decorators dropped, renamed ``scheme_step``, ``scene_accel``, ...), the module-level
constants and helper functions they read, and the loop ``advance_n``, every function
``numba.njit(cache=True)``. The file's name carries a hash of its own text (and of this
module, numba's and Python's versions), so an edited scheme or scene yields a new file that
compiles afresh, and a kernel compiled from old source is never loaded: numba's own cache
checks only the file a function is defined in, never its callees in other files, and caches
no function that takes or passes a function as an argument (the scheme's kernels become
globals of the file instead). Files live under ``$HARNESS_CACHE`` (default ``~/.cache/integrator-harness``)
in ``kernels/``, numba's cache beside them in ``__pycache__``; both are written under a
temporary name and then put in place, so worker processes compiling the same pair at once
each see a whole file.

Two loops, both running the unchanged step function:

* **pointwise** (the scene declares ``pointwise``: ``accel[i, b]`` and ``solve[i, b]``
  depend only on entry (i, b) of the state, so every entry is its own 1-DOF system) and the
  scheme unconstrained: the step runs on a tuple of floats, one entry at a time, and numba
  inlines it into a loop of scalars without an array temporary. On one entry the steps run
  in registers (the entry outermost); on a batch the entries run innermost, over contiguous
  memory, so the loop vectorises. The entries are independent, so either order computes
  every entry's float operations in the step's order: the same states as the array path.
  An implicit step on a linear scene takes one Newton iteration (exact); the file then also
  holds the step copied for exactly one (``scheme_step_once``: the iteration loop's convergence exit
  dropped, which a single pass never takes), straight-line code that vectorises.
* **array** (every other pair): the step on the state's arrays, as the interpreted driver
  runs it; each operation allocates its result.

A third function, ``run_counted``, runs the interpreted driver's whole loop compiled: every
step checked for divergence, the observed state recorded every ``every`` steps, and each call
of the scene's force, solve and projection counted, as ``reference._integrate.Counted`` counts
them (the step copied as ``scheme_step_counted``, each kernel call ``K(...)`` made
``K_counted(_cnt, ...)``). It computes the interpreted run's bits where every operation of the
pair is one numba and numpy compute alike (``KernelFile.exact_why`` empty; see
``exact_operations``): ``reference._compiled.integrate_exact`` runs the accuracy measurements
there.

A pair whose source cannot be copied (a global that is neither a number, a module nor a
function of this project) is compiled in memory instead, every process anew, and says so
(``Kernels.cached`` False).
"""
from __future__ import annotations

import ast
import builtins
import hashlib
import importlib.util
import inspect
import math
import os
import sys
import tempfile
import textwrap
import time
import types
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from records.trajectory import DIVERGED

from ._scheme import largest_magnitude

#: Modules a copied function may name, and the import line that gives them.
_MODULE_IMPORTS = {np: "import numpy as {name}", math: "import math as {name}"}
#: Packages whose functions may be copied into a kernel file.
_OWN_PACKAGES = ("reference", "scenarios")
#: Functions the kernel file imports rather than copies (numba compiles them through the
#: overloads registered below).
_IMPORTED = {largest_magnitude: "from reference._scheme import largest_magnitude"}


def cache_dir() -> Path:
    """Where kernel files and numba's cache of them live: ``$HARNESS_CACHE/kernels``, else
    ``~/.cache/integrator-harness/kernels`` (``$XDG_CACHE_HOME`` if set)."""
    root = os.environ.get("HARNESS_CACHE")
    if not root:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        root = os.path.join(base, "integrator-harness")
    return Path(root) / "kernels"


class SourceUnavailable(Exception):
    """A function's source cannot be copied into a kernel file (the reason is the message)."""


@dataclass
class Stats:
    """What this process compiled and what it loaded from the disk cache."""

    compiled: int = 0
    compile_s: float = 0.0
    loaded: int = 0
    load_s: float = 0.0

    def snapshot(self) -> dict:
        return {"kernels_compiled": self.compiled, "compile_s": self.compile_s,
                "kernels_loaded": self.loaded, "load_s": self.load_s}


STATS = Stats()


_OVERLOADS: list = []


def _register_overloads() -> None:
    """``largest_magnitude`` inside compiled code: ``abs`` of a float (the pointwise loop),
    ``max(abs)`` of an array (the array loop), as the interpreted function computes it.
    Registered before the first kernel compiles, not on import (numba takes ~0.5 s to import)."""
    if _OVERLOADS:
        return
    from numba.core import types as nbtypes
    from numba.extending import overload

    @overload(largest_magnitude)
    def _largest_magnitude(x):
        if isinstance(x, nbtypes.Float):
            return lambda x: abs(x)
        if isinstance(x, nbtypes.Array):
            return lambda x: np.max(np.abs(x))
        return None

    _OVERLOADS.append(_largest_magnitude)


# ------------------------------------------------------------------ exactness
#: Calls whose result numba computes bit for bit as numpy and Python do: IEEE 754's correctly
#: rounded square root, the exact abs, min and max, and making arrays.
EXACT_CALLS = frozenset({"np.sqrt", "math.sqrt", "np.abs", "abs", "min", "max", "np.empty_like", "np.zeros_like",
                         "np.empty", "np.zeros", "np.eye", "np.outer", "np.ascontiguousarray", "range", "len", "float",
                         "int"})
#: Array methods likewise exact.
EXACT_METHODS = frozenset({"copy"})
#: Functions both sides take from a library: the C library's sin, cos and exp (where numpy does
#: not bring its own vectorised version) and LAPACK's dense solve (numpy's bundled build against
#: the one numba calls through scipy): the same bits exactly where this machine's builds agree
#: on them (``reference._libm.agrees``, checked once per process).
LIBM_CALLS = frozenset({"np.sin", "np.cos", "np.exp", "math.sin", "math.cos", "math.exp", "np.linalg.solve"})


def exact_operations(tree: ast.FunctionDef, modules: dict[str, str], known: set[str], libm: set[str]) -> str:
    """Why numba might compute other bits than the interpreted function ``tree``, or "".

    Interpreted, a kernel runs numpy's elementwise operations and Python's float arithmetic;
    compiled, numba's. Both round every +, -, *, / and sqrt as IEEE 754 says, in the order the
    source writes them (numba neither reassociates nor contracts a*b + c into one rounding
    without fastmath, which the kernels do not ask for), so a function built only of those,
    of exact operations and of calls to other such functions computes the same bits either
    way. A reduction (np.sum, np.dot, @: numpy sums pairwise, numba in order), ``**`` (numpy's
    pow against numba's repeated products) or any call not listed might not; a library
    function (``LIBM_CALLS``) does where the machine's builds agree. ``modules`` maps the names bound to numpy and math to "np" and
    "math"; ``known``: functions and kernels of the file (exact if their own source is);
    the libm functions called are added to ``libm``."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.BinOp, ast.AugAssign)) and isinstance(node.op, (ast.Pow, ast.MatMult)):
            return f"uses {'**' if isinstance(node.op, ast.Pow) else '@'}"
        if not isinstance(node, ast.Call):
            continue
        func = node.func
        if isinstance(func, ast.Name):
            name = func.id
            if name in known or name in EXACT_CALLS:
                continue
            return f"calls {name}"
        root, path = func, []
        while isinstance(root, ast.Attribute):
            path.insert(0, root.attr)
            root = root.value
        if path and isinstance(root, ast.Name) and root.id in modules:
            name = ".".join([modules[root.id], *path])
            if name in EXACT_CALLS:
                continue
            if name in LIBM_CALLS:
                libm.add(name)
                continue
            return f"calls {name}"
        if isinstance(func, ast.Attribute) and func.attr in EXACT_METHODS:
            continue
        return f"calls {ast.unparse(func)}"
    return ""


# ------------------------------------------------------------------ source
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

    def add_counted(self, name: str, new_name: str, kernels: dict[str, int]) -> None:
        """Copy the already copied ``name`` as ``new_name`` that counts its kernels' calls: a first
        parameter ``_cnt`` (int64, one entry per kernel: ``kernels`` maps a kernel's name to its
        entry) and every call ``K(...)`` of a kernel made ``K_counted(_cnt, ...)``. A kernel named
        other than as the function of a call (passed on as a value) cannot be counted."""
        tree = ast.parse(self.functions[name]).body[0]
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in kernels:
                node.args.insert(0, ast.Name("_cnt", ast.Load()))
                node.func.id += "_counted"
        for node in ast.walk(tree):
            if isinstance(node, ast.Name) and node.id in kernels:
                raise SourceUnavailable(f"{self.origins[name]} passes the kernel {node.id} on as a value: "
                                        "its calls cannot be counted")
        tree.args.args.insert(0, ast.arg("_cnt"))
        tree.name = new_name
        self.origins[new_name] = self.origins[name] + ", counted"
        self.functions[new_name] = ast.unparse(ast.fix_missing_locations(tree))
        self._trees[new_name] = tree
        for kernel, entry in kernels.items():
            wrapper = f"{kernel}_counted"
            if wrapper in self.functions:
                continue
            params = ", ".join(a.arg for a in self._trees[kernel].args.args)
            self.origins[wrapper] = f"{self.origins[kernel]}, counted in _cnt[{entry}]"
            self.functions[wrapper] = (f"def {wrapper}(_cnt, {params}):\n    _cnt[{entry}] += 1\n"
                                       f"    return {kernel}({params})")

    def exact_why(self) -> tuple[str, tuple[str, ...]]:
        """(why numba may compute other bits than numpy, or "", the libm functions the kernels
        call) by ``exact_operations``, over every function copied."""
        modules = {}
        for alias, line in self.imports.items():
            if line.startswith("import numpy"):
                modules[alias] = "np"
            elif line.startswith("import math"):
                modules[alias] = "math"
        libm = set()
        for name, tree in self._trees.items():
            why = exact_operations(tree, modules, set(self.functions) | set(self.imports), libm)
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


def _loop_source(kind: str, nstate: int, pointwise: bool, once: bool = False) -> str:
    """``advance_n(state, t0, h, i0, n, p, k) -> state``: steps i0 .. i0 + n - 1 of a run
    started at t0 (step i starts at t0 + i h, as in the interpreted driver, so a run cut into
    pieces is the same run). ``k`` is the one integer a scheme takes besides the state: Newton
    iterations allowed (implicit) or projection passes (constrained). The state passed in is
    not modified. ``once``: the file has ``scheme_step_once``, the step for one Newton iteration."""
    extra = "k, " if kind in ("implicit", "constrained") else ""
    call = f"scheme_step({extra}{{x}}, {{t}}, h, p)"
    if not pointwise:
        return "\n".join([
            "@_jit",
            "def advance_n(state, t0, h, i0, n, p, k):",
            "    for i in range(i0, i0 + n):",
            "        state = " + call.format(x="state", t="t0 + i * h"),
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
        lines += ["    if k == 1:", *loops(call.replace("scheme_step(k, ", "scheme_step_once(1, "), "        "),
                  "    else:", *loops(call, "        ")]
    else:
        lines += loops(call, "    ")
    lines += ["    return (" + ", ".join(s) + ",)", ""]
    return "\n".join(lines)


def _counted_one_source(kind: str) -> str:
    """``run_counted_one(x, t0, h, n, every, p, k, out_q, out_v, cnt) -> (recorded, failed)``:
    ``run_counted`` on a pointwise scene with one entry (one DOF, batch one), its state ``x``
    the floats ``start_counted`` returns for floats: the same operations on scalars, which
    numba compiles in a fraction of the time it takes over array expressions."""
    extra = "k, " if kind in ("implicit", "constrained") else ""
    return "\n".join([
        "@_jit",
        "def run_counted_one(x, t0, h, n, every, p, k, out_q, out_v, cnt):",
        "    qo, vo = observe(x, t0, h, p)",
        "    out_q[0, 0, 0] = qo",
        "    out_v[0, 0, 0] = vo",
        "    j = 1",
        "    for i in range(n):",
        f"        x = scheme_step_counted(cnt, {extra}x, t0 + i * h, h, p)",
        "        if not (abs(x[0]) <= _DIVERGED and abs(x[1]) <= _DIVERGED):",
        "            return j, i + 1",
        "        if (i + 1) % every == 0 or i + 1 == n:",
        "            qo, vo = observe(x, t0 + (i + 1) * h, h, p)",
        "            out_q[j, 0, 0] = qo",
        "            out_v[j, 0, 0] = vo",
        "            j += 1",
        "    return j, 0",
        ""])


def _counted_source(kind: str) -> str:
    """``run_counted(state, t0, h, n, every, p, k, out_q, out_v, cnt) -> (state, recorded,
    failed)``: ``reference._integrate.integrate``'s loop, compiled. Steps 1 .. n of a run started
    at t0 (step i + 1 starts at t0 + i h), each checked as ``records.trajectory.diverged``
    checks it (a component not finite or beyond DIVERGED stops the run: ``failed`` is that
    step, else 0); the observed state of step 0, every ``every`` steps and the last written to
    ``out_q``/``out_v`` (kernel layout, one record per row; ``recorded`` rows written); the
    force, solve and projection calls added to ``cnt``."""
    extra = "k, " if kind in ("implicit", "constrained") else ""
    return "\n".join([
        f"_DIVERGED = {DIVERGED!r}",
        "",
        "",
        "@_jit",
        "def _within(x):",
        "    for e in x.flat:",
        "        if not abs(e) <= _DIVERGED:",
        "            return False",
        "    return True",
        "",
        "",
        "@_jit",
        "def run_counted(state, t0, h, n, every, p, k, out_q, out_v, cnt):",
        "    qo, vo = observe(state, t0, h, p)",
        "    out_q[0, :, :] = qo",
        "    out_v[0, :, :] = vo",
        "    j = 1",
        "    for i in range(n):",
        f"        state = scheme_step_counted(cnt, {extra}state, t0 + i * h, h, p)",
        "        if not (_within(state[0]) and _within(state[1])):",
        "            return state, j, i + 1",
        "        if (i + 1) % every == 0 or i + 1 == n:",
        "            qo, vo = observe(state, t0 + (i + 1) * h, h, p)",
        "            out_q[j, :, :] = qo",
        "            out_v[j, :, :] = vo",
        "            j += 1",
        "    return state, j, 0",
        ""])


#: The counters of ``run_counted``: the entry of ``cnt`` each kernel's calls are added to.
COUNTED = {"scene_accel": 0, "scene_solve": 1, "scene_project": 2}


@dataclass(frozen=True)
class KernelFile:
    """The text of a pair's kernel file and what it holds. ``exact_why``: why the file has no
    ``run_counted``, or why it might compute other bits than the interpreted driver ("" where
    it computes the same; ``exact_operations``); ``libm``: the library functions it calls."""

    text: str
    pointwise: bool
    exact_why: str
    libm: tuple[str, ...]


def kernel_source(scheme, scene_cls, nstate: int) -> tuple[str, bool]:
    """(text of the kernel file, pointwise?) for a pair. Raises SourceUnavailable."""
    f = kernel_file(scheme, scene_cls, nstate)
    return f.text, f.pointwise


def kernel_file(scheme, scene_cls, nstate: int) -> KernelFile:
    """The kernel file of a pair (``KernelFile``). Raises SourceUnavailable."""
    kind = ("constrained" if scheme.constrained else "implicit" if scheme.implicit
            else "decay" if getattr(scheme, "decay", False) else "explicit")
    pointwise = bool(getattr(scene_cls, "pointwise", False)) and not scheme.constrained
    src = _Source()
    kernels = {"explicit": ("scene_accel",), "implicit": ("scene_accel", "scene_solve"),
               "constrained": ("scene_accel", "scene_project"),
               "decay": ("scene_accel", "scene_damping_rate")}[kind]
    src.add(scheme.step, "scheme_step", kernels)
    src.add(scheme.start, "start", ("scene_accel",))
    src.add(scheme.observe, "observe", ("scene_accel",))
    src.add(scene_cls.accel, "scene_accel")
    if kind == "implicit":
        src.add(scene_cls.solve, "scene_solve")
    if kind == "constrained":
        src.add(scene_cls.project, "scene_project")
    if kind == "decay":
        src.add(scene_cls.damping_rate, "scene_damping_rate")
    once = False
    if kind == "implicit" and pointwise:
        # The Newton parameter is the step's first after the two kernels.
        params = src._trees["scheme_step"].args.args
        once = bool(params) and src.add_one_iteration("scheme_step", "scheme_step_once", params[0].arg)
    loops = _loop_source(kind, nstate, pointwise, once)
    try:
        called = {name: entry for name, entry in COUNTED.items() if name in kernels}
        src.add_counted("scheme_step", "scheme_step_counted", called)
        src.add_counted("start", "start_counted", {"scene_accel": COUNTED["scene_accel"]})
        loops += "\n\n" + _counted_source(kind)
        if pointwise:
            loops += "\n\n" + _counted_one_source(kind)
        exact_why, libm = src.exact_why()
    except SourceUnavailable as exc:
        exact_why, libm = str(exc), ()
    header = (f'"""Kernels of ref:{scheme.id} on {scene_cls.__name__} ({kind}, '
              f'{"pointwise" if pointwise else "array"} loop), generated by reference._kernels."""')
    return KernelFile(src.text(header, loops), pointwise, exact_why, libm)


# ------------------------------------------------------------------ files
def _key(text: str) -> str:
    """Hash of the kernel file's text, of this module (the overloads the text compiles
    through) and of numba's and Python's versions."""
    import numba

    h = hashlib.sha256(text.encode())
    h.update(Path(__file__).read_bytes())
    h.update(f"numba {numba.__version__} python {sys.version}".encode())
    return h.hexdigest()[:16]


def _write_once(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` unless a file is already there: to a temporary name in the
    same directory, then linked to its name, which fails if another process got there first
    (its file is the same text). A reader never sees half a file, and a file once there is
    never replaced: numba's cache of it is stamped with its modification time."""
    if path.exists():
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".py")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        try:
            os.link(tmp, path)
        except FileExistsError:
            pass
        except OSError:  # a file system without hard links: rename (the same text if raced)
            os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _import_file(name: str, path: Path):
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


@dataclass
class Kernels:
    """The compiled pieces of one pair. ``path`` is the kernel file (None when compiled in
    memory, ``why_uncached`` then says why); ``pointwise`` which loop ``advance_n`` runs."""

    start: object
    advance_n: object
    observe: object
    pointwise: bool
    path: Path | None
    why_uncached: str = ""
    #: ``start_counted`` and ``run_counted`` (None where the file has none: ``exact_why`` says
    #: why), and on a pointwise scene ``run_counted_one`` (one entry, on floats).
    start_counted: object = None
    run_counted: object = None
    run_counted_one: object = None
    #: Why ``run_counted`` might not compute the interpreted driver's bits ("" where it does,
    #: given ``libm``: the C library functions it calls, which ``reference._libm`` checks).
    exact_why: str = "compiled in memory: no counted run"
    libm: tuple[str, ...] = ()

    @property
    def cached(self) -> bool:
        return self.path is not None

    def dispatchers(self) -> list:
        return [self.start, self.advance_n, self.observe]

    def counted_dispatchers(self) -> list:
        return [d for d in (self.start_counted, self.run_counted, self.run_counted_one, self.observe) if d is not None]

    @property
    def _counted_mark(self) -> Path | None:
        return None if self.path is None else self.path.with_suffix(".counted")

    def counted_compiled(self) -> bool:
        """Whether the counted run was compiled on this machine before (and so loads from the
        disk cache): a mark put beside the kernel file by :meth:`mark_counted`."""
        mark = self._counted_mark
        return mark is not None and mark.exists()

    def mark_counted(self) -> None:
        mark = self._counted_mark
        if mark is not None:
            mark.touch()


def load(scheme, scene_cls, nstate: int) -> Kernels:
    """The kernels of a pair from its kernel file (written first if missing). Not yet
    compiled: the first call compiles, or loads numba's cache of the file."""
    _register_overloads()
    try:
        f = kernel_file(scheme, scene_cls, nstate)
    except SourceUnavailable as exc:
        return _in_memory(scheme, scene_cls, str(exc))
    key = _key(f.text)
    stem = f"k_{scheme.id}_{scene_cls.__name__.lower()}_{key}"
    path = cache_dir() / f"{stem}.py"
    _write_once(path, f.text)
    module = _import_file(f"_harness_kernels.{stem}", path)
    return Kernels(module.start, module.advance_n, module.observe, f.pointwise, path,
                   start_counted=getattr(module, "start_counted", None), run_counted=getattr(module, "run_counted", None),
                   run_counted_one=getattr(module, "run_counted_one", None),
                   exact_why=f.exact_why, libm=f.libm)


def _in_memory(scheme, scene_cls, why: str) -> Kernels:
    """The array loop compiled from the function objects themselves (not cacheable)."""
    import numba

    jit = numba.njit(error_model="numpy")
    step, scheme_start, scheme_observe = jit(scheme.step), jit(scheme.start), jit(scheme.observe)
    accel, solve, project = jit(scene_cls.accel), jit(scene_cls.solve), jit(scene_cls.project)

    @jit
    def start(q, v, t, h, p):
        return scheme_start(accel, q, v, t, h, p)

    @jit
    def observe(state, t, h, p):
        return scheme_observe(accel, state, t, h, p)

    if scheme.constrained:
        @jit
        def advance_n(state, t0, h, i0, n, p, k):
            for i in range(i0, i0 + n):
                state = step(accel, project, k, state, t0 + i * h, h, p)
            return state
    elif scheme.implicit:
        @jit
        def advance_n(state, t0, h, i0, n, p, k):
            for i in range(i0, i0 + n):
                state = step(accel, solve, k, state, t0 + i * h, h, p)
            return state
    elif getattr(scheme, "decay", False):
        rate = jit(scene_cls.damping_rate)

        @jit
        def advance_n(state, t0, h, i0, n, p, k):
            for i in range(i0, i0 + n):
                state = step(accel, rate, state, t0 + i * h, h, p)
            return state
    else:
        @jit
        def advance_n(state, t0, h, i0, n, p, k):
            for i in range(i0, i0 + n):
                state = step(accel, state, t0 + i * h, h, p)
            return state
    return Kernels(start, advance_n, observe, False, None, why)


def warm(kernels: Kernels, call, dispatchers: list | None = None) -> float:
    """Run ``call()`` (the first call of the pair's kernels, which compiles them or loads them
    from the cache), account it in ``STATS`` and return its seconds, CPU seconds of this
    process (numba compiles in this thread; a core shared with other work does not inflate them).
    ``dispatchers``: the functions ``call`` compiles (default: the timing loop's)."""
    t = time.process_time()
    call()
    seconds = time.process_time() - t
    misses = sum(sum(d.stats.cache_misses.values()) for d in dispatchers or kernels.dispatchers())
    if kernels.cached and misses == 0:
        STATS.loaded += 1
        STATS.load_s += seconds
    else:
        STATS.compiled += 1
        STATS.compile_s += seconds
    return seconds
