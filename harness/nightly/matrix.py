"""Engine versions as an axis of the nightly, as asv's ``matrix`` does for dependencies:
``harness nightly --engine mujoco==3.3.7 --engine mujoco==4.0.0`` (or ``[tool.harness] engines``).

Each release gets an environment of its own, built once and kept under the harness cache
(``harness.execution.engine_env``: the release alone, installed with pip into a folder that goes
first on the path; everything else is the project's). The suite then runs once per release, each
run a nightly of its own in a process started on that environment, stored in the same history with
the versions it ran on: runs of different engine releases are different series
(``harness.history.storage.engine_series``), so a release changes nothing's regression verdict.
The matrix's own report (``<out>/report.md``) links each release's report and says, for each
engine with more than one release, what changed from one release to the next
(``reports.versions_section``).

A matrix killed part way is resumed as a nightly is (``--resume``): ``<out>/matrix.json`` records
the releases planned and the run each one stored; on resume a release whose run completed is
kept, the release whose run was killed is continued with ``--resume`` in its own environment
(its tasks already stored are kept), and the rest are run.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

from records import InvalidInput

#: Set in the environment of a run on one release of a matrix.
CHILD_ENV = "HARNESS_MATRIX_RUN"


def parse_spec(text: str) -> tuple[str, str]:
    """``"mujoco==3.3.7"`` -> ("mujoco", "3.3.7"); one-line InvalidInput otherwise."""
    from harness.execution.engine_env import dist_of, engines

    dist, sep, version = str(text).partition("==")
    dist, version = dist.strip(), version.strip()
    known = sorted(engines())
    if not sep or not dist or not version:
        raise InvalidInput(f"--engine {text!r}: write ENGINE==VERSION (engines: {', '.join(known)})")
    try:
        return dist_of(dist), version
    except InvalidInput:
        raise InvalidInput(f"--engine {text!r}: unknown engine {dist!r} (valid: {', '.join(known)})") from None


def configured_engines(pyproject: Path | str = "pyproject.toml") -> list[str]:
    """The engine releases ``[tool.harness] engines`` lists (``"mujoco==3.3.7"``), or none (and none
    in a matrix's run on one release)."""
    pyproject = Path(pyproject)
    if os.environ.get(CHILD_ENV) or not pyproject.is_file():
        return []
    try:
        data = tomllib.loads(pyproject.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise InvalidInput(f"{pyproject}: [tool.harness] cannot be read ({exc})") from None
    engines = data.get("tool", {}).get("harness", {}).get("engines", [])
    if not isinstance(engines, list) or not all(isinstance(e, str) for e in engines):
        raise InvalidInput(f"{pyproject}: [tool.harness] engines must be a list of ENGINE==VERSION (got {engines!r})")
    return engines


def plan(specs) -> dict[str, list[str]]:
    """{engine: its releases, oldest first}, every spec checked and every release resolved against
    the registry before anything is installed or run."""
    from harness.execution.engine_env import check_release, releases, version_key

    by_engine: dict[str, list[str]] = {}
    listed: dict[str, list[str]] = {}
    for text in specs:
        dist, version = parse_spec(text)
        if dist not in listed:
            listed[dist] = releases(dist)
        version = check_release(dist, version, listed[dist], field=f"--engine {dist}")
        by_engine.setdefault(dist, [])
        if version not in by_engine[dist]:
            by_engine[dist].append(version)
    return {d: sorted(vs, key=version_key) for d, vs in by_engine.items()}


def _child_env(path: Path) -> dict:
    from harness.execution.engine_env import environ

    env = environ(path)
    env[CHILD_ENV] = "1"  # the run on one release is a plain nightly, not a matrix again
    return env


#: The matrix's own record of what it planned and stored (``<out>/matrix.json``).
STATE = "matrix.json"


def _state(out: Path, suite: str, releases: dict, db: Path, resume: bool) -> dict:
    """The matrix's record: a new one (the history's last run id noted, so that a resume tells this
    matrix's runs from older ones), or on ``resume`` the one a killed matrix left, which must have
    planned the same suite and releases."""
    from harness.history.storage import History

    path = out / STATE
    planned = [[d, v] for d, vs in releases.items() for v in vs]
    if resume:
        if not path.is_file():
            raise InvalidInput(f"--resume: no engine matrix to resume in {out} (no {STATE}; run without --resume)")
        state = json.loads(path.read_text())
        if state.get("suite") != suite or state.get("planned") != planned:
            raise InvalidInput(
                f"--resume: the matrix in {out} planned {state.get('suite')} on "
                f"{', '.join('=='.join(p) for p in state.get('planned', []))}, not this; run without --resume"
            )
        return state
    runs = History(db).runs(complete_only=False) if Path(db).exists() else None
    floor = int(runs.run_id.max()) if runs is not None and not runs.empty else 0
    return {"suite": suite, "planned": planned, "after_run": floor, "stored": {}}


def _save(out: Path, state: dict) -> None:
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / f".{STATE}.{os.getpid()}.tmp"
    tmp.write_text(json.dumps(state, indent=1))
    os.replace(tmp, out / STATE)


def _left_off(db: Path, suite: str, dist: str, version: str, after: int) -> tuple[int, bool] | None:
    """The run this matrix stored for a release before it was killed: (run id, complete), or None."""
    from harness.history.storage import History

    if not Path(db).exists():
        return None
    runs = History(db).runs(complete_only=False)
    runs = runs[(runs.suite == suite) & (runs.run_id > after)]
    mine = [r for r in runs.itertuples() if ((r.versions or {}).get("engines") or {}).get(dist) == version]
    return (int(mine[-1].run_id), bool(mine[-1].complete)) if mine else None


def run_matrix(specs, suite: str, out: Path, db: Path, extra_args=(), stream=None, resume: bool = False) -> dict:
    """Run ``suite`` once per engine release of ``specs`` (module docstring); returns
    {"runs": [{"engine", "version", "run_id", "report", "regressions", "skipped"}], "report": path}.
    ``resume``: continue the matrix a kill left in ``out``."""
    from harness.execution.engine_env import ensure
    from harness.history.storage import History

    stream = stream or sys.stderr
    releases = plan(specs)
    out, db = Path(out), Path(db)
    state = _state(out, suite, releases, db, resume)
    _save(out, state)
    runs = []
    for dist, versions in releases.items():
        for version in versions:
            key = f"{dist}=={version}"
            sub_out = out / f"{dist}-{version}"
            left = _left_off(db, suite, dist, version, state["after_run"]) if resume else None
            if key in state["stored"] or (left is not None and left[1]):
                run_id = state["stored"].get(key) or left[0]
                print(f"matrix: {dist} {version}: run {run_id} stored before, kept", file=stream, flush=True)
                runs.append(_release_row(db, dist, version, run_id, sub_out, regressions=[]))
                continue
            env_path = ensure(dist, version)
            again = ["--resume"] if left is not None else []
            print(
                f"matrix: {dist} {version}: the suite on {env_path}" + (" (resumed)" if again else ""),
                file=stream,
                flush=True,
            )
            cmd = [
                sys.executable,
                "-m",
                "harness",
                "nightly",
                "--suite",
                suite,
                "--db",
                str(db),
                "--out",
                str(sub_out),
                "--json",
                *again,
                *extra_args,
            ]
            done = subprocess.run(cmd, env=_child_env(env_path), stdout=subprocess.PIPE, stderr=stream, text=True)
            if done.returncode not in (0, 1):
                raise InvalidInput(
                    f"--engine {dist}=={version}: the run on that release stopped (exit "
                    f"{done.returncode}); the other releases' runs are stored (--resume continues)"
                )
            summary = json.loads(done.stdout)
            run_id = int(summary["run_id"])
            recorded = (History(db).run(run_id)["versions"].get("engines") or {}).get(dist)
            if recorded != version:
                raise InvalidInput(f"--engine {dist}=={version}: the run imported {dist} {recorded} instead")
            runs.append(_release_row(db, dist, version, run_id, sub_out, summary["regressions"]))
            state["stored"][key] = run_id
            _save(out, state)
    for run in runs:  # JSON keys are text
        run["skipped_lines"] = [f"{m} on {s}: {why}" for (s, m), why in run["skipped"].items()]
    report = write_matrix_report(suite, releases, runs, db, out)
    return {"runs": runs, "report": report}


def _release_row(db: Path, dist: str, version: str, run_id: int, sub_out: Path, regressions) -> dict:
    from harness.history.storage import History

    stored = History(db).run(run_id)
    skipped = {
        (s["scene"], s["method"]): s["reason"]
        for s in stored["settings"].get("skipped", [])
        if s["method"].split(":")[0] == dist
    }
    return {
        "engine": dist,
        "version": version,
        "run_id": run_id,
        "report": str(sub_out / "report.md"),
        "regressions": regressions,
        "skipped": skipped,
    }


def write_matrix_report(suite: str, releases: dict, runs: list[dict], db: Path, out: Path) -> Path:
    """The matrix's report: each release's run and report, then "Between versions" per engine."""
    from harness.history.storage import History
    from reports.versions_section import between_versions_section

    history = History(db)
    lines = [f"# Engine versions: the {suite} suite on each release", ""]
    lines += [
        f"- {r['engine']} {r['version']}: run {r['run_id']}, [report]({Path(r['report']).relative_to(out)})"
        + (f", {len(r['regressions'])} regression(s) in its own series" if r["regressions"] else "")
        for r in runs
    ]
    lines.append("")
    for dist in releases:
        mine = [r for r in runs if r["engine"] == dist]
        if len(mine) < 2:
            continue
        groups = [(r["version"], history.cell_records(r["run_id"])) for r in mine]
        lines += between_versions_section(dist, groups, {r["version"]: r["skipped"] for r in mine})
    out.mkdir(parents=True, exist_ok=True)
    report = out / "report.md"
    tmp = out / f".report.md.{os.getpid()}.tmp"
    tmp.write_text("\n".join(lines) + "\n")
    os.replace(tmp, report)
    return report
