"""MuJoCo's bare loops for ``harness bench --engines``: ``mujoco.rollout`` (one call, as a user
writes it, the state array allocated and recorded) and a Python loop of ``mj_step``, on the model
the adapter built."""

from __future__ import annotations

import numpy as np

from .._engine import import_engine


def bare_loops(mode, mj, model, scene, dt: float):
    """([(name, once(n)), ...], what they are): the target's loop first."""
    rollout = import_engine(f"{mj.__name__}.rollout")
    m, d = model.m, model.d
    full = int(mj.mjtState.mjSTATE_FULLPHYSICS)

    def rolled(n):
        rollout.rollout(m, d, _state(mj, m, d, full), nstep=n)

    def stepped(n):
        step = mj.mj_step
        for _ in range(n):
            step(m, d)

    return [
        ("mujoco.rollout", rolled),
        ("mj_step loop", stepped),
    ], "mujoco.rollout(m, d, state, nstep=N); a Python loop of mj_step(m, d)"


def _state(mj, m, d, full: int):
    state = np.empty(mj.mj_stateSize(m, full))
    mj.mj_getState(m, d, state, full)
    return state
