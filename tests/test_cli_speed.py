"""The single-scene commands step reference schemes as the nightly does, on the pair's compiled
loop wherever it computes the interpreted bits (``reference.RefMethod``), give the nightly cell's
numbers where they ask its question, and say what they are doing once they run longer than a few
seconds.

No test here reads a clock to judge: the progress threshold is injected."""

import io
import json
from contextlib import redirect_stderr, redirect_stdout

import pytest

from reference import _compiled, method as ref_method
from scenarios import make_scene

from harness.cli import main
from harness.nightly import progress


def cli(*argv):
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as exc:  # argparse errors
            code = exc.code
    return code, out.getvalue(), err.getvalue()


@pytest.fixture
def stepped(monkeypatch):
    """Every reference run of this process, by the path it took: the interpreted driver's steps
    (``integrate``) and the runs on the compiled loop."""
    seen = {"interpreted_steps": 0, "compiled": 0}
    integrate, integrate_compiled = ref_method.integrate, ref_method.integrate_compiled

    def counting(scheme, scene, dt, steps, every=1, **kw):
        seen["interpreted_steps"] += int(steps)
        return integrate(scheme, scene, dt, steps, every, **kw)

    def recording(*args, **kw):
        seen["compiled"] += 1
        return integrate_compiled(*args, **kw)

    monkeypatch.setattr(ref_method, "integrate", counting)
    monkeypatch.setattr(ref_method, "integrate_compiled", recording)
    return seen


def test_stability_steps_the_compiled_run_not_the_interpreter(stepped):
    # The command on a 3 x 3 cloth (the default 8 x 8 costs its compile, the same path).
    code, out, _ = cli(
        "stability",
        "cloth",
        "--set",
        "n=3",
        "--set",
        "m=3",
        "--method",
        "ref:semi_implicit_euler",
        "--steps",
        "300",
        "--hi",
        "10",
        "--rtol",
        "1e-2",
        "--json",
    )
    assert code == 0, out
    res = json.loads(out)
    assert res["criterion"] == "finite_horizon" and res["verdict"] == "limited"
    # One run on the compiled loop per finite-horizon test, nothing interpreted.
    assert stepped["compiled"] == res["evaluations"]
    assert stepped["interpreted_steps"] == 0


@pytest.mark.parametrize("cached", [True, False], ids=["loops_cached", "cache_empty"])
def test_identify_steps_every_candidate_it_runs_in_full_on_the_compiled_run(stepped, monkeypatch, cached):
    """A candidate's full run takes its compiled loop where the kernel cache holds it, and is
    interpreted (the same bits) where it does not: a candidate never compiles. The cache's state
    is the test's (``_loop_compiled``), so the count does not depend on what ran before."""
    from harness.measures import identify as ident

    monkeypatch.setattr(ident, "_CANDIDATES", {})
    monkeypatch.setattr(ident, "_stored", lambda key, run: run())  # no candidate run read from the disk
    monkeypatch.setattr(ident, "_loop_compiled", lambda ref, scene: cached)
    # Which path each run takes is the question, not its bits (the same either way: held by
    # tests/test_compiled_runs.py): a run sent to the compiled loop is counted there and stepped by
    # the interpreter, so that no candidate's loop compiles here on an empty cache.
    from reference import integrate as interpreted

    def compiled_path(scheme, scene, dt, steps, every=1, counted=False, **kw):
        stepped["compiled"] += 1
        return interpreted(scheme, scene, dt, steps, every, **kw)

    monkeypatch.setattr(ref_method, "integrate_compiled", compiled_path)
    code, out, _ = cli("identify", "spring", "--method", "ref:leapfrog", "--steps", "200", "--json")
    assert code in (0, 1), out  # 1: no other scheme matches
    res = json.loads(out)
    # The method's own run, and each candidate's in full where its loop is cached, on the compiled
    # loop; the screen's short runs step ``reference.integrate`` itself (interpreted), never the
    # method's backend.
    full = sum(c["steps"] == res["steps"] for c in res["candidates"])
    assert full >= 1
    assert stepped["compiled"] == 1 + (full if cached else 0)


@pytest.mark.parametrize(
    "argv",
    [
        ("run", "pendulum", "--method", "ref:rk4", "--dt", "0.01", "--steps", "50", "--format", "csv"),
        ("energy", "pendulum", "--method", "ref:rk4", "--dt", "0.05", "--steps", "200"),
        ("order", "pendulum", "--method", "ref:leapfrog", "--points", "6", "--periods", "0.25"),
        (
            "cost",
            "pendulum",
            "--method",
            "ref:leapfrog",
            "--dt",
            "0.05",
            "--repeats",
            "1",
            "--time-steps",
            "100",
            "--count-steps",
            "50",
        ),
        ("workprecision", "pendulum", "--method", "ref:leapfrog", "--points", "2", "--repeats", "1"),
    ],
)
def test_every_single_scene_command_steps_the_compiled_run(stepped, argv):
    code, out, _ = cli(*argv)
    assert code == 0, out
    assert stepped["compiled"] and stepped["interpreted_steps"] == 0


def test_stability_gives_the_nightly_cells_numbers_for_its_question():
    """The standard suite's stability question on the pendulum, asked by the command, is
    answered with the nightly cell's numbers, bit for bit."""
    from harness.methods import get_method
    from harness.nightly.cells import _stability
    from harness.nightly.run import Task
    from harness.nightly.suites import SUITES

    suite = SUITES["standard"]
    spec = suite.scenes["pendulum"]
    task = Task("cell", "pendulum", "ref:leapfrog", "ref", {}, suite)
    scene = make_scene("pendulum")
    cell = _stability(task, get_method("ref:leapfrog", compiled_where_bitwise=True), scene, suite, spec)
    code, out, _ = cli(
        "stability",
        "pendulum",
        "--method",
        "ref:leapfrog",
        "--steps",
        str(suite.stability_steps),
        "--hi",
        repr(suite.stability_homega_max),
        "--rtol",
        repr(suite.stability_rtol),
        "--json",
    )
    assert code == 0, out
    res = json.loads(out)
    assert (res["omega_dt_max"], res["dt_max"], res["criterion"]) == (
        cell.value,
        cell.figures.dt_max,
        cell.figures.criterion,
    )


def test_identify_gives_the_nightly_cells_answer():
    from harness.methods import get_method
    from harness.nightly.cells import _identity
    from harness.nightly.run import Task

    task = Task("cell", "spring", "mujoco:euler", "mujoco", {}, "standard")
    scene = make_scene("spring")
    cell = _identity(task, get_method("mujoco:euler"), scene)
    code, out, _ = cli("identify", "spring", "--method", "mujoco:euler", "--json")
    assert code == 0, out
    res = json.loads(out)
    assert (res["match"], res["max_deviation"]) == (cell.figures.match, cell.value)
    assert res["runner_up"]["max_deviation"] == cell.figures.runner_up_deviation


def test_a_long_command_says_what_it_is_doing(monkeypatch, tmp_path):
    monkeypatch.setattr(progress, "QUIET_S", 0.0)  # every line at once, as past the threshold
    monkeypatch.setenv("HARNESS_CACHE", str(tmp_path))  # nothing compiled here: the compile is named
    monkeypatch.setattr(_compiled, "_DRIVERS", {})  # nor loaded in this process
    code, out, err = cli(
        "stability", "pendulum", "--method", "ref:leapfrog", "--steps", "200", "--hi", "10", "--rtol", "1e-2", "--json"
    )
    assert code == 0, out
    res = json.loads(out)
    lines = err.splitlines()
    assert any(line.startswith("compiling the loop of leapfrog on pendulum") for line in lines)
    runs = [line for line in lines if line.startswith("stability: ")]
    assert len(runs) == res["evaluations"]
    assert runs[0].startswith("stability: scanning h*omega from 0.0001 up to 10 by x2: run 1 of at most 18 ")
    bisect = [line for line in runs if line.startswith("stability: bisecting h*omega in [")]
    assert bisect and bisect[-1].split(": run ")[1].startswith(f"{res['evaluations']} of ~{res['evaluations']} ")


def test_progress_is_quiet_for_its_first_seconds_then_says_the_latest():
    now = [0.0]
    stream = io.StringIO()
    lines = progress.Lines(stream, quiet_s=1e6, clock=lambda: now[0])  # the timer never fires in a test
    with lines:
        lines("identify: candidate ref:rk4, 1 of 11")
        lines("identify: candidate ref:leapfrog, 2 of 11")
        assert stream.getvalue() == ""  # a quick answer prints nothing but itself
        lines._wake()  # the moment the threshold passes: the latest line held is said
        assert stream.getvalue() == "identify: candidate ref:leapfrog, 2 of 11\n"
        lines("identify: candidate ref:verlet, 3 of 11")
    assert stream.getvalue().splitlines()[-1] == "identify: candidate ref:verlet, 3 of 11"

    stream = io.StringIO()
    with progress.Lines(stream, quiet_s=5.0, clock=lambda: now[0]) as lines:
        lines("held")
        now[0] = 5.0  # past the threshold on the command's clock: the newer line is said, not the held one
        lines("said")
        lines._wake()  # a timer late behind a compile says nothing more
    lines._wake()
    assert stream.getvalue() == "said\n"


@pytest.mark.parametrize(
    "argv,env,field",
    [
        (("stability", "spring", "--method", "ref:rk4", "--rtol", "1.5"), None, "--rtol"),
        (("stability", "spring", "--method", "ref:rk4", "--rtol", "nan"), None, "--rtol"),
        (("run", "spring", "--method", "ref:rk4", "--dt", "0.1", "--steps", "2"), "soon", "HARNESS_PROGRESS_AFTER"),
        (("run", "spring", "--method", "ref:rk4", "--dt", "0.1", "--steps", "2"), "-1", "HARNESS_PROGRESS_AFTER"),
    ],
)
def test_bad_input_is_one_line_naming_the_field(monkeypatch, argv, env, field):
    if env is not None:
        monkeypatch.setenv("HARNESS_PROGRESS_AFTER", env)
    code, out, err = cli(*argv)
    assert code == 2 and out == "" and err.count("\n") == 1 and field in err and "allowed" in err


def test_the_advice_the_sweep_and_the_contact_advice_say_what_they_are_doing(monkeypatch):
    """The multi-method commands name each method's search as it ends, each value of a sweep and each
    contact mode's runs, on stderr: their answer on stdout is the same as without."""
    monkeypatch.setattr(progress, "QUIET_S", 0.0)
    methods = ("--methods", "ref:rk4,ref:leapfrog", "--jobs", "1")
    code, out, err = cli("advise", "spring", "--hz", "60", "--horizon", "2", *methods)
    assert code == 0, err
    lines = [line for line in err.splitlines() if line.startswith("advise: ")]
    assert lines[:2] == [
        "advise: the predictable horizon (two references of spring)",
        "advise: 2 methods searched in 1 workers",
    ]
    ended = sorted(line.split("(")[1] for line in lines[2:])
    assert [line.split(" of 2")[0] for line in lines[2:]] == ["advise: 1", "advise: 2"]
    assert ended == ["ref:leapfrog: 1 substep)", "ref:rk4: 1 substep)"]
    assert "ref:rk4" in out and "advise: " not in out
    code, out, err = cli("advise", "spring", "--hz", "60", "--horizon", "2", "--sweep", "k=1..100:2", *methods)
    assert code == 0, err
    sweep = [line for line in err.splitlines() if line.startswith("sweep: ")]
    assert sweep == ["sweep: k = 1, value 1 of 2, 2 methods", "sweep: k = 100, value 2 of 2, 2 methods"]
    code, out, err = cli("contact", "--advise", "--hz", "60", "--modes", "mujoco:euler", "--json")
    assert code == 0, err
    said = [line for line in err.splitlines() if line.startswith("contact: ")]
    assert said[:3] == [f"contact: {s}, mujoco:euler at dt 1/60" for s in ("ball", "slide", "stack")]
    assert json.loads(out)  # the answer alone on stdout
