"""The energy classification rule (harness.measures.energy) against series built to break it (issue 12):
saturation at order one, escape, a slow secular drift hidden under a large oscillation, a
random walk; and the run that broke it, explicit Euler over 1e7 days on the outer solar system.

Each synthetic series runs over 1000 time units with 20,001 states; the oscillation's period
is 2 pi, so each tenth holds 16 periods (the rule wants a few)."""

from __future__ import annotations

import numpy as np
import pytest

from harness.measures import energy
from harness.measures.energy import classify
from scenarios import make_scene

T = np.linspace(0.0, 1000.0, 20_001)
ONE = np.ones_like(T)


def test_a_band_is_bounded_and_a_steady_growth_grows():
    assert classify(1 + 1e-2 * np.sin(T), ONE, T)["classification"] == "bounded"
    assert classify(np.exp(1e-4 * T), ONE, T)["classification"] == "grows"


def test_a_decay_says_the_error_grew_not_the_energy():
    """An energy that decays has an error whose envelope grows: the rule says which envelope
    ('decays (envelope grew; ...)' read as a contradiction), with its two figures."""
    res = classify(np.exp(-1e-4 * T), ONE, T)
    assert res["classification"] == "decays"
    assert res["rule"].startswith("the error's envelope grew from 1.00e-02 in the first tenth to 1.00e-01 in the last")


def test_saturation_at_order_one_is_not_bounded():
    # Energy gained quickly (within the first tenth), then flat at +92%: the envelope stops
    # growing, so the envelope test alone read it as bounded.
    series = 1 + 0.92 * (1 - np.exp(-T / 20.0))
    g = np.log(series)
    assert np.max(g[-2000:]) <= 2 * np.max(g[:2000])  # the envelope test alone: bounded
    res = classify(series, ONE, T)
    assert res["classification"] == "grows" and f"reached {energy.ORDER_ONE:g}" in res["rule"]
    # A bound orbit (negative energy) losing its binding to 8% of it: gained energy, saturated.
    bound = -1.0 * (1 - 0.92 * (1 - np.exp(-T / 20.0)))
    assert classify(bound, -ONE, T)["classification"] == "grows"
    # ... and a loss saturating at -60% decays.
    assert classify(1 - 0.6 * (1 - np.exp(-T / 20.0)), ONE, T)["classification"] == "decays"


def test_an_escape_is_not_bounded_even_where_the_energy_error_stays_small():
    # A light body leaves early: the total energy error saturates at 2% (below order one) and
    # the envelope stops growing; the scene's escape test says what happened.
    series = 1 + 0.02 * (1 - np.exp(-T / 20.0))
    g = np.log(series)
    assert np.max(g[-2000:]) <= 2 * np.max(g[:2000])  # the envelope test alone: bounded
    escaped = T > 60.0
    res = classify(series, ONE, T, escaped=escaped)
    assert res["classification"] == "grows" and res["escaped_index"] == int(np.argmax(escaped))
    assert "left the system" in res["rule"]


def test_the_solar_system_says_when_a_planet_is_unbound():
    solar = make_scene("solar_system")
    q, v = solar.initial_state()
    assert not solar.escaped(q[None], v[None])[0]
    v_fast = v.copy()
    v_fast[3 * 5 : 3 * 6] *= 2.0  # Pluto at twice its speed: well past escape (sqrt 2)
    assert solar.escaped(np.stack([q, q]), np.stack([v, v_fast])).tolist() == [False, True]


def test_a_slow_drift_hidden_under_a_large_oscillation_is_not_bounded():
    # Oscillation 1e-2, drift 5e-3 over the run: last-tenth envelope 1.5e-2 < 2 x the first's
    # 1.05e-2, so the envelope test passes; the trend (0.48 of the first envelope) does not.
    series = np.exp(1e-2 * np.sin(T) + 5e-6 * T)
    res = classify(series, ONE, T)
    assert res["envelope_ratio"] < energy.ENVELOPE_RATIO
    assert res["secular_change"] > energy.SECULAR_SHARE * res["first_tenth_envelope"]
    assert res["classification"] == "grows"
    assert classify(np.exp(1e-2 * np.sin(T) - 5e-6 * T), ONE, T)["classification"] == "decays"


def test_a_random_walk_drifts():
    # Brouwer's law: rounding errors walk the energy like sqrt(t).
    rng = np.random.default_rng(3)
    walk = np.exp(1e-8 * np.cumsum(rng.standard_normal(T.size)))
    res = classify(walk, ONE, T)
    assert res["classification"] == "drifts", res["rule"]


@pytest.mark.slow
def test_explicit_euler_over_1e7_days_on_the_outer_solar_system_is_not_bounded():
    """The run that was classed bounded: 1e6 steps of 10 days, compiled. Its |dE/E| saturates
    at 0.92 once the planets have left; a planet is unbound before the end."""
    from reference import RefMethod
    from reference import METHODS

    solar = make_scene("solar_system")
    res = energy.energy_behaviour(
        RefMethod(METHODS["explicit_euler"], compiled=True), solar, 10.0, 1_000_000, every=250
    )
    assert res["status"] == "ok"
    assert res["classification"] == "grows", res["rule"]
    assert res["max_rel_error"] > energy.ORDER_ONE


def test_the_state_error_stands_beside_the_energy_error():
    """Energy alone overstates accuracy: implicit midpoint keeps the spring's energy to roundoff
    (measured 5.1e-15) while its phase drifts h^2/12 per unit time: 0.83 rad after 1000 at
    h = 0.1, a state error of 2 sin(0.83/2) = 0.81 of the amplitude (measured 0.808)."""
    res = energy.energy_behaviour("ref:implicit_midpoint", make_scene("spring"), 0.1, 10_000, every=10)
    assert res["classification"] == "bounded" and res["max_rel_error"] < 1e-13
    assert res["state_error_source"] == "exact"
    assert res["state_error_final"] == pytest.approx(2 * np.sin(0.1**2 / 12 * 1000 / 2), rel=0.01)


def test_cli_energy_prints_the_state_error(capsys):
    from harness.cli import main

    assert main(["energy", "spring", "--method", "ref:implicit_midpoint", "--dt", "0.1", "--steps", "2000"]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if "state error" in x)
    assert "against the exact solution" in line and "max 1.66" in line  # 2 sin(h^2 T/24) at T = 200


@pytest.mark.slow
def test_ias15_energy_error_does_not_grow_linearly_over_1e7_days():
    """Brouwer's law says roundoff walks the energy like sqrt(t): slope 0.5 of log|dE/E| against
    log t, where a systematic error would give 1. Over 1e7 days (output every 1e4 days, 5 s)
    IAS15's |dE/E| on the outer solar system sits at its roundoff floor: an offset of 1.3e-14
    set in the first output interval, and fluctuations around it whose RMS over windows
    [T/2, T] (T from 2e5 to 1e7 days) grows with slope 0.15 (r = 0.62), measured: slower than
    the random walk, far from linear. Asserted: the slope is below Brouwer's 0.5 plus the fit's
    room (0.7), above -0.2, and the error stays below 1e-13."""
    from scipy.stats import linregress

    solar = make_scene("solar_system")
    res = energy.energy_behaviour("rebound:ias15", solar, 1.0e4, 1000, series=True, state_error=False)
    assert res["status"] == "ok" and res["max_rel_error"] < 1e-13
    t, rel = np.asarray(res["t"]), np.asarray(res["rel_error"])
    walk = rel - rel[1]
    windows = np.geomspace(2.0e5, 1.0e7, 12)
    rms = [np.sqrt(np.mean(walk[(t > w / 2) & (t <= w)] ** 2)) for w in windows]
    slope = linregress(np.log(windows), np.log(rms)).slope
    assert -0.2 < slope < 0.7, slope


def test_an_orbit_that_spirals_in_and_is_thrown_out_says_so_beside_its_class():
    """Backward Euler on Kepler loses energy for 245 steps, spirals in to r = 0.006 and is thrown
    out at that close approach: its class ("grows", the energy crossed zero) alone misleads, so
    the run names both events, at the steps they happened (the run stepped again recording every
    step, where it recorded every tenth)."""
    from harness.measures.energy import energy_behaviour
    from scenarios import make_scene

    r = energy_behaviour("ref:implicit_euler", make_scene("kepler"), 0.02, 20000, every=10)
    assert r["classification"] == "grows"
    close, ejected = r["events"]
    assert (close["kind"], close["step"]) == ("close approach", 245) and close["r"] == pytest.approx(0.00634, rel=1e-2)
    assert (ejected["kind"], ejected["step"]) == ("ejected", 246)
    assert energy_behaviour("ref:leapfrog", make_scene("kepler"), 0.02, 2000)["events"] == []


def test_a_planet_ejected_from_the_solar_system_is_named():
    from harness.measures.energy import energy_behaviour
    from scenarios import make_scene

    r = energy_behaviour("ref:explicit_euler", make_scene("solar_system"), 200.0, 2000, every=10)
    first = r["events"][0]
    assert first["kind"] == "ejected" and first["body"] == "Jupiter" and first["step"] <= 400
    assert first["text"].startswith("Jupiter ejected (unbound from the Sun) by step ")


def test_the_report_names_the_events_beside_the_class():
    from records.cell import Cell, pivot
    from reports.markdown import scene_section

    ev = {"kind": "ejected", "step": 246, "t": 4.92, "r": 0.54, "text": "ejected (unbound) by step 246, at r = 0.54"}
    cell = Cell.from_row(
        {
            "scene": "kepler",
            "method": "ref:implicit_euler",
            "family": "ref",
            "measure": "energy",
            "dt": 0.02,
            "steps": 20000,
            "status": "ok",
            "value": 4.9,
            "data": {"class": "grows", "events": [ev]},
        }
    )
    row = next(line for line in scene_section("kepler", pivot([cell]), {}) if line.startswith("| `ref:implicit"))
    assert "| grows (ejected (unbound) by step 246, at r = 0.54) |" in row


def test_brouwers_law_holds_over_an_ensemble_of_ias15_runs_on_the_outer_solar_system():
    """One IAS15 run's energy error is one path of a random walk (its log-log slope read 0.15);
    the law is the ensemble's: 24 runs from states perturbed at 1e-15, their RMS |dE/E| against t
    over 2e6 days has slope 0.53, its 95% bootstrap interval 0.42-0.63 holding Brouwer's 0.5.
    Seeded: the same ensemble, the same bits, every time."""
    from harness.measures.brouwer import energy_walk
    from harness.methods import get_method
    from harness.nightly.suites import SOLAR_BROUWER
    from scenarios import make_scene

    settings = SOLAR_BROUWER["rebound:ias15"]
    res = energy_walk(
        get_method("rebound:ias15"),
        make_scene("solar_system"),
        settings["horizon"] / 100,
        100,
        1,
        realizations=settings["realizations"],
    )
    lo, hi = res["ci95"]
    assert res["failed"] == 0 and lo <= res["slope"] <= hi and res["contains_brouwer"] and lo <= 0.5 <= hi
    assert len(res["t"]) == len(res["rms"]) == 99 and np.all(np.diff(res["t"]) > 0)
    assert "error_slope" not in res  # an adaptive method's position error holds the perturbation's drift


def test_leapfrog_beside_it_keeps_its_energy_and_loses_its_phase_linearly():
    from harness.measures.brouwer import energy_walk
    from harness.methods import get_method
    from scenarios import make_scene

    kepler = make_scene("kepler")
    res = energy_walk(get_method("rebound:leapfrog"), kepler, 0.02, 300_000, 1000, realizations=3)
    assert abs(res["slope"]) < 0.25  # bounded: its oscillation, sampled, not a growth
    assert res["error_slope"] == pytest.approx(1.0, abs=0.1) and res["error_fit_until"] > 0


def test_a_max_energy_error_without_a_meaning_is_none_in_the_command_as_in_the_nightly():
    """Where the exact energy crosses zero (a falling projectile) dE/E means nothing: the command
    read 273 where the nightly's cell stored none. One rule now (``energy_figures``): none in both,
    and none for a run that blew up (its failed step says what happened)."""
    from harness.measures.energy import energy_behaviour
    from scenarios import make_scene

    falling = energy_behaviour("ref:explicit_euler", make_scene("projectile"), 0.01, 1000)
    assert falling["rel_error_defined"] is False and falling["max_rel_error"] is None
    assert falling["classification"] is None
    blown = energy_behaviour("ref:explicit_euler", make_scene("spring"), 1.5, 2000)
    assert blown["status"] == "unstable" and blown["max_rel_error"] is None and blown["classification"] == "grows"


def test_on_a_dissipative_scene_damping_less_than_the_exact_motion_is_not_a_gain():
    """Issue 54: the exact energy falls (a damped spring). A method whose energy falls but less
    than the exact one damps less; one whose energy ends above its start gains energy; one that
    falls faster damps more. A rise from one state to the next, or above the start for a while,
    in a run that ends below its start is counted and named, not called a gain."""
    exact = np.exp(-1e-2 * T)
    less = classify(np.exp(-0.9e-2 * T), exact, T)
    assert less["classification"] == "damps less" and not less["energy_rose"]
    assert less["end_ratio"] == pytest.approx(np.exp(1e-3 * T[-1]))
    more = classify(np.exp(-1.1e-2 * T), exact, T)
    assert more["classification"] == "damps more"
    bumped = np.exp(-0.9e-2 * T)
    bumped[5000] = bumped[4999] * (1 + 1e-9)  # one step that raises it, still below the start
    wobble = classify(bumped, exact, T)
    assert wobble["classification"] == "damps less" and wobble["energy_step_rises"] == 1
    assert "rose at 1 of" in wobble["rule"] and not wobble["energy_rose"]
    above = np.exp(-0.9e-2 * T)
    above[5000] = 1.0 + 1e-9  # above its start for a moment, ending below it: a loss over the run
    transient = classify(above, exact, T)
    assert transient["classification"] == "damps less" and transient["energy_rose"]
    assert not transient["energy_gained"] and "a loss over the run, not a gain" in transient["rule"]
    gaining = np.exp(-0.9e-2 * T) + 1e-3 * T / T[-1] * 1e4  # ends above its start: a gain
    gained = classify(gaining, exact, T)
    assert gaining[-1] > gaining[0] and gained["classification"] == "grows" and gained["energy_gained"]
    # A band around the exact energy's fall, drifting (tenth means not monotone), ending above it.
    x = T / T[-1]
    wavy = exact * (1.0 + 0.2 * x * (1.0 + 0.9 * np.sin(6 * np.pi * x)))
    drift = classify(wavy, exact, T)
    assert drift["classification"] == "damps less" and drift["end_ratio"] == pytest.approx(1.2, rel=1e-2)
    assert "tenth means of g not monotone" in drift["rule"]  # classed drifts first
    assert energy.claim_met("grows", "damps less") and energy.claim_met("decays", "damps more")
    assert not energy.claim_met("bounded", "damps less")


def test_mujoco_euler_on_the_damped_spring_damps_less_and_no_finding_says_it_gains():
    from harness.execution.simulate import simulate
    from harness.methods import get_method

    scene = make_scene("damped_spring")
    run = simulate(get_method("mujoco:euler"), scene, 0.1, 3142)
    # independently: the engine's energy falls at every recorded step
    assert np.all(np.diff(run.energy[:, 0]) < 0.0)
    res = classify(run.energy[:, 0], scene.exact_energy(run.t), run.t)
    assert res["classification"] == "damps less" and res["end_ratio"] > 1.0
