"""Numerical damping of a method on a scene of independent normal modes (the spring chain),
at a timestep far beyond every explicit scheme's stability limit.

The rule, one way for every method:

* **Timestep**: ``dt = factor * EXPLICIT_LIMIT / omega`` with ``EXPLICIT_LIMIT = 2`` (the
  h*omega limit of the Verlet family on the stiffest mode); ``factor`` 100 is the issue's
  "100x that dt", h*omega_max = 200.
* **Energy kept**: ``steps`` (default 5) steps from the scene's initial state;
  ``energy_kept[n] = E_n / E_0`` (the exact solution keeps 1). The run's status says whether
  the method survived them.
* **Per mode**: the one-step map M (``stability.one_step_map``), measured from a generic
  state (``GENERIC_SEED``: standard-normal q and v/omega, no two coordinates equal; see
  ``one_step_map``'s ``base``), transformed to modal coordinates (the scene's orthonormal
  ``modal`` transform on q and on v). A method that treats the modes independently (every
  linear one on this scene) leaves a 2x2 block per mode and nothing else (``modal_leak``, the
  largest entry outside the blocks relative to the largest entry, measures it). For mode j
  with block eigenvalues lambda:

  - ``rho`` = max |lambda| (above 1 + ``stability.RHO_TOL``: the mode grows, the method is
    unstable there) and ``energy_factor`` = rho^2, the asymptotic energy kept per step;
  - ``zeta``, the damping ratio of the continuous oscillator whose exact flow over one step
    is this block: lambda = exp(h (-zeta w +- i w sqrt(1 - zeta^2))) for a complex pair,
    zeta = -ln r / sqrt(ln^2 r + theta^2) with lambda = r e^{+-i theta}; for two positive real
    eigenvalues (an overdamped oscillator) zeta = -(ln l1 + ln l2) / (2 sqrt(ln l1 ln l2));
    None where no oscillator matches (a negative eigenvalue: the map flips sign each step).
    The exact flow has zeta = 0; backward Euler's is zeta = ln(1 + y^2) / sqrt(ln^2(1 + y^2)
    + 4 atan^2 y) at y = h w_j.

Reported for the highest mode (``highest``, w_N = omega) and the lowest (``lowest``, w_1).
"""

from __future__ import annotations

import math

import numpy as np

from records import InvalidInput

from scenarios import Scene

from harness.measures.common import resolve, step
from harness.measures.stability import RHO_TOL, one_step_map

EXPLICIT_LIMIT = 2.0
FACTOR = 100.0
STEPS = 5
GENERIC_SEED = 0


def generic_state(scene: Scene, seed: int = GENERIC_SEED) -> np.ndarray:
    """A state y = (q, v) with standard-normal q and v/omega: no coordinate coincidences."""
    rng = np.random.default_rng(seed)
    n = scene.ndof
    return np.concatenate([rng.standard_normal(n), scene.omega * rng.standard_normal(n)])


def mode_damping(block: np.ndarray, dt: float) -> dict:
    """rho, energy_factor and zeta (module docstring) of one mode's 2x2 one-step block."""
    lam = np.linalg.eigvals(block)
    rho = float(np.max(np.abs(lam)))
    zeta = None
    if abs(lam[0].imag) > 0.0:
        r, theta = abs(lam[0]), abs(math.atan2(lam[0].imag, lam[0].real))
        zeta = -math.log(r) / math.hypot(math.log(r), theta)
    elif np.all(lam.real > 0.0):
        l1, l2 = np.log(lam.real)
        if l1 * l2 > 0.0:
            zeta = float(-(l1 + l2) / (2.0 * math.sqrt(l1 * l2)))
    return {
        "rho": rho,
        "energy_factor": rho * rho,
        "zeta": zeta,
        "eigenvalues": [[float(x.real), float(x.imag)] for x in lam],
    }


def damping_far_beyond_the_limit(
    method, scene: Scene, *, factor: float = FACTOR, steps: int = STEPS, timeout: float | None = None
) -> dict:
    """Energy kept and per-mode damping at ``factor`` times the explicit limit (module docstring)."""
    method = resolve(method, scene)
    if not scene.has_modes:
        raise InvalidInput(f"scene {scene.id} has no normal modes to measure damping on (valid: chain)")
    if not (factor > 0.0 and math.isfinite(factor)):
        raise InvalidInput(f"factor={factor} is out of range (allowed: finite, > 0)")
    dt = factor * EXPLICIT_LIMIT / scene.omega
    out = {
        "scene": scene.id,
        "params": dict(scene.values),
        "method": method.id,
        "factor": factor,
        "dt": dt,
        "omega_dt": dt * scene.omega,
        "steps": int(steps),
    }
    traj = step(method, scene, dt, steps, 1, timeout)
    with np.errstate(all="ignore"):
        kept = (traj.energy[:, 0] / traj.energy[0, 0]).tolist() if traj.q.shape[0] else []
    out.update(
        status=traj.status,
        detail=traj.detail,
        failed_step=traj.failed_step,
        energy_kept=kept,
        energy_kept_one_step=kept[1] if len(kept) > 1 else None,
    )

    res = one_step_map(method, scene, dt, timeout=timeout, base=generic_state(scene))
    if res["rho"] is None:
        out.update(rho=None, reason=res["reason"], stable=None)
        return out
    n = scene.ndof
    S = scene.modal(np.eye(n))  # orthonormal and symmetric: its own inverse
    T = np.block([[S, np.zeros((n, n))], [np.zeros((n, n)), S]])
    modal = T @ res["matrix"] @ T
    j = np.arange(n)
    in_block = np.zeros((2 * n, 2 * n), dtype=bool)
    for a, b in ((j, j), (j, j + n), (j + n, j), (j + n, j + n)):
        in_block[a, b] = True
    scale = float(np.max(np.abs(modal)))
    leak = float(np.max(np.abs(modal[~in_block]), initial=0.0)) / scale if scale > 0 else 0.0
    w = scene.mode_frequencies()
    modes = []
    for k in range(n):
        block = modal[np.ix_([k, k + n], [k, k + n])]
        modes.append({"mode": k + 1, "omega": float(w[k]), "omega_dt": float(w[k] * dt), **mode_damping(block, dt)})
    out.update(
        rho=res["rho"],
        stable=bool(res["rho"] <= 1.0 + RHO_TOL),
        linearity_residual=res["linearity_residual"],
        modal_leak=leak,
        highest=modes[-1],
        lowest=modes[0],
        modes=modes,
    )
    return out
