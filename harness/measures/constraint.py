"""Constraint drift of a method on a scene with links or springs (the rope; the chain, the cloth and
the net, whose springs stretch), with the energy it loses.

The rule, one way for every method: run ``steps`` steps of ``dt`` from the scene's initial
state and evaluate the scene's own ``constraint_error`` (the rope's: the largest relative
stretch max_j |d_j - l| / l over its links; the cloth's the same over its springs' rest lengths;
the chain's the springs' largest extension relative to the initial displacement) at every
recorded state:

* ``max_stretch`` (the largest over the run), ``final_stretch`` (at the last state);
* ``energy_change`` = (E_end - E_0) / |E_0| and ``max_energy_change`` = max |E_n - E_0| / |E_0|
  over the run (the rope's exact energy is E_0 at all times).

A method in reduced coordinates (MuJoCo's hinge chain) keeps the links at length l by
construction: its stretch is roundoff. A position-based method (``ref:verlet_constrained``)
and an impulse-based one (pymunk's pin joints) hold the links only approximately.
"""

from __future__ import annotations

import numpy as np

from records import InvalidInput

from scenarios import Scene

from harness.measures.common import resolve, step


def constraint_drift(
    method, scene: Scene, dt: float, steps: int, *, every: int = 1, timeout: float | None = None
) -> dict:
    """Constraint error and energy change of ``method`` on ``scene`` (module docstring)."""
    method = resolve(method, scene)
    if not scene.has_stretch:
        raise InvalidInput(f"scene {scene.id} has no links or springs to stretch (valid: rope, chain, cloth, net)")
    return drift_of(step(method, scene, dt, steps, every, timeout), scene, method, dt, steps, every)


def drift_of(traj, scene: Scene, method, dt: float, steps: int, every: int = 1) -> dict:
    """``constraint_drift``'s figures of a run already stepped (the nightly's energy run, which the
    constraint cell reads rather than stepping it again)."""
    out = {
        "scene": scene.id,
        "params": dict(scene.values),
        "method": method.id,
        "dt": float(dt),
        "steps": int(steps),
        "every": int(every),
        "status": traj.status,
        "detail": traj.detail,
        "failed_step": traj.failed_step,
    }
    if traj.meta.iterations is not None:
        out["iterations"] = traj.meta.iterations
    if traj.q.shape[0] == 0:
        return {**out, "max_stretch": None, "final_stretch": None, "energy_change": None, "max_energy_change": None}
    with np.errstate(all="ignore"):
        stretch = np.asarray(scene.constraint_error(traj.q[:, 0]), dtype=float)
        e = traj.energy[:, 0]
        rel = (e - e[0]) / abs(e[0])
    out.update(
        max_stretch=float(np.max(stretch)),
        final_stretch=float(stretch[-1]),
        t_final=float(traj.t[-1]),
        energy_change=float(rel[-1]),
        max_energy_change=float(np.max(np.abs(rel))),
    )
    return out
