"""Brouwer's law, measured as it is stated: over an ensemble, not one run.

A scheme whose truncation error is below the double-precision roundoff (IAS15; Rein & Spiegel
2015) still makes one rounding error a step, at random; its energy error then walks like a
random walk, |dE/E| growing as t^(1/2), and its phase error as t^(3/2) (Brouwer 1937). One run's
error is one path of that walk: its log-log slope is noise (one IAS15 run on the outer solar
system read 0.15). The law is a statement about the ensemble's RMS, so:

* **Realizations**: ``realizations`` runs from the scene's initial state with every coordinate
  multiplied by 1 + ``PERTURBATION`` x a standard normal draw (seeded by the realization's index:
  the ensemble is the same every night), a perturbation at the roundoff level that only decorrelates
  the rounding errors.
* **The walk**: each run's energy relative to its own first recorded state after the start,
  (E(t) - E(t_1)) / |E(0)|, so that a fixed offset made in the first output interval (IAS15's
  first step sizes itself) is not read as growth.
* **The slope**: least squares of log RMS over the ensemble against log t, over the recorded
  states after the first two; its 95% interval by a bootstrap over the realizations (they are
  independent; the recorded times of one run are not), ``BOOTSTRAP`` resamples, seeded. The law
  is the walk's once it is established, so the run must be long: IAS15 on Kepler grows as
  t^0.38 (0.28-0.47) over 3,000 orbits and t^0.58 (0.46-0.70) over 10,000 (24 realizations,
  measured): its first thousand orbits walk slower than at random.
* **Beside it**, for a fixed-step method on a scene with an exact solution: the ensemble's RMS
  position error and its slope, fitted where it is below ``SATURATION`` (a phase error grows
  until the body is across its orbit): a symplectic scheme's truncation error puts the body
  behind or ahead at a rate, a phase error growing as t. Not for IAS15: its position error
  against the unperturbed orbit holds the perturbation's own drift (a 1e-15 change of the
  semi-major axis moves the mean motion), which is not its roundoff.

A scheme whose energy error is bounded (leapfrog) reads a slope near 0 on the same measure.
"""

from __future__ import annotations

import numpy as np

from scenarios import Scene

from harness.measures.common import resolve, started_at

#: Relative size of the initial perturbation: the roundoff level.
PERTURBATION = 1e-15
#: Bootstrap resamples of the realizations for the slope's interval.
BOOTSTRAP = 1000
#: The position error (in the scene's length unit) below which its growth is fitted.
SATURATION = 0.1
#: Brouwer's exponent for the energy error, and for the phase (position) error.
ENERGY_EXPONENT, PHASE_EXPONENT = 0.5, 1.5


def _slope(t: np.ndarray, rms: np.ndarray) -> float:
    keep = (t > 0) & (rms > 0) & np.isfinite(rms)
    if keep.sum() < 3:
        return float("nan")
    from scipy.stats import (
        linregress,
    )  # here: most processes importing this module never fit, and scipy.stats is a large import

    return float(linregress(np.log(t[keep]), np.log(rms[keep])).slope)


def _fit(t: np.ndarray, walks: np.ndarray, rng) -> dict:
    """The ensemble RMS of ``walks`` (realization x time) and its slope, with the bootstrap interval."""
    rms = np.sqrt(np.mean(walks**2, axis=0))
    slope = _slope(t, rms)
    boots = [
        _slope(t, np.sqrt(np.mean(walks[rng.integers(0, len(walks), len(walks))] ** 2, axis=0)))
        for _ in range(BOOTSTRAP)
    ]
    lo, hi = np.nanpercentile(boots, [2.5, 97.5])
    return {"slope": slope, "ci95": [float(lo), float(hi)], "rms": rms}


def energy_walk(
    method, scene: Scene, dt: float, steps: int, every: int, *, realizations: int = 16, seed: int = 0
) -> dict:
    """The ensemble measurement of the module docstring, in this process (an engine mode is
    stepped here: the nightly's cells run in a worker already). Returns the energy slope and its
    95% interval, the RMS series, the position-error slope where the scene has an exact solution,
    and the ensemble's settings."""
    method = resolve(method, scene)
    q0, v0 = scene.initial_state()
    walks, errors, t, t_abs, statuses = [], [], None, None, []
    for r in range(int(realizations)):
        rng = np.random.default_rng([seed, r])
        q = q0 * (1.0 + PERTURBATION * rng.standard_normal(q0.shape))
        v = v0 * (1.0 + PERTURBATION * rng.standard_normal(v0.shape))
        moved = started_at(scene, q, v)
        traj = method.simulate(moved, dt, steps, every)
        statuses.append(traj.status)
        if not traj.ok:
            continue
        e = traj.energy[:, 0]
        walks.append((e[1:] - e[1]) / abs(e[0]))
        t, t_abs = traj.t[1:] - traj.t[1], traj.t[1:]
        exact = None if method.adaptive else scene.closed_form(traj.t)
        if exact is not None:
            errors.append(np.linalg.norm(traj.q[:, 0] - exact[0], axis=-1)[1:])
    out = {
        "realizations": int(realizations),
        "perturbation": PERTURBATION,
        "dt": float(dt),
        "steps": int(steps),
        "every": int(every),
        "horizon": float(dt) * steps,
        "periods": float(dt) * steps / scene.period,
        "failed": sum(s != "ok" for s in statuses),
        "expected_slope": ENERGY_EXPONENT,
    }
    if len(walks) < 3:
        return {**out, "slope": None, "ci95": None, "reason": f"{len(walks)} realizations finished (of {realizations})"}
    rng = np.random.default_rng([seed, 10_000])
    fit = _fit(t[1:], np.array(walks)[:, 1:], rng)
    out.update(
        slope=fit["slope"],
        ci95=fit["ci95"],
        t=t[1:],
        rms=fit["rms"],
        contains_brouwer=bool(fit["ci95"][0] <= ENERGY_EXPONENT <= fit["ci95"][1]),
    )
    if errors:
        errors = np.array(errors)[:, 1:]
        below = np.sqrt(np.mean(errors**2, axis=0)) < SATURATION
        n = int(np.argmin(below)) if not below.all() else len(below)  # up to the first saturated point
        if n >= 3:
            err = _fit(t_abs[1:][:n], errors[:, :n], rng)
            out.update(error_slope=err["slope"], error_ci95=err["ci95"], error_fit_until=float(t_abs[1:][n - 1]))
    return out
