"""Do two engines agree on a model? Two engine modes of the same scheme run from the same state
on the same scene (a model file's conservative variant), compared in the error measure's norm.

The rule:

* ``difference``: max over the recorded steps of ||y_a - y_b|| / max ||y_ref||, y = (q, v/omega),
  over the scene's reference horizon (``harness.measures.error``);
* each engine's own estimate of its discretisation error, from its own refined run (the same
  engine at dt/2, Richardson for the mode's order p, 1 for the semi-implicit modes compared):
  ``||y(dt) - y(dt/2)|| / (1 - 2^-p)``, ``errors``; MuJoCo's halved-RK4 reference's own
  estimated error beside them, ``reference_error``;
* they **disagree** where ``difference > error_a + error_b + reference_error``: more than the two
  discretisations can account for (the triangle inequality), so the engines integrate
  different models. Then what each engine built is compared at the initial state
  (``EngineModel.anatomy``): total mass, the mass matrix, the joint axes in the world frame, each
  listed where it differs by more than ANATOMY_RTOL (relative), with both values.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from records.result import Result

from scenarios import Scene

from harness.measures.common import declared_order, resolve, scaled_state, step
from harness.measures.error import richardson, trajectory_error, true_state

#: Relative difference above which a built quantity is said to differ (a few thousand eps:
#: two engines' sums of the same inertias in another order agree far closer).
ANATOMY_RTOL = 1e-9


@dataclass(frozen=True)
class CrossEngineResult(Result):
    scene: str
    params: dict
    methods: list
    dt: float
    steps: int
    statuses: list
    difference: float | None = None
    errors: list | None = None               # each run against the reference
    reference_error: float | None = None
    disagree: bool | None = None
    differences: list | None = None          # what differs in the built models, one line each
    anatomies: list | None = None
    detail: str = ""


def _anatomy_in_worker(method_id: str, scene: Scene, dt: float):
    from harness.methods import get_method

    return get_method(method_id).anatomy(scene, dt)


def anatomy(method_id: str, scene: Scene, dt: float, timeout: float = 60.0) -> dict | None:
    from harness.execution import isolation

    if isolation.IN_WORKER:
        return _anatomy_in_worker(method_id, scene, dt)
    out = isolation.run_in_worker(_anatomy_in_worker, (method_id, scene, dt), timeout=timeout)
    return None if isinstance(out, isolation.WorkerFailure) else out


def anatomy_differences(a: dict, b: dict, names: tuple[str, str], coords) -> list[str]:
    """One line per built quantity that differs between the two engines' models."""
    out = []
    rel = abs(a["total_mass"] - b["total_mass"]) / max(abs(a["total_mass"]), 1e-300)
    if rel > ANATOMY_RTOL:
        out.append(f"total mass: {names[0]} {a['total_mass']:.9g}, {names[1]} {b['total_mass']:.9g}")
    if a["mass_matrix"] is not None and b["mass_matrix"] is not None:
        ma, mb = np.array(a["mass_matrix"]), np.array(b["mass_matrix"])
        d = np.abs(ma - mb) / max(float(np.max(np.abs(ma))), 1e-300)
        if d.size and float(np.max(d)) > ANATOMY_RTOL:
            i, j = np.unravel_index(int(np.argmax(d)), d.shape)
            out.append(f"mass matrix at the initial state: max relative difference {float(np.max(d)):.3g}, at "
                       f"({coords[i]}, {coords[j]}): {names[0]} {ma[i, j]:.6g}, {names[1]} {mb[i, j]:.6g}")
    for name, xa, xb in zip(coords, a["joint_axes"], b["joint_axes"]):
        xa, xb = np.array(xa), np.array(xb)
        cos = float(np.dot(xa, xb) / (np.linalg.norm(xa) * np.linalg.norm(xb)))
        if not abs(cos - 1.0) <= ANATOMY_RTOL:
            out.append(f"joint axis of {name} (world): {names[0]} {np.round(xa, 6).tolist()}, "
                       f"{names[1]} {np.round(xb, 6).tolist()} ({math.degrees(math.acos(max(-1.0, min(1.0, cos)))):.3g} deg apart)")
    return out


def cross_engine(scene: Scene, a: str = "mujoco:euler", b: str = "pybullet:semi_implicit",
                 dt: float | None = None, steps: int | None = None, timeout: float | None = None) -> CrossEngineResult:
    """Compare modes ``a`` and ``b`` on ``scene`` by the rule in the module docstring; ``dt``: the
    scene's own timestep by default, ``steps``: over its reference horizon."""
    ma, mb = resolve(a, scene), resolve(b, scene)
    dt = float(dt if dt is not None else scene.own_timestep)
    steps = int(steps if steps is not None else max(1, round(scene.reference_horizon / dt)))
    runs = [step(m, scene, dt, steps, 1, timeout) for m in (ma, mb)]
    halved = [step(m, scene, dt / 2, 2 * steps, 2, timeout) for m in (ma, mb)]
    base = {"scene": scene.id, "params": dict(scene.values), "methods": [ma.id, mb.id], "dt": dt, "steps": steps,
            "statuses": [r.status for r in runs]}
    if not all(r.ok for r in runs + halved):
        return CrossEngineResult(**base, detail="; ".join(f"{r.method} {r.status}: {r.detail}"
                                                          for r in runs + halved if not r.ok))
    ref = trajectory_error(runs[0], scene)["reference_error"]
    q_true, v_true, _ = true_state(scene, runs[0].t)
    scale = float(np.max(np.linalg.norm(scaled_state(scene, q_true, v_true), axis=-1)))

    def y(r):
        return scaled_state(scene, r.q[:, 0], r.v[:, 0])

    diff = float(np.max(np.linalg.norm(y(runs[0]) - y(runs[1]), axis=-1))) / scale
    orders = [declared_order(m, scene) or 1 for m in (ma, mb)]
    errs = [richardson(scene, r, h, p, scale)[0] for r, h, p in zip(runs, halved, orders)]
    disagree = diff > errs[0] + errs[1] + ref
    anatomies = [anatomy(m.id, scene, dt) for m in (ma, mb)]
    differences = []
    if disagree and all(x is not None for x in anatomies):
        differences = anatomy_differences(*anatomies, (ma.id, mb.id), scene.dof_names) or [
            "total mass, mass matrix and joint axes agree: the engines differ in the forces "
            "(what each reads of the file's damping, friction, springs) or in how they step"]
    return CrossEngineResult(**base, difference=diff, errors=errs, reference_error=ref,
                             disagree=bool(disagree), differences=differences, anatomies=anatomies)
