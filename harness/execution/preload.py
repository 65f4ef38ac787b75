"""Imported once by the worker forkserver (see ``isolation.PRELOAD``): the installed engines,
with their import-time output silenced, so that each worker forked from the server starts with
the engines loaded (an engine's import is a noticeable share of a short task; the server pays it
once). Every engine, unless the process that started the server named the ones its run uses
(``isolation.preload_engines``, passed in ``isolation.ENGINES_ENV``)."""

import contextlib
import os

from adapters import ENGINES, import_engine
from harness.execution.isolation import ENGINES_ENV

#: Submodules an adapter imports where it builds a model (an engine's top-level import does not
#: load them; ``Engine.submodules``): a worker forked without them imports them afresh, on every
#: one-step map a stability search runs in a worker of its own.
SUBMODULES = {e.module: e.submodules for e in ENGINES.values() if e.submodules}

_NAMED = os.environ.get(ENGINES_ENV)
_MODULES = {e.module for e in ENGINES.values()}
for _module in sorted(_MODULES if _NAMED is None else _MODULES & set(filter(None, _NAMED.split(",")))):
    with contextlib.suppress(Exception):
        import_engine(_module)
        for _sub in SUBMODULES.get(_module, ()):
            import_engine(_sub)
