"""An engine's installation, as every adapter asks about it: its import with the engine's own
output silenced, the release installed, the releases an adapter supports, and the ``Engine`` entry
each engine package declares.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import importlib.metadata
import os
import re
import sys
from dataclasses import dataclass, field
from collections.abc import Callable, Mapping


@contextlib.contextmanager
def quiet_fds():
    """Send file descriptors 1 and 2 to /dev/null for the duration (C-level output included:
    pybullet prints its build banner with printf on import). C stdio buffers are flushed
    before the descriptors are put back, so buffered engine output cannot surface later.
    Where 1 or 2 is not open there is nothing to protect, and nothing is redirected."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    try:
        saved = [os.dup(1), os.dup(2)]
    except OSError:
        yield
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        _flush_c_stdio()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


def _flush_c_stdio() -> None:
    try:
        import ctypes

        ctypes.CDLL(None).fflush(None)
    except Exception:  # pragma: no cover - no C library to flush (not on Linux/macOS)
        pass


def import_engine(name: str):
    """Import an engine module with its import-time output silenced."""
    if sys.modules.get(name) is not None:  # already imported: skip the descriptor juggling
        return sys.modules[name]
    with quiet_fds():
        return importlib.import_module(name)


def engine_version(dist: str) -> str | None:
    """The installed version of ``dist``: the first one on ``sys.path``, so an engine environment
    put ahead of the venv (``harness.execution.engine_env``) names its own release. Asked once per
    distribution and search path: every method lookup checks it (``EngineMode.available``), and
    reading the metadata scans the path."""
    return _engine_version(dist, tuple(sys.path))


@functools.lru_cache(maxsize=64)
def _engine_version(dist: str, path: tuple) -> str | None:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return None


_VERSION = re.compile(r"^v?(\d+(?:\.\d+)*)(?:[.-]?(a|b|rc)(\d+))?(?:[.-]?post(\d+))?(?:[.-]?dev(\d+))?$")


def version_key(version: str) -> tuple:
    """A sort key of a release number (PEP 440's final, pre-, post- and dev-releases: what a
    registry lists): ``2.3.1.post1`` after ``2.3.1``, ``3.0.0rc1`` before ``3.0.0``, trailing
    zeros ignored (``4.0`` == ``4.0.0``). ValueError for anything else."""
    match = _VERSION.match(version.strip())
    if match is None:
        raise ValueError(f"{version!r} is not a release number")
    release, pre, pre_n, post, dev = match.groups()
    parts = [int(x) for x in release.split(".")]
    while len(parts) > 1 and parts[-1] == 0:
        parts.pop()
    pre_key = ({"a": 0, "b": 1, "rc": 2}[pre], int(pre_n)) if pre else (3, 0)
    return (tuple(parts), pre_key, int(post) if post else -1, int(dev) if dev else 1 << 30)


@dataclass(frozen=True)
class EngineVersions:
    """The engine releases an adapter supports (``low`` inclusive up to ``below`` exclusive, None:
    no upper bound) and those it was measured on (``tested``). Between releases the adapter asks
    the engine what it has (a member of an enum, a binding's signature), not its version."""

    low: str
    below: str | None = None
    tested: tuple[str, ...] = ()

    def __contains__(self, version: str) -> bool:
        key = version_key(version)
        return key >= version_key(self.low) and (self.below is None or key < version_key(self.below))

    def __str__(self) -> str:
        return f">={self.low}" + (f",<{self.below}" if self.below else "")

    def outside(self, dist: str, version: str | None) -> str | None:
        """Why ``version`` of ``dist`` cannot be used (one line naming the range), None where it can."""
        if version is None:
            return None
        try:
            if version in self:
                return None
        except ValueError:
            pass
        tested = f"; tested on {', '.join(self.tested)}" if self.tested else ""
        return f"{dist} {version} is outside the versions its adapter supports ({dist}{self}{tested})"


@dataclass(frozen=True)
class Engine:
    """One engine, declared once in its package (``adapters/<engine>/``, as ``ENGINE``): everything
    the harness lists by engine is read from these entries (``adapters.ENGINES``), never written
    out again by hand.

    ``id``: the family its method ids carry (``drake`` in ``drake:radau3``); ``module``: what is
    imported (``pydrake``); ``dists``: the distributions whose release its numbers depend on, the
    engine's own first (its release, ``dist``), then any it computes through (Newton's Warp);
    ``versions``: the releases its adapter supports; ``methods``: its modes by id; ``poses``: how it
    poses each scene (``POSES``); ``build``: its model builder, ``build(engine, mode, scene, dt,
    count=False)``; ``bare_loops``: its bare loops for ``harness bench --engines``,
    ``bare_loops(mode, engine, model, scene, dt) -> ([(name, once(n)), ...], what they are)`` on a
    model ``build`` made, the first the target's; ``model_loader``: how it loads a user's model file
    (None: it loads none); ``loader_without_contact``: why that loader's models step without their
    contacts (None: with them); ``submodules``: what its adapter imports where it builds a model
    beyond the engine's top-level import (a worker's server preloads them); ``contact_modes``: its
    contact modes by id (``adapters/<engine>/contact.py``'s ``MODES``: each integrator with its
    contact model, posing the contact scenes its ``POSES`` there names)."""

    id: str
    module: str
    dists: tuple[str, ...]
    versions: EngineVersions
    methods: Mapping[str, object]
    poses: Mapping[str, object]
    build: Callable
    bare_loops: Callable | None = None
    model_loader: str | None = None
    loader_without_contact: str | None = None
    submodules: tuple[str, ...] = ()
    contact_modes: Mapping[str, object] = field(default_factory=dict)

    @property
    def dist(self) -> str:
        """The engine's own distribution: its release is the engine's."""
        return self.dists[0]
