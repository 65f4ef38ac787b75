"""The session's worker forkserver imports every installed engine: one test session runs every
engine's isolated workers from it, and a nightly it runs in-process would otherwise narrow it to
that nightly's engines (``harness.execution.isolation.preload_engines``: the first choice stands)."""

from adapters import ENGINE_METHODS
from harness.execution.isolation import preload_engines


def pytest_configure(config):
    preload_engines({mode.module for mode in ENGINE_METHODS.values()})
