"""Engine environments: one folder per engine release, built once under the harness cache and
reused, from which a process imports that release of the engine instead of the venv's.

* :func:`releases` lists a distribution's releases from the package registry (``pip index
  versions``), oldest first.
* :func:`ensure` installs exactly one release into ``<cache>/engines/<dist>-<version>`` with
  ``pip install --no-deps --target`` (into a temporary folder renamed into place when complete,
  so a folder that exists is whole) and returns the folder; a second call installs nothing.
  Besides the release itself it installs what the venv lacks of the release's own requirements:
  its companions pinned to the same version (mujoco 4's code is the ``mujoco-core`` distribution)
  and any requirement the venv does not satisfy (mujoco 3.3.7 imports ``typing_extensions``
  through ``etils``). Everything else (numpy, ...) comes from the venv.
* :func:`environ` is the environment of a process that runs on one: the folder first on
  ``PYTHONPATH`` (ahead of the venv's site-packages, so ``import mujoco`` and
  ``importlib.metadata.version("mujoco")`` find that release), this checkout after it.
  ``python_command`` is the interpreter to start (the venv's).

The cache is the harness cache (``$HARNESS_CACHE``, else ``~/.cache/integrator-harness``: the
folder that holds the compiled kernels). Bad input is ``records.InvalidInput``, one line naming
the field and the valid choices, raised before anything is installed.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
from importlib import metadata
from pathlib import Path

from records import InvalidInput

#: The cache's subfolder holding one folder per engine release.
ENGINES_DIR = "engines"

#: Seconds ``pip`` may wait for the registry per request, and its retries: a registry that does
#: not answer is said so promptly instead of after pip's default minutes of retrying.
PIP_TIMEOUT_S = 20
PIP_RETRIES = 1

#: What pip prints when it cannot reach the registry (as opposed to a name it does not know).
_UNREACHABLE = re.compile(
    r"NewConnectionError|ConnectTimeout|ReadTimeout|Max retries exceeded|"
    r"Temporary failure in name resolution|Name or service not known|Connection refused|"
    r"Network is unreachable|ProxyError|SSLError|Could not fetch URL|No route to host",
    re.I,
)

_PROJECT_ROOT = Path(__file__).resolve().parents[2]


def cache_root() -> Path:
    """The harness cache: ``$HARNESS_CACHE``, else ``$XDG_CACHE_HOME`` or ``~/.cache``, then
    ``integrator-harness`` (the folder ``reference``'s kernel cache lives in)."""
    from reference import kernel_cache_dir

    return kernel_cache_dir().parent


def env_dir(dist: str, version: str) -> Path:
    """Where release ``version`` of ``dist`` lives once :func:`ensure` has built it."""
    return cache_root() / ENGINES_DIR / f"{dist}-{version}"


def engines() -> dict[str, str]:
    """Engine name -> its distribution, for every engine mode the harness knows (the adapters'
    and those of the plugins in ``$HARNESS_PLUGINS``)."""
    from adapters import ENGINES
    from harness.methods import all_methods

    out: dict[str, str] = {e.id: e.dist for e in ENGINES.values()}
    for method in all_methods().values():
        dist = getattr(method, "dist", None) or getattr(getattr(method, "inner", None), "dist", None)
        engine = getattr(method, "engine", None) or getattr(getattr(method, "inner", None), "engine", None)
        if dist and engine:
            out.setdefault(engine, dist)
    return out


def dist_of(engine: str) -> str:
    """The distribution of engine (or distribution) ``engine``; InvalidInput naming the valid ones."""
    known = engines()
    if engine in known:
        return known[engine]
    if engine in known.values():
        return engine
    raise InvalidInput(f"engine: unknown engine {engine!r} (valid: {', '.join(sorted(known))})")


def version_key(version: str) -> tuple:
    from adapters import version_key as key

    return key(version)


def _pip(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    cmd = [
        sys.executable,
        "-m",
        "pip",
        *args,
        "--disable-pip-version-check",
        "--timeout",
        str(PIP_TIMEOUT_S),
        "--retries",
        str(PIP_RETRIES),
    ]
    return subprocess.run(cmd, capture_output=True, text=True, env=env)


def _unreachable(text: str) -> bool:
    return bool(_UNREACHABLE.search(text))


def releases(dist: str, *, env: dict | None = None) -> list[str]:
    """The releases of ``dist`` the registry lists (``pip index versions``), oldest first.

    InvalidInput where the registry does not answer (an offline machine) or does not know
    ``dist``. ``env``: the environment pip runs in (tests point ``PIP_INDEX_URL`` elsewhere)."""
    done = _pip("index", "versions", dist, env=env)
    text = done.stdout + done.stderr
    if done.returncode != 0:
        if _unreachable(text):
            raise InvalidInput(
                f"engine: the package registry did not answer for {dist!r} (offline? pip index "
                f"versions failed: {_last_error(text)})"
            )
        raise InvalidInput(f"engine: the package registry lists no releases of {dist!r} ({_last_error(text)})")
    for line in done.stdout.splitlines():
        if line.startswith("Available versions:"):
            listed = [v.strip() for v in line.split(":", 1)[1].split(",") if v.strip()]
            usable = []
            for v in listed:
                try:
                    version_key(v)
                except ValueError:
                    continue
                usable.append(v)
            return sorted(usable, key=version_key)
    raise InvalidInput(f"engine: pip index versions printed no release list for {dist!r}")


def _last_error(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip() and not line.startswith("WARNING: Location")]
    errors = [line for line in lines if line.startswith("ERROR")]
    return (errors or lines or ["no output"])[-1][:200]


def nearest(version: str, listed: list[str], n: int = 2) -> list[str]:
    """Up to ``n`` listed releases on each side of ``version`` (by release order)."""
    try:
        key = version_key(version)
    except ValueError:
        return listed[-n:]
    below = [v for v in listed if version_key(v) < key][-n:]
    above = [v for v in listed if version_key(v) > key][:n]
    return below + above


def check_release(dist: str, version: str, listed: list[str], field: str = "version") -> str:
    """``version`` as the registry spells it where ``listed`` has it (``4.0`` finds ``4.0.0``),
    else InvalidInput naming the nearest releases."""
    if version in listed:
        return version
    try:
        key = version_key(version)
    except ValueError:
        key = None
    same = [v for v in listed if key is not None and version_key(v) == key]
    if same:
        return same[0]
    near = nearest(version, listed)
    raise InvalidInput(f"{field}: {dist} has no release {version!r} (nearest: {', '.join(near) or 'none listed'})")


def check_range(dist: str, low: str, high: str, listed: list[str]) -> list[str]:
    """The listed releases from ``low`` to ``high`` inclusive, both checked (``check_release``);
    InvalidInput where the range is in the wrong order."""
    low = check_release(dist, low, listed, "LOW")
    high = check_release(dist, high, listed, "HIGH")
    if version_key(low) >= version_key(high):
        raise InvalidInput(
            f"LOW, HIGH: {dist} {low} is not older than {high} (give the older release first, e.g. {dist} {high} {low})"
            if version_key(low) > version_key(high)
            else f"LOW, HIGH: both are {dist} {low} (give two different releases)"
        )
    return [v for v in listed if version_key(low) <= version_key(v) <= version_key(high)]


def _venv_has(requirement) -> bool:
    """Whether the venv (not an engine folder) satisfies ``requirement`` (a packaging Requirement)."""
    try:
        have = metadata.version(requirement.name)
    except metadata.PackageNotFoundError:
        return False
    return not requirement.specifier or requirement.specifier.contains(have, prereleases=True)


def _requirements(folder: Path, name: str, extras: frozenset = frozenset()) -> list:
    """The requirements of distribution ``name`` installed in ``folder`` that apply here (markers
    evaluated, with ``extras``)."""
    from packaging.requirements import Requirement  # matplotlib's dependency: always in the venv

    dists = list(metadata.distributions(path=[str(folder)], name=name))
    if not dists:
        return []
    out = []
    for line in dists[0].requires or ():
        req = Requirement(line)
        if req.marker is None or any(req.marker.evaluate({"extra": e}) for e in (extras or {""})):
            out.append(req)
    return out


def _install(target: Path, specs: list[str]) -> None:
    done = _pip("install", "--no-deps", "--no-compile", "--quiet", "--target", str(target), *specs)
    if done.returncode != 0:
        text = done.stdout + done.stderr
        if _unreachable(text):
            raise InvalidInput(
                f"engine: the package registry did not answer while installing {' '.join(specs)} "
                f"(offline? {_last_error(text)})"
            )
        raise InvalidInput(f"engine: pip could not install {' '.join(specs)} ({_last_error(text)})")


def _normal(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _build(dist: str, version: str, target: Path) -> None:
    """Install ``dist==version`` into ``target`` without its dependencies, then what the venv lacks
    of its requirements (module docstring), each with ``--no-deps``, until nothing is missing."""
    _install(target, [f"{dist}=={version}"])
    done: set[str] = {_normal(dist)}
    todo = [(dist, frozenset())]
    while todo:
        wanted = []
        for name, extras in todo:
            for req in _requirements(target, name, extras):
                key = _normal(req.name)
                pinned_here = str(req.specifier) == f"=={version}"
                if key in done or (not pinned_here and _venv_has(req)):
                    continue
                done.add(key)
                wanted.append(req)
        if not wanted:
            break
        _install(target, [f"{r.name}{r.specifier}" for r in wanted])
        todo = [(r.name, frozenset(r.extras)) for r in wanted]


def ensure(dist: str, version: str, *, listed: list[str] | None = None) -> Path:
    """The folder holding release ``version`` of ``dist`` (an engine name is taken for its
    distribution), built on the first call and reused after (module docstring). The version is
    checked against the registry's list first (``listed``, else :func:`releases`) where the folder
    does not exist yet: a release that does not exist is InvalidInput naming the nearest ones."""
    dist = dist_of(dist)
    folder = env_dir(dist, version)
    if folder.is_dir():
        return folder
    listed = releases(dist) if listed is None else listed
    version = check_release(dist, version, listed)
    folder = env_dir(dist, version)
    if folder.is_dir():
        return folder
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{dist}-{version}-", dir=folder.parent))
    try:
        _build(dist, version, tmp)
        try:
            tmp.rename(folder)
        except OSError:  # another process finished the same release first: theirs is whole
            if not folder.is_dir():
                raise
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return folder


def environ(folder: Path | str | None, base: dict | None = None) -> dict[str, str]:
    """The environment of a process that imports its engine from ``folder`` (None: the venv's):
    ``folder`` first on PYTHONPATH, this checkout after it, the rest of ``base`` (default
    ``os.environ``) kept."""
    env = dict(os.environ if base is None else base)
    parts = [str(folder)] if folder is not None else []
    parts.append(str(_PROJECT_ROOT))
    if env.get("PYTHONPATH"):
        parts.append(env["PYTHONPATH"])
    env["PYTHONPATH"] = os.pathsep.join(parts)
    return env


def python_command() -> list[str]:
    """The interpreter a process on an engine folder runs: this one (the venv's)."""
    return [sys.executable]


def run_harness(
    folder: Path | str | None, argv: list[str], *, env: dict | None = None, timeout: float | None = None
) -> subprocess.CompletedProcess:
    """``harness ARGV`` in a new process importing its engine from ``folder`` (``environ``);
    stdout and stderr captured as text."""
    return subprocess.run(
        [*python_command(), "-m", "harness", *argv],
        capture_output=True,
        text=True,
        env=environ(folder, env),
        timeout=timeout,
    )
