"""The reference of a model file, which has no closed form: MuJoCo's own RK4 on the model's
variant, the step halved until two successive halvings agree.

Over [0, T] (T the scene's ``reference_horizon``, or further where asked), level k steps
h_k = h_0 / 2^k with h_0 = T / max(ceil(T omega / H0_OMEGA), ceil(T / h_model)) (so h_0 omega <= 0.1,
h_0 is never coarser than the model's own timestep h_model, and the levels share their grid
points). Levels are compared on level k's grid in the error measure's own
norm, ``max_n ||y_k(t_n) - y_{k+1}(t_n)|| / max_n ||y_{k+1}(t_n)||`` with y = (q, v/omega);
halving stops once that difference is at most REFERENCE_RTOL, after MAX_HALVINGS, or where
the difference stops falling (roundoff, or a model that is not smooth: a contact switching on
moves the point of the switch by the step). The finer level is the reference and the last
difference its **estimated error** (for a smooth model RK4's error falls 16-fold per halving,
so the finer level is better than that: the estimate is an upper bound). A reference whose
estimated error is above REFERENCE_JUDGES has not converged (a chaotic contact-rich motion over
the horizon, or a model that is not smooth): it judges no cell, and the cells say so
(``judges``).

The scene supplies ``engine_model()`` (a fresh compiled model), ``engine_state(q, v)`` (its
coordinates -> MuJoCo's qpos, qvel) and ``scene_state(qpos, qvel)`` (back): the identity for a
model file, a map of the flex's vertices for ``cloth_flex``; states are compared and returned
in the scene's coordinates.

A state at a time between grid points is one RK4 step of the remaining length from the grid
point before it (a shorter step than the grid's, so no less accurate). Grids are cached per
process, by scene id (file hash), variant and T.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Two successive halvings agreeing to this (relative, the error measure's norm) end the refinement.
REFERENCE_RTOL = 1e-11
#: A reference whose last two levels differ by more than this (relative) judges nothing.
REFERENCE_JUDGES = 1e-2
#: h_0 omega of the coarsest level.
H0_OMEGA = 0.1
MAX_HALVINGS = 12
#: The most steps one level may take (a stiff model with a long period would otherwise run for minutes).
MAX_STEPS = 2_000_000


@dataclass
class Grid:
    """The reference over [0, T] on a uniform grid of step h."""

    T: float
    h: float
    state: np.ndarray  # (N + 1, nstate) MuJoCo full physics states
    q: np.ndarray  # (N + 1, nq)
    v: np.ndarray  # (N + 1, nv)
    error: float  # the estimated relative error (difference of the last two levels)
    halvings: int
    converged: bool  # the difference reached REFERENCE_RTOL
    history: list  # (h, difference to the next level) per level compared

    @property
    def judges(self) -> bool:
        """Whether its error is small enough to judge another run against (REFERENCE_JUDGES)."""
        return math.isfinite(self.error) and self.error <= REFERENCE_JUDGES

    def describe(self) -> str:
        how = "agreed" if self.converged else "stopped"
        return (
            f"MuJoCo RK4 at h = {self.h:.3g} ({self.halvings} halvings; the last two {how} to "
            f"{self.error:.2g}: its estimated error)"
        )


_GRIDS: dict[tuple, Grid] = {}


def _run(scene, m, d, h: float, n: int):
    """(states (n + 1, nstate), qpos, qvel) of n RK4 steps of h from the scene's initial state;
    None where MuJoCo warned or a state is not finite."""
    import mujoco
    from mujoco import rollout

    m.opt.timestep = h
    spec = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
    nstate = mujoco.mj_stateSize(m, spec)
    mujoco.mj_resetData(m, d)
    q0, v0 = scene.engine_state(*scene.initial_state())
    d.qpos[:] = q0
    d.qvel[:] = v0
    mujoco.mj_forward(m, d)
    s0 = np.empty(nstate)
    mujoco.mj_getState(m, d, s0, spec)
    states = np.empty((n + 1, nstate))
    states[0] = s0
    if n:
        out = rollout.rollout(m, d, s0[None, :], nstep=n)[0]
        states[1:] = out[0]
        if any(w.number for w in d.warning):
            return None
    if not np.all(np.isfinite(states)):
        return None
    nq, nv = m.nq, m.nv
    return (states, *scene.scene_state(states[:, 1 : 1 + nq], states[:, 1 + nq : 1 + nq + nv]))


def _scaled(scene, q, v):
    return np.concatenate([q, v / scene.omega], axis=-1)


def reference_grid(scene, t_end: float | None = None) -> Grid:
    import mujoco

    T = float(scene.reference_horizon if t_end is None else max(t_end, scene.reference_horizon))
    key = (scene.id, tuple(sorted(scene.values.items())))
    have = _GRIDS.get(key)
    if have is not None and have.T >= T:
        return have
    m = scene.engine_model()
    m.opt.integrator = int(mujoco.mjtIntegrator.mjINT_RK4)
    m.opt.disableflags |= int(
        getattr(mujoco.mjtDisableBit, "mjDSBL_AUTORESET", 0)
    )  # absent in older releases (2.3.7, 3.0.0)
    d = mujoco.MjData(m)
    own = getattr(scene, "own_timestep", None)
    n0 = max(8, math.ceil(T * scene.omega / H0_OMEGA), math.ceil(T / own - 1e-9) if own else 0)
    prev, history = None, []
    best = None
    for k in range(MAX_HALVINGS + 1):
        n = n0 * 2**k
        if n > MAX_STEPS:
            break
        h = T / n
        run = _run(scene, m, d, h, n)
        if run is None:
            prev = None
            continue
        if prev is not None:
            yc = _scaled(scene, prev[1], prev[2])
            yf = _scaled(scene, run[1][::2], run[2][::2])
            scale = float(np.max(np.linalg.norm(yf, axis=-1))) or 1.0
            diff = float(np.max(np.linalg.norm(yc - yf, axis=-1))) / scale
            history.append((T / (n // 2), diff))
            if best is None or diff < best[0]:
                best = (diff, h, run, k)
            if diff <= REFERENCE_RTOL:
                break
            if len(history) >= 3 and diff > 0.5 * history[-2][1]:
                break  # no longer falling: roundoff, or a model that is not smooth
        prev = run
    if best is None:
        nan = math.nan
        grid = Grid(
            T, T, np.full((1, 1), nan), np.full((1, m.nq), nan), np.full((1, m.nv), nan), math.inf, 0, False, history
        )
    else:
        diff, h, run, k = best
        grid = Grid(T, h, run[0], run[1], run[2], diff, k, diff <= REFERENCE_RTOL, history)
    _GRIDS[key] = grid
    return grid


def reference_at(scene, t) -> tuple[np.ndarray, np.ndarray]:
    """(q, v) of the reference at times t, shapes (len(t), nq) and (len(t), nv)."""
    import mujoco

    t = np.atleast_1d(np.asarray(t, dtype=float))
    grid = reference_grid(scene, float(t.max(initial=0.0)))
    nq, nv = grid.q.shape[1], grid.v.shape[1]
    q = np.empty((len(t), nq))
    v = np.empty((len(t), nv))
    if not math.isfinite(grid.error):
        q[:] = np.nan
        v[:] = np.nan
        return q, v
    m, d = None, None
    spec = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
    for i, ti in enumerate(t):
        n = int(math.floor(ti / grid.h + 1e-9))
        rest = ti - n * grid.h
        if rest <= 1e-12 * max(ti, grid.h) or n >= len(grid.q) - 1 and rest <= 0:
            q[i], v[i] = grid.q[n], grid.v[n]
            continue
        if m is None:
            m = scene.engine_model()
            m.opt.integrator = int(mujoco.mjtIntegrator.mjINT_RK4)
            m.opt.disableflags |= int(
                getattr(mujoco.mjtDisableBit, "mjDSBL_AUTORESET", 0)
            )  # absent in older releases (2.3.7, 3.0.0)
            d = mujoco.MjData(m)
        mujoco.mj_setState(m, d, grid.state[n], spec)
        m.opt.timestep = rest
        mujoco.mj_step(m, d)
        q[i], v[i] = scene.scene_state(d.qpos, d.qvel)
    return q, v


class RefinedRunReference:
    """A scene whose reference is MuJoCo's own RK4, halved until two halvings agree (a model file,
    MuJoCo's flex cloth): mixed in before the ``Scene`` class it completes."""

    reference_engine = "mujoco"

    def reference_solution(self, t):
        return reference_at(self, t)

    def reference_error(self, t) -> float | None:
        return reference_grid(self).error

    def reference_judges(self) -> bool:
        return reference_grid(self).judges

    def reference_description(self) -> str:
        return reference_grid(self).describe()
