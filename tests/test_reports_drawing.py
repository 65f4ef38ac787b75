"""Drawing a report's charts in worker processes (reports.drawing): the same files as drawing them
one after another, and a chart that raises or kills its worker costs that chart only.
The report written from a real run, drawn both ways, is checked in test_nightly.py."""

import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from reports import charts
from reports.drawing import Chart, ChartNotDrawn, draw_charts


def line_chart(slope: float, path: Path) -> bool:
    """A line of the given slope: a chart with something to draw."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(3, 2))
    x = np.linspace(0.1, 10, 20)
    ax.plot(x, slope * x, label=f"slope {slope:g}")
    ax.set_yscale("log")
    ax.legend()
    return charts._save(fig, path)


def empty_chart(path: Path) -> bool:
    """A chart with nothing to draw: no file, False."""
    return False


def raising_chart(path: Path) -> bool:
    raise ValueError("no such column")


def dying_chart(path: Path) -> bool:
    """What a segfault in the drawing library does to a worker: the process is gone."""
    os._exit(3)


def _charts(*extra) -> list[Chart]:
    return [Chart(f"charts/line{i}.png", line_chart, (float(i),)) for i in range(1, 6)] + list(extra)


def _pixels(folder: Path) -> dict:
    return {p.name: imread(p) for p in sorted((folder / "charts").glob("*.png"))}


def test_parallel_draws_the_same_files_as_serial(tmp_path):
    todo = _charts(Chart("charts/empty.png", empty_chart, ()))
    with warnings.catch_warnings():
        warnings.simplefilter("error", ChartNotDrawn)  # a chart with nothing to draw is no failure
        serial = draw_charts(todo, tmp_path / "serial", jobs=1)
        parallel = draw_charts(todo, tmp_path / "parallel", jobs=2)
    assert serial == parallel == [f"charts/line{i}.png" for i in range(1, 6)]
    a, b = _pixels(tmp_path / "serial"), _pixels(tmp_path / "parallel")
    assert list(a) == list(b) == [f"line{i}.png" for i in range(1, 6)]  # no .tmp.png left behind
    for name in a:  # the same drawing code on the same data: the same pixels, exactly
        assert a[name].shape == b[name].shape and np.array_equal(a[name], b[name]), name


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_chart_that_raises_is_left_out_and_named(tmp_path, jobs):
    todo = _charts(Chart("charts/broken.png", raising_chart, ()))
    with pytest.warns(ChartNotDrawn, match=r"charts/broken\.png .*ValueError: no such column"):
        drawn = draw_charts(todo, tmp_path, jobs=jobs)
    assert drawn == [f"charts/line{i}.png" for i in range(1, 6)]
    assert not (tmp_path / "charts" / "broken.png").exists()


def test_a_worker_that_dies_costs_its_chart_only(tmp_path):
    """The dying chart first, so the pool breaks while every other chart is still to draw."""
    todo = [Chart("charts/dies.png", dying_chart, ())] + _charts()
    with pytest.warns(ChartNotDrawn, match=r"charts/dies\.png .*worker process died"):
        drawn = draw_charts(todo, tmp_path, jobs=2)
    assert drawn == [f"charts/line{i}.png" for i in range(1, 6)]
    assert sorted(p.name for p in (tmp_path / "charts").iterdir()) == [f"line{i}.png" for i in range(1, 6)]


@pytest.mark.parametrize(
    "mathtext, plain",
    [
        (r"$\mathdefault{10^{-10}}$", "10⁻¹⁰"),
        (r"$\mathdefault{10^{0}}$", "10⁰"),
        (r"$\mathdefault{10^{6}}$", "10⁶"),
        (r"$\mathdefault{4\times10^{-1}}$", "4×10⁻¹"),
        (r"$\mathdefault{0}$", "0"),
        (r"$\mathdefault{-10^{2}}$", "−10²"),
        ("", ""),
        ("0.5", "0.5"),
        (r"$\alpha$", r"$\alpha$"),  # not a power of ten: left as it is
    ],
)
def test_log_tick_labels_are_written_without_mathtext(mathtext, plain):
    assert charts.plain_power_label(mathtext) == plain


def test_a_saved_log_axis_keeps_its_ticks_and_labels_them_in_plain_text(tmp_path):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([1e-7, 1e-2], [1e-9, 1e-2])
    ax.set_xscale("log")
    ax.set_yscale("log")
    ticks = ax.get_xticks()
    labels = [t.get_text() for t in ax.xaxis.get_majorticklabels()]
    charts._plain_power_labels(fig)
    fig.canvas.draw()
    assert np.array_equal(ax.get_xticks(), ticks)
    assert [t.get_text() for t in ax.xaxis.get_majorticklabels()] == [charts.plain_power_label(s) for s in labels]
    assert "10⁻⁵" in [t.get_text() for t in ax.xaxis.get_majorticklabels()]
    plt.close(fig)


def test_the_names_of_methods_that_blow_up_at_nearby_costs_do_not_overlap(tmp_path, monkeypatch):
    """The 60 Hz chart printed the names of the methods unstable there along its top edge on top of
    each other; each now takes the first row where it overlaps no name already placed."""
    from records.cell import AdviceFigures, Cell
    from reports import charts

    names = [f"ref:scheme_number_{i}" for i in range(8)]
    cells = [
        Cell(
            scene="cloth",
            method=m,
            family="ref",
            measure="advise",
            status="ok",
            value=None,
            dt=1 / 60,
            figures=AdviceFigures(
                hz=60.0,
                request={"energy_tol": 0.5, "error_tol": None},
                rows=[
                    {"cost_per_frame_s": 1e-5 * (1 + 0.01 * i), "energy_error": None, "stable": False},
                    {"cost_per_frame_s": 1e-3, "energy_error": 1e-2, "stable": True},
                ],
            ),
        )
        for i, m in enumerate(names)
    ]
    drawn = {}

    def keep(fig, path):
        drawn["fig"] = fig
        return True

    monkeypatch.setattr(charts, "_save", keep)
    assert charts.advice_chart(cells, "cloth", 60.0, tmp_path / "a.png")
    fig = drawn["fig"]
    renderer = fig.canvas.get_renderer()
    texts = [t for t in fig.axes[0].texts if t.get_text() in names]
    assert sorted(t.get_text() for t in texts) == sorted(names)
    boxes = [t.get_window_extent(renderer) for t in texts]
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1 :])


def test_a_chart_that_cannot_be_sent_to_a_worker_is_drawn_here(tmp_path):
    """A measure's chart declared as a lambda (a plugin may) does not pickle: the pool cannot
    take it, so it is drawn in this process and the report keeps it (it once lost the report)."""
    todo = _charts(Chart("charts/lambda.png", lambda path: line_chart(7.0, path), ()))
    drawn = draw_charts(todo, tmp_path, jobs=2)
    assert "charts/lambda.png" in drawn and (tmp_path / "charts" / "lambda.png").stat().st_size > 0
    assert drawn == [c.name for c in todo]
