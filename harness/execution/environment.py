"""The environment a run computes in, written in one place: the package versions a run records
(``RECORDED_PACKAGES``), the subset its numbers depend on, which a Dask worker must share with the
client (``COMPUTING_PACKAGES``), and a digest of the project's own code."""

from __future__ import annotations

import hashlib
import multiprocessing
import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path

from adapters import ENGINE_DISTS
from records.run import NUMBA_OPT_KEY

#: Packages whose version the numbers depend on: a Dask worker must run the client's. The engines'
#: are every ``adapters.ENGINES`` entry's distributions.
COMPUTING_PACKAGES = ("numpy", "scipy", "numba", *ENGINE_DISTS)

#: Packages whose version every run records (the report's appendix, the history's comparisons).
RECORDED_PACKAGES = (
    "integrator-harness",
    "numpy",
    "scipy",
    "numba",
    "pandas",
    "matplotlib",
    *ENGINE_DISTS,
    "dask",
    "distributed",
)

#: The project's packages whose code a worker runs; their digest must match the client's.
CODE_PACKAGES = ("records", "scenarios", "reference", "adapters", "harness")

_ROOT = Path(__file__).resolve().parents[2]


def _numba_opt() -> dict[str, str]:
    from reference import kernel_opt_level

    return {NUMBA_OPT_KEY: kernel_opt_level()}


def versions(packages=RECORDED_PACKAGES) -> dict[str, str | None]:
    """Installed version of each package (None where it is not installed)."""
    out = {}
    for pkg in packages:
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = None
    return out


def code_digest() -> str:
    """SHA-256 over the project's package files (path and content), to tell two copies apart."""
    h = hashlib.sha256()
    for pkg in CODE_PACKAGES:
        for path in sorted((_ROOT / pkg).rglob("*")):
            if path.suffix in (".py", ".csv", ".toml") and "__pycache__" not in path.parts:
                h.update(str(path.relative_to(_ROOT)).encode())
                h.update(path.read_bytes())
    return h.hexdigest()[:16]


def environment() -> dict:
    """What a process would compute cells with: compared between the Dask client and each worker."""
    from harness.history.storage import MEASUREMENT_VERSION

    return {
        "python": ".".join(platform.python_version_tuple()[:2]),
        "measurement version": MEASUREMENT_VERSION,
        "code digest": code_digest(),
        **versions(COMPUTING_PACKAGES),
        **_numba_opt(),
        "daemon": multiprocessing.current_process().daemon,
    }


def run_metadata() -> tuple[str | None, dict, dict]:
    """(commit, versions, machine) of a run: the checkout's commit (``+dirty`` with uncommitted
    changes to tracked files), Python's and every recorded package's version, the machine."""
    try:
        commit = (
            subprocess.run(
                ["git", "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10, cwd=_ROOT
            ).stdout.strip()
            or None
        )
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
            cwd=_ROOT,
        ).stdout.strip()
        if commit and dirty:
            commit += "+dirty"
    except (OSError, subprocess.SubprocessError):
        commit = None
    machine = {
        "node": platform.node(),
        "system": platform.system(),
        "release": platform.release(),
        "machine": platform.machine(),
        "processor": platform.processor(),
        "cpus": os.cpu_count(),
    }
    return commit, {"python": platform.python_version(), **versions(), **_numba_opt()}, machine


def plugin_versions(modules) -> dict[str, str | None]:
    """``{"plugin MODULE": version}`` of each ``$HARNESS_PLUGINS`` module: its ``__version__``
    where it declares one, else a digest of its source, so that a plugin's change (a user's own
    engine mode, stepped differently) is seen between two runs as an engine's upgrade is."""
    import importlib

    out = {}
    for name in modules:
        try:
            module = importlib.import_module(name)
        except Exception:  # noqa: BLE001 - a plugin that fails to import is reported by its tasks
            out[f"plugin {name}"] = None
            continue
        version = getattr(module, "__version__", None)
        if version is None and getattr(module, "__file__", None):
            version = "sha256:" + hashlib.sha256(Path(module.__file__).read_bytes()).hexdigest()[:12]
        out[f"plugin {name}"] = None if version is None else str(version)
    return out


def machine_busy_s() -> float | None:
    """CPU seconds the whole machine has spent busy (every process; user, system, irq) since it
    booted, from ``/proc/stat``; None where there is none (not Linux). Two readings around the
    cells, less the harness's own CPU, are what other processes took while they ran."""
    try:
        with open("/proc/stat") as fh:
            fields = fh.readline().split()
    except OSError:
        return None
    if not fields or fields[0] != "cpu":
        return None
    user, nice, system, idle, iowait, irq, softirq, steal = (int(x) for x in (fields[1:9] + ["0"] * 8)[:8])
    return (user + nice + system + irq + softirq) / os.sysconf("SC_CLK_TCK")
