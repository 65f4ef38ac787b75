"""``ref:verlet_constrained`` on ``rope`` against the number of projection passes per step:
constraint error (relative stretch), energy behaviour, error against the reference solution
and compiled cost per step."""

from __future__ import annotations

import numpy as np
import pandas as pd

from reference import METHODS, integrate, time_per_step
from scenarios import make_scene


def rope_vs_iterations(
    iterations=(1, 2, 4, 8, 16, 32, 64),
    dt: float = 1e-3,
    t_end: float = 2.0,
    timing: bool = True,
    timing_steps: int = 2000,
    **scene_params,
) -> pd.DataFrame:
    """One row per pass count K. Columns:

    * ``max_stretch`` / ``final_stretch``: largest and last max_j |d_j - l|/l of the run;
    * ``energy_change``: (E_end - E0)/E0, ``max_energy_change``: the largest |E - E0|/E0
      (E0 = m g l N(N+1)/2, the energy above the hanging rest state);
    * ``max_position_error``: the largest |q - q_ref| over t <= min(t_end, reference horizon);
    * ``ns_per_step``: compiled cost per step (minimum of 5 calls), if ``timing``.

    The accuracy runs are interpreted (every force evaluation counted, as everywhere else).
    """
    scene = make_scene("rope", **scene_params)
    scheme = METHODS["verlet_constrained"]
    steps = int(round(t_end / dt))
    e0 = float(scene.energy(*scene.initial_state()))
    rows = []
    for k in iterations:
        tr = integrate(scheme, scene, dt, steps, iterations=int(k))
        q, energy = tr.q[:, 0], tr.energy[:, 0]
        stretch = scene.constraint_error(q)
        sel = tr.t <= min(t_end, scene.reference_horizon)
        q_ref, _ = scene.reference_solution(tr.t[sel])
        row = {
            "iterations": int(k),
            "dt": dt,
            "t_end": t_end,
            "status": tr.status,
            "max_stretch": float(np.max(stretch)),
            "final_stretch": float(stretch[-1]),
            "energy_change": float((energy[-1] - e0) / e0),
            "max_energy_change": float(np.max(np.abs(energy - e0)) / e0),
            "max_position_error": float(np.max(np.abs(q[sel] - q_ref))),
            "force_evals_per_step": tr.force_evals / steps,
            "projections_per_step": tr.meta.projections / steps,
        }
        if timing:
            t = time_per_step(scheme, scene, dt, timing_steps, iterations=int(k))
            row["ns_per_step"] = t["s_per_step"] * 1e9
        rows.append(row)
    frame = pd.DataFrame(rows)
    frame.attrs.update({"scene": scene.id, "params": dict(scene.values), "method": "ref:verlet_constrained"})
    return frame
