"""harness.judge: the check/cross rules against the claims, the bounds, the verdict and the scenes'
findings tables, on cells built by hand; and reports/ rendering the records it returns without
importing anything of the harness."""

from __future__ import annotations

import ast
import dataclasses
import math
from pathlib import Path
from types import SimpleNamespace

import pytest

from records.cell import FIGURES, Cell, Claims
from records.findings import MARK, Finding
from records.method import Behaviour

from harness import judge
from reports.markdown import CHECK, CROSS, finding_line, verdict as verdict_lines

LEAPFROG = Claims(scheme="ref:leapfrog", order=2, force_evals=1, force_evals_text="1", energy="bounded", homega_max=2.0)


def cell(measure, value=None, method="ref:leapfrog", scene="spring", status="ok", claims=LEAPFROG, **figures):
    return Cell(
        scene=scene,
        method=method,
        family=method.split(":")[0],
        measure=measure,
        status=status,
        value=value,
        dt=0.1,
        steps=100,
        figures=FIGURES[measure](**figures),
        claims=claims,
    )


def checks(*cells):
    return judge.claim_checks({c.measure: c for c in cells})


def test_order_is_checked_within_its_tolerance():
    assert checks(cell("order", 2.0 + 0.99 * judge.ORDER_TOL)).order is True
    assert checks(cell("order", 2.0 + 1.01 * judge.ORDER_TOL)).order is False
    assert checks(cell("order", 2.0, status="unstable")).order is None


def test_evaluations_energy_and_the_claims_judged_against():
    got = checks(cell("cost", 1e-7, force_evals_per_step=1.0), cell("energy", 1e-4, energy_class="bounded"))
    assert (got.evals, got.energy, got.claims) == (True, True, LEAPFROG)
    got = checks(cell("cost", 1e-7, force_evals_per_step=2.0), cell("energy", 1e-1, energy_class="grows"))
    assert (got.evals, got.energy) == (False, False)
    # A cell whose class is unknown (crashed) is not judged.
    assert checks(cell("energy", status="crashed")).energy is None


@pytest.mark.parametrize(
    "claim, value, figures, ok",
    [
        (2.0, 2.0 * (1 + 0.99 * judge.STABILITY_TOL), {}, True),
        (2.0, 2.0 * (1 + 1.01 * judge.STABILITY_TOL), {}, False),
        (2.0, math.inf, {"unbounded": True}, False),
        (None, None, {"unstable_everywhere": True}, True),  # explicit Euler: no h is stable
        (None, None, {"unresolved": True}, True),  # Heun: growing at every step, no stable step resolved
        (None, 2.0, {}, False),
        (math.inf, math.inf, {"unbounded": True}, True),  # backward Euler: every h is
        (math.inf, 50.0, {}, False),
    ],
)
def test_the_stability_limit_against_its_claim(claim, value, figures, ok):
    claims = Claims(scheme="ref:x", homega_max=claim)
    assert checks(cell("stability", value, claims=claims, **figures)).homega is ok


def test_no_stable_step_resolved_reads_check_none_in_the_tradeoff_table():
    """Heun's row (issue 42): the measured limit is no number where the search resolves no stable
    step, and agrees with the declared none."""
    from records.cell import pivot
    from reports.markdown import tradeoff_table

    claims = Claims(scheme="ref:heun", order=2, force_evals=2, force_evals_text="2", energy="grows", homega_max=None)
    stab = cell("stability", None, method="ref:heun", claims=claims, verdict="unresolved", unresolved=True)
    piv = pivot([stab])
    row = next(line for line in tradeoff_table(piv, judge.judge([stab]).claims) if "ref:heun" in line)
    assert row.endswith(f"| no stable step resolved [none] {CHECK} |")


def test_an_identity_row_says_matched_only_where_a_scheme_matched():
    from records.cell import pivot
    from reports.markdown import identity_table

    def row(**figures):
        c = cell(
            "identity", 6.97e-3, method="newton:xpbd", scene="cloth", claims=Claims(), precision="float32", **figures
        )
        return next(line for line in identity_table(pivot([c])) if "newton:xpbd" in line)

    unmatched = row(closest="ref:linearly_implicit_euler")
    assert "none (closest `ref:linearly_implicit_euler`)" in unmatched and "matched" not in unmatched
    assert "no scheme within float32 rounding" in unmatched
    assert "(float32: matched at float32 rounding)" in row(match="ref:xpbd_jacobi", matches=["ref:xpbd_jacobi"])


def test_a_method_without_claims_is_not_judged():
    got = checks(cell("stability", 2.0, claims=Claims()), cell("order", 2.0, claims=Claims()))
    assert got.homega is None and got.order is False and not got.claims.known


def test_bounds():
    assert judge.bound_ok(cell("bound", 1e-3, bound=1e-3)) is True
    assert judge.bound_ok(cell("bound", 1.1e-3, bound=1e-3)) is False
    assert judge.bound_ok(cell("bound", None, status="crashed", bound=1e-3)) is False


def test_the_verdict_names_every_method_that_failed():
    cells = [
        cell("energy", 1e-3),
        cell("cost", None, method="faulty:hang", status="timed_out"),
        cell("order", None, method="faulty:abort", status="crashed"),
        cell("error", None, status="unstable"),
    ]
    v = judge.verdict(cells, previous=3)
    assert v.failed == (("spring", "faulty:abort"), ("spring", "faulty:hang")) and v.regressions == ()
    text = "\n".join(verdict_lines(v))
    assert "**No regressions** against run 3." in text and "2 method(s) could not be measured" in text


def test_every_scene_check_names_a_finding_and_a_measure():
    for scene, rows in judge.SCENE_CHECKS.items():
        for row in rows:
            assert row.finding in judge.FINDINGS, (scene, row)
            assert row.measure in {
                "energy",
                "error",
                "order",
                "cost",
                "stability",
                "identity",
                "constraint",
                "damping",
                "scaling",
                "brouwer",
            }
            assert row.of is None or row.of in judge.DECLARED, (scene, row)
    assert set(judge.DECLARED) <= {f.name for f in dataclasses.fields(Behaviour)}


def test_the_judge_names_no_engine_mode():
    """What an engine mode was measured to do is its declared behaviour, which a row reads
    through ``of``: the judge and its engine findings name no engine's mode."""
    import adapters
    from harness import engine_findings

    engines = {m.engine for m in adapters.ENGINE_METHODS.values()}
    for path in (judge.__file__, engine_findings.__file__):
        text = Path(path).read_text()
        assert not [e for e in engines if f"{e}:" in text], path


def test_a_row_applies_to_every_method_of_the_run_that_declares_its_field():
    """A method that declares the row's field and sets nothing of it joins the row's methods; one
    that sets some of its fields (the scheme expected) is a row of its own; a method the registry
    does not hold (a plugin not loaded now) and one that declares nothing are left out."""
    one = SimpleNamespace(behaviour=Behaviour(integrates_as={"cloth": "ref:rk4"}), no_match={})
    two = SimpleNamespace(behaviour=Behaviour(roundoff=True), no_match={})
    methods = {"x:one": one, "x:two": two, "x:none": SimpleNamespace(behaviour=Behaviour(), no_match={})}
    piv = {("cloth", m): None for m in ("x:one", "x:two", "x:none", "x:unknown", "ref:rk4")}
    row = judge.Check("integrates_as", "identity", of="integrates_as")
    assert judge.declared_checks(row, "cloth", piv, methods) == [
        judge.Check("integrates_as", "identity", methods=("x:one",), expect="ref:rk4")
    ]
    row = judge.Check("energy_within", "energy", methods=("ref:rk4",), tolerance=1e-13, of="roundoff")
    assert judge.declared_checks(row, "cloth", piv, methods) == [
        judge.Check("energy_within", "energy", methods=("ref:rk4", "x:two"), tolerance=1e-13)
    ]
    # No method of its own and none declaring: no row (an empty ``methods`` would mean every method).
    assert judge.declared_checks(judge.Check("brouwer_law", "brouwer", of="roundoff"), "spring", piv, methods) == []


def solar(ias15=5e-14, rk4_class="decays", whfast_class="bounded", match="ref:leapfrog"):
    return [
        cell("energy", 1e-5, method="rebound:whfast", scene="solar_system", energy_class=whfast_class),
        cell("energy", 1e-5, method="ref:leapfrog", scene="solar_system", energy_class="bounded"),
        cell(
            "energy",
            1e-4,
            method="ref:rk4",
            scene="solar_system",
            energy_class=rk4_class,
            numbers={"first_tenth_envelope": 1e-6, "last_tenth_envelope": 1e-4, "secular_rate": -1e-9},
        ),
        cell("energy", ias15, method="rebound:ias15", scene="solar_system", energy_class="bounded"),
        cell(
            "identity",
            0.0,
            method="rebound:leapfrog",
            scene="solar_system",
            match=match,
            runner_up="ref:velocity_verlet",
            runner_up_deviation=1e-9,
        ),
    ]


def test_the_solar_systems_table_passes_a_run_that_holds():
    found = judge.judge(solar()).findings
    judged = [f for f in found if f.ok is not None]
    assert len(judged) == 4 and all(f.ok for f in judged), found
    lines = [finding_line(f) for f in found]
    assert any(
        "symplectic `rebound:whfast` 1.0e-05 bounded, `ref:leapfrog` 1.0e-05 bounded: all bounded ✓. "
        "Others: `rebound:ias15` 5.0e-14 bounded, `ref:rk4` 1.0e-04 decays." in ln
        for ln in lines
    ), lines
    assert "`solar_system`: `rebound:ias15` keeps max |ΔE/E| = 5.0e-14 over the run (limit 1e-13) ✓." in lines


def test_the_solar_systems_table_fails_each_check_that_does_not_hold():
    found = judge.judge(solar(ias15=2e-13, rk4_class="bounded", whfast_class="grows", match="ref:verlet")).findings
    judged = [f for f in found if f.ok is not None]
    assert len(judged) == 4 and not any(f.ok for f in judged), found
    assert all(CROSS in finding_line(f) and CHECK not in finding_line(f) for f in judged)
    # WHFast gaining energy on a scene is an engine finding of its own.
    assert any("`rebound:whfast` gains energy on `solar_system`" in f.text for f in found)


def test_a_finding_prints_its_mark_where_its_text_carries_it():
    assert finding_line(Finding(f"all bounded {MARK}. Others", True)) == "all bounded ✓. Others"
    assert finding_line(Finding(f"x {MARK}.", False)) == "x ✗."
    assert finding_line(Finding("nothing judged")) == "nothing judged"


def test_engine_findings_say_what_a_mode_integrates_as():
    ident = cell(
        "identity",
        1e-15,
        method="mujoco:implicit",
        claims=Claims(),
        match="ref:semi_implicit_euler",
        matches=["ref:semi_implicit_euler"],
        name_suggests="implicit_euler",
    )
    (f,) = judge.judge([ident]).findings
    assert (
        f.text
        == (
            "`mujoco:implicit` on `spring` integrates as **`ref:semi_implicit_euler`** (max deviation "
            "1.0e-15), not the implicit euler its name suggests."
        )
        and f.ok is None
    )


def test_reports_import_nothing_of_the_harness():
    """reports/ renders records: it imports records/ and plotting, never harness, adapters,
    reference or scenarios."""
    for path in sorted((Path(__file__).resolve().parent.parent / "reports").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module or ""]
                if isinstance(node, ast.ImportFrom) and not node.level
                else []
            )
            for name in names:
                assert name.split(".")[0] not in {"harness", "adapters", "reference", "scenarios"}, (path.name, name)


def test_a_mode_that_takes_two_half_steps_is_said_with_the_energy_each_keeps():
    """Drake's implicit_euler identified as implicit Euler by step doubling: the finding sets the
    energy it keeps beside ref:implicit_euler's at the same time, read from the run's cells; the
    unit spring's closed forms are (1 + h^2)^-n and (1 + h^2/4)^-2n."""
    from records.cell import Cell, EnergyFigures, IdentityFigures

    from harness import judge as judge_mod

    h, n = 0.1, 1000
    t = [0.0, n * h]

    def energy(method, kept):
        return Cell(
            scene="spring",
            method=method,
            family=method.split(":")[0],
            measure="energy",
            status="ok",
            value=1.0,
            dt=h,
            steps=2 * n,
            figures=EnergyFigures(series={"t": t, "energy": [0.5, 0.5 * kept]}),
        )

    cells = [
        Cell(
            scene="spring",
            method="drake:implicit_euler",
            family="drake",
            measure="identity",
            status="ok",
            value=1e-13,
            dt=0.125,
            steps=1000,
            figures=IdentityFigures(match="ref:implicit_euler_doubled"),
        ),
        energy("drake:implicit_euler", (1 + h * h / 4) ** (-2 * n)),
        energy("ref:implicit_euler", (1 + h * h) ** -n),
    ]
    found = [f for f in judge_mod.judge(cells).findings if "half steps" in f.text]
    assert len(found) == 1 and found[0].ok
    assert "keeps 0.00678 of the energy where `ref:implicit_euler` keeps 4.77e-05" in found[0].text


def test_a_scheme_whose_stages_iterate_is_judged_by_whole_passes_of_its_declared_evaluations():
    """Two-stage Radau IIA declares 2 evaluations a Newton pass and iterates even on the linear
    spring (its stage matrix has complex eigenvalues): 13.9 counted a step is ✓ (about seven
    passes), fewer than one pass's 2 is ✗; a one-pass scheme is still held to its exact count."""
    from harness.judge import claim_checks
    from harness.methods import get_method
    from harness.nightly.cells import _claims
    from records.cell import Cell
    from records.figures import CostFigures
    from scenarios import make_scene

    spring = make_scene("spring")

    def checks(method, counted):
        claims = _claims(get_method(method), spring)
        cost = Cell(
            scene="spring",
            method=method,
            family="ref",
            measure="cost",
            status="ok",
            value=1e-8,
            figures=CostFigures(force_evals_per_step=counted),
            claims=claims,
        )
        return claim_checks({"cost": cost}).evals

    assert _claims(get_method("ref:radau_iia2"), spring).force_evals_text == "2 a pass + solve"
    assert checks("ref:radau_iia2", 13.9) is True and checks("ref:radau_iia2", 1.0) is False
    assert checks("ref:implicit_euler", 1.0) is True and checks("ref:implicit_euler", 3.0) is False
