"""How the cost of an implicit step grows with the size of the chain.

Backward Euler on ``chain`` solves a tridiagonal system per step (a Thomas sweep in the scene's
``solve``), so its cost per step should grow like N: a log-log slope of 1. A dense solve would
show 3 (LU) or at least 2 (assembling the matrix).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.stats import linregress

from reference import METHODS, time_per_step
from scenarios import make_scene

#: dof-steps per timed call: enough that a call lasts milliseconds at every N.
WORK_PER_CALL = 5_000_000


def implicit_cost_vs_n(ns=(10, 100, 1000, 10000), scheme: str = "implicit_euler", dt: float = 1e-3,
                       repeats: int = 5, work_per_call: int = WORK_PER_CALL) -> pd.DataFrame:
    """Compiled cost per step of ``ref:<scheme>`` on ``chain`` at each N (the minimum over
    ``repeats`` timed calls). Columns: N, steps, s_per_step, median_s_per_step, ns_per_dof_step.
    ``frame.attrs``: ``slope`` and ``intercept`` of log(s_per_step) against log(N), ``rvalue``."""
    s = METHODS[scheme]
    rows = []
    for n in ns:
        steps = int(np.clip(work_per_call // n, 20, 200_000))
        t = time_per_step(s, make_scene("chain", N=n), dt, steps, repeats=repeats)
        rows.append({"N": int(n), "steps": steps, "s_per_step": t["s_per_step"],
                     "median_s_per_step": t["median_s_per_step"],
                     "ns_per_dof_step": t["s_per_step"] * 1e9 / n})
    frame = pd.DataFrame(rows)
    fit = linregress(np.log(frame["N"]), np.log(frame["s_per_step"]))
    frame.attrs.update({"method": f"ref:{scheme}", "scene": "chain", "slope": float(fit.slope),
                        "intercept": float(fit.intercept), "rvalue": float(fit.rvalue)})
    return frame
