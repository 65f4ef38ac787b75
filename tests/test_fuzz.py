"""Every command's input, fuzzed: the harness answers bad input in one line, never a traceback.

A property-based test (hypothesis) per command of ``harness.cli.COMMANDS``: its flags drawn from
valid values mixed with hostile ones (NaN, inf, negative, zero, huge, not a number, empty,
unknown scene / method / suite / measure names, unknown or out-of-range ``--set`` parameters of
every scene, unknown ``--opt`` options) and its files (``--db``, ``--bounds``, ``--file``) from
empty, truncated and foreign files beside a real history. The property, for every input:

* the exit code is 0, 1 or 2 and no exception escapes ``harness.cli.main`` (argparse's exits
  included);
* nothing printed is a traceback;
* an exit 2 is exactly one line on stderr, ``harness: error: ...``;
* a history given as ``--db`` holds, after a refused command, exactly the rows it held before,
  and passes SQLite's integrity check.

Commands whose valid input would measure for long (``nightly``, ``bench``, ``cost``,
``workprecision``, ``stability``, ``order``, ``advise``, ``identify``) are given at least one
field that is certainly invalid, and must exit 2: their validation runs before any engine is
touched. ``run`` and ``energy`` run their valid inputs, on few steps.

The CI version draws ``EXAMPLES`` inputs a command, derandomized (the same ones every run); the
long version draws ``LONG_EXAMPLES`` at random: ``pytest -m slow tests/test_fuzz.py``.
"""

from __future__ import annotations

import contextlib
import io
import sqlite3
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from harness.cli import COMMANDS, main
from harness.history.storage import History
from scenarios import SCENES

EXAMPLES = 12
LONG_EXAMPLES = 300

SCENE_IDS = list(SCENES)
METHODS = [
    "ref:explicit_euler",
    "ref:semi_implicit_euler",
    "ref:rk4",
    "ref:verlet_constrained",
    "ref:ias15",
    "mujoco:euler",
    "mujoco:rk4",
    "pymunk:applied_force",
    "pybullet:semi_implicit",
    "rebound:whfast",
]
#: Numbers as a command line spells them, hostile ones first.
HOSTILE = [
    "nan",
    "NaN",
    "inf",
    "-inf",
    "Infinity",
    "-1",
    "0",
    "-0",
    "0.0",
    "1e308",
    "1e400",
    "-1e400",
    "1e-320",
    "10" * 20,
    "abc",
    "",
    " ",
    "0x10",
    "1,5",
    "None",
    "☃",
    "1e",
    "--",
]
#: Values certain to be refused by a numeric field that wants a positive finite number or a count.
CERTAINLY_BAD = ["nan", "inf", "-inf", "-1", "abc", "", "1e400", "☃"]

text = st.text(alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=8)
hostile_number = st.one_of(
    st.sampled_from(HOSTILE),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-(10**40), 10**40).map(str),
    text,
)
name = st.one_of(st.sampled_from(SCENE_IDS + METHODS + ["spring ", "SPRING", "ref:", ":", "ref:nope", "mujoco:"]), text)


def set_values() -> st.SearchStrategy:
    """``--set KEY=VALUE`` of every scene's parameters: valid keys with hostile values, unknown
    keys, malformed pairs."""
    keys = sorted({k for cls in SCENES.values() for k in cls.params} | {"bogus", "", "k k"})
    pair = st.builds(lambda k, v: f"{k}={v}", st.sampled_from(keys), hostile_number)
    return st.one_of(pair, text, st.sampled_from(["k", "=1", "k==1", "N=1e9", "N=2.5", "e=1", "theta0=4"]))


def flags(draw, spec: dict) -> list[str]:
    """Some of ``spec``'s flags (name -> strategy of values), each maybe given, in drawn order."""
    out = []
    for flag, values in spec.items():
        if draw(st.booleans()):
            out += [flag, draw(values)]
    return out


@st.composite
def files(draw, paths: dict) -> str:
    return str(paths[draw(st.sampled_from(sorted(paths)))])


@pytest.fixture(scope="module")
def paths(tmp_path_factory) -> dict:
    """A real history (one complete run, one cell), and files that are not one."""
    tmp = tmp_path_factory.mktemp("fuzz")
    h = History(tmp / "history.sqlite")
    run = h.start_run(
        started="2026-11-25T02:00:00+00:00", suite="smoke", git_commit="a" * 40, versions={}, machine={}, settings={}
    )
    h.add_cell(
        run,
        {
            "scene": "spring",
            "method": "ref:rk4",
            "family": "ref",
            "measure": "energy",
            "dt": 0.1,
            "steps": 100,
            "status": "ok",
            "value": 2.5e-6,
            "data": {},
        },
    )
    h.finish_run(run, finished="t", wall_s=1.0, timing={}, regressions=0)
    real = (tmp / "history.sqlite").read_bytes()
    bounds = (Path(__file__).resolve().parents[1] / "harness" / "history" / "energy_bounds.csv").read_text()
    out = {"history": tmp / "history.sqlite", "missing": tmp / "nowhere" / "h.sqlite"}
    for label, content in {
        "empty": b"",
        "truncated_db": real[: len(real) // 3],
        "garbage": bytes(range(256)) * 4,
        "truncated_csv": bounds[: len(bounds) // 2].encode(),
        "empty_csv": b"",
        "csv_header_only": bounds.splitlines()[0].encode() + b"\n",
    }.items():
        (tmp / label).write_bytes(content)
        out[label] = tmp / label
    out["directory"] = tmp
    return out


def dump(db: Path) -> list | None:
    """Every row of a history's tables (None: not a readable history)."""
    try:
        with contextlib.closing(sqlite3.connect(db)) as con:
            return [con.execute(f"SELECT * FROM {t} ORDER BY rowid").fetchall() for t in ("runs", "cells")]
    except sqlite3.DatabaseError:
        return None


def check(argv: list[str], must_refuse: bool, history: Path) -> None:
    """The property (module docstring) for one command line."""
    before = dump(history)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse: --help, and its own refusals
            code = exc.code
    said = err.getvalue()
    assert code in (0, 1, 2), (argv, code, said[-2000:])
    assert "Traceback" not in said and "Traceback" not in out.getvalue(), (argv, said[-2000:])
    if code == 2:
        lines = said.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("harness: error: "), (argv, said[-2000:])
        assert dump(history) == before, argv  # refused: nothing written
    if must_refuse:
        assert code == 2, (argv, code, said[-500:])
    with contextlib.closing(sqlite3.connect(history)) as con:
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"


# ----------------------------------------------------------------------------- the command lines
def _measure_common(draw, scene_valid: bool = True) -> list[str]:
    scene = draw(st.sampled_from(SCENE_IDS)) if scene_valid else draw(name)
    out = [scene]
    if draw(st.booleans()):
        out += ["--method", draw(st.one_of(st.sampled_from(METHODS), name))]
    for _ in range(draw(st.integers(0, 2))):
        out += ["--set", draw(set_values())]
    return out


def _poisoned(draw, spec: dict, certainly_bad: dict) -> list[str]:
    """``spec``'s flags, one of ``certainly_bad``'s certainly refused: the command must exit 2."""
    poison = draw(st.sampled_from(sorted(certainly_bad)))
    spec = {k: v for k, v in spec.items() if k != poison}
    return flags(draw, spec) + [poison, draw(certainly_bad[poison])]


bad = st.sampled_from(CERTAINLY_BAD)
small_count = st.one_of(st.integers(0, 20).map(str), hostile_number)


@st.composite
def argv_for(draw, command: str, paths: dict) -> tuple[list[str], bool]:
    """(a command line of ``command``, whether it must be refused)."""
    db = files(paths)
    if command == "list":
        return ["list", *(["--json"] if draw(st.booleans()) else [])], False
    if command in ("run", "energy"):
        head = [command, *_measure_common(draw)]
        if "--method" not in head:
            head += ["--method", draw(st.sampled_from(METHODS))]
        spec = {
            "--dt": st.one_of(st.sampled_from(["0.1", "0.01", "1e-3"]), hostile_number),
            "--steps": small_count,
            "--every": small_count,
            "--timeout": st.one_of(st.just("30"), hostile_number),
        }
        if command == "run":
            spec["--format"] = st.one_of(st.sampled_from(["table", "csv", "json"]), text)
            spec["--opt"] = st.one_of(st.sampled_from(["iterations=3", "iterations=0", "iterations=1e30"]), text)
        argv = head + flags(draw, spec)
        for required in ("--dt", "--steps"):  # usually given, so that the valid runs run
            if required not in argv and draw(st.integers(0, 4)):
                argv += [required, draw(spec[required])]
        return argv, False
    measuring = {
        "order": {
            "--points": small_count,
            "--span": hostile_number,
            "--periods": hostile_number,
            "--order-hint": small_count,
            "--dt": hostile_number,
            "--timeout": hostile_number,
        },
        "stability": {
            "--criterion": st.one_of(st.sampled_from(["energy", "state"]), text),
            "--steps": small_count,
            "--lo": hostile_number,
            "--hi": hostile_number,
            "--timeout": hostile_number,
        },
        "cost": {
            "--dt": hostile_number,
            "--repeats": small_count,
            "--time-steps": small_count,
            "--count-steps": small_count,
            "--timeout": hostile_number,
        },
        "workprecision": {
            "--points": small_count,
            "--homega-max": hostile_number,
            "--periods": hostile_number,
            "--repeats": small_count,
            "--timeout": hostile_number,
        },
        "advise": {
            "--hz": hostile_number,
            "--horizon": hostile_number,
            "--energy-tol": hostile_number,
            "--error-tol": hostile_number,
            "--max-substeps": small_count,
            "--jobs": small_count,
            "--timeout": hostile_number,
            "--methods": st.one_of(name, st.just("ref:*")),
        },
        "identify": {"--dt": hostile_number, "--steps": small_count, "--timeout": hostile_number},
    }
    if command in measuring:
        spec = measuring[command]
        poisonable = {k: bad for k in spec if k not in ("--methods", "--criterion")}
        return [command, *_measure_common(draw), *_poisoned(draw, spec, poisonable)], True
    if command == "nightly":
        spec = {
            "--suite": st.one_of(st.sampled_from(["smoke", "standard"]), name),
            "--jobs": small_count,
            "--cell-timeout": hostile_number,
            "--bounds": files(paths),
            "--scheduler": text,
            "--db": db,
            "--out": st.just(str(paths["directory"] / "out")),
        }
        poisonable = {
            "--suite": st.one_of(st.just("bogus"), st.just("")),
            "--jobs": bad,
            "--engine": st.sampled_from(["nope==1.0", "mujoco", "==4.0.0", "mujoco==", "mujoco=4.0.0"]),
            "--cell-timeout": bad,
            "--bounds": st.sampled_from([str(paths["truncated_csv"]), str(paths["garbage"])]),
        }
        return ["nightly", *_poisoned(draw, spec, poisonable)], True
    if command == "model":
        # The file is never a model (a history, garbage, a missing .xml): refused whatever the flags.
        path = draw(st.one_of(files(paths), st.just(str(paths["directory"] / "nope.xml"))))
        spec = {
            "--variant": st.one_of(st.sampled_from(["as_written", "conservative"]), name),
            "--keep": st.one_of(st.sampled_from(["contact", "gravity"]), name),
            "--seed": small_count,
            "--perturb": hostile_number,
            "--hz": hostile_number,
            "--energy-tol": hostile_number,
            "--jobs": small_count,
            "--db": db,
            "--out": st.just(str(paths["directory"] / "out")),
        }
        return ["model", path, *flags(draw, spec), *(["--json"] if draw(st.booleans()) else [])], True
    if command == "bisect":
        # Always one field refused before the registry is asked or anything installed.
        spec = {
            "--scene": st.one_of(st.sampled_from(["spring", "pendulum"]), name),
            "--method": st.one_of(st.just("mujoco:euler"), name),
            "--measure": st.one_of(st.sampled_from(["trajectory", "energy", "stability"]), text),
            "--dt": hostile_number,
            "--steps": small_count,
        }
        poisonable = {
            "--measure": st.sampled_from(["bogus", "", "cost"]),
            "--dt": bad,
            "--steps": bad,
            "--method": st.sampled_from(["ref:rk4", "pybullet:semi_implicit", "mujoco:nope"]),
            "--scene": st.sampled_from(["nope", str(paths["garbage"]), str(paths["directory"] / "x.xml")]),
        }
        versions = st.one_of(st.sampled_from(["2.3.7", "3.3.7", "4.0.0"]), text)
        head = ["bisect", draw(st.one_of(st.just("mujoco"), name)), draw(versions), draw(versions)]
        return head + _poisoned(draw, spec, poisonable), True
    if command == "bench":
        return [
            "bench",
            "--methods",
            draw(st.sampled_from(["ref:nope", "", "mujoco:", "x"])),
            *(["--engines"] if draw(st.booleans()) else []),
        ], True
    if command == "history":
        spec = {
            "--scene": name,
            "--method": name,
            "--measure": st.one_of(st.sampled_from(["energy", "cost"]), text),
            "--last": small_count,
            "--suite": name,
            "--measurement-version": small_count,
            "--db": db,
        }
        return ["history", *flags(draw, spec), *(["--json"] if draw(st.booleans()) else [])], False
    if command == "compare":
        argv = ["compare"] + [draw(small_count) for _ in range(draw(st.integers(0, 2)))]
        return argv + flags(draw, {"--db": db, "--bounds": files(paths)}), False
    if command == "bounds":
        spec = {"--run": small_count, "--db": db, "--file": files(paths)}
        argv = ["bounds", *flags(draw, spec)]
        for switch in ("--update", "--allow-loosen", "--json"):  # never --write: it would rewrite a file
            if draw(st.booleans()):
                argv.append(switch)
        return argv, False
    if command == "contact":  # every line poisoned: a valid one steps every engine, too slow to fuzz
        kind = draw(st.sampled_from(["scene", "penalty", "advise"]))
        if kind == "scene":
            argv = ["contact", draw(st.sampled_from(["ball", "slide", "rest", "stack"]))]
            argv += _poisoned(draw, {"--set": set_values(), "--modes": name}, {"--dt": bad})
        elif kind == "penalty":
            argv = ["contact", "--penalty"] + _poisoned(draw, {"--methods": name}, {"--grid": bad})
        else:
            argv = ["contact", "--advise"] + _poisoned(draw, {"--modes": name}, {"--hz": bad})
        return argv, True
    raise AssertionError(f"no fuzzing for command {command!r}: add it")


def _fuzz(command: str, paths: dict, data) -> None:
    argv, must_refuse = data.draw(argv_for(command, paths))
    check(argv, must_refuse, paths["history"])


def test_every_command_is_fuzzed():
    assert set(COMMANDS) == {
        "run",
        "list",
        "bench",
        "identify",
        "energy",
        "order",
        "stability",
        "cost",
        "workprecision",
        "advise",
        "model",
        "contact",
        "nightly",
        "compare",
        "history",
        "bounds",
        "bisect",
    }


@pytest.mark.parametrize("command", COMMANDS)
@settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.data_too_large],
)
@given(data=st.data())
def test_bad_input_is_one_line_never_a_traceback(command, paths, data):
    _fuzz(command, paths, data)


@pytest.mark.slow
@pytest.mark.parametrize("command", COMMANDS)
@settings(
    max_examples=LONG_EXAMPLES,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.data_too_large],
)
@given(data=st.data())
def test_bad_input_is_one_line_never_a_traceback_long(command, paths, data):
    _fuzz(command, paths, data)
