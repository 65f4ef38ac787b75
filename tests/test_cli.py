"""The ``harness`` CLI: run, list, bench; bad input is one line and exit 2."""

import io
import json
import subprocess
import sys
from contextlib import redirect_stderr, redirect_stdout

import pytest

from harness.cli import main


def cli(*argv):
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as exc:  # argparse errors
            code = exc.code
    return code, out.getvalue(), err.getvalue()


def test_seed_example_csv():
    code, out, _ = cli(
        "run", "spring", "--method", "ref:semi_implicit_euler", "--dt", "0.5", "--steps", "4", "--format", "csv"
    )
    assert code == 0
    lines = out.strip().splitlines()
    assert lines[0] == "step,t,q0,v0,energy"
    rows = [[float(x) for x in line.split(",")] for line in lines[1:]]
    assert [r[0] for r in rows] == [0, 1, 2, 3, 4]
    # To the seed's printed 3 decimals (0.3125 prints as 0.313: half a unit either way).
    for col, want in (
        (2, [1, 0.75, 0.313, -0.203, -0.668]),
        (3, [0, -0.5, -0.875, -1.031, -0.930]),
        (4, [0.5, 0.406, 0.432, 0.552, 0.655]),
    ):
        assert all(abs(r[col] - w) <= 0.0005 + 1e-12 for r, w in zip(rows, want)), col


def test_csv_has_one_column_per_dof_and_every():
    code, out, _ = cli(
        "run", "kepler", "--method", "ref:rk4", "--dt", "0.1", "--steps", "10", "--every", "4", "--format", "csv"
    )
    assert code == 0
    lines = out.strip().splitlines()
    assert lines[0] == "step,t,q0,q1,v0,v1,energy"
    assert [int(line.split(",")[0]) for line in lines[1:]] == [0, 4, 8, 10]


def test_json_and_table_formats():
    code, out, _ = cli(
        "run",
        "pendulum",
        "--method",
        "ref:leapfrog",
        "--dt",
        "0.01",
        "--steps",
        "3",
        "--format",
        "json",
        "--set",
        "theta0=1.0",
    )
    assert code == 0
    doc = json.loads(out)
    assert doc["status"] == "ok" and len(doc["rows"]) == 4 and doc["rows"][0]["q0"] == 1.0
    assert doc["force_evals"] == 3
    code, out, _ = cli("run", "spring", "--method", "ref:rk4", "--dt", "0.1", "--steps", "2")
    assert code == 0 and out.splitlines()[0].split() == ["step", "t", "q0", "v0", "energy"]


@pytest.mark.parametrize(
    "argv,field",
    [
        (["run", "sprung", "--method", "ref:rk4", "--dt", "0.1", "--steps", "2"], "scene"),
        (["run", "spring", "--method", "ref:rk5", "--dt", "0.1", "--steps", "2"], "method"),
        (["run", "spring", "--method", "ref:rk4", "--dt", "0", "--steps", "2"], "--dt"),
        (["run", "spring", "--method", "ref:rk4", "--dt", "-0.1", "--steps", "2"], "--dt"),
        (["run", "spring", "--method", "ref:rk4", "--dt", "nan", "--steps", "2"], "--dt"),
        (["run", "spring", "--method", "ref:rk4", "--dt", "inf", "--steps", "2"], "--dt"),
        (["run", "spring", "--method", "ref:rk4", "--dt", "0.1", "--steps", "-1"], "--steps"),
        (["run", "spring", "--method", "ref:rk4", "--dt", "0.1", "--steps", "2.5"], "--steps"),
        (["run", "spring", "--method", "ref:rk4", "--dt", "0.1", "--steps", "2", "--set", "q=1"], "q"),
        (["run", "kepler", "--method", "ref:rk4", "--dt", "0.1", "--steps", "2", "--set", "e=1.5"], "e=1.5"),
        (["run", "spring", "--method", "ref:rk4", "--dt", "0.1", "--steps", "2", "--format", "xml"], "--format"),
    ],
)
def test_bad_input_is_one_line_naming_the_field_exit_2(argv, field):
    code, out, err = cli(*argv)
    assert code == 2
    assert out == ""  # nothing stepped, nothing printed
    assert err.count("\n") == 1 and field in err


def test_unknown_method_lists_valid_choices():
    _, _, err = cli("run", "spring", "--method", "ref:rk5", "--dt", "0.1", "--steps", "2")
    assert "valid:" in err and "ref:rk4" in err and "ref:semi_implicit_euler" in err


def test_list_shows_scenes_and_method_metadata():
    code, out, _ = cli("list", "--json")
    assert code == 0
    cat = json.loads(out)
    assert {"spring", "damped_spring", "pendulum", "kepler", "projectile"} <= set(cat["scenes"])
    rk4 = cat["methods"]["ref:rk4"]
    assert rk4["order"] == 4 and rk4["force_evals"] == "4" and rk4["available"]
    assert cat["methods"]["ref:implicit_euler"]["force_evals"] == "1 + solve"
    code, out, _ = cli("list")
    assert code == 0 and "ref:forest_ruth" in out and "kepler" in out


def test_bench_json_reports_ns_per_step_beside_the_floor():
    code, out, _ = cli("bench", "--json", "--methods", "semi_implicit_euler")
    assert code == 0
    result = json.loads(out)
    (row,) = result["rows"]
    assert row["method"] == "ref:semi_implicit_euler"
    for figure in ("single", "batch1000"):
        kernel = row[f"{figure}_ns_per_step" if figure == "single" else f"{figure}_ns_per_spring_step"]
        floor = row[f"{figure}_floor_ns_per_step" if figure == "single" else f"{figure}_floor_ns_per_spring_step"]
        assert kernel > 0 and floor > 0
        assert row[f"{figure}_ratio_to_floor"] == pytest.approx(kernel / floor, rel=1e-12)
    judged = {t["target"]: t for t in result["targets"]}
    # The floor ratios on one spring and the batch, and semi-implicit Euler's two absolute targets.
    assert len(judged) == 4 and all(t["met"] == (t["value"] <= t["bound"]) for t in judged.values())


def test_console_script_entry_point_runs():
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "harness",
            "run",
            "spring",
            "--method",
            "ref:rk4",
            "--dt",
            "0.1",
            "--steps",
            "1",
            "--format",
            "csv",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    assert proc.stdout.startswith("step,t,q0,v0,energy\n")
