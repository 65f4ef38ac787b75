"""Compiled kernels of a (scheme, scene) pair, generated as source and cached on disk.

Three modules, one concern each: ``reference._codegen`` writes the pair's kernel file as source,
``reference._bitwise`` judges which of its operations compute the interpreted bits, and this
one caches the file on disk, loads and compiles it, or compiles it in memory.

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

The loop runs the unchanged step function in one of two ways:

* **pointwise** (the scene declares ``pointwise``: ``accel[i, b]`` and ``solve[i, b]``
  depend only on entry (i, b) of the state, so every entry is its own 1-DOF system) and the
  scheme unconstrained: the step runs on a tuple of floats, one entry at a time, and numba
  inlines it into a loop of scalars without an array temporary. On one entry the steps run
  in registers (the entry outermost); on a batch the entries run innermost, over contiguous
  memory, so the loop vectorises. The entries are independent, so either order computes
  every entry's float operations in the step's order: the same states as the array path, but
  for a Newton iteration's exit, which the array path takes on the largest update over every
  entry and this loop on each entry's own (the same where the run has one entry, or the step
  one iteration).
  An implicit step on a linear scene takes one Newton iteration (exact); the file then also
  holds the step copied for exactly one (``scheme_step_once``: the iteration loop's convergence exit
  dropped, which a single pass never takes), straight-line code that vectorises.
* **array** (every other pair): the step on the state's arrays, as the interpreted driver
  runs it; each operation allocates its result.

The one loop serves both the timings and the accuracy runs: ``reference._compiled.integrate_compiled``
records it as the interpreted driver records, and computes the interpreted run's bits where every
operation of the pair is one numba and numpy compute alike (``KernelFile.bitwise_why`` empty; see
``reference._bitwise`` and ``reference._compiled.bitwise_why``).

A pair whose source cannot be copied (a global that is neither a number, a module nor a
function of this project) is compiled in memory instead, every process anew, and says so
(``Kernels.cached`` False).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import tempfile
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import _numba_config
from ._codegen import SourceUnavailable, kernel_file
from ._scheme import largest_magnitude


def cache_dir() -> Path:
    """Where kernel files and numba's cache of them live: ``$HARNESS_CACHE/kernels``, else
    ``~/.cache/integrator-harness/kernels`` (``$XDG_CACHE_HOME`` if set)."""
    root = os.environ.get("HARNESS_CACHE")
    if not root:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        root = os.path.join(base, "integrator-harness")
    return Path(root) / "kernels"


@dataclass
class Stats:
    """What this process compiled and what it loaded from the disk cache, in CPU seconds of
    this process: ``compiled`` / ``loaded`` count the first calls of a pair's entry points
    (``warm``), ``numba_s`` every numba compilation however it was reached (a variant compiled on
    a later call, a floor), from numba's own compile events."""

    compiled: int = 0
    compile_s: float = 0.0
    loaded: int = 0
    load_s: float = 0.0
    numba_s: float = 0.0

    def snapshot(self) -> dict:
        return {
            "kernels_compiled": self.compiled,
            "compile_s": self.compile_s,
            "kernels_loaded": self.loaded,
            "load_s": self.load_s,
            "numba_s": self.numba_s,
        }


STATS = Stats()


_OVERLOADS: list = []


def _register_overloads() -> None:
    """``largest_magnitude`` inside compiled code: ``abs`` of a float (the pointwise loop),
    ``max(abs)`` of an array (the array loop), as the interpreted function computes it.
    Registered before the first kernel compiles, not on import (a process that compiles nothing
    need not import numba)."""
    if _OVERLOADS:
        return
    _numba_config.configure()
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
    _listen_to_compiles()


def _listen_to_compiles() -> None:
    """Add every numba compilation of this process to ``STATS.numba_s`` (the outermost only:
    a kernel's callees compile inside it)."""
    from numba.core import event

    class _Compiles(event.Listener):
        depth, t0 = 0, 0.0

        def on_start(self, ev):
            if self.depth == 0:
                self.t0 = time.process_time()
            self.depth += 1

        def on_end(self, ev):
            self.depth -= 1
            if self.depth == 0:
                STATS.numba_s += time.process_time() - self.t0

    event.register("numba:compile", _Compiles())


# ------------------------------------------------------------------ files
def _key(text: str) -> str:
    """Hash of the kernel file's text, of this module (the overloads the text compiles
    through), of numba's and Python's versions and of the optimisation level it compiles at
    (``reference._numba_config``: numba's cache of a file does not record it)."""
    import numba

    h = hashlib.sha256(text.encode())
    h.update(Path(__file__).read_bytes())
    h.update(f"numba {numba.__version__} opt {_numba_config.opt_level()} python {sys.version}".encode())
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
    #: Why the loop might not compute the interpreted driver's bits ("" where it does, given
    #: ``libm``: the C library functions it calls, which ``reference._libm`` checks).
    bitwise_why: str = "compiled in memory from the function objects: not checked"
    libm: tuple[str, ...] = ()

    @property
    def cached(self) -> bool:
        return self.path is not None

    def dispatchers(self) -> list:
        return [self.start, self.advance_n, self.observe]


def _path(scheme, scene_cls, f) -> Path:
    return cache_dir() / f"k_{scheme.id}_{scene_cls.__name__.lower()}_{_key(f.text)}.py"


@dataclass(frozen=True)
class Cached:
    """What the disk cache holds of a pair, before anything here loads it: its kernel file (the
    pair was run on this machine before) and its loop compiled (numba's index of ``advance_n``).
    Both False for a pair compiled in memory, which nothing caches."""

    file: bool = False
    compiled: bool = False
    #: The kernel file's name (two schemes that compile as one share it); "" in memory.
    name: str = ""


def cached(scheme, scene_cls, nstate: int) -> Cached:
    try:
        path = _path(scheme, scene_cls, kernel_file(scheme, scene_cls, nstate))
    except SourceUnavailable:
        return Cached()
    if not path.exists():
        return Cached(name=path.name)
    return Cached(True, path.stem in _loops_compiled(path.parent / "__pycache__"), path.name)


def _loops_compiled(folder: Path) -> set[str]:
    """The kernel files (stems) whose loop numba has cached in ``folder``: an index
    ``<stem>.advance_n-<line>.py<version>.nbi``. The folder is listed once while it is
    unchanged (its mtime), not globbed pair by pair: it holds thousands of files."""
    try:
        stamp = folder.stat().st_mtime_ns
    except OSError:
        return set()
    have = _LISTINGS.get(folder)
    if have is None or have[0] != stamp:
        stems = {
            name.split(".advance_n-", 1)[0]
            for name in os.listdir(folder)
            if ".advance_n-" in name and name.endswith(".nbi")
        }
        have = _LISTINGS[folder] = (stamp, stems)
    return have[1]


_LISTINGS: dict[Path, tuple[int, set[str]]] = {}


def load(scheme, scene_cls, nstate: int) -> Kernels:
    """The kernels of a pair from its kernel file (written first if missing). Not yet
    compiled: the first call compiles, or loads numba's cache of the file."""
    _register_overloads()
    try:
        f = kernel_file(scheme, scene_cls, nstate)
    except SourceUnavailable as exc:
        return _in_memory(scheme, scene_cls, str(exc))
    path = _path(scheme, scene_cls, f)
    stem = path.stem
    _write_once(path, f.text)
    module = _import_file(f"_harness_kernels.{stem}", path)
    return Kernels(
        module.start, module.advance_n, module.observe, f.pointwise, path, bitwise_why=f.bitwise_why, libm=f.libm
    )


def _in_memory(scheme, scene_cls, why: str) -> Kernels:
    """The array loop compiled from the function objects themselves (not cacheable)."""
    import numba

    jit = numba.njit(error_model="numpy")
    step, scheme_start, scheme_observe = jit(scheme.step), jit(scheme.start), jit(scheme.observe)
    accel = jit(scene_cls.accel)

    @jit
    def start(q, v, t, h, p):
        return scheme_start(accel, q, v, t, h, p)

    @jit
    def observe(state, t, h, p):
        return scheme_observe(accel, state, t, h, p)

    advance_n = scheme.kind.in_memory_loop(jit, step, accel, scene_cls)
    return Kernels(start, advance_n, observe, False, None, why)


#: Told a line before a pair's loop compiles in this process (not where it loads from the disk
#: cache): a command's progress (``compile_notices``).
_NOTICES: list = []


@contextmanager
def compile_notices(tell):
    """Within the block, ``tell(line)`` is called before each loop this process compiles (a
    compile takes seconds, a load from the disk cache does not), naming the pair."""
    _NOTICES.append(tell)
    try:
        yield tell
    finally:
        _NOTICES.remove(tell)


def _will_compile(kernels: Kernels) -> bool:
    """Whether warming the pair's loop compiles it, from what the disk cache holds (``cached``)."""
    if not kernels.cached:
        return True
    return kernels.path.stem not in _loops_compiled(kernels.path.parent / "__pycache__")


def warm(kernels: Kernels, call, label: str = "") -> float:
    """Run ``call()`` (the first call of the pair's kernels, which compiles them or loads them
    from the cache), account it in ``STATS`` and return its seconds, CPU seconds of this
    process (numba compiles in this thread; a core shared with other work does not inflate them).
    ``label``: the pair, for ``compile_notices``."""
    dispatchers = kernels.dispatchers()
    if _NOTICES and _will_compile(kernels):
        where = (
            "once on this machine, then loaded from the kernel cache"
            if kernels.cached
            else f"in memory, not cached: {kernels.why_uncached}"
        )
        line = f"compiling the loop of {label or (kernels.path.stem if kernels.path else 'a pair')} ({where})"
        for tell in list(_NOTICES):
            tell(line)

    def misses():  # a dispatcher another path compiled before (``observe``) brings its own misses
        return sum(sum(d.stats.cache_misses.values()) for d in dispatchers)

    before = misses()
    t = time.process_time()
    call()
    seconds = time.process_time() - t
    if kernels.cached and misses() == before:
        STATS.loaded += 1
        STATS.load_s += seconds
    else:
        STATS.compiled += 1
        STATS.compile_s += seconds
    return seconds
