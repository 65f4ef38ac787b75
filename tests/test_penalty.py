"""The penalty ground and its table (the seed's "lively bounces go dead"): one impact's restitution
per scheme against h*omega_c, each figure checked by a route of its own (a closed form, or a bare
numpy loop written here), implicit Euler's step solved exactly (its equation or its complementarity
conditions at every step, the share of impacts with no consistent branch), the bounces to rest run
as long as the motion needs, no figure on an unsolved step, and the stored cells old and new."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from records.cell import Cell
from records.contact import PenaltyFigures
from records.measures import Comparison
from scenarios import make_scene
from scenarios.penalty_ball import restitution_of, zeta_for

from harness.contact.penalty import (
    GRID,
    closed_form,
    discrete_restitution,
    exact_bounces,
    exact_exit_speed,
    impact,
    implicit_euler_step,
    no_branch_share,
    row,
    unsolved_steps,
)

W = 1000.0
G = 9.81


def _ie_closed(hw: float) -> float:
    """Implicit Euler's restitution at zeta = 0, written out."""
    return (1.0 + hw * hw) ** (-math.pi / (2.0 * math.atan(hw)))


def _ee_closed(hw: float) -> float:
    return (1.0 + hw * hw) ** (math.pi / (2.0 * math.atan(hw)))


def _half_turn(m: np.ndarray) -> float:
    """|lambda|^(pi / arg lambda) of a 2x2 step matrix, by numpy's eigenvalues."""
    lam = np.linalg.eigvals(m)
    lam = lam[np.argmax(lam.imag)]
    return float(np.abs(lam) ** (math.pi / np.angle(lam)))


# ----------------------------------------------------------------------------- the exact motion
def test_the_penalty_ground_exact_motion():
    assert restitution_of(zeta_for(0.8)) == pytest.approx(0.8, abs=1e-14)
    elastic = make_scene("penalty_ball")
    assert elastic.apexes(5) == pytest.approx([1.0] * 6, abs=1e-12)
    q, v = elastic.closed_form(np.linspace(0, 5, 50001))
    energy = elastic.energy(q, v)
    assert np.ptp(energy) < 1e-12 * energy[0]  # conserved across every contact, gravity in the contact kept
    damped = make_scene("penalty_ball", zeta=zeta_for(0.8))
    apexes = damped.apexes(5)
    e_n = np.sqrt(np.array(apexes[1:]) / np.array(apexes[:-1]))
    # gravity inside the contact takes a little from the ideal e: g / (omega_c v) = 2.2e-3 of it
    assert np.all(np.abs(e_n - 0.8) < 3e-3) and np.all(e_n < 0.8)
    # the table's own exact contact (its bounce count) against the scene's phases, bounce by bounce
    v_in = math.sqrt(2 * G)
    for apex in apexes[1:]:
        v_in = exact_exit_speed(v_in, G, W, zeta_for(0.8))
        assert v_in == pytest.approx(math.sqrt(2 * G * apex), rel=1e-9)
    assert exact_bounces(W, zeta_for(0.8)) == (23, "rests")
    assert exact_bounces(W, 0.0)[1] == "cap"


# ----------------------------------------------------------------------------- closed forms
@pytest.mark.parametrize("e", [1.0, 0.8, 0.3])
@pytest.mark.parametrize("hw", [0.01, 0.3, 1.0, 3.0, 30.0])
def test_the_closed_forms_are_the_step_maps_half_turn(e, hw):
    """|lambda|^(pi / arg lambda) of explicit and implicit Euler's step on the contact, the matrices
    written out here; at zeta = 0 the formulas (1 + (h w)^2)^(-/+ pi / (2 atan h w)); the exact
    step's map gives e at every h."""
    z = zeta_for(e)
    a = np.array([[0.0, hw], [-hw, -2.0 * z * hw]])  # h times the contact's (y, v / w) system
    explicit, implicit = np.eye(2) + a, np.linalg.inv(np.eye(2) - a)
    assert closed_form("ref:explicit_euler", z, hw) == pytest.approx(_half_turn(explicit), rel=1e-9)
    assert closed_form("ref:implicit_euler", z, hw) == pytest.approx(_half_turn(implicit), rel=1e-9)
    if e == 1.0:
        assert closed_form("ref:implicit_euler", z, hw) == pytest.approx(_ie_closed(hw), rel=1e-12)
        assert closed_form("ref:explicit_euler", z, hw) == pytest.approx(_ee_closed(hw), rel=1e-12)
    w, v = np.linalg.eig(a)
    exact = (v @ np.diag(np.exp(w)) @ np.linalg.inv(v)).real
    if hw < math.pi:  # the exact map turns by less than a half turn a step
        assert _half_turn(exact) == pytest.approx(e, rel=1e-9)
    assert closed_form("ref:rk4", z, hw) is None
    assert discrete_restitution(0.5) == 0.0


# ----------------------------------------------------------------------------- the table
def test_the_table_reads_one_impact_beside_the_closed_forms():
    """Implicit Euler at h*omega_c = 1 keeps 0.250 (every phase); at 2 about 0.10; explicit Euler at
    0.1 gains 1.17 a bounce, marked; at e = 0.8 it keeps 0.94, too lively, not "loses"."""
    from reports.penalty_section import impact_text

    ie = row("ref:implicit_euler", 1.0, 1.0)
    assert ie["impact_mean"] == pytest.approx(0.25, abs=5e-3) and _ie_closed(1.0) == pytest.approx(0.25)
    assert ie["impact_max"] - ie["impact_min"] < 1e-3 and ie["verdict"] == "loses energy"
    assert impact_text(ie) == "0.250−"
    assert row("ref:implicit_euler", 1.0, 2.0)["impact_mean"] == pytest.approx(_ie_closed(2.0), abs=0.01)
    ee = row("ref:explicit_euler", 1.0, 0.1)
    assert ee["impact_mean"] == pytest.approx(_ee_closed(0.1), abs=5e-3) and abs(ee["impact_mean"] - 1.17) < 0.005
    assert ee["verdict"] == "gains energy" and impact_text(ee) == "1.170↑" and impact_text(ee, plain=True) == "1.170^"
    lively = row("ref:explicit_euler", 0.8, 0.1)
    assert lively["impact_mean"] == pytest.approx(closed_form("ref:explicit_euler", zeta_for(0.8), 0.1), abs=5e-3)
    assert lively["impact_mean"] > 0.93 and lively["verdict"] == "too lively"
    sie = row("ref:semi_implicit_euler", 1.0, 1.0)
    assert sie["verdict"] == "within" and sie["closed_form"] is None and sie["exact"] == 1.0
    # the conditions the figures are measured in, stated with them
    assert ie["gravity_share"] <= 1e-8 and ie["step_gravity"] <= 1e-6 and ie["phases"] >= 32
    assert row("ref:rk4", 1.0, 100.0)["verdict"] == "gains energy"


def test_one_impact_by_a_bare_loop():
    """Explicit and semi-implicit Euler's impact at each phase, stepped here by hand (gravity
    negligible: left out), against the table's run phase by phase."""
    hw, h, n = 0.3, 0.3 / W, 16
    s = (np.arange(n) + 0.5) / n
    for method, kick_first in (("ref:explicit_euler", False), ("ref:semi_implicit_euler", True)):
        table = impact(method, 1.0, hw, phases=n)["ratio"]
        for j in range(n):
            x, v = s[j] * h, -1.0
            while True:
                a = -W * W * x if x < 0.0 else 0.0
                if kick_first:
                    v = v + h * a
                    x = x + h * v
                else:
                    x, v = x + h * v, v + h * a
                if x >= 0.0 and v > 0.0:
                    break
            assert table[j] == pytest.approx(v, rel=1e-6)


def test_no_figure_rests_on_an_unsolved_step():
    """Implicit midpoint at e = 0.8 and h*omega_c = 1: Newton fails at some step, so the cell is the
    count, no figure; implicit Euler's Newton run likewise, its exact solve printed instead."""
    from reports.penalty_section import impact_text, newton_text

    mid = row("ref:implicit_midpoint", 0.8, 1.0)
    assert mid["verdict"] == "unsolved" and mid["unsolved"] > 0
    assert mid["impact_mean"] is None and mid["impact_min"] is None
    assert impact_text(mid) == f"unsolved at {mid['unsolved']} step{'s' if mid['unsolved'] > 1 else ''}"
    ie = row("ref:implicit_euler", 0.8, 1.0)
    assert ie["newton_unsolved"] > 0 and ie["newton_mean"] is None
    assert newton_text(ie) == f"unsolved at {ie['newton_unsolved']} steps" and ie["newton_unsolved"] > 1
    assert ie["impact_mean"] == pytest.approx(closed_form("ref:implicit_euler", zeta_for(0.8), 1.0), abs=0.01)
    # a step checked by hand: solved, and off by a millimetre
    scene = make_scene("penalty_ball")
    x0, v0, h = np.array([-0.01]), np.array([-1.0]), 1e-3
    v1 = (v0 - h * G - h * W * W * x0) / (1 + h * h * W * W)
    x1 = x0 + h * v1
    assert unsolved_steps("ref:implicit_euler", scene, np.r_[x0, x1], np.r_[v0, v1], h, 1.0) == 0
    assert unsolved_steps("ref:implicit_euler", scene, np.r_[x0, x1 + 1e-3], np.r_[v0, v1], h, 1.0) == 1
    assert unsolved_steps("ref:semi_implicit_euler", scene, np.r_[x0, x1], np.r_[v0, v1], h, 1.0) is None


# ----------------------------------------------------------------------------- implicit Euler, exact
def _check_step(x0, v0, x1, v1, kind, h, g, w, z):
    """The implicit Euler equation on the branch the new state is on, or at x1 = 0 the
    complementarity conditions: the acceleration between the two branches' at x = 0, and neither
    branch consistent."""
    scale = 1e-12 * (1.0 + np.abs(v0) + w * np.abs(x0))
    assert np.all(np.abs(x1 - x0 - h * v1) <= 1e-12 * (np.abs(x0) + h * np.abs(v1)))
    out, inside, comp = kind == 0, kind == 1, kind == 2
    assert np.all(x1[out] >= 0.0) and np.all(x1[inside] < 0.0) and np.all(x1[comp] == 0.0)
    a = (v1 - v0) / h
    a_out, a_in = -g, -g - w * w * x1 - 2.0 * z * w * v1
    assert np.all(np.abs(a - a_out)[out] * h <= scale[out])
    assert np.all(np.abs(a - a_in)[inside] * h <= scale[inside])
    lo, hi = np.minimum(a_out, a_in), np.maximum(a_out, a_in)
    assert np.all(((a >= lo - scale / h) & (a <= hi + scale / h))[comp])
    # at a complementarity step neither branch holds: outside would end below, inside above
    xo = x0 + h * (v0 - g * h)
    xi = x0 + h * (v0 - g * h - w * w * h * x0) / (1 + 2 * z * h * w + (h * w) ** 2)
    assert np.all(xo[comp] < 0.0) and np.all(xi[comp] >= 0.0)


@pytest.mark.parametrize("hw", [0.1, 1.0, 10.0])
def test_the_exact_implicit_euler_step_solves_its_equation_at_every_step(hw):
    z, g, h = zeta_for(0.8), G, hw / W
    rng = np.random.default_rng(7)
    # states about the surface, in and out, moving either way
    x0 = rng.uniform(-2.0, 2.0, 20000) * h
    v0 = rng.uniform(-1.0, 1.0, 20000)
    x1, v1, kind = implicit_euler_step(x0, v0, h, g, W, z)
    assert set(np.unique(kind)) == {0, 1, 2}
    _check_step(x0, v0, x1, v1, kind, h, g, W, z)
    # the float path takes the same branch to the same bits
    for i in range(0, 20000, 997):
        xf, vf, kf = implicit_euler_step(float(x0[i]), float(v0[i]), h, g, W, z)
        assert (xf, vf, kf) == (x1[i], v1[i], kind[i])
    # and through whole impacts, from every phase, until the ball is out
    n = 64
    x, v = (np.arange(n) + 0.5) / n * h, np.full(n, -1.0)
    for _ in range(10 * math.ceil(math.pi / hw) + 10):
        xn, vn, kind = implicit_euler_step(x, v, h, g, W, z)
        _check_step(x, v, xn, vn, kind, h, g, W, z)
        x, v = xn, vn


@pytest.mark.parametrize("hw", [0.1, 1.0, 3.0, 30.0])
def test_the_share_of_impacts_with_no_consistent_branch(hw):
    """2 zeta h w / (1 + 2 zeta h w) of impacts, over where the contact falls in the step: the
    table's phases (evenly spaced: within 1/n), and random phases stepped here (within 4 sigma)."""
    z = zeta_for(0.8)
    expected = 2 * z * hw / (1 + 2 * z * hw)
    assert no_branch_share(z, hw) == pytest.approx(expected)
    n = 256
    exact = impact("ref:implicit_euler", 0.8, hw, phases=n)["complementarity"]
    assert abs(exact.mean() - expected) <= 1.0 / n
    # the harness's Newton solve fails at exactly those impacts, one step each
    newton = impact("ref:implicit_euler", 0.8, hw, phases=n, exact=False)["unsolved"]
    assert np.array_equal(newton > 0, exact) and newton.max() == 1
    h, m = hw / W, 4000
    s = np.random.default_rng(3).uniform(0.0, 1.0, m)
    x, v = s * h, np.full(m, -1.0)
    _, _, kind = implicit_euler_step(x, v, h, 1e-6, W, z)  # the entering step: gravity negligible
    sigma = math.sqrt(expected * (1 - expected) / m)
    assert abs(np.mean(kind == 2) - expected) <= 4 * sigma + 1e-12
    assert row("ref:implicit_euler", 0.8, hw)["no_branch_expected"] == pytest.approx(expected)


# ----------------------------------------------------------------------------- bounces to rest
def test_bounces_are_counted_apart_and_never_cut_short():
    """Explicit Euler at h*omega_c = 0.1 gains 1.17 a bounce at every bounce of its drop, which runs
    until the ball runs away (not to the exact motion's length); its first bounce, stepped here by a
    bare loop, is the same. Implicit Euler at 1 rests after 3 bounces (then meets the ground too
    slowly to leave its sag); the exact motion at e = 0.8 after 23."""
    ee = row("ref:explicit_euler", 1.0, 0.1)
    ratios = ee["bounce_ratios"]
    assert ee["bounces_end"] == "runaway" and ee["bounces"] == len(ratios) >= 15
    assert all(abs(r - 1.17) < 0.01 for r in ratios)
    h = 0.1 / W
    x, v, top, bounced = 1.0, 0.0, 0.0, False
    while True:  # explicit Euler, gravity and the ground, by hand: to the first apex after the bounce
        a = -G - (W * W * x if x < 0.0 else 0.0)
        x, v = x + h * v, v + h * a
        if v > 0.0 and x >= 0.0:
            bounced = True
        if bounced and v <= 0.0:
            top = x
            break
    assert math.sqrt(top / 1.0) == pytest.approx(ratios[0], abs=2e-3)
    ie = row("ref:implicit_euler", 1.0, 1.0)
    assert (ie["bounces"], ie["bounces_end"]) == (3, "rests")
    assert ie["bounce_ratios"][0] == pytest.approx(0.25, abs=0.01)
    damped = row("ref:semi_implicit_euler", 0.8, 0.1)
    assert (damped["exact_bounces"], damped["exact_end"]) == (23, "rests")
    assert abs(damped["bounces"] - 23) <= 1 and damped["bounces_end"] == "rests"


# ----------------------------------------------------------------------------- cells, report, command
def _legacy_row(method, e, hw, mean, verdict):
    return {
        "method": method,
        "e": e,
        "homega": hw,
        "mean_restitution": mean,
        "verdict": verdict,
        "unconverged": 0,
        "exact_restitution": [e] * 5,
    }


def test_old_stored_cells_render_and_are_not_compared():
    """A cell stored before the per-impact table has rows without its keys: the section shows them
    as measured (five bounces, said so), the seed's claim is judged on them, no chart, and the
    regression rule does not compare the two measures."""
    import harness.nightly.cells  # noqa: F401  (registers the measures, the penalty one among them)
    from harness.judge import judge
    from records.measures import measures
    from reports.penalty_section import penalty_chart, penalty_lines

    grid = [1.0]

    def cell(method, mean, verdict, value):
        figures = PenaltyFigures(
            rows=[_legacy_row(method, 1.0, 1.0, mean, verdict)], grid=grid, omega_c=W, tolerance=0.05, gain=0.01
        )
        return Cell("penalty_ball", method, "ref", "penalty", value=value, figures=figures)

    old = [cell("ref:semi_implicit_euler", 1.0, "within", 1.0), cell("ref:implicit_euler", 0.14, "loses energy", None)]
    verdict = judge(old)
    piv = {("penalty_ball", c.method): {"penalty": c} for c in old}
    text = "\n".join(penalty_lines("penalty_ball", piv))
    assert "as stored before the per-impact table" in text and "| `ref:implicit_euler` | 0.140 |" in text
    seed = [f for f in verdict.findings if "lively bounces go dead" in f.text]
    assert len(seed) == 1 and "five bounces" in seed[0].text
    assert penalty_chart(old, "penalty_ball", "/nonexistent/chart.png") is False
    rule = next(m for m in measures() if m.name == "penalty").regression
    new = Cell(
        "penalty_ball",
        "ref:semi_implicit_euler",
        "ref",
        "penalty",
        value=None,
        figures=PenaltyFigures(rows=[row("ref:semi_implicit_euler", 1.0, 3.0)], grid=[3.0], omega_c=W),
    )
    assert rule(old[0], new, Comparison()) is None
    assert rule(new, new, Comparison()) is None
    worse = rule(dataclass_replace(new, value=3.0), new, Comparison())
    assert worse is not None and "h*omega_c 3 -> none" in worse.detail


def dataclass_replace(cell, **kw):
    import dataclasses

    return dataclasses.replace(cell, **kw)


def test_the_command_prints_and_dumps_the_table(capsys):
    from harness.cli import main

    argv = ["contact", "--penalty", "--methods", "ref:semi_implicit_euler,ref:implicit_euler", "--grid", "1"]
    assert main(argv + ["--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    ie = next(r for r in out["rows"] if r["method"] == "ref:implicit_euler" and r["e"] == 1.0)
    assert ie["impact_mean"] == pytest.approx(0.25, abs=5e-3) and ie["bounces"] == 3
    assert out["seed_claim"]["holds"] and out["seed_claim"]["where"] == [1.0]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "0.250-" in text and "unsolved at" in text and "holds (h*omega_c 1: 1.000 vs 0.250" in text
    assert "g/(ω_c v_in) = 1e-09" in text and "rests after 23" in text
    assert list(GRID) == [0.01, 0.03, 0.1, 0.3, 1.0, 2.0, 3.0, 10.0, 30.0, 100.0]
