"""The nightly on a Dask cluster: the same cells as a local run, lost workers, bad schedulers.

Two nightlies of a small suite (``SUITE``) run once for the module: one in local worker processes, one on
``--scheduler local:2`` with ``tests/dask_faults.py`` preloaded into the Dask workers (Dask's own
``distributed.worker.preload``), so that one task kills its worker once and another kills it
on every attempt. Comparing the two covers both "same numbers as a local run" and "a killed
worker costs its cell one retry", in one Dask run.
"""

import contextlib
import json
import os
import re
import signal
import socket
import time
from collections import Counter
from pathlib import Path

import dask
import pytest
from dask.distributed import LocalCluster

import dask_faults
from harness.execution import distributed
from harness.cli import main
from harness.execution.isolation import ORPHAN_GRACE_S, WorkerFailure, run_in_worker
from harness.execution.cpu_limit import WALL_FACTOR
from harness.nightly.cells import run_task
from harness.nightly.run import Task, build_tasks
from harness.history.storage import History
from harness.nightly.run import run_nightly
from harness.nightly.suites import SUITES, SceneSpec, Suite
from tests.shared_fixture import built_once
from records.cell import FIGURES

FAULTS = str(Path(__file__).with_name("dask_faults.py"))
KILLED_ONCE = "cell spring ref:rk4"  # its worker dies on the first attempt only
KILLED_ALWAYS = "cell spring ref:implicit_euler"  # its worker dies on every attempt
KEY = ["scene", "method", "measure", "dt"]


#: The cluster's run and its local twin: the least suite with every kind of task the cluster must
#: carry (two reference schemes and two engine modes, each with every measure), ``KILLED_ONCE`` among them.
SUITE = Suite(
    "dask-smoke",
    scenes={"spring": SceneSpec(periods=2, order_span=2.0, advise=SUITES["smoke"].scenes["spring"].advise)},
    methods=("ref:semi_implicit_euler", "ref:rk4", "mujoco:euler", "pymunk:applied_force"),
    cost_repeats=3,
    bounds=False,
    frame_rates=SUITES["smoke"].frame_rates,
)


def nightly_argv(tmp, *extra):
    return ["nightly", "--suite", "smoke", "--out", str(tmp / "out"), "--db", str(tmp / "h.sqlite"), *extra]


def stored(tmp):
    history = History(tmp / "h.sqlite")
    runs = history.runs(complete_only=False)
    return runs, history.cells(int(runs.run_id.iloc[-1]))


def _nightly(tmp, **where) -> int:
    """``SUITE``'s nightly, its exit code as ``harness nightly`` gives it (1: a regression)."""
    result = run_nightly(SUITE, tmp / "out", tmp / "h.sqlite", **where)
    return 1 if result["regressions"] else 0


def _local_run(tmp):
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv(distributed.ENV_VAR, raising=False)
        code = _nightly(tmp, jobs=2)
    return tmp, code


@pytest.fixture(scope="module")
def local_run(tmp_path_factory):
    return built_once(tmp_path_factory, "distributed-local", _local_run)


@contextlib.contextmanager
def worker_kills(tmp, plan: dict):
    """Dask workers that preload tests/dask_faults.py with ``plan`` (task label -> attempts that
    die), logging every attempt under ``tmp/kills``; no scheduler from the environment. Restores
    the worker preload and the daemon flag the executor sets for its LocalCluster."""
    kills = tmp / "kills"
    kills.mkdir()
    config = {
        "distributed.worker.preload": [FAULTS],
        "distributed.worker.daemon": dask.config.get("distributed.worker.daemon"),
    }
    with pytest.MonkeyPatch.context() as mp, dask.config.set(config):
        mp.delenv(distributed.ENV_VAR, raising=False)
        mp.setenv(dask_faults.PLAN_VAR, json.dumps(plan))
        mp.setenv(dask_faults.DIR_VAR, str(kills))
        yield


def _dask_run(tmp):
    with worker_kills(tmp, {KILLED_ONCE: 1}):
        code = _nightly(tmp, scheduler="local:2")
    return tmp, code


@pytest.fixture(scope="module")
def dask_run(tmp_path_factory):
    return built_once(tmp_path_factory, "distributed-dask", _dask_run)


@pytest.fixture(scope="module")
def dask_dead_run(tmp_path_factory):
    """One task, whose worker dies on every attempt, on ``local:2``."""
    tmp = tmp_path_factory.mktemp("dask_dead")
    suite = Suite("dead", scenes={"spring": SceneSpec(periods=1)}, methods=(KILLED_ALWAYS.split()[-1],), bounds=False)
    with worker_kills(tmp, {KILLED_ALWAYS: 99}):
        result = run_nightly(suite, tmp / "out", tmp / "h.sqlite", scheduler="local:2")
    return tmp, result, suite


def test_dask_smoke_run_matches_the_local_run_cell_for_cell(local_run, dask_run):
    """Tolerance: none. Both runs execute the same code on the same machine, and every accuracy
    number is a deterministic floating-point computation (no randomness, no threads in a scheme),
    so the Dask run reproduces it bit for bit: the cell retried after its worker died included.
    Cost cells hold wall time per step, which no two runs share: their status and their counted
    force evaluations are compared instead; advice cells (a cost per frame) their measured rows,
    less the cost."""
    (ltmp, lcode), (dtmp, dcode) = local_run, dask_run
    assert (lcode, dcode) == (0, 0)
    _, local = stored(ltmp)
    _, on_dask = stored(dtmp)
    # dt is NaN for the cells of a sweep (order, stability); -1 makes those keys compare equal.
    local = local.fillna({"dt": -1.0}).set_index(KEY).sort_index()
    on_dask = on_dask.fillna({"dt": -1.0}).set_index(KEY).sort_index()
    assert list(local.index) == list(on_dask.index)
    tasks, _ = build_tasks(SUITE)
    assert len(local) == sum(len(t.measures()) for t in tasks)
    for key, a in local.iterrows():
        b = on_dask.loc[key]
        assert (key, b.status) == (key, a.status)
        fa, fb = (FIGURES[key[2]].from_data(r.data)[0] for r in (a, b))
        if key[2] == "cost":
            assert fb.force_evals_per_step == fa.force_evals_per_step, key
        elif key[2] == "advise":

            def measured(rows):
                return [{k: v for k, v in r.items() if k != "cost_per_frame_s"} for r in rows]

            assert measured(fb.rows) == measured(fa.rows), key
            assert fb.best == fa.best, key
        else:
            assert b.value == a.value or (a.value != a.value and b.value != b.value), (key, a.value, b.value)
            assert b.data.get("class") == a.data.get("class"), key


def test_a_killed_worker_costs_its_cell_one_retry_and_every_cell_is_stored_once(dask_run):
    tmp, code = dask_run
    assert code == 0
    runs, cells = stored(tmp)
    assert runs.complete.tolist() == [1]
    assert not cells.duplicated(KEY).any()
    tasks, _ = build_tasks(SUITE)
    expected = Counter((t.scene, t.method, m) for t in tasks for m in t.measures())
    assert Counter(zip(cells.scene, cells.method, cells.measure)) == expected

    kills = tmp / "kills"
    once = dask_faults.attempts(kills, KILLED_ONCE)
    assert [a.split()[0] for a in once] == ["killed", "ran"]
    assert once[0].split()[1] != once[1].split()[1]  # the retry ran in another worker process
    rk4 = cells[cells.method == "ref:rk4"]
    assert set(rk4.status) == {"ok"}
    assert set(cells.status) == {"ok"}  # the death cost no other task its cell


def test_a_worker_killed_on_every_attempt_costs_its_task_two_attempts_then_crashed_cells(dask_dead_run):
    tmp, result, suite = dask_dead_run
    always = dask_faults.attempts(tmp / "kills", KILLED_ALWAYS)
    assert [a.split()[0] for a in always] == ["killed", "killed"]
    assert len(always) == distributed.ALLOWED_FAILURES + 1 == 2  # one retry, not Dask's default three
    assert always[0].split()[1] != always[1].split()[1]
    _, cells = stored(tmp)
    tasks, _ = build_tasks(suite)
    assert [t.label for t in tasks] == [KILLED_ALWAYS]
    assert len(cells) == len(tasks[0].measures()) >= 5 and set(cells.status) == {"crashed"}
    for detail in cells.detail:
        assert "Dask worker died on each of 2 attempts (KilledWorker" in detail
    report = (tmp / "out" / "report.md").read_text()
    assert "| `ref:implicit_euler` | crashed |" in report


def test_the_report_footer_says_where_the_cells_ran(local_run, dask_run):
    (ltmp, _), (dtmp, _) = local_run, dask_run
    local_footer = (ltmp / "out" / "report.md").read_text().split("\n---\n")[-1]
    assert "Cells ran on: local worker processes (2 at a time)" in local_footer
    footer = (dtmp / "out" / "report.md").read_text().split("\n---\n")[-1]
    where = re.search(
        r"Cells ran on: (Dask LocalCluster at tcp://127\.0\.0\.1:\d+ \(2 worker processes, "
        r"1 thread each; a cell whose worker dies is retried once\))",
        footer,
    )
    assert where, footer
    runs, _ = stored(dtmp)
    assert runs.settings.iloc[-1]["executor"] == where.group(1)


# ----------------------------------------------------------------------------- the option
@pytest.mark.parametrize(
    "spec, says",
    [
        ("local:0", "local:N needs N >= 1"),
        ("local:two", "local:N needs N >= 1"),
        ("scheduler", "expected local:N"),
        ("tcp://scheduler", "expected local:N"),
        ("http://scheduler:8786", "unknown scheme 'http'"),
        ("tcp://scheduler:99999", "not in 1..65535"),
    ],
)
def test_a_bad_scheduler_is_one_line_exit_2_before_anything_runs(tmp_path, capsys, spec, says):
    assert main(nightly_argv(tmp_path, "--scheduler", spec)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--scheduler={spec}: " in err and says in err
    assert not (tmp_path / "h.sqlite").exists()


@pytest.mark.parametrize("spec", ["tcp://10.0.0.5:8786", "scheduler:8786", "tls://[::1]:8786", "local:4"])
def test_good_scheduler_forms_parse(spec):
    assert distributed.parse_scheduler(spec)[0] == ("local" if spec.startswith("local") else "address")


def test_the_scheduler_comes_from_the_environment_unless_the_command_line_says_otherwise(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv(distributed.ENV_VAR, "tcp://10.0.0.5:8786")
    assert distributed.resolve_scheduler(None, jobs_given=False) == ("tcp://10.0.0.5:8786", "$HARNESS_SCHEDULER")
    assert distributed.resolve_scheduler("local:2", jobs_given=False) == ("local:2", "--scheduler")
    assert distributed.resolve_scheduler(None, jobs_given=True) is None  # --jobs asks for local processes
    monkeypatch.setenv(distributed.ENV_VAR, "nowhere")
    assert main(nightly_argv(tmp_path)) == 2
    assert "$HARNESS_SCHEDULER=nowhere: expected local:N" in capsys.readouterr().err
    assert main(nightly_argv(tmp_path, "--scheduler", "local:2", "--jobs", "2")) == 2
    assert capsys.readouterr().err.startswith("harness: error: --jobs: ")
    assert not (tmp_path / "h.sqlite").exists()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def previous_run(db) -> History:
    history = History(db)
    run = history.start_run(
        started="2026-01-01T00:00:00+00:00", suite="smoke", git_commit=None, versions={}, machine={}, settings={}
    )
    history.finish_run(run, finished="2026-01-01T00:01:00+00:00", wall_s=60.0, timing={}, regressions=0)
    return history


def test_an_unreachable_scheduler_is_one_line_exit_2_and_nothing_stored_is_lost(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(distributed, "CONNECT_TIMEOUT_S", 1.0)  # nobody listens: no need to wait 30 s
    history = previous_run(tmp_path / "h.sqlite")
    address = f"tcp://127.0.0.1:{free_port()}"
    assert main(nightly_argv(tmp_path, "--scheduler", address)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--scheduler={address}: no Dask scheduler reachable within 1 s" in err
    assert history.runs(complete_only=False).run_id.tolist() == [1]


def test_a_scheduler_without_workers_is_exit_2(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(distributed, "WORKER_WAIT_S", 0.5)
    with LocalCluster(n_workers=0, processes=False, protocol="tcp", dashboard_address=None) as cluster:
        assert main(nightly_argv(tmp_path, "--scheduler", cluster.scheduler_address)) == 2
    assert "the scheduler has no workers (none joined within 0.5 s)" in capsys.readouterr().err
    assert History(tmp_path / "h.sqlite").runs(complete_only=False).empty


@pytest.mark.parametrize("loss", ["workers retired", "scheduler closed"])
def test_a_cluster_lost_mid_run_stops_the_run_incomplete_exit_3(tmp_path, monkeypatch, capsys, loss):
    """Never a hung run: with no worker left, or no scheduler, the client gives up (within
    WORKER_WAIT_S, or the client's reconnection timeout) instead of waiting for results forever."""
    monkeypatch.setattr(distributed, "WORKER_WAIT_S", 1.0)
    monkeypatch.setattr(distributed, "CONNECT_TIMEOUT_S", 1.0)
    history = previous_run(tmp_path / "h.sqlite")
    cluster = LocalCluster(n_workers=1, processes=False, protocol="tcp", dashboard_address=None)
    describe = distributed.DaskExecutor._describe

    def describe_then_lose_the_cluster(self, kind):  # the last step before cells are sent
        out = describe(self, kind)
        if loss == "workers retired":
            self.client.retire_workers()
        else:
            cluster.close()
        return out

    monkeypatch.setattr(distributed.DaskExecutor, "_describe", describe_then_lose_the_cluster)
    try:
        assert main(nightly_argv(tmp_path, "--scheduler", cluster.scheduler_address)) == 3
    finally:
        cluster.close()
    err = capsys.readouterr().err.splitlines()[-1]
    assert err.endswith("the run is left incomplete (never compared, the previous report kept)")
    assert ("no workers for 1 s" if loss == "workers retired" else "lost the connection to the Dask scheduler") in err
    assert history.runs(complete_only=True).run_id.tolist() == [1]
    assert history.runs(complete_only=False).complete.tolist() == [1, 0]
    assert not (tmp_path / "out" / "report.md").exists()


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return Path(f"/proc/{pid}").exists() and "Z" not in Path(f"/proc/{pid}/stat").read_text().split()[2]


def wait_for(predicate, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.05)
    return predicate()


def test_a_hung_cell_in_a_dask_worker_is_timed_out_and_never_outlives_its_worker(tmp_path):
    """The cell's child process is killed at the timeout; the Dask worker survives (same pid) and
    runs the next task. A 1 ms limit stands for a hang: no child answers within it. And a child
    whose Dask worker is killed first (nobody left to enforce its limit) ends itself ORPHAN_GRACE_S
    after WALL_FACTOR times its limit of wall time (a sleeping hang spends no CPU) instead of hanging
    on for good."""
    bound = Task("bound", "spring", "ref:semi_implicit_euler", "ref", {}, "smoke", 0.1, 1000, 1.0)
    with dask.config.set({"distributed.worker.daemon": dask.config.get("distributed.worker.daemon")}):
        executor = distributed.DaskExecutor("local:1", run_task=run_task)
        try:
            assert executor.describe().endswith(
                "(1 worker process, 1 thread each; a cell whose worker dies is retried once)"
            )
            pid = executor.client.run(os.getpid)
            [(_, hung)] = list(executor.run([bound], timeout=0.001))
            [(_, cells)] = list(executor.run([bound], timeout=60.0))
            assert executor.client.run(os.getpid) == pid

            pid_file, limit = tmp_path / "child.pid", 0.5
            executor.client.submit(run_in_worker, dask_faults.hang, (str(pid_file),), timeout=limit, pure=False)
            assert wait_for(pid_file.exists, 10.0)
            os.kill(next(iter(pid.values())), signal.SIGKILL)
            child = int(pid_file.read_text())
            assert alive(child)  # orphaned, and hung
            assert wait_for(lambda: not alive(child), WALL_FACTOR * limit + ORPHAN_GRACE_S + 3.0)
        finally:
            executor.close()
    assert isinstance(hung, WorkerFailure) and hung.status == "timed_out"
    assert "0.001 CPU s limit" in hung.detail and hung.detail.endswith("worker killed")
    assert [(c.measure, c.status) for c in cells] == [("bound", "ok")]
