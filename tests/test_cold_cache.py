"""A nightly on an empty kernel cache (a fresh machine, a CI runner that keeps nothing) and on a full
one store the same cells, bit for bit; the run says beforehand what it will compile, and afterwards
what compiling took and what a kept cache would have saved; a second run compiles nothing.

Each (scheme, scene) pair has one compiled loop, for its timings and its accuracy runs alike
(``harness.nightly.kernels``): the first run compiles it, the next ones load it. Timings are injected
(``HARNESS_INJECT_TIMINGS``), so that the cost cells are as deterministic as the accuracy figures;
what differs between the runs is only how they ran (the kernels compiled or loaded, the seconds).
"""

import json
import subprocess
import sys
from dataclasses import replace

import pytest

from harness.history.storage import History
from harness.nightly.kernels import KernelPlan
from harness.nightly.progress import compile_line
from records.run import RunTiming
from tests.shared_fixture import built_once
from tests.test_resume import CLOCKED, ROOT, SUITE, TIMINGS, cells_of, env

#: How a run ran, beside what it measured.
HOW = CLOCKED
#: The resume tests' suite less a scheme and an engine mode, and its bound: one reference task (its
#: energy, error, order, cost, advice and stability cells), one engine task (its identity too, whose
#: candidates step on their compiled loops).
COLD = replace(SUITE, name="cold-smoke", methods=("ref:rk4", "mujoco:euler"), bounds=False)


#: One nightly of ``COLD`` in a process of its own, so that its worker processes start with this
#: test's ``HARNESS_CACHE`` (a forkserver another test started keeps the environment it had).
NIGHTLY = (
    "import sys; from pathlib import Path; from harness.nightly.run import run_nightly; "
    "from tests.test_cold_cache import COLD; run_nightly(COLD, Path(sys.argv[1]), Path(sys.argv[2]), jobs=2)"
)


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    """The suite twice on one kernel cache, empty at first: {run: (cells, timing, progress,
    stored cells)}; once per test run."""
    return built_once(tmp_path_factory, "cold-cache-runs", _two_runs)


def _two_runs(tmp):
    timings = tmp / "timings.json"
    timings.write_text(json.dumps(TIMINGS))
    db = tmp / "h.sqlite"
    out = {}
    for run in (1, 2):
        done = subprocess.run(
            [sys.executable, "-c", NIGHTLY, str(tmp / "out"), str(db)],
            cwd=ROOT,
            text=True,
            env=env(HARNESS_INJECT_TIMINGS=str(timings), HARNESS_CACHE=str(tmp / "cache")),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            timeout=600,
        )
        assert done.returncode == 0, done.stderr[-2000:]
        history = History(db)
        out[run] = (cells_of(db, run), RunTiming.of(history.run(run)["timing"]), done.stderr, history.cells(run))
    return out


def _measured(cells: dict) -> dict:
    """The cells less how they ran (``cells_of`` leaves out the clocks; the backend too)."""
    out = {}
    for key, (status, detail, value, data) in cells.items():
        out[key] = (
            status,
            detail,
            value,
            json.dumps({k: v for k, v in json.loads(data).items() if k not in HOW}, sort_keys=True),
        )
    return out


def _backends(frame) -> set:
    energy = frame[(frame.measure == "energy") & (frame.family == "ref")]
    return {d["backend"] for d in energy.data}


def test_an_empty_and_a_full_kernel_cache_store_the_same_cells(two_runs):
    cold, warm = (two_runs[r][0] for r in (1, 2))
    assert _measured(cold) == _measured(warm)  # every figure bitwise, the accuracy cells too
    # ... each run's accuracy runs on the one compiled loop, compiled in the first, loaded in the second.
    assert _backends(two_runs[1][3]) == _backends(two_runs[2][3]) == {"compiled"}


def test_the_run_says_what_it_will_compile_and_what_compiling_took(two_runs):
    (_, t1, p1, _), (_, t2, p2, _) = (two_runs[r] for r in (1, 2))
    # Empty: RK4's loop (its task) and explicit Euler's (the cost cells' baseline and the
    # calibration's). The identity candidates beside mujoco:euler compile nothing: their loops are
    # not in the cache, so their runs are interpreted (the same bits), and kept on disk.
    assert p1.splitlines()[0].startswith("cold cache: about 2 kernels to compile (of the 2 the run steps)")
    # (Explicit Euler's loop may compile in both workers, which need it at once: hence "about".)
    assert 2 <= t1.kernels_compiled <= 3 and t1.numba_compile_s > 0
    assert "compiling: " in p1 and "a kept kernel cache would have saved about" in p1
    # The second run: nothing compiles, and it says so before and after.
    assert p2.splitlines()[0].startswith("kernel cache warm: nothing to compile")
    assert t2.kernels_compiled == 0 and t2.kernels_loaded > 0
    assert p2.splitlines()[-1].startswith("kernels: ") and "none compiled" in p2.splitlines()[-1]


def test_what_a_cache_would_have_saved():
    # 40 CPU-s compiling 20 kernels; this run loaded 10 in 0.5 s: a load costs 0.05 s here.
    t = RunTiming(numba_compile_s=40.0, kernels_compiled=20, kernels_loaded=10, kernel_load_s=0.5, worker_cpu_s=80.0)
    assert t.cache_would_save_s == pytest.approx(40.0 - 20 * 0.05)
    assert t.compile_share == pytest.approx(0.5)
    assert compile_line(t) == (
        "compiling: 40.0 CPU-s for 20 kernels (50% of the workers' CPU); a kept kernel "
        "cache would have saved about 39 CPU-s"
    )
    # None loaded to measure a load by: the stated 0.02 s.
    assert RunTiming(numba_compile_s=10.0, kernels_compiled=100).cache_would_save_s == pytest.approx(8.0)
    assert KernelPlan(0, "/c", 5).line() == "kernel cache warm: nothing to compile; kernel cache /c"
    # Some of the run's loops cached: not a cold cache.
    assert (
        KernelPlan(3, "/c", 5).line() == "kernel cache: about 3 kernels to compile (of the 5 the run steps); "
        "kernel cache /c"
    )
    assert KernelPlan(5, "/c", 5).line().startswith("cold cache: about 5 kernels to compile (of the 5")
