"""``harness advise SCENE --sweep k=LO..HI[:POINTS]``: the advice over a log grid of one scene
parameter, each method searched past ``--max-substeps``, and the crossover where the cheapest
family changes (``harness.measures.sweep``), with its nightly cell, chart, section and finding.

Verdicts drawn from timings (which method is cheapest, where a search stops on the cost bound,
where the crossover falls) are tested with injected timings or injected rows, never the clock's.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from harness.cli import main
from harness.cli.advise import sweep_lines
from harness.measures.advise import Request
from harness.measures.sweep import crossovers, family_of, parse_grid, run_sweep
from harness.methods import get_method
from records import InvalidInput
from records.advice import SweepEntry, SweepFigures, SweepPoint, family_name
from records.cell import Cell
from scenarios import make_scene


# ----------------------------------------------------------------------------- the grid
def test_a_log_grid_from_its_ends_and_points():
    cloth = make_scene("cloth", n=4, m=4)
    g = parse_grid("k=1e2..1e6:5", cloth)
    assert g.param == "k" and g.values == (100.0, 1000.0, 10000.0, 100000.0, 1000000.0)
    assert g.values == pytest.approx(np.geomspace(1e2, 1e6, 5), rel=1e-12)
    assert len(parse_grid("k=1e2..1e6", cloth).values) == 9  # the default number of points
    assert len(parse_grid("k=1e2..1e6", cloth, points=3).values) == 3
    assert parse_grid("n=2..4:9", cloth).values == (2.0, 3.0, 4.0)  # an integer parameter: its integers


@pytest.mark.parametrize(
    "text, points, says",
    [
        ("k1e2..1e6", None, "--sweep 'k1e2..1e6' is not a grid (allowed: NAME=LO..HI"),
        ("q=1..2", None, "--sweep parameter 'q' is not a parameter of scene cloth (valid: n, m, s, mass, k,"),
        ("k=1e6..1e2", None, "--sweep k=1e+06..100 is not a log grid (allowed: finite 0 < LO < HI)"),
        ("k=0..1e2", None, "--sweep k=0..100 is not a log grid"),
        ("k=1..inf", None, "--sweep k=1..inf is not a log grid"),
        ("k=a..2", None, "--sweep k LO='a' is not a number"),
        ("n=2..200", None, "--sweep: parameter n=200.0 is out of range (allowed: integer in [2, 100])"),
        ("k=1..10:1", None, "--sweep points=1 is out of range (allowed: integer from 2 to 50)"),
        ("k=1..10", "0", "--points=0 is out of range"),
        ("k=1..10:5", "4", "give two numbers of points"),
    ],
)
def test_a_bad_grid_is_one_line_naming_the_field(text, points, says):
    with pytest.raises(InvalidInput) as err:
        parse_grid(text, make_scene("cloth", n=4, m=4), points)
    assert says in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    "argv, says",
    [
        (["--sweep", "q=1..2"], "--sweep parameter 'q' is not a parameter of scene spring (valid: k, m, x0, v0)"),
        (["--sweep", "k=1..2", "--set", "k=3"], "--sweep k and --set k name the same parameter"),
        (["--points", "3"], "--points is for a --sweep"),
        (["--sweep", "k=1..2", "--factor", "0.5"], "--factor=0.5 is out of range (allowed: >= 1)"),
        (["--sweep", "k=1..2", "--sweep-max-substeps", "8"], "--sweep-max-substeps=8 is out of range"),
    ],
)
def test_the_command_refuses_a_bad_sweep_before_any_engine_runs(argv, says, capsys):
    assert main(["advise", "spring", "--hz", "60", "--energy-tol", "1e-3", *argv]) == 2
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1


# ----------------------------------------------------------------------------- the search past max-substeps
#: Leapfrog meets 1e-3 at one substep on the unit spring at 60 Hz; semi-implicit Euler's energy error
#: h*omega/2 needs h*omega <= 2e-3: 16 substeps at k = 1 (omega 1), 32 at k = 4 (omega 2). Their
#: costs per step are injected, so where each search stops is the same on any machine.
TIMINGS = {"s_per_step": {"ref:leapfrog": 1e-8, "ref:semi_implicit_euler": 1e-8, "*": 1e-6}}
SPRING = Request(hz=60, horizon=10, energy_tol=1e-3, max_substeps=2)


@pytest.fixture()
def injected(tmp_path, monkeypatch):
    path = tmp_path / "timings.json"
    path.write_text(json.dumps(TIMINGS))
    monkeypatch.setenv("HARNESS_INJECT_TIMINGS", str(path))


def _sweep(factor, cap):
    spring = make_scene("spring")
    return run_sweep(
        spring,
        parse_grid("k=1..4:2", spring),
        SPRING,
        ["ref:leapfrog", "ref:semi_implicit_euler"],
        factor=factor,
        cap=cap,
        pool=False,
    )


def test_the_search_goes_on_past_max_substeps_until_a_method_meets_them(injected):
    """max_substeps 2; semi-implicit Euler is searched on, 4, 8, 16 (32 at k = 4), within 100 x
    leapfrog's frame (1e-8 s): it meets the tolerances where its energy error h*omega/2 does."""
    sw = _sweep(factor=100, cap=4096)
    for point, need in zip(sw.points, (16, 32)):
        lf, sie = point.entries
        assert lf.ended == "met" and lf.substeps == 1 and lf.cost_per_frame_s == pytest.approx(1e-8)
        assert sie.ended == "met" and sie.substeps == need and sie.searched == need
        assert sie.cost_per_frame_s == pytest.approx(need * 1e-8)
        assert sie.homega == pytest.approx(point.omega / (60 * need))
        assert sie.energy_error <= 1e-3 < point.omega / (60 * need / 2) / 2  # half the substeps miss (theory)
        assert point.cheapest.method == "ref:leapfrog"


def test_the_search_stops_at_the_cost_factor_and_at_the_cap_and_says_which(injected):
    # 10 x leapfrog's 1e-8 s: 8 substeps (8e-8 s) run and miss; 16 (1.6e-7 s) would pass it, unrun.
    cost = _sweep(factor=10, cap=4096).points[0].entries[1]
    assert cost.ended == "cost" and cost.searched == 8 and cost.substeps is None
    assert "16 substeps would cost 0.16 µs a frame, past 10 x the cheapest (0.01 µs)" in cost.why
    capped = _sweep(factor=1000, cap=8).points[1].entries[1]
    assert capped.ended == "cap" and capped.searched == 8
    assert capped.why.startswith("no level up to 8 substeps meets them")


def test_the_sweep_runs_no_counting_run(injected, monkeypatch):
    """A sweep prints no evaluations per frame, so its levels skip the interpreted counting run a
    compiled implicit run leaves to ``counted_evaluations`` (on a 16 x 16 cloth, the scene's
    conjugate gradients in Python: dearer than the whole search)."""
    import harness.measures.cost as cost

    def refuse(*args, **kwargs):
        raise AssertionError("a sweep level ran a counting run")

    monkeypatch.setattr(cost, "counted_evaluations", refuse)
    cloth = make_scene("cloth", n=3, m=3)
    request = Request(hz=60, horizon=0.2, energy_tol=0.5, max_substeps=2, error_rel=None)
    sw = run_sweep(cloth, parse_grid("k=1e2..1e3:2", cloth), request, ["ref:linearly_implicit_euler"], pool=False)
    assert [e.ended for p in sw.points for e in p.entries] == ["met"] * 2


def test_the_command_prints_the_sweep_and_its_json(injected, capsys):
    argv = [
        "advise",
        "spring",
        "--hz",
        "60",
        "--horizon",
        "10",
        "--energy-tol",
        "1e-3",
        "--max-substeps",
        "2",
        "--methods",
        "ref:leapfrog,ref:semi_implicit_euler",
        "--sweep",
        "k=1..4:2",
        "--factor",
        "100",
        "--jobs",
        "1",
    ]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert (
        "sweep spring (m=1, x0=1, v0=0) over k = 1 .. 4 (2 values, log) at 60 Hz over 10: energy error <= 0.001 "
        "and position error <= 0.05 (5% of the scene's length scale 1)"
    ) in out
    # Each pick with its energy and position error (leapfrog at 1/60: h*omega/2 squared, and its phase).
    assert "ref:leapfrog 1 x 0.01 (E 6.9e-05, x 9.2e-05)" in out
    assert "no crossover: the cheapest family is explicit substeps at every value" in out
    assert "the seed's claims" not in out  # one family searched: nothing to set against the other
    row = next(line for line in out.splitlines() if line.strip().startswith("ref:semi_implicit_euler"))
    assert row.split()[1:] == ["16:", "0.16", "32:", "0.32"]
    assert main([*argv, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["param"] == "k" and d["grid"] == [1.0, 4.0] and d["clock"] == "cpu" and d["crossovers"] == []
    assert [e["substeps"] for p in d["points"] for e in p["entries"]] == [1, 16, 1, 32]


def test_a_pick_whose_win_rests_on_its_passes_is_marked(tmp_path, monkeypatch):
    """Issue 42's cloth at k = 1e5, the energy alone asked (no accuracy tolerance, said first):
    XPBD's one substep keeps 53% of the energy (within 0.5), at a hundred passes 49%: the pick
    carries a * and the legend says why; the convergence check ran and is in the JSON."""
    path = tmp_path / "timings.json"
    path.write_text(json.dumps({"s_per_step": {"ref:xpbd": 1e-8, "*": 1e-6}}))
    monkeypatch.setenv("HARNESS_INJECT_TIMINGS", str(path))
    cloth = make_scene("cloth", n=4, m=4)
    request = Request(hz=60, horizon=2, energy_tol=0.5, max_substeps=1, error_rel=None)
    sw = run_sweep(cloth, parse_grid("k=5e4..1e5:2", cloth), request, ["ref:xpbd"], pool=False)
    xpbd = sw.points[-1].entries[0]
    assert xpbd.ended == "met" and xpbd.substeps == 1 and xpbd.rests_on_solve
    assert xpbd.converged["method"] == "ref:xpbd?iterations=100" and xpbd.converged["energy_error"] > 0.5
    lines = list(sweep_lines(sw))
    assert lines[0].endswith("energy error <= 0.5; no accuracy tolerance (positions not judged)")
    assert any("ref:xpbd 1 x 0.01 (E 0.47, x -)*" in line for line in lines)
    assert any("*: its win rests on the solve's own error" in line for line in lines)
    assert sw.as_dict()["points"][-1]["entries"][0]["converged"]["meets"] is False


# ----------------------------------------------------------------------------- families and the crossover
def test_a_family_is_what_the_method_declares():
    assert family_of(get_method("ref:leapfrog")) == "explicit"
    assert family_of(get_method("ref:implicit_euler")) == "implicit"
    assert family_of(get_method("ref:linearly_implicit_euler")) == "implicit"
    assert family_of(get_method("ref:verlet_constrained")) == "constrained"
    assert family_of(get_method("mujoco:euler")) == "explicit"  # an engine mode declares no kind
    # A kind the house adds later is its own family, named by itself where no name is given.
    assert family_name("position_based") == "position-based solves" and family_name("newkind") == "newkind"


def _point(value, homega, energy=None, **costs):
    """A point with one entry per family=cost_us (None: that family met nothing there, its search
    ended on the cost bound); ``energy``: family -> the fewest substeps within the energy tolerance."""
    energy = energy or {}
    entries = [
        SweepEntry(
            f"ref:{fam}_scheme",
            fam,
            "met" if us is not None else "cost",
            4 if us else None,
            cost_per_frame_s=None if us is None else us * 1e-6,
            searched=4 if us else 8,
            next_substeps=None if us else 16,
            energy_substeps=energy.get(fam),
        )
        for fam, us in costs.items()
    ]
    return SweepPoint(value, homega * 60, homega, entries)


#: Injected rows: explicit substeps cost 1, 4, 32 µs a frame at k = 1e2, 1e3, 1e4 (h*omega 1, 3, 9 at
#: one substep), implicit solves 8 µs at each.
ROWS = [
    _point(1e2, 1.0, explicit=1.0, implicit=8.0),
    _point(1e3, 3.0, explicit=4.0, implicit=8.0),
    _point(1e4, 9.0, explicit=32.0, implicit=8.0),
]


def test_the_crossover_is_where_the_cheapest_family_changes_interpolated_log_log():
    (x,) = crossovers(ROWS)
    assert (x.below, x.above, x.from_family, x.to_family) == (1e3, 1e4, "explicit", "implicit")
    assert (x.from_method, x.to_method) == ("ref:explicit_scheme", "ref:implicit_scheme")
    # log(explicit / implicit) runs from log(1/2) to log(4): zero a third of the way, in log k and log h*omega.
    assert x.interpolated and x.value == pytest.approx(1e3 * 10 ** (1 / 3), rel=1e-12)
    assert x.homega_one == pytest.approx(3.0 * 3.0 ** (1 / 3), rel=1e-12)


def test_a_family_with_no_cost_at_one_end_puts_the_crossover_midway_and_new_kinds_cross_too():
    rows = [_point(1e2, 1.0, explicit=1.0, position_based=3.0), _point(1e4, 10.0, explicit=None, position_based=5.0)]
    (x,) = crossovers(rows)
    assert not x.interpolated and x.to_family == "position_based"
    assert x.value == pytest.approx(1e3, rel=1e-12) and x.homega_one == pytest.approx(math.sqrt(10), rel=1e-12)
    assert crossovers([ROWS[0], _point(1e3, 3.0, explicit=None, implicit=None), ROWS[2]]) == []  # none met between
    assert crossovers(ROWS[:2]) == []


def _cell(points, label="4 x 4", method="ref:implicit_euler", error_rel=None):
    figures = SweepFigures(
        label=label,
        param="k",
        params={"n": 4, "m": 4},
        hz=60.0,
        request={"horizon": 2.0, "energy_tol": 0.5, "error_tol": None, "max_substeps": 16, "error_rel": error_rel},
        factor=10.0,
        cap=4096,
        clock="cpu",
        points=[p.as_dict() for p in points],
        crossovers=[c.as_dict() for c in crossovers(points)],
    )
    cross = crossovers(points)
    return Cell(
        scene="cloth",
        method=method,
        family="ref",
        measure="sweep",
        status="ok",
        params={},
        dt=1 / 60,
        value=cross[0].homega_one if cross else None,
        figures=figures,
    )


def _claims(points, error_rel=0.05):
    from harness.sweep_findings import sweep_findings

    found = sweep_findings("cloth", {("cloth", "ref:implicit_euler"): {"sweep": _cell(points, error_rel=error_rel)}})
    assert len(found) == 2 and all("absurdly tiny timesteps" in f.text for f in found)
    return found


def test_the_first_claim_asks_steps_at_least_ten_times_longer_within_the_energy_tolerance():
    """Survives: at the stiffest value an implicit solve within the energy tolerance at 2 substeps
    against explicit substeps' 32 (16 x) holds; at 4 against 32 (8 x) does not; with no implicit
    solve within it, or no explicit one within its bound, the line says which."""

    def first(energy, **costs):
        return _claims([ROWS[0], _point(1e4, 9.0, energy=energy, **costs)])[0]

    f = first({"explicit": 32, "implicit": 2}, explicit=32.0, implicit=8.0)
    assert f.ok is True and "implicit Euler survives where explicit steps must be tiny (energy tolerance)" in f.text
    assert (
        "at k = 1e+04 (h·ω = 9 at one substep): `ref:implicit_scheme` stays within energy error ≤ 0.5 at 2 "
        "substeps; explicit substeps need 32 (`ref:explicit_scheme`): steps 16 x shorter (≥ the 10 x the claim "
        "asks)"
    ) in f.text
    assert first({"explicit": 32, "implicit": 4}, explicit=32.0, implicit=8.0).ok is False
    # No explicit scheme within the energy tolerance up to its 8 substeps (next 16): at least 16 x at 1 substep.
    g = first({"implicit": 1}, explicit=None, implicit=8.0)
    assert (
        g.ok is True
        and "no explicit scheme is within it below 16 substeps (`ref:explicit_scheme` the first to "
        "stop): steps at least 16 x shorter"
        in g.text
    )
    # One explicit scheme within it at 32, another's search ended at 16 before it was: at least 16.
    stiff = _point(1e4, 9.0, energy={"explicit": 32, "implicit": 1}, explicit=32.0, implicit=8.0, rk=None)
    stiff.entries[2].family = "explicit"
    k = _claims([ROWS[0], stiff])[0]
    assert (
        k.ok is True
        and (
            "explicit substeps need at least 16 (`ref:rk_scheme` not within it below 16, its search "
            "ended there; `ref:explicit_scheme` within it at 32): steps at least 16 x shorter"
        )
        in k.text
    )
    stiff = _point(1e4, 9.0, energy={"explicit": 32}, explicit=32.0, implicit=None)
    cut = _claims([ROWS[0], stiff])[0]  # every implicit search ended on its cost bound: not known
    assert cut.ok is None and "{mark}" not in cut.text and "not judged: every implicit search ended" in cut.text
    stiff.entries[1].ended = "cap"  # searched to the most substeps, never within the energy tolerance
    h = _claims([ROWS[0], stiff])[0]
    assert h.ok is False and "no implicit solve stays stable within energy error ≤ 0.5" in h.text


def test_the_second_claim_holds_the_cheapest_frames_that_meet_every_tolerance_and_names_the_crossover():
    from records.findings import MARK

    f = _claims(ROWS)[1]
    assert f.ok is True and f.text.startswith(MARK) and "implicit Euler is the cheaper usable frame" in f.text
    assert "position error ≤ 5% of the scene's length scale" in f.text and "energy error ≤ 0.5" in f.text
    assert (
        "implicit solves' cheapest frame that meets them, `ref:implicit_scheme` 4 × = 8 µs a frame, against "
        "explicit substeps' `ref:explicit_scheme` 4 × = 32 µs a frame: implicit 4 x cheaper"
    ) in f.text
    assert "implicit solves take over from explicit substeps at k ≈ 2.15e+03 (h·ω ≈ 4.33 at one substep)" in f.text
    flipped = [_point(1e2, 1.0, explicit=8.0, implicit=1.0), _point(1e4, 9.0, explicit=1.0, implicit=8.0)]
    g = _claims(flipped)[1]
    assert g.ok is False and "explicit 8 x cheaper" in g.text and "take over" not in g.text
    # A third family cheaper than both at the stiff end: the claim is judged on explicit against
    # implicit, and the line says which family is cheapest there.
    third = [
        _point(1e2, 1.0, explicit=1.0, implicit=8.0, position_based=4.0),
        _point(1e4, 9.0, explicit=32.0, implicit=8.0, position_based=2.0),
    ]
    h = _claims(third)[1]
    assert (
        h.ok is True
        and "the cheapest frame there is position-based solves (`ref:position_based_scheme`, 2 µs)" in h.text
    )
    # The implicit pick's win resting on its solve's own error (its motion moves once the solve converges
    # further, issue 53): the solve's win, not implicit Euler's; said, and not counted.
    rests = [ROWS[0], _point(1e4, 9.0, explicit=32.0, implicit=8.0)]
    rests[1].entries[1].converged = {
        "method": "ref:implicit_scheme?tol=1e-5",
        "meets": False,
        "moved": 0.05,
        "tol": 0.015,
        "until": None,
    }
    r = _claims(rests)[1]
    assert r.ok is False and "no implicit solve meets them with its solve converged" in r.text
    assert (
        "not counted, their wins resting on the solve's own error: `ref:implicit_scheme` 4 × = 8 µs "
        "(`ref:implicit_scheme?tol=1e-5`: its positions move 0.05 > 0.015)"
    ) in r.text
    # No implicit solve meets them: the furthest search and why it ended.
    none = [ROWS[0], _point(1e4, 9.0, explicit=32.0, implicit=None)]
    none[1].entries[1].why = "16 substeps would cost 2 µs a frame; position error 0.05 > 0.015 at 8 substeps"
    n = _claims(none)[1]
    assert (
        n.ok is False
        and (
            "no implicit solve meets them (1 searched, ended on cost; the furthest, "
            "`ref:implicit_scheme` to 8 substeps: position error 0.05 > 0.015 at 8 substeps); "
            "explicit substeps do: `ref:explicit_scheme` 4 × = 32 µs a frame"
        )
        in n.text
    )
    # No implicit solve searched (a sweep of explicit schemes): neither claim is judged.
    alone = [_point(1e2, 1.0, explicit=1.0), _point(1e4, 9.0, explicit=4.0)]
    assert [f.ok for f in _claims(alone)] == [None, None]
    # The energy alone asked: the second claim is not judged, and says so with no mark.
    e = _claims(ROWS, error_rel=None)[1]
    assert e.ok is None and "not judged: the sweep asked no accuracy tolerance" in e.text and MARK not in e.text


def test_the_section_and_the_chart_are_drawn_from_the_cells(tmp_path):
    from reports.sweep_section import sweep_chart, sweep_section

    cells = [_cell(ROWS), _cell(ROWS, "16 x 16", "ref:linearly_implicit_euler")]
    cells[1].figures.params.update(n=16, m=16)
    piv = {("cloth", c.method): {"sweep": c} for c in cells}
    lines = sweep_section("cloth", piv)
    assert lines[0].startswith("**Where the trade-off flips on `cloth` 4 x 4** (n=4, m=4)")
    assert "| k | h·ω at 1 substep | explicit substeps | implicit solves | cheapest |" in lines
    assert (
        "| 1e+04 | 9 | `ref:explicit_scheme` 4 × = 32 µs (E –, x –) | `ref:implicit_scheme` 4 × = 8 µs (E –, x –) "
        "| implicit solves |"
    ) in lines
    assert "energy error ≤ 0.5, no accuracy tolerance (positions not judged)" in lines[0]
    # A pick with its errors, its win resting on its solve's own error: marked.
    marked = [_point(1e2, 1.0, explicit=1.0), _point(1e3, 3.0, explicit=4.0)]
    e = marked[1].entries[0]
    e.energy_error, e.position_error = 0.47, 0.233
    e.converged = {
        "method": "ref:explicit_scheme?iterations=100",
        "meets": False,
        "why": "energy falls 51%",
        "energy_error": 0.51,
        "position_error": 0.2,
    }
    cell = _cell(marked)
    cell.figures.request.update(error_rel=0.05)
    text = sweep_section("cloth", {("cloth", cell.method): {"sweep": cell}})
    assert "| 1e+03 | 3 | `ref:explicit_scheme` 4 × = 4 µs (E 0.47, x 0.23) \\* | explicit substeps |" in text
    assert "position error ≤ 5% of the scene's length scale" in text[0]
    assert any(
        line.startswith("Crossover: explicit substeps (`ref:explicit_scheme`) → implicit solves") for line in lines
    )
    path = tmp_path / "sweep.png"
    assert sweep_chart(cells, "cloth", path) and path.stat().st_size > 10_000
    assert not sweep_chart([], "cloth", tmp_path / "none.png")


def test_the_sweep_is_a_registered_measure_of_the_full_suite_only():
    from records.measures import get
    from harness.nightly.suites import SUITES

    m = get("sweep")
    assert m is not None and m.chart is not None and m.section is not None and m.findings is not None
    full = SUITES["full"].scenes
    sizes = [s["params"] for s in full["cloth"].extras.sweep["sizes"]]
    assert [(p["n"], p["m"]) for p in sizes] == [(4, 4), (16, 16), (32, 32)]
    assert len({s["task"] for s in full["cloth"].extras.sweep["sizes"]}) == 3  # three tasks, side by side
    assert full["net"].extras.sweep and full["chain"].extras.sweep
    assert all(spec.extras.sweep is None for name in ("smoke", "standard") for spec in SUITES[name].scenes.values())


def test_the_nightly_cell_is_measured_in_its_named_task_only(injected):
    """A suite whose spring sweeps k = 1..4 in leapfrog's task: the cell carries every value's
    entries (the search past max_substeps as the command's) and no crossover (one family)."""
    from harness.nightly.cells import context, measures_for
    from harness.nightly.run import Task
    from harness.nightly.suites import SceneExtras, SceneSpec, Suite
    from records.measures import get

    sweep = {
        "grid": "k=1..4:2",
        "hz": 60.0,
        "request": {"horizon": 10.0, "energy_tol": 1e-3, "max_substeps": 2},
        "methods": ("ref:leapfrog", "ref:semi_implicit_euler"),
        "factor": 100.0,
        "cap": 64,
        "sizes": ({"label": "unit", "params": {}, "task": "ref:leapfrog"},),
    }
    suite = Suite("tiny", scenes={"spring": SceneSpec(extras=SceneExtras(sweep=sweep))})
    task = Task("cell", "spring", "ref:leapfrog", "ref", {}, suite)
    assert "sweep" in measures_for(task)
    assert "sweep" not in measures_for(Task("cell", "spring", "ref:rk4", "ref", {}, suite))
    (cell,) = get("sweep").run(context(task))
    f = cell.figures
    assert cell.status == "ok" and cell.value is None and f.crossovers == [] and f.clock == "cpu"
    assert f.label == "unit" and f.param == "k" and f.factor == 100.0 and f.cap == 64
    points = f.sweep_points()
    assert [p.value for p in points] == [1.0, 4.0]
    assert [(e.method, e.ended, e.substeps) for e in points[1].entries] == [
        ("ref:leapfrog", "met", 1),
        ("ref:semi_implicit_euler", "met", 32),
    ]


def test_the_command_prints_both_claims_under_its_table_and_in_its_json():
    from harness.measures.sweep import Sweep

    cloth = make_scene("cloth", n=4, m=4)
    stiff = _point(1e4, 9.0, energy={"explicit": 32, "implicit": 2}, explicit=32.0, implicit=8.0)
    sw = Sweep(
        "cloth",
        {},
        parse_grid("k=1e2..1e4:3", cloth),
        Request(hz=60, horizon=2, energy_tol=0.5).checked(),
        10.0,
        4096,
        ROWS[:2] + [stiff],
        [],
        0.3,
    )
    lines = list(sweep_lines(sw))
    at = lines.index("the seed's claims (stiff cloth to implicit Euler), judged at the stiffest value:")
    assert lines[at + 1].startswith(
        "  implicit Euler survives where explicit steps must be tiny (energy tolerance): holds; at k = 1e+04"
    )
    assert lines[at + 2].startswith("  implicit Euler is the cheaper usable frame (accuracy tolerance too): holds;")
    assert "`" not in lines[at + 1] + lines[at + 2]
    claims = sw.as_dict()["claims"]
    assert [c["ok"] for c in claims] == [True, True] and claims[0]["text"].endswith("(≥ the 10 x the claim asks)")


def test_the_first_claim_probes_survival_past_the_cost_bound_so_timings_cannot_turn_it(tmp_path, monkeypatch):
    """Implicit Euler made dear (injected) has its search cut by the cost bound before it runs a level;
    at the stiffest value it is run on past the bound for the first claim alone, up to ten times fewer
    substeps than the explicit schemes need, and survives there: ✓, said to be probed. Its frame and
    cost stay the search's (not met)."""
    from harness.sweep_findings import survives

    path = tmp_path / "timings.json"
    path.write_text(json.dumps({"s_per_step": {"ref:leapfrog": 1e-7, "ref:rk4": 4e-7, "*": 1e-2}}))
    monkeypatch.setenv("HARNESS_INJECT_TIMINGS", str(path))
    cloth = make_scene("cloth", n=3, m=3)
    request = Request(hz=60, horizon=0.5, energy_tol=0.5, max_substeps=16)
    sw = run_sweep(
        cloth, parse_grid("k=1e5..1e6:2", cloth), request, ["ref:leapfrog", "ref:rk4", "ref:implicit_euler"], pool=False
    )
    soft, stiff = sw.points
    imp = {e.method: e for e in stiff.entries}["ref:implicit_euler"]
    assert imp.ended == "cost" and imp.substeps is None and imp.probed and imp.energy_substeps == imp.probed[-1]
    assert not {e.method: e for e in soft.entries}["ref:implicit_euler"].probed  # the stiffest value only
    claim = survives(sw.points, "k", 0.5, accuracy=False)
    assert claim.ok is True and "run past its search's cost bound" in claim.text


def test_a_sweep_names_the_frames_within_the_timing_spread_as_a_tie():
    """Issue 54: at k = 100 on the 4 x 4 sheet RK4's 2 substeps and leapfrog's 8 cost 19.5 and 20.8 µs
    a frame, each repeat's range 10%: the family's pick names both (~), and where another family's
    frame ties with the cheapest the last column says so; apart by more than the spread, no mark."""
    from harness.measures.sweep import Sweep
    from records.advice import SweepEntry, SweepPoint

    def entry(method, family, substeps, us, spread=0.1):
        return SweepEntry(method, family, "met", substeps, cost_per_frame_s=us * 1e-6, cost_rel_spread=spread)

    cloth = make_scene("cloth", n=4, m=4)
    tied = SweepPoint(
        100.0, 89.0, 1.48, [entry("ref:rk4", "explicit", 2, 19.5), entry("ref:leapfrog", "explicit", 8, 20.8)]
    )
    across = SweepPoint(
        1000.0,
        239.0,
        3.98,
        [entry("ref:leapfrog", "explicit", 16, 38.6), entry("ref:implicit_euler", "implicit", 2, 40.0)],
    )
    apart = SweepPoint(
        1e4, 739.0, 12.3, [entry("ref:leapfrog", "explicit", 32, 77.3), entry("ref:rk4", "explicit", 8, 120.0)]
    )
    sw = Sweep(
        "cloth",
        {},
        parse_grid("k=1e2..1e4:3", cloth),
        Request(hz=60, horizon=2, energy_tol=0.5).checked(),
        10.0,
        4096,
        [tied, across, apart],
        [],
        0.3,
    )
    rows = [line for line in sweep_lines(sw) if line.startswith(("        100", "      1e+03", "      1e+04"))]
    assert "ref:rk4 2 x 19.5 (E -, x -) ~ ref:leapfrog 8 x 20.8" in rows[0] and rows[0].endswith("explicit substeps")
    assert rows[1].endswith("a tie: explicit substeps / implicit solves")
    assert " ~ " not in rows[2] and rows[2].endswith("explicit substeps")
    assert any("~ a method whose frame costs the same within the timing spread (a tie)" in x for x in sweep_lines(sw))
