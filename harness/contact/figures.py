"""A contact run measured against its scene's analytic truth (``scenarios.contact``).

* ball: the apexes are the largest recorded heights of the ball's lowest point between impacts
  (an impact: the ball moving down, then up, having risen since the impact before); restitution per bounce sqrt(H_n / H_(n-1)) and
  H_bounces / H0, never a velocity ratio read from samples, which is ambiguous by g h / v. A bounce
  gains energy where its apex exceeds the one before by more than ``Tolerances.gain``. A ball that
  stops bouncing has restitution 0 for the bounces it did not make.
* slide: where the box stopped, the first recorded step whose speed along x is below
  ``STOPPED`` (m/s) and stays below it to the end (its x from the start), and what it moved after.
* rest and stack: the deepest penetration (into the plane, or of a box into the one below, from
  the centres: the poses keep the boxes upright), the largest displacement of any body from
  where it was placed, and the kinetic energy left at the end.
"""
from __future__ import annotations

import math

import numpy as np

from records.contact import ContactFigures, ContactRun
from records.trajectory import OK
from scenarios.contact import TOLERANCES, ContactScene, Tolerances

#: Below this speed (m/s) the slide's box has stopped.
STOPPED = 1e-3


def apexes(z: np.ndarray, vz: np.ndarray, lift: float) -> tuple[list[float], list[int]]:
    """The recorded maxima of ``z`` (heights above the plane) between impacts, and the steps of the
    impacts themselves: apex 0 is the start, apex n the largest height after impact n. An impact
    is the velocity turning from down to up (in flight gravity never turns it) after the ball has
    risen above ``lift`` since the impact before: a soft contact's chatter, which never lifts the
    ball, is not a bounce; a long step that reverses the velocity far from the plane still is one."""
    impacts = []
    down, lifted = False, bool(z[0] > lift)
    for i in range(1, len(z)):
        if z[i] > lift:
            lifted = True
        if vz[i] < 0.0:
            down = True
        elif down and vz[i] > 0.0:
            if lifted:
                impacts.append(i)
            down, lifted = False, False
    heights = [float(z[0])]
    for j, i in enumerate(impacts):
        end = impacts[j + 1] if j + 1 < len(impacts) else len(z)
        heights.append(float(np.max(z[i:end])))
    return heights, impacts


def ball_figures(scene, run: ContactRun, tol: Tolerances = TOLERANCES) -> dict:
    z = run.centres[:, 0, 2] - scene.radius
    vz = run.velocities[:, 0, 2]
    # A bounce lifts the ball clear of a contact's chatter (a soft contact's sink, g / omega_c^2, is a
    # fraction of a millimetre in every pose): a few millimetres of a metre's drop.
    lift = 2e-3 + 1e-3 * scene.h0
    heights, impacts = apexes(z, vz, lift)
    n = scene.bounces
    h = heights[:n + 1] + [0.0] * (n + 1 - len(heights))
    e_n = [math.sqrt(max(h[i], 0.0) / h[i - 1]) if h[i - 1] > 0 else 0.0 for i in range(1, n + 1)]
    gained = [i for i in range(1, n + 1) if h[i] > h[i - 1] * (1.0 + tol.gain)]
    times = run.t[impacts]
    truth = scene.truth()
    ratio = h[n] / h[0] if h[0] > 0 else None
    passes = {
        "restitution": all(abs(x - scene.e) <= tol.restitution for x in e_n),
        "apex_ratio": ratio is not None and abs(ratio - truth["apex_ratio"]) <= tol.apex_ratio * truth["apex_ratio"],
        "gain": not gained,
    }
    return {"restitution": e_n, "apex_ratio": ratio, "gained": gained,
            "intervals": [float(b - a) for a, b in zip(times[:n], times[1:n + 1])], "passes": passes}


def slide_figures(scene, run: ContactRun, tol: Tolerances = TOLERANCES) -> dict:
    x = run.centres[:, 0, 0] - run.centres[0, 0, 0]
    speed = np.abs(run.velocities[:, 0, 0])
    moving = np.nonzero(speed >= STOPPED)[0]
    truth = scene.truth()
    if len(moving) and moving[-1] == len(x) - 1:
        return {"stop": None, "stop_time": None, "creep": None, "passes": {"stop": False, "creep": False},
                "detail": f"still moving at the end (t = {run.t[-1]:.3g} s, {speed[-1]:.3g} m/s)"}
    i = int(moving[-1]) + 1 if len(moving) else 0
    stop, creep = float(x[i]), float(np.max(np.abs(x[i:] - x[i])))
    return {"stop": stop, "stop_time": float(run.t[i]), "creep": creep,
            "passes": {"stop": abs(stop - truth["stop"]) <= tol.stop * truth["stop"], "creep": creep <= tol.creep}}


def rest_figures(scene, run: ContactRun, tol: Tolerances = TOLERANCES) -> dict:
    half, mass = scene.half, scene.mass
    z = run.centres[:, :, 2]
    bottoms = z - half
    below = np.concatenate([np.zeros((len(z), 1)), z[:, :-1] + half], axis=1)  # the plane, then each box's top
    penetration = float(max(0.0, np.max(below - bottoms)))
    start = run.centres[0]
    drift = float(np.max(np.linalg.norm(run.centres - start[None], axis=2)))
    kinetic = float(0.5 * mass * np.sum(run.velocities[-1] ** 2))
    return {"penetration": penetration, "drift": drift, "kinetic": kinetic,
            "passes": {"penetration": penetration <= tol.penetration, "drift": drift <= tol.drift,
                       "kinetic": kinetic <= tol.kinetic}}


MEASURE = {"ball": ball_figures, "slide": slide_figures, "rest": rest_figures, "stack": rest_figures}


def contact_figures(scene: ContactScene, run: ContactRun, tol: Tolerances = TOLERANCES) -> ContactFigures:
    """The run's figures against the scene's truth (all None but the settings where it failed)."""
    from dataclasses import asdict

    common = dict(scene=scene.id, params=dict(scene.values), dt=run.dt, status=run.status, truth=scene.truth(),
                  tolerances=asdict(tol), settings=dict(run.settings), loop=run.loop or None,
                  engine_version=run.engine_version)
    if run.status != OK:
        return ContactFigures(**common, detail=run.detail)
    got = MEASURE[scene.id](scene, run, tol)
    cpu = run.loop_cpu_s / (run.steps * run.dt) if run.loop_cpu_s is not None and run.steps else None
    return ContactFigures(**common, **got, cpu_per_s=cpu)


def within(figures: ContactFigures) -> bool | None:
    """Every judged figure ✓ (None where the run failed: nothing was judged)."""
    if not figures.passes:
        return None
    return all(figures.passes.values())
