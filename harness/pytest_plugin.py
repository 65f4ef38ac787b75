"""pytest plugin (entry point ``integrator_harness`` in pyproject.toml): puts the versions that
decide the numbers (numpy, scipy, numba) in the test report's header, so a failing tolerance can
be read against what produced it."""
from __future__ import annotations

from importlib import metadata


def pytest_report_header(config):
    versions = []
    for name in ("numpy", "scipy", "numba"):
        try:
            versions.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            versions.append(f"{name} missing")
    return "integrator-harness: " + ", ".join(versions)
