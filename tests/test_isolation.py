"""Worker-process isolation: an abort, a segfault, a hang or an exception in an engine run
becomes a recorded result, and the harness goes on (issue 3, "Isolation and failure").

The probe functions below run inside the worker; they must be module-level so that the
worker can import them by name.
"""

from __future__ import annotations

import ctypes
import os
import time

import pytest

from harness.execution.isolation import WorkerFailure, run_in_worker
from harness.execution.pool import WorkerPool, report_partial
from harness.execution.simulate import simulate_isolated
from scenarios import make_scene


def double_and_chatter(x):
    print("python stdout noise")
    os.write(1, b"fd-1 noise\n")
    os.write(2, b"fd-2 noise\n")
    ctypes.CDLL(None).printf(b"C stdio noise\n")
    with open("MUJOCO_LOG.TXT", "w") as f:
        f.write("a file an engine leaves in its working directory\n")
    return {"value": 2 * x, "cwd": os.getcwd()}


def abort_probe():
    os.abort()


def segfault_probe():
    ctypes.string_at(0)


def hang_probe(pid_file):
    with open(pid_file, "w") as f:
        f.write(str(os.getpid()))
    time.sleep(600)


def spin_probe(pid_file):
    """A computation that never ends: it spends CPU for as long as it is let."""
    with open(pid_file, "w") as f:
        f.write(str(os.getpid()))
    x = 0
    while True:
        x += 1


def nap_probe(seconds):
    """A call that waits without computing (as a worker does while neighbours hold the cores)."""
    time.sleep(seconds)
    return "done"


def raise_probe():
    raise ValueError("the engine refused")


def remember_probe(value=None):
    """A pool worker keeps module state between calls: what a call left, the next one sees."""
    global _REMEMBERED
    before = globals().get("_REMEMBERED")
    _REMEMBERED = value
    return os.getpid(), before


def partial_then_abort_probe():
    report_partial({"measure": "energy"})
    report_partial({"measure": "error"})
    os.abort()


def rebound_dt_zero_hang():
    # REBOUND's integrate(t) never returns with dt = 0 (sim.steps(n) does; the adapter uses that).
    import rebound

    sim = rebound.Simulation()
    sim.integrator = "leapfrog"
    sim.dt = 0.0
    sim.add(m=1.0)
    sim.add(m=0.0, x=0.5, vy=1.7)
    sim.integrate(1.0)


def test_result_comes_back_and_noise_and_files_stay_in_the_worker(tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)
    out = run_in_worker(double_and_chatter, (21,), timeout=60)
    assert out["value"] == 42
    assert os.path.realpath(out["cwd"]) != os.path.realpath(tmp_path)
    assert not os.path.exists(out["cwd"])  # the worker's temporary directory is removed
    assert os.listdir(tmp_path) == []
    captured = capfd.readouterr()
    assert "noise" not in captured.out + captured.err


def test_abort_is_crashed_with_the_signal_and_the_harness_goes_on():
    failure = run_in_worker(abort_probe, timeout=60)
    assert isinstance(failure, WorkerFailure)
    assert (failure.status, failure.signal) == ("crashed", "SIGABRT")
    assert "SIGABRT" in failure.detail
    assert run_in_worker(divmod, (7, 2), timeout=60) == (3, 1)


def test_segfault_is_crashed_with_the_signal():
    failure = run_in_worker(segfault_probe, timeout=60)
    assert (failure.status, failure.signal) == ("crashed", "SIGSEGV")
    assert "Segmentation fault" in failure.detail  # faulthandler's first line, from the worker


def test_a_computation_past_its_cpu_limit_is_timed_out_and_the_worker_is_killed(tmp_path):
    # The limit is the worker's CPU, which includes importing this module in it: the probe may not
    # have started when a short limit strikes. Such a try proves nothing about the kill, so the
    # limit doubles until the probe was running when it struck.
    pid_file, limit = tmp_path / "pid", 1.0
    while True:
        failure = run_in_worker(spin_probe, (str(pid_file),), timeout=limit)
        assert failure.status == "timed_out" and "CPU s" in failure.detail and f"limit {limit:g}" in failure.detail
        if (pid_file.exists() and pid_file.read_text()) or limit >= 32:
            break
        limit *= 2
    with pytest.raises(ProcessLookupError):
        os.kill(int(pid_file.read_text()), 0)


def test_a_hang_that_spends_no_cpu_is_stopped_after_its_wall_factor(tmp_path, monkeypatch):
    from harness.execution import cpu_limit

    pid_file = tmp_path / "pid"
    failure = run_in_worker(hang_probe, (str(pid_file),), timeout=0.2)  # hung at 10 x 0.2 s of wall time
    assert failure.status == "timed_out" and "hung" in failure.detail and cpu_limit.WALL_FACTOR == 10.0
    with pytest.raises(ProcessLookupError):
        os.kill(int(pid_file.read_text()), 0)


def test_a_call_slowed_by_its_neighbours_is_not_timed_out():
    """Waiting is not spending: a call whose wall time runs to three times its limit while it
    spends almost no CPU (what a loaded machine does to a worker) finishes and is measured."""
    assert run_in_worker(nap_probe, (3.0,), timeout=1.0) == "done"
    with WorkerPool(1) as pool:
        assert pool.call(nap_probe, (3.0,), timeout=1.0) == "done"


def test_exception_is_crashed_with_the_exception():
    failure = run_in_worker(raise_probe, timeout=60)
    assert failure.status == "crashed" and failure.detail == "raised ValueError: the engine refused"
    assert "Traceback" in failure.output


def test_real_engine_hang_rebound_dt_zero_is_timed_out():
    failure = run_in_worker(rebound_dt_zero_hang, timeout=2.0)
    assert failure.status == "timed_out"


def test_real_engine_abort_pymunk_negative_mass_is_a_crashed_trajectory():
    # Scene validation refuses m <= 0; mutating the values hands the engine what the harness
    # never would (runner.simulate re-validates; simulate_isolated deliberately does not).
    spring = make_scene("spring")
    spring.values["m"] = -1.0
    run = simulate_isolated("pymunk:applied_force", spring, 0.1, 10, timeout=60)
    assert run.status == "crashed" and run.failed_step is None
    assert "SIGABRT" in run.detail and "Mass must be positive" in run.detail
    assert run.meta.worker["signal"] == "SIGABRT" and run.meta.engine_version == "7.3.1"
    assert run.q.shape == (0, 1, 1)
    after = simulate_isolated("pymunk:applied_force", make_scene("spring"), 0.1, 10, timeout=60)
    assert after.ok and len(after.step) == 11


def test_slow_engine_run_is_a_timed_out_trajectory_then_the_harness_goes_on():
    kepler = make_scene("kepler")
    run = simulate_isolated("rebound:ias15", kepler, 0.01, 10**8, timeout=1.0)
    assert run.status == "timed_out" and "worker killed" in run.detail
    after = simulate_isolated("rebound:whfast", kepler, 0.01, 100, timeout=60)
    assert after.ok and after.meta.engine_version


def test_pool_reuses_its_worker_and_replaces_one_that_dies_or_hangs(tmp_path):
    with WorkerPool(1) as pool:
        pid, before = pool.call(remember_probe, ("kernels",), timeout=60)
        assert before is None
        assert pool.call(remember_probe, timeout=60) == (pid, "kernels")  # same process, state kept
        failure = pool.call(raise_probe, timeout=60)  # an exception costs the call, not the worker
        assert failure.status == "crashed" and failure.detail == "raised ValueError: the engine refused"
        assert pool.call(remember_probe, timeout=60)[0] == pid
        failure, stats = pool.call_with_stats(partial_then_abort_probe, timeout=60)
        assert (failure.status, failure.signal) == ("crashed", "SIGABRT")
        assert failure.partial == [{"measure": "energy"}, {"measure": "error"}]  # sent before it died
        assert stats.cpu_s is None and stats.worker_pid == pid
        pid2, before = pool.call(remember_probe, timeout=60)
        assert pid2 != pid and before is None  # a fresh worker took over
        failure = pool.call(spin_probe, (str(tmp_path / "pid"),), timeout=1.0)
        assert failure.status == "timed_out" and "CPU s" in failure.detail
        with pytest.raises(ProcessLookupError):
            os.kill(int((tmp_path / "pid").read_text()), 0)
        result, stats = pool.call_with_stats(divmod, (7, 2), timeout=60)
        assert result == (3, 1) and stats.cpu_s is not None and stats.worker_pid not in (pid, pid2)
        assert pool.started == 3


#: A process that starts a pool worker, prints the worker's folder and waits to be killed.
_KILLED_CALLER = """
import os, time
from harness.execution.pool import WorkerPool
pool = WorkerPool(1)
pool.call(os.getpid, timeout=60)
print(next(iter(pool._all)).workdir, flush=True)
time.sleep(600)
"""


def test_a_pool_worker_whose_caller_is_killed_removes_its_folder_and_one_let_go_too(tmp_path):
    """A nightly killed with SIGKILL (a lost machine, the OOM killer) leaves no worker folder behind
    in the temporary directory: its workers see the pipe close, end and take their folders with
    them; a pool closed as usual removes them as well."""
    import signal
    import subprocess
    import sys
    from pathlib import Path

    with WorkerPool(1) as pool:
        pool.call(os.getpid, timeout=60)
        closed = Path(next(iter(pool._all)).workdir)
        assert closed.is_dir()
    assert not closed.exists()

    root = Path(__file__).resolve().parents[1]
    caller = subprocess.Popen(
        [sys.executable, "-c", _KILLED_CALLER],
        cwd=root,
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(root)},
    )
    folder = Path(caller.stdout.readline().strip())
    assert folder.is_dir() and folder.name.startswith("harness-worker-")
    caller.send_signal(signal.SIGKILL)
    caller.wait(timeout=60)
    deadline = time.monotonic() + 60  # the worker sees EOF at once; a loaded machine may take a while
    while folder.exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not folder.exists()


#: In a fresh process: a run that names its engines has a forkserver that imports those and no
#: other, the first choice standing; the workers' sys.modules say what the server imported.
NARROWED = """
from harness.execution import isolation
from tests.test_isolation import imported
isolation.preload_engines({"pymunk"})
isolation.preload_engines({"mujoco", "newton"})
print(isolation.run_in_worker(imported, (("pymunk", "mujoco", "newton"),), timeout=60))
"""


def imported(names) -> list:
    import sys

    return [n for n in names if n in sys.modules]


def test_a_run_that_names_its_engines_preloads_those_alone_and_the_first_choice_stands():
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    out = subprocess.run(
        [sys.executable, "-c", NARROWED],
        cwd=root,
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONPATH": str(root)},
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split("\n")[-2] == "['pymunk']"


def cpu_timed_probe():
    """A compiled loop timed on the process CPU clock, as the cost measure times it."""
    from harness.measures.cost import wall_time_per_step
    from harness.methods import get_method

    timed = wall_time_per_step(
        get_method("ref:rk4", compiled_where_bitwise=True), make_scene("spring"), 1 / 60, repeats=3, clock="cpu"
    )
    return timed["s_per_step"]


def test_a_call_with_a_limit_keeps_the_cpu_clock_fine_enough_to_time_a_fast_loop():
    """The limit's own timers must not coarsen the clock the cost measures read: a process CPU timer
    makes Linux read CLOCK_PROCESS_CPUTIME_ID at the scheduler's tick, and a 1-DOF spring's
    timed run then reads as no time at all."""
    with WorkerPool(1) as pool:
        assert pool.call(cpu_timed_probe, timeout=120) > 0.0
    assert run_in_worker(cpu_timed_probe, timeout=120) > 0.0
