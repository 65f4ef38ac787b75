"""A measure is one declared object (``records.measures``): a measure registered from a test-only
module (``tests/momentum_measure.py``, named in ``$HARNESS_PLUGINS``, editing no other file) is in
``harness list``, measured as a nightly cell, stored in the history, compared run to run by its
own rule, judged by its own findings, and reported with its column and its chart. The same module
dropped into ``harness/nightly/measures/`` is a built-in measure (docs/contributing.md's recipe)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from records.measures import REGISTRY, Measure, columns, measures, register, trended

from harness.history.storage import History
from harness.nightly.run import run_nightly
from harness.nightly.suites import SceneSpec, Suite

PLUGIN = "tests.momentum_measure"


@pytest.fixture(autouse=True)
def _forget_the_toy_measure():
    """The toy measure leaves this test process's registry when the test ends (a later test's
    nightly in the same process must not measure it)."""
    yield
    from records.measures import unregister

    unregister("momentum")


def test_the_built_in_measures_are_registered_in_the_order_a_task_runs_them():
    from harness.nightly import cells
    from harness.nightly.measures import declared

    names = [m.name for m in measures()]
    # The harness registers them: the task's own, then every module's of harness.nightly.measures.
    assert names[: len(cells.MEASURES) + len(declared())] == [m.name for m in (*cells.MEASURES, *declared())]
    assert names[:7] == ["identity", "energy", "error", "order", "cost", "advise", "stability"]
    assert {"constraint", "damping", "stability_vs_damping", "scaling", "brouwer", "cross_engine"} <= set(names)
    assert [c.header for c in columns()][:5] == [
        "max \\|ΔE/E\\|",
        "energy",
        "max global error",
        "order",
        "largest stable h·ω",
    ]
    # The task's own measures the history trends; a measure added to harness/nightly/measures
    # declares its own ``trend`` and joins them without this line changing.
    assert {"energy", "error", "order", "stability", "cost"} <= set(trended())
    assert not {"identity", "advise"} & set(trended())
    with pytest.raises(ValueError, match="already registered"):
        register(Measure("energy"))


def test_a_measure_from_a_test_only_module_is_listed_measured_stored_compared_judged_and_reported(
    tmp_path, monkeypatch
):
    monkeypatch.setenv("HARNESS_PLUGINS", PLUGIN)
    listed = subprocess.run(
        [sys.executable, "-m", "harness", "list"],
        capture_output=True,
        text=True,
        env={**__import__("os").environ, "PYTHONPATH": "."},
        timeout=300,
    )
    assert listed.returncode == 0, listed.stderr
    assert "momentum" in listed.stdout.split("Methods")[0]

    suite = Suite(
        "toy",
        scenes={"spring": SceneSpec(periods=2)},
        methods=("ref:semi_implicit_euler", "ref:explicit_euler"),
        bounds=False,
        identify=False,
    )
    db, out = tmp_path / "h.sqlite", tmp_path / "out"
    first = run_nightly(suite, out, db, jobs=1)
    second = run_nightly(suite, out, db, jobs=1)
    assert "momentum" in REGISTRY and REGISTRY["momentum"].figures.__name__ == "MomentumFigures"
    cells = History(db).cell_records(second["run_id"])
    momentum = {c.method: c for c in cells if c.measure == "momentum"}
    assert set(momentum) == {"ref:semi_implicit_euler", "ref:explicit_euler"}
    # Stored and read back with its own figures type.
    assert type(momentum["ref:explicit_euler"].figures).__name__ == "MomentumFigures"
    # Independent number: explicit Euler gains energy, so its peak momentum passes the exact one;
    # semi-implicit Euler's stays within its bounded band (h*omega / 2 of it at most).
    assert momentum["ref:explicit_euler"].value > 1.0
    homega = momentum["ref:semi_implicit_euler"].dt * 1.0
    assert abs(momentum["ref:semi_implicit_euler"].value - 1.0) <= homega
    assert second["previous"] == first["run_id"] and second["regressions"] == []
    report = (out / "report.md").read_text()
    assert "peak \\|p\\| / exact" in report
    assert "`ref:explicit_euler` on `spring`: peak |p| is" in report
    assert f"charts/run{second['run_id']}-spring-momentum.png" in report
    assert (out / "charts" / f"run{second['run_id']}-spring-momentum.png").is_file()
    # The history trends it, and its own rule compares it.
    from harness.history.compare import compare_cells

    frame = History(db).cells(second["run_id"])
    worse = frame.copy()
    worse.loc[(worse.measure == "momentum") & (worse.method == "ref:semi_implicit_euler"), "value"] = 1.5
    found = [r for r in compare_cells(frame, worse, []) if r.measure == "momentum"]
    assert [r.kind for r in found] == ["momentum"]
    assert "momentum" in trended()


def test_a_built_in_measure_is_one_module_in_harness_nightly_measures(tmp_path, monkeypatch):
    """docs/contributing.md's recipe, followed as written: the toy measure's module, put in
    ``harness/nightly/measures/`` as ``momentum.py`` (a folder added to the package's path here,
    so the tree is untouched) with no other file edited, is among the built-in measures the
    harness registers, and a nightly task measures it."""
    import harness.nightly.measures as builtin
    from harness.nightly.cells import run_task
    from harness.nightly.run import Task

    shutil.copy(Path(__file__).with_name("momentum_measure.py"), tmp_path / "momentum.py")
    monkeypatch.setattr(builtin, "__path__", [*builtin.__path__, str(tmp_path)])
    monkeypatch.delitem(sys.modules, f"{builtin.__name__}.momentum", raising=False)
    try:
        found = builtin.declared()
        assert "momentum" in [m.name for m in found] and "momentum" not in REGISTRY
        for m in found:
            register(m, builtin=True)  # what harness.nightly.cells does with every one of them
        assert "momentum" in [m.name for m in measures()] and "momentum" in trended()
        suite = Suite(
            "toy",
            scenes={"spring": SceneSpec(periods=2)},
            methods=("ref:explicit_euler",),
            bounds=False,
            identify=False,
        )
        cells = {c.measure: c for c in run_task(Task("cell", "spring", "ref:explicit_euler", "ref", {}, suite))}
        assert cells["momentum"].status == "ok" and type(cells["momentum"].figures).__name__ == "MomentumFigures"
        assert cells["momentum"].value > 1.0  # explicit Euler gains energy: its peak momentum passes the exact one
        assert set(cells) >= {"energy", "error", "order", "cost", "stability"}
    finally:
        sys.modules.pop(f"{builtin.__name__}.momentum", None)
