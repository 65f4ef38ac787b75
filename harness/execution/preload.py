"""Imported once by the worker forkserver (see ``isolation.PRELOAD``): every installed engine,
with its import-time output silenced, so that each worker forked from the server starts with
the engines loaded (an engine's import is a noticeable share of a short task; the server pays it
once)."""
import contextlib

from adapters import ENGINE_METHODS, import_engine

for _module in sorted({m.module for m in ENGINE_METHODS.values()}):
    with contextlib.suppress(Exception):
        import_engine(_module)
