"""The work-precision Pareto front (``harness.measures.workprecision.pareto_front``), the chart that
marks it with at most a handful of named series, and ``harness workprecision --chart``."""

from __future__ import annotations

import json

from harness.measures.workprecision import pareto_front, pareto_summary


def test_the_front_keeps_the_points_no_other_beats_in_both_cost_and_error():
    curves = {
        "a": ([1.0, 2.0, 4.0], [10.0, 5.0, 4.0]),
        "b": ([1.5, 3.0, 8.0], [3.0, 0.5, 0.01]),
        "c": ([0.5, 9.0], [50.0, 0.02]),  # cheapest at its first point; dominated by b's last
    }
    front = pareto_front(curves)
    assert front == [(0.5, 50.0, "c"), (1.0, 10.0, "a"), (1.5, 3.0, "b"), (3.0, 0.5, "b"), (8.0, 0.01, "b")]
    # every point off the front is beaten in both by one on it
    on = set(front)
    for m, (cs, es) in curves.items():
        for c, e in zip(cs, es):
            if (c, e, m) not in on:
                assert any(fc <= c and fe <= e for fc, fe, _ in front)
    assert pareto_summary(front) == [
        "c: cost 0.5, error 50",
        "a: cost 1, error 10",
        "b: cost 1.5 to 8, error 3 down to 0.01",
    ]


def test_the_chart_names_at_most_a_handful_those_on_the_front_first():
    from reports import charts

    curves = {f"ref:m{i}": ([1.0 + i, 2.0 + i], [1.0 / (1 + i), 0.5 / (1 + i)]) for i in range(12)}
    curves["ref:best"] = ([0.1, 0.2], [1e-3, 1e-4])
    fig, ax = charts.plt.subplots()
    named = charts.draw_workprecision(ax, curves)
    charts.plt.close(fig)
    assert len(named) == charts.MAX_NAMED and named[0] == "ref:best"


def test_harness_workprecision_draws_its_chart_and_states_its_front(tmp_path, capsys):
    from harness.cli import main

    png = tmp_path / "wp.png"
    argv = ["workprecision", "spring", "--method", "ref:rk4", "--method", "ref:explicit_euler", "--points", "3"]
    assert main([*argv, "--chart", str(png), "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert png.stat().st_size > 0 and "Pareto front" in out and f"chart: {png}" in out
    assert main([*argv, "--repeats", "1", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["pareto_front"] and {p["method"] for p in data["pareto_front"]} <= {"ref:rk4", "ref:explicit_euler"}
