"""Engine versions as an axis: runs on different engine releases are different series (never a
regression of each other), and the report says what changed from one release to the next."""

from __future__ import annotations


from records.cell import Cell, CostFigures, EnergyFigures, IdentityFigures

from harness.history.storage import History, engine_series
from harness.nightly.run import engine_versions, version_change_lines
from reports.versions_section import between_versions_section, compare_releases


def _cell(method, measure, value, **figures):
    kind = {"energy": EnergyFigures, "identity": IdentityFigures, "cost": CostFigures}[measure]
    return Cell(
        scene="spring",
        method=method,
        family=method.split(":")[0],
        measure=measure,
        status="ok",
        value=value,
        dt=0.1,
        steps=100,
        figures=kind(**figures),
    )


def _run(history, mujoco_version, cells):
    versions = {"mujoco": mujoco_version, "numpy": "2", "engines": {"mujoco": mujoco_version, "pymunk": "7.3.1"}}
    run_id = history.start_run(
        started="2026-11-26T00:00:00", suite="toy", git_commit="abc", versions=versions, machine={}, settings={}
    )
    history.add_task_cells(run_id, "t", cells)
    history.finish_run(run_id, finished="2026-11-26T00:01:00", wall_s=1.0, timing={}, regressions=0)
    return run_id


def test_the_nightly_records_every_adapters_engine_version():
    import adapters

    recorded = engine_versions()  # each mode's engine, and what an engine computes through (Newton's Warp)
    assert set(recorded) == {m.dist for m in adapters.ENGINE_METHODS.values()} | {"warp-lang"}
    assert recorded["mujoco"] is not None


def test_runs_on_another_engine_release_are_another_series(tmp_path):
    h = History(tmp_path / "h.sqlite")
    a = _run(h, "3.3.7", [_cell("mujoco:euler", "energy", 1e-3, energy_class="bounded")])
    b = _run(h, "4.0.0", [_cell("mujoco:euler", "energy", 2e-3, energy_class="bounded")])
    c = _run(h, "4.0.0", [_cell("mujoco:euler", "energy", 2e-3, energy_class="bounded")])
    assert engine_series(h.run(b)["versions"]) == (("mujoco", "4.0.0"), ("pymunk", "7.3.1"))
    assert h.previous_complete(b) is None and h.previous_complete(b, same_engines=False) == a
    assert h.previous_complete(c) == b
    # The trend of run c holds runs b and c only, and says what it left out.
    from harness.history.series import load

    trend = load(h, run_id=c)
    assert [r.run_id for r in trend.runs] == [b, c]
    assert "on other engine releases left out" in trend.left_out


def test_an_upgrade_is_reported_as_a_version_change_with_what_changed(tmp_path):
    h = History(tmp_path / "h.sqlite")
    old = [
        _cell("mujoco:euler", "energy", 1e-3, energy_class="bounded"),
        _cell("mujoco:rk4", "energy", 5e-9, energy_class="decays"),
        _cell("mujoco:euler", "identity", 0.0, match="ref:semi_implicit_euler"),
        _cell("pymunk:spring_force", "energy", 1e-3, energy_class="bounded"),
    ]
    new = [
        _cell("mujoco:euler", "energy", 1e-3, energy_class="bounded"),
        _cell("mujoco:rk4", "energy", 6e-9, energy_class="decays"),
        _cell("mujoco:euler", "identity", 0.0, match="ref:semi_implicit_euler"),
        _cell("mujoco:discrete", "energy", 1e-2, energy_class="decays"),
        _cell("pymunk:spring_force", "energy", 1e-3, energy_class="bounded"),
    ]
    _run(h, "3.3.7", old)
    b = _run(h, "4.0.0", new)
    lines = version_change_lines(h, b)
    text = "\n".join(lines)
    assert "mujoco 3.3.7 → 4.0.0" in text and "nothing is compared as a regression" in text
    assert "2 cells bit for bit unchanged, 1 changed" in text
    assert "| spring | `mujoco:rk4` | energy | 5e-09 (decays) | 6e-09 (decays) | value |" in text
    assert "`mujoco:discrete` on spring: measured on mujoco 4.0.0 only; on 3.3.7: no such cell on mujoco 3.3.7" in text
    assert "pymunk" not in text  # an engine whose release did not change is not compared


def test_releases_that_change_nothing_read_bit_for_bit_unchanged_and_cost_within_its_spread():
    a = [
        _cell("mujoco:euler", "energy", 1e-3, energy_class="bounded"),
        _cell("mujoco:euler", "cost", 1e-6, ratio_to_explicit_euler=10.0),
    ]
    b = [
        _cell("mujoco:euler", "energy", 1e-3, energy_class="bounded"),
        _cell("mujoco:euler", "cost", 1.2e-6, ratio_to_explicit_euler=12.0),
    ]
    res = compare_releases("mujoco", ("3.3.7", a), ("4.0.0", b))
    assert res.unchanged == 2 and not res.changed
    lines = between_versions_section("mujoco", [("3.3.7", a), ("4.0.0", b)])
    assert "**mujoco 3.3.7 → 4.0.0**: bit for bit unchanged (2 cells)." in lines
    slower = [b[0], _cell("mujoco:euler", "cost", 2e-6, ratio_to_explicit_euler=20.0)]
    assert len(compare_releases("mujoco", ("3.3.7", a), ("4.0.0", slower)).changed) == 1


def test_an_advice_cell_is_compared_less_its_costs_and_a_crashed_cell_meets_its_counterpart():
    from records.cell import AdviceFigures

    def advice(cost, substeps):
        return Cell(
            scene="spring",
            method="mujoco:euler",
            family="mujoco",
            measure="advise",
            status="ok",
            value=cost,
            dt=1 / 60,
            figures=AdviceFigures(best=0, rows=[{"substeps": substeps, "cost_per_frame_s": cost}]),
        )

    assert compare_releases("mujoco", ("a", [advice(1e-5, 4)]), ("b", [advice(2e-5, 4)])).unchanged == 1
    changed = compare_releases("mujoco", ("a", [advice(1e-5, 4)]), ("b", [advice(1e-5, 8)])).changed
    assert len(changed) == 1
    crashed = Cell(
        scene="spring",
        method="mujoco:euler",
        family="mujoco",
        measure="energy",
        status="crashed",
        value=None,
        dt=None,
        figures=EnergyFigures(),
    )
    res = compare_releases(
        "mujoco", ("a", [crashed]), ("b", [_cell("mujoco:euler", "energy", 1e-3, energy_class="bounded")])
    )
    assert len(res.changed) == 1 and not res.only_before and not res.only_after
