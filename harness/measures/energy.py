"""Energy behaviour: the relative energy error series and its classification.

The series, for every recorded step n (energy always from the state, by the scene):

    dE/E (t_n) = (E_n - E_exact(t_n)) / |E_exact(t_n)|

against the exact energy at that time (``scene.exact_energy``): for a damped scene the
exact *decaying* energy, not E_0. ``max_rel_error`` and ``final_rel_error`` are max |dE/E|
and |dE/E| at the last step.

The classification, one rule for every method. Growth and decay are multiplicative
(explicit Euler gains a factor 1 + h^2 w^2 a step), so the rule reads the signed log-ratio
``g_n = sign(E_exact) ln(E_n / E_exact(t_n))`` (about dE/E while small; positive when energy
was gained, also for a negative energy such as a bound orbit's), where both make straight lines:

0. The exact energy is zero or changes sign during the run (its zero is a convention,
   and a falling projectile's crosses it): dE/E is undefined there; not classified.
1. The run went unstable, or an energy is not finite                  -> ``grows``
   (a run that crashed or timed out is not classified).
2. E_n reached or crossed zero while the exact energy did not (its sign flipped):
   ``grows`` if E_n - E_exact > 0 there, else ``decays``.
3. A body left the system (the scene's ``escaped``, where it has one: a planet on an
   unbound heliocentric orbit) at some recorded state: ``grows`` if g > 0 there, else
   ``decays``. After an escape the energy error stops growing (it saturates at whatever
   the escaped body took with it), which rule 5 alone would read as bounded.
4. |dE/E| reached ORDER_ONE (0.5) at some recorded state: the energy is lost, not kept
   (explicit Euler on the outer solar system saturates at 0.92 once the planets have gone):
   ``grows`` if g > 0 there, else ``decays``.
5. Split the run into tenths by step. A = max |g| over the first tenth, B = max |g| over
   the last, S = |secular_rate| x the run's span (the least-squares trend of g over the
   whole run). If ``B <= ENVELOPE_RATIO * A + FLOOR`` (the error did not outgrow its start)
   and ``S <= SECULAR_SHARE * A + FLOOR`` (no trend hidden under the oscillation): ``bounded``.
6. Otherwise look at the mean of g over each tenth: increasing from every tenth to the
   next -> ``grows``; decreasing -> ``decays``; neither (a random walk, or a trend smaller
   than the oscillation around it) -> ``drifts``.
7. On a dissipative scene (its exact energy falls over the run: a damped spring), g growing
   says the method damps less than the exact motion, not that it gains energy. There the
   class is ``grows`` only where the run gained energy: its energy ends above its start (by
   more than roundoff, ``RISE``), or the run blew up. A rise from one recorded state to the
   next, or above the start for a while, in a run that ends below its start is a loss over the
   run (a discrete energy's wobble within a period, ½(q² + v²) under semi-implicit Euler, or an
   early transient), counted and named, not a gain. Else a run classed ``grows``, ``decays`` or
   ``drifts`` is ``damps less`` (E ends above E_exact) or ``damps more``, with ``end_ratio``,
   E / E_exact at the end, saying by how much.
   A method claimed to gain energy (``grows``) meets its claim on such a scene by damping less
   (``claim_met``), one claimed to lose it (``decays``) by damping more.

ENVELOPE_RATIO = 2 leaves room for a symplectic method's band to be met a little later
than the first tenth; SECULAR_SHARE = 0.25: a band leaves a least-squares trend too, a pure
sinusoid over N periods 12/(2 pi N) = 1.9/N of its amplitude (0.19 at the rule's minimum of
ten periods), and the bands measured here far less (0.026 of the envelope at most:
semi-implicit Euler on the outer solar system; 0.02 on the chain, 0.014 on the pendulum and
Kepler); a drift of a quarter of the envelope over the run is a drift; FLOOR = 1e-10 is
roundoff: at the horizons used (<= 1e6 steps), rounding accumulates at most ~1e-16 a step, so a smaller error
says nothing. The rule
needs the first tenth to hold a few oscillations of the energy error (a few periods
of the scene), so classify over at least ten periods (``short_horizon`` says when not),
and at least MIN_RECORDED recorded states. The numbers behind the verdict come with it,
with ``secular_rate``, the least-squares slope of g against t (per unit time).
"""

from __future__ import annotations

import numpy as np

from records import Trajectory

from scenarios import Scene
from records.trajectory import UNSTABLE

from harness.measures.common import resolve, step

ENVELOPE_RATIO = 2.0
FLOOR = 1e-10
ORDER_ONE = 0.5
SECULAR_SHARE = 0.25
#: Fewest recorded states that leave ten tenths of ten points each.
MIN_RECORDED = 100
#: The rule wants this many periods of the scene in the run.
MIN_PERIODS = 10.0
CLASSES = ("grows", "bounded", "decays", "drifts", "damps less", "damps more")
#: On a dissipative scene, an energy rise smaller than this fraction of the start's is roundoff.
RISE = 1e-12
#: The class a claim of each energy behaviour is met by on a dissipative scene (rule 7).
DISSIPATIVE_CLAIM = {"grows": "damps less", "decays": "damps more"}


def claim_met(claim: str | None, classification: str | None) -> bool:
    """Whether a measured class meets a method's claimed energy behaviour (rule 7 included)."""
    return claim == classification or (claim is not None and DISSIPATIVE_CLAIM.get(claim) == classification)


def dissipative(e_exact: np.ndarray) -> bool:
    """The exact energy falls over the run and never rises (a damped scene's)."""
    return len(e_exact) > 1 and e_exact[-1] < e_exact[0] and bool(np.all(np.diff(e_exact) <= 0.0))


def _dissipation_words(out: dict, energy: np.ndarray, e_exact: np.ndarray) -> dict:
    """Rule 7 on an already classified run of a dissipative scene."""
    scale = abs(float(energy[0])) or 1.0
    above = bool(np.max(energy) > energy[0] + RISE * scale)
    gained = bool(energy[-1] > energy[0] + RISE * scale)
    rises = int(np.count_nonzero(np.diff(energy) > RISE * scale))
    out.update(
        dissipative=True,
        energy_rose=above,
        energy_gained=gained,
        energy_step_rises=rises,
        end_ratio=float(energy[-1] / e_exact[-1]),
        max_over_start=float(np.max(energy) / energy[0]),
    )
    cls = out.get("classification")
    if cls not in ("grows", "decays", "drifts") or gained:
        return out
    if str(out.get("rule", "")).startswith("run unstable"):
        return out
    words = "damps less" if out["end_ratio"] > 1.0 else "damps more"
    out["classification"] = words
    if above:
        how = (
            f"; its energy rose above its start at some steps (to {out['max_over_start']:.6g} x it) and ends "
            f"below it: a loss over the run, not a gain"
        )
    elif rises:
        how = (
            f"; its energy rose at {rises} of {len(energy) - 1} steps, never above its start (a discrete "
            "energy's wobble within a period, not a gain)"
        )
    else:
        how = ""
    out["rule"] = (
        f"{out.get('rule')}; a dissipative scene whose energy ends below its start: it {words} "
        f"than the exact motion (E/E_exact {out['end_ratio']:.3g} at the end){how}"
    )
    return out


def relative_error_series(traj: Trajectory, scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """(E_exact(t_n), dE/E(t_n)) for batch member 0 of a trajectory."""
    e_exact = np.asarray(scene.exact_energy(traj.t), dtype=float)
    with np.errstate(all="ignore"):
        rel = (traj.energy[:, 0] - e_exact) / np.abs(e_exact)
    return e_exact, rel


def relative_error_defined(e_exact: np.ndarray) -> bool:
    """Rule 0: dE/E means something only while the exact energy keeps one sign, never zero."""
    e_exact = np.asarray(e_exact, dtype=float)
    return not (np.any(e_exact == 0.0) or np.any(np.sign(e_exact) != np.sign(e_exact[0])))


def escaped_states(scene: Scene, traj: Trajectory) -> np.ndarray | None:
    """Per recorded state of batch member 0, whether a body had left the system (the scene's
    ``escaped``), or None for a scene that cannot tell."""
    if traj.q.shape[0] == 0:
        return None
    with np.errstate(all="ignore"):
        flags = scene.escaped(traj.q[:, 0], traj.v[:, 0])
    return None if flags is None else np.asarray(flags, dtype=bool)


#: The most steps a run is stepped again, recording every step, to place its events exactly.
EVENT_REPLAY_STEPS = 200_000


def run_events(scene: Scene, traj: Trajectory, method=None, timeout: float | None = None) -> list[dict]:
    """What the bodies did in the run (``Scene.events``: ejections, close approaches), named beside
    the energy class, which alone can mislead. Where the run recorded every ``every`` > 1 steps and
    something happened, ``method`` (a fixed-step method steps the same states again) is stepped
    again up to the last event's recorded step, recording every step: the step it happened at and
    the closest approach, which fall between recorded states, are then the run's own."""
    if traj.q.shape[0] == 0:
        return []
    found = scene.events(traj.step, traj.t, traj.q[:, 0], traj.v[:, 0])
    if not found or traj.every <= 1 or method is None or getattr(method, "adaptive", False):
        return found
    upto = min(max(ev["step"] for ev in found), EVENT_REPLAY_STEPS)
    fine = step(method, scene, traj.dt, upto, 1, timeout)
    if fine.q.shape[0] < 2:
        return found
    early = scene.events(fine.step, fine.t, fine.q[:, 0], fine.v[:, 0])
    kinds = {ev["kind"] for ev in early}
    return sorted(early + [ev for ev in found if ev["kind"] not in kinds], key=lambda ev: ev["step"])


def classify(
    energy: np.ndarray, e_exact: np.ndarray, t: np.ndarray, unstable: bool = False, escaped: np.ndarray | None = None
) -> dict:
    """The classification of an energy series by the rule in the module docstring, with
    the numbers behind it. ``escaped``: per recorded state, whether a body had left the
    system (the scene's ``escaped``), or None where the scene cannot tell."""
    out = _classify(energy, e_exact, t, unstable, escaped)
    energy, e_exact = np.asarray(energy, dtype=float), np.asarray(e_exact, dtype=float)
    if out.get("classification") is not None and np.all(np.isfinite(energy)) and dissipative(e_exact):
        out = _dissipation_words(out, energy, e_exact)
    return out


def _classify(energy, e_exact, t, unstable: bool = False, escaped=None) -> dict:
    energy, e_exact, t = (np.asarray(a, dtype=float) for a in (energy, e_exact, t))
    out: dict = {"classification": None, "rule": None}
    if not relative_error_defined(e_exact):
        # An energy's zero is a convention (a falling projectile's exact energy crosses it):
        # relative to it, dE/E means nothing there.
        out["rule"] = "exact energy is zero or changes sign over the run: dE/E undefined, not classified"
        return out
    if unstable or not np.all(np.isfinite(energy)):
        out.update(classification="grows", rule="run unstable or energy not finite")
        return out
    ratio = energy / e_exact
    if np.any(ratio <= 0.0):
        i = int(np.argmax(ratio <= 0.0))
        up = energy[i] - e_exact[i] > 0.0
        out.update(
            classification="grows" if up else "decays",
            rule=f"energy crossed zero at step index {i} (exact energy did not)",
        )
        return out
    g = np.sign(e_exact) * np.log(ratio)
    if escaped is not None and np.any(escaped):
        i = int(np.argmax(np.asarray(escaped)))
        out.update(
            classification="grows" if g[i] > 0 else "decays",
            escaped_index=i,
            rule=f"a body left the system at step index {i}: not bounded",
        )
        return out
    rel = np.abs(energy - e_exact) / np.abs(e_exact)
    if np.any(rel >= ORDER_ONE):
        i = int(np.argmax(rel >= ORDER_ONE))
        out.update(
            classification="grows" if g[i] > 0 else "decays",
            rule=f"|dE/E| reached {ORDER_ONE:g} at step index {i}: energy lost (saturated or escaped), not bounded",
        )
        return out
    if len(energy) < MIN_RECORDED:
        out["rule"] = f"too few recorded states ({len(energy)} < {MIN_RECORDED}) to classify"
        return out
    tenths = np.array_split(np.arange(len(g)), 10)
    first = float(np.max(np.abs(g[tenths[0]])))
    last = float(np.max(np.abs(g[tenths[-1]])))
    means = np.array([float(np.mean(g[idx])) for idx in tenths])
    from scipy.stats import (
        linregress,
    )  # here: most processes importing this module never fit, and scipy.stats is a large import

    slope = float(linregress(t, g).slope) if np.ptp(t) > 0 else 0.0
    secular = abs(slope) * float(np.ptp(t))
    out.update(
        first_tenth_envelope=first,
        last_tenth_envelope=last,
        envelope_ratio=last / first if first > 0 else None,
        tenth_means=means.tolist(),
        secular_rate=slope,
        secular_change=secular,
    )
    within = last <= ENVELOPE_RATIO * first + FLOOR
    if within and secular <= SECULAR_SHARE * first + FLOOR:
        out.update(
            classification="bounded",
            rule=f"last-tenth envelope {last:.3g} <= {ENVELOPE_RATIO:g} x first {first:.3g} + {FLOOR:g}, "
            f"trend {secular:.3g} <= {SECULAR_SHARE:g} x first",
        )
        return out
    # The envelope is the error's, |g|: an energy that decays has an error that grows.
    why = (
        f"trend {secular:.3g} > {SECULAR_SHARE:g} x the first tenth's error envelope {first:.3g}"
        if within
        else f"the error's envelope grew from {first:.2e} in the first tenth to {last:.2e} in the last"
    )
    if np.all(np.diff(means) > 0):
        out.update(classification="grows", rule=f"{why}; tenth means of g increase")
    elif np.all(np.diff(means) < 0):
        out.update(classification="decays", rule=f"{why}; tenth means of g decrease")
    else:
        out.update(classification="drifts", rule=f"{why}; tenth means of g not monotone")
    return out


def _finite(x) -> float | None:
    return float(x) if x is not None and np.isfinite(x) else None


def energy_figures(
    traj: Trajectory, scene: Scene, method=None, timeout: float | None = None
) -> tuple[dict, np.ndarray]:
    """The energy figures of a run with recorded states, one rule for ``harness energy`` and the
    nightly's energy cell: ``max_rel_error`` and ``final_rel_error`` (|dE/E|; None where the run
    did not finish, where the exact energy crosses zero, rule 0, a number without a meaning,
    or where not finite), ``rel_error_defined``, the classification and the numbers behind it,
    the run's ``events`` and, where the scene measures it, ``mass_matrix_varies`` (how much M(q)
    changes over the run's configurations). Returns (figures, the dE/E series)."""
    e_exact, rel = relative_error_series(traj, scene)
    defined = relative_error_defined(e_exact)
    out: dict = {"rel_error_defined": defined, "max_rel_error": None, "final_rel_error": None}
    if traj.ok and defined:
        with np.errstate(all="ignore"):
            out.update(max_rel_error=_finite(np.nanmax(np.abs(rel))), final_rel_error=_finite(abs(rel[-1])))
    if traj.ok or traj.status == UNSTABLE:
        out.update(
            classify(traj.energy[:, 0], e_exact, traj.t, unstable=not traj.ok, escaped=escaped_states(scene, traj))
        )
    else:  # a crash or a timeout says nothing about the energy
        out.update(classification=None, rule=f"run {traj.status}: not classified")
    variation = mass_matrix_varies(traj, scene)
    if variation is not None:
        out["mass_matrix_varies"] = variation
    out["events"] = run_events(scene, traj, method, timeout)
    return out, rel


def mass_matrix_varies(traj: Trajectory, scene: Scene) -> float | None:
    """The scene's ``mass_matrix_variation`` over the run's recorded configurations, where the
    run finished and the scene is conservative (a dissipating model's class is the model's, not
    the method's); None where the scene does not measure it. Where M(q) varies, a scheme that is
    semi-implicit in the velocity (MuJoCo's Euler) is not symplectic and its energy may drift
    although its scheme claims a bounded error (docs/findings.md): the figure that says why."""
    if not traj.ok or not scene.conservative or traj.q.shape[0] < 2:
        return None
    return scene.mass_matrix_variation(traj.q[:, 0])


def energy_behaviour(
    method,
    scene: Scene,
    dt: float,
    steps: int,
    *,
    every: int = 1,
    timeout: float | None = None,
    series: bool = False,
    state_error: bool = True,
    progress=None,
) -> dict:
    """Step ``method`` and measure its energy behaviour against the exact energy.

    Returns the run's status and ``energy_figures``'s (``max_rel_error``, ``final_rel_error``,
    the classification and the numbers behind it, the events); ``series`` adds ``t`` and
    ``rel_error``.

    Beside it, from the same run, the global error of the state against the exact or reference
    solution (``harness.measures.error``: ||(q, v/omega) - true|| relative to the true state's size, so
    a phase error counts in full): ``state_error_max``, ``state_error_final`` and where it
    comes from. Energy alone overstates accuracy: implicit midpoint keeps a spring's energy to
    roundoff while its phase drifts by h^2/12 a unit of time (``state_error`` False skips it).
    ``progress``: told a line before the run and before the state error (a command's progress)."""
    method = resolve(method, scene)
    say = progress or (lambda line: None)
    say(f"energy: stepping {method.id}, {steps} steps at dt {dt:.6g}")
    traj = step(method, scene, dt, steps, every, timeout)
    out = {
        "scene": scene.id,
        "params": dict(scene.values),
        "method": method.id,
        "dt": float(dt),
        "steps": int(steps),
        "every": int(every),
        "omega_dt": float(dt) * scene.omega,
        "periods": float(dt) * steps / scene.period,
        "status": traj.status,
        "detail": traj.detail,
        "failed_step": traj.failed_step,
    }
    if traj.q.shape[0] == 0:
        out.update(classification=None, rule=f"no states recorded ({traj.status})")
        return out
    figures, rel = energy_figures(traj, scene, method, timeout)
    out.update(figures)
    out["short_horizon"] = out["periods"] < MIN_PERIODS
    if state_error and traj.ok:
        from harness.measures.error import run_error

        say("energy: the state error against the exact or reference solution")
        err = run_error(method, scene, traj, timeout)
        out.update(
            state_error_max=err["error_max"],
            state_error_final=err["error_final"],
            state_error_source=err["source"],
            state_error_t_compared=err["t_compared"],
        )
    if series:
        out["t"] = traj.t
        out["rel_error"] = rel
    return out
