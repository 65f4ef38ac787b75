"""The README is a guide and the code says what it does: README.md stays at most 250 lines and
every ``docs/`` page it links exists; no code comment or docstring carries a machine timing.

A machine timing (how long something took on some machine) goes stale with the machine, the
load and the code; it belongs in ``docs/performance.md`` with its date and commit. A physical
time (``dt = 0.01 s``, "over 2 s of simulated time") or a setting (a timeout, a time budget
named by its constant) is not one.

The rule, in two parts, applied to each clause (text between ``;``, ``:`` or a sentence end)
of every comment and docstring of the project's packages:

* a number with a sub-second unit (ns, µs, us, ms) or a CPU-time unit (CPU-s, CPU-min) is a
  timing: no scene's physical time is stated in those units (the scenes' time unit is the
  second, and their steps are written as bare numbers, ``h = 1e-3``);
* a number of seconds, minutes or hours is a timing where its clause also names what machines
  spend time on: taking, costing, running, compiling, importing, loading, interpreting, a wall
  or CPU clock, cores, a machine, "measured here". A physical time's clause names the scene, a step or an energy
  instead ("measured" alone does not decide: a physical figure is measured too).

A number that restates a named setting, ``RUN_S`` (20 ms), ``ENGINE_RUN_BUDGET_S (0.1 s``, or
follows "at most" (a budget, not a measurement), is not flagged. Both parts are held against
the timings once written in the code (``TIMINGS`` below, as they read) and against physical
times the code states (``PHYSICAL``).
"""

from __future__ import annotations

import ast
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("adapters", "harness", "records", "reference", "reports", "scenarios")
README_MAX_LINES = 250

_NUMBER = r"(?<![\w.])\d+(?:\.\d+)?(?:\s?-\s?\d+(?:\.\d+)?)?"
_SHORT = re.compile(_NUMBER + r"\s?(?:ns|µs|us|ms|CPU-s|CPU-min)\b")
_LONG = re.compile(_NUMBER + r"\s?(?:s|secs?|seconds?|min|minutes?|hours?)\b")
_MACHINE = re.compile(
    r"\b(?:took|takes?|taking|costs?|costing|ran|runs? in|compil\w*|import\w*|"
    r"load\w*|interpret\w*|measured here|wall(?:[- ]clock|[- ]time)?\b(?! spring)|CPU|cores?|"
    r"machine)\b",
    re.IGNORECASE,
)
#: A number that restates a named setting or a budget: ``NAME_S`` (20 ms), NAME_S (0.1 s, ..., at most 0.02 s.
_SETTING = re.compile(r"(?:\b[A-Z][A-Z0-9_]*_S`{0,2}\s\(|\bat most\s)$")
_CLAUSE = re.compile(r";\s|\.\s+(?=[A-Z(`*])|\n\s*\n")


def timings_in(text: str) -> list[str]:
    """The clauses of ``text`` that state a machine timing (the rule in the module docstring)."""
    found = []
    for clause in _CLAUSE.split(" ".join(text.split())):
        for pattern in (_SHORT, _LONG):
            for m in pattern.finditer(clause):
                if _SETTING.search(clause[: m.start()]):
                    continue
                if pattern is _SHORT or _MACHINE.search(clause):
                    found.append(clause.strip())
                    break
            else:
                continue
            break
    return found


def comments_and_docstrings(path: Path):
    """``(line, text)`` of every comment and every docstring (module, class, function) of a file."""
    source = path.read_text(encoding="utf-8")
    block: list[tuple[int, str]] = []  # a comment continued on the next lines is one text
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type != tokenize.COMMENT:
            continue
        if block and tok.start[0] != block[-1][0] + 1:
            yield block[0][0], " ".join(text for _, text in block)
            block = []
        block.append((tok.start[0], tok.string.lstrip("#:").strip()))
    if block:
        yield block[0][0], " ".join(text for _, text in block)
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=True)
            if doc:
                yield node.body[0].lineno, doc


def _sources():
    for package in PACKAGES:
        yield from sorted((ROOT / package).rglob("*.py"))


#: Timings the code once carried in its comments and docstrings, as they read; moved to docs/performance.md.
TIMINGS = [
    "each array handed to serialize_particle_data costs ~5 us of ctypes conversion.",
    "Compiling a counted run costs about 0.5 CPU-s on a pointwise scene and 1.2-2 on an array scene",
    "pymunk's step read 30-73 us of wall time and 9.2-13 us of CPU time",
    "a finite-horizon test against a reference solve took 24 s at h*omega = 1 on the solar system",
    "MuJoCo's flexcomp membrane on the cloth's grid: not the same model, measured against its own refined RK4 "
    "run; left out of the standard suite (one task took 40 s, the stability search of mujoco:discrete to "
    "h*omega 80 the most of it).",
    "interpreted in a fraction of the 0.3-3 CPU-s a compile costs.",
    "``standard`` is what ``make nightly`` runs (<= 5 minutes on 2 cores),",
    "its finite-horizon test costs in proportion to dt: 4.6 s at 100 on Kepler",
    "so a search to 1e4 would take about 15 minutes.",
    "each costs its (scheme, scene) numba compile, 5-10 s of CPU.",
    "Measured here: IAS15 on Kepler, 12 realizations, 31 s (the full suite's 24, 63 s)",
    "left out of the standard suite (one task took 40 s, the stability search of mujoco:discrete",
    "backward Euler's Newton iterations over the cloth's solve, interpreted, passed the 120 s limit at 4 x 4.",
    "Steps of each workload per repeat: about 1 ms each on this project's machine.",
    "Kepler's implicit midpoint at 1.2 us a step, or the solar system's RK4, say in 20 ms what 100,000 steps say",
    "(1,000 WHFast steps on the solar system, 1.5 ms, came out at -0.6 us a step",
    "a 32-body chain stepped from Python costs ~100 us a step, and 10,000 steps x 6 runs would take half a minute",
    "a worker's compiled explicit Euler ran at 80 ns a step and, for seconds on end, at 140-150 ns",
    "so 26 steps, 0.2 ms, are timed against a 0.04 ms setup",
    "the engines loaded (importing MuJoCo alone takes about 0.3 s).",
    "(a warm standard nightly: 227 kernels in 4.7 s on this project's 2-core machine).",
    "compiling them took 87 CPU-s at level 2 against 150 at level 3",
    "Registered before the first kernel compiles, not on import (numba takes ~0.5 s to import).",
    "a pair compiles once per machine and source, 1-15 s, then loads in milliseconds",
    "for a few milliseconds (a few hundred on the cloth, whose interpreted step takes 1.5-3 ms).",
    "numba compiles it in 1.7 s instead of 11 s and runs it in 0.25 us instead of 7.3 us",
    "interpreted it takes 103 us instead of 492 us (measured, batch 1).",
    "numba compiled those in 8.2 s against 0.6 s for the loops, measured",
    "Loops written out, as in ``accel`` (compile 1.8 s -> 0.4 s).",
    "(measured 4.4 ns against 0.45 ns per spring-step for a batch of 1000).",
    "measured compiled at h = 1/60 on square sheets of constant mass per node: LDL^T 0.37 ms against CG 0.83 ms",
    "made a compiled pass 7x slower (2.5 us against 0.35 us per pass of 10 links)",
]

#: Physical times, settings and budgets the code states: none is a timing.
PHYSICAL = [
    "defaults to 0.1 (4.2e-3 apart there, 0.9% of the energy gone in 1 s).",
    "rope it follows the reduced-coordinate reference to 1.3e-9 over 2 s at dt = 1e-4.",
    "the energy decays at a rate proportional to h (measured on the default rope, 16 passes: -10% after 1 s "
    "at h = 2e-3, -5.8% at 1e-3, -3.2% at 5e-4).",
    "The advice on the cloth: over the reference's trusted 2 s (the falling sheet is chaotic past",
    "The advice a game or animation programmer asks for: 10 s at the suite's frame rates",
    "folds chaotically, differences growing about 100-fold per half second after t = 1.5",
    "(free floating, no springs) is given a period of 2 pi seconds.",
    "* **Steps**: N such that the bare loop runs about ``RUN_S`` (20 ms), at least ``MIN_STEPS``;",
    "REF_RUN_BUDGET_S (0.02 s, judged from a pilot run of REF_PILOT_STEPS, 2,000) runs fewer steps",
    "a compiled loop's repeat at most 0.02 s and an engine's at most 0.1 s (a slow kernel's figure",
    "bending, ``k_bend``: (i, j)-(i, j+2) and (i, j)-(i+2, j), rest length 2 s.",
    "the wall springs are the missing neighbours of the end masses, 1 s apart",
]


@pytest.mark.parametrize("text", TIMINGS)
def test_the_rule_finds_each_timing_the_code_once_carried(text):
    assert timings_in(text), text


@pytest.mark.parametrize("text", PHYSICAL)
def test_the_rule_leaves_physical_times_and_settings_alone(text):
    assert not timings_in(text), text


def test_no_comment_or_docstring_carries_a_machine_timing():
    found = [
        f"{path.relative_to(ROOT)}:{line}: {clause}"
        for path in _sources()
        for line, text in comments_and_docstrings(path)
        for clause in timings_in(text)
    ]
    assert not found, (
        "machine timings in comments or docstrings (say what the code does and why; the "
        "measurement goes to docs/performance.md with its date and commit):\n" + "\n".join(found)
    )


def test_the_readme_is_a_guide_of_at_most_250_lines():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines (at most {README_MAX_LINES})"


def test_every_docs_page_the_readme_links_exists():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    links = set(re.findall(r"\]\((docs/[^)#\s]+)", text)) | set(re.findall(r"`(docs/[\w./-]+\.md)`", text))
    assert links, "README.md links no docs/ page"
    missing = sorted(link for link in links if not (ROOT / link).is_file())
    assert not missing, f"README.md links docs/ pages that do not exist: {missing}"


#: README commands whose output is neither timed nor minutes long: their excerpts are run and held
#: to the real output. (``advise``, ``workprecision``, ``cost`` and ``bench`` print timings; ``model``,
#: ``nightly`` and Newton's identification run for minutes: their excerpts are measured by hand.)
CHECKED_COMMANDS = (
    "list",
    "run",
    "identify spring --method mujoco:",
    "identify spring --method drake:",
    "energy",
    "order",
    "stability",
)
#: The one mark of rows an excerpt leaves out.
ELIDED = "…"


def readme_excerpts() -> list[tuple[str, list[str]]]:
    """(command, the lines README shows of its output) for every ``$ harness ...`` in README's code blocks."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    out = []
    for block in re.findall(r"```\n(.*?)```", text, re.S):
        command, shown = None, []
        for line in block.splitlines():
            if line.startswith("$ harness "):
                if command is not None:
                    out.append((command, shown))
                command, shown = line[len("$ harness ") :], []
            elif command is not None:
                shown.append(line)
        if command is not None:
            out.append((command, shown))
    return out


def elision_errors(shown: list[str], real: list[str]) -> list[str]:
    """What is wrong with an excerpt of ``real``: a line shown that the command does not print (in
    order), or rows left out with no ``…`` where they were."""
    errors, at, gap = [], -1, False
    for line in shown:
        if line.strip() == ELIDED:
            gap = True
            continue
        try:
            i = real.index(line, at + 1)
        except ValueError:
            errors.append(f"not printed (or out of order): {line!r}")
            continue
        if i != at + 1 and not gap:
            errors.append(f"rows left out before {line!r} with no {ELIDED}")
        at, gap = i, False
    if at < len(real) - 1 and not gap:
        errors.append(f"rows left out after the last line shown with no {ELIDED}")
    return errors


def test_the_elision_rule():
    real = ["a", "b", "c", "d"]
    assert elision_errors(["a", "b", "c", "d"], real) == []
    assert elision_errors(["a", ELIDED, "d"], real) == [] and elision_errors(["a", "b", ELIDED], real) == []
    assert elision_errors(["a", "d"], real) == ["rows left out before 'd' with no …"]
    assert elision_errors(["a", "b"], real) == ["rows left out after the last line shown with no …"]
    assert elision_errors(["a", "x"], real)[0].startswith("not printed")


def test_readme_excerpts_are_the_commands_real_output_and_mark_what_they_leave_out(capsys):
    """Issue 42: README's excerpts dropped rows without a mark. Every excerpt of a command that prints
    no timing is run here and held to its output, rows left out marked ``…``; every excerpt marks
    with ``…`` alone, never "..."."""
    import shlex

    from harness.cli import main

    excerpts = readme_excerpts()
    assert not [line for _, shown in excerpts for line in shown if line.strip() == "..."]
    checked = 0
    for command, shown in excerpts:
        if not command.startswith(CHECKED_COMMANDS):
            continue
        capsys.readouterr()
        main(shlex.split(command))
        real = capsys.readouterr().out.splitlines()
        assert not elision_errors(shown, real), (command, elision_errors(shown, real))
        checked += 1
    assert checked >= 6  # list, run, identify, energy, order, stability


def test_the_model_file_readme_runs_is_shipped():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    files = re.findall(r"harness model (\S+\.(?:xml|urdf))", text)
    assert files and all((ROOT / f).is_file() for f in files), files
