"""How the cost of an implicit step grows with the size of a scene.

Backward Euler on ``chain`` solves a tridiagonal system per step (a Thomas sweep in the scene's
``solve``), so its cost per step should grow like N: a log-log slope of 1. A dense solve would
show 3 (LU) or at least 2 (assembling the matrix).

On ``cloth`` the implicit schemes solve the sheet's sparse system: a banded factorisation up to
``scenarios.cloth.DIRECT_MAX_DOF`` unknowns, conjugate gradients above, whose iterations are set
by h omega_max. The sizes keep the mass of each node (``CLOTH_NODE_MASS``), so that omega_max and
h omega_max stay the same at every size and only the number of masses grows.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from reference import METHODS, time_per_step
from scenarios import make_scene

#: dof-steps per timed call: enough that a call lasts milliseconds at every N.
WORK_PER_CALL = 5_000_000
#: The default cloth's node mass (1 kg over 8 x 8), kept at every size of the cloth study.
CLOTH_NODE_MASS = 1.0 / 64.0


def cloth_sizes(sides=(8, 12, 16, 24, 32)) -> list[dict]:
    """Square cloths of the given sides, each node of mass ``CLOTH_NODE_MASS``."""
    return [{"n": int(k), "m": int(k), "mass": k * k * CLOTH_NODE_MASS} for k in sides]


def cost_vs_size(
    scene_id: str,
    sizes: list[dict],
    scheme: str = "implicit_euler",
    dt: float = 1e-3,
    repeats: int = 5,
    work_per_call: int = WORK_PER_CALL,
    min_steps: int = 20,
) -> pd.DataFrame:
    """Compiled cost per step of ``ref:<scheme>`` on ``scene_id`` at each parameter set of ``sizes``
    (the minimum over ``repeats`` timed calls). Columns: ndof (the unknowns), the size's
    parameters, steps, s_per_step, median_s_per_step, ns_per_dof_step. ``frame.attrs``: ``slope``
    and ``intercept`` of log(s_per_step) against log(ndof), ``rvalue``."""
    s = METHODS[scheme]
    rows = []
    for params in sizes:
        scene = make_scene(scene_id, **params)
        n = scene.ndof
        steps = int(np.clip(work_per_call // n, min_steps, 200_000))
        t = time_per_step(s, scene, dt, steps, repeats=repeats)
        rows.append(
            {
                "ndof": int(n),
                **params,
                "steps": steps,
                "s_per_step": t["s_per_step"],
                "median_s_per_step": t["median_s_per_step"],
                "ns_per_dof_step": t["s_per_step"] * 1e9 / n,
            }
        )
    frame = pd.DataFrame(rows)
    from scipy.stats import (
        linregress,
    )  # here: most processes importing this module never fit, and scipy.stats is a large import

    fit = linregress(np.log(frame["ndof"]), np.log(frame["s_per_step"]))
    frame.attrs.update(
        {
            "method": f"ref:{scheme}",
            "scene": scene_id,
            "slope": float(fit.slope),
            "intercept": float(fit.intercept),
            "rvalue": float(fit.rvalue),
        }
    )
    return frame


def implicit_cost_vs_n(
    ns=(10, 100, 1000, 10000),
    scheme: str = "implicit_euler",
    dt: float = 1e-3,
    repeats: int = 5,
    work_per_call: int = WORK_PER_CALL,
) -> pd.DataFrame:
    """``cost_vs_size`` on ``chain`` at each N (column N as well as ndof)."""
    frame = cost_vs_size("chain", [{"N": int(n)} for n in ns], scheme, dt, repeats, work_per_call)
    return frame
