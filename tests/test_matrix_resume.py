"""A killed engine-version matrix resumes (``harness nightly --engine ... --resume``): the releases
whose runs completed are kept, the release whose run was killed is continued with ``--resume`` in
its own environment, the rest are run. The child nightly on each release is replaced here by a
stand-in that stores a run as the real one does (its versions, complete or not), so that the
matrix's own bookkeeping is what is tested; the nightly's resume itself is tested in
tests/test_nightly.py."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from records import InvalidInput
from harness.history.storage import History
from harness.nightly import matrix

RELEASES = {"mujoco": ["3.3.7", "3.4.0"], "pymunk": ["7.3.1"]}


@pytest.fixture
def fake_matrix(monkeypatch, tmp_path):
    """The matrix with its plan, environments and child runs stood in for: each child stores a run
    of the release it is given, completes it unless told to die, and records how it was called."""
    calls, dies = [], set()
    db = tmp_path / "h.sqlite"
    monkeypatch.setattr(matrix, "plan", lambda specs: RELEASES)
    monkeypatch.setattr("harness.execution.engine_env.ensure", lambda dist, version: Path(f"/env/{dist}-{version}"))
    current: dict = {}
    monkeypatch.setattr(matrix, "_child_env", lambda path: current.update(env=str(path)) or {})

    def child(cmd, env=None, stdout=None, stderr=None, text=None):
        dist, version = Path(current["env"]).name.split("-")
        resumed = "--resume" in cmd
        calls.append((dist, version, resumed))
        h = History(db)
        if resumed:
            runs = h.runs(complete_only=False)
            run_id = int(runs.run_id.iloc[-1])
        else:
            run_id = h.start_run(
                started="now",
                suite="smoke",
                git_commit="c",
                versions={"engines": {dist: version}},
                machine={},
                settings={"skipped": []},
            )
        if (dist, version) in dies and not resumed:
            return subprocess.CompletedProcess(cmd, -9, stdout="")
        h.finish_run(run_id, finished="then", wall_s=1.0, timing={}, regressions=0)
        return subprocess.CompletedProcess(cmd, 0, stdout=json.dumps({"run_id": run_id, "regressions": []}))

    monkeypatch.setattr(matrix.subprocess, "run", child)
    monkeypatch.setattr(matrix, "write_matrix_report", lambda *a: tmp_path / "out" / "report.md")
    return calls, dies, db, tmp_path / "out"


def test_a_killed_matrix_resumes_where_it_stopped(fake_matrix):
    calls, dies, db, out = fake_matrix
    dies.add(("mujoco", "3.4.0"))
    with pytest.raises(InvalidInput, match="--resume continues"):
        matrix.run_matrix(["x"], "smoke", out, db)
    assert calls == [("mujoco", "3.3.7", False), ("mujoco", "3.4.0", False)]
    calls.clear()
    result = matrix.run_matrix(["x"], "smoke", out, db, resume=True)
    # the completed release kept, the killed one continued, the one never started run
    assert calls == [("mujoco", "3.4.0", True), ("pymunk", "7.3.1", False)]
    assert [(r["engine"], r["version"], r["run_id"]) for r in result["runs"]] == [
        ("mujoco", "3.3.7", 1),
        ("mujoco", "3.4.0", 2),
        ("pymunk", "7.3.1", 3),
    ]
    assert json.loads((out / matrix.STATE).read_text())["stored"] == {
        "mujoco==3.3.7": 1,
        "mujoco==3.4.0": 2,
        "pymunk==7.3.1": 3,
    }


def test_a_matrix_killed_after_a_release_finished_but_before_it_was_noted_keeps_that_run(fake_matrix):
    calls, dies, db, out = fake_matrix
    matrix.run_matrix(["x"], "smoke", out, db)
    state = json.loads((out / matrix.STATE).read_text())
    state["stored"] = {"mujoco==3.3.7": 1}  # as if killed between run 2's end and its note
    (out / matrix.STATE).write_text(json.dumps(state))
    calls.clear()
    result = matrix.run_matrix(["x"], "smoke", out, db, resume=True)
    assert calls == [] and [r["run_id"] for r in result["runs"]] == [1, 2, 3]


def test_resuming_what_is_not_there_or_another_matrix_is_one_line(fake_matrix, monkeypatch):
    calls, dies, db, out = fake_matrix
    with pytest.raises(InvalidInput, match="no engine matrix to resume"):
        matrix.run_matrix(["x"], "smoke", out, db, resume=True)
    matrix.run_matrix(["x"], "smoke", out, db)
    monkeypatch.setattr(matrix, "plan", lambda specs: {"mujoco": ["3.3.7"]})
    with pytest.raises(InvalidInput, match="not this; run without --resume"):
        matrix.run_matrix(["x"], "smoke", out, db, resume=True)
