"""The two loops that turn an engine model (``adapters._model``) into a :class:`Trajectory`.

Both record exactly as ``reference/_integrate.py`` records a scheme (step 0, then every
``every`` steps, always the last), so the two are compared like with like; the energy is the
scene's, from the state.

* ``loop="engine"`` (the default, :func:`run_engine_loop`): the engine advances from one output
  point to the next through its own loop (``mujoco.rollout``, REBOUND's ``sim.steps(n)``, a
  Python loop that calls only the step function for pybullet and pymunk) and the state is read
  at output points only. This is what ``engine s/step`` times.
* ``loop="harness"`` (:func:`drive`): one ``advance()`` per step, the state read and checked
  after every step: the path the harness always took, kept as the trajectories' witness and
  timed as ``as stepped by the harness``.

Both give the same trajectory bitwise (``tests/test_engine_loops.py``). A run whose engine
loop meets a diverged output state or an engine warning is run again from its start on the
per-step path, which stops it at the exact step (``EngineMode.simulate``).
"""

from __future__ import annotations

import numpy as np

from records import Trajectory
from records.trajectory import OK, UNSTABLE, RunMeta, divergence_detail, diverged, output_marks, step_loop
from scenarios import Scene

from ._model import Model


def drive(model: Model, scene: Scene, method: str, dt: float, steps: int, every: int = 1) -> Trajectory:
    """Step ``model`` ``steps`` times, recording as the reference driver records.

    A step whose state diverged (the reference driver's criterion, ``records.trajectory.diverged``)
    or where the engine reported a divergence, stops the
    run: status ``unstable`` with that step, the arrays ending at the last good recorded state.
    """
    now = list(model.state())  # (q, v) after the latest step
    rec_step, rec_q, rec_v = [], [], []

    def check(n: int) -> str:
        now[:] = model.state()
        trouble = model.trouble()
        if trouble is not None:
            return f"{trouble} at step {n} (t = {n * dt:g})"
        return divergence_detail(n, n * dt) if diverged(*now) else ""

    def record(n: int) -> None:
        rec_step.append(n)
        rec_q.append(now[0])
        rec_v.append(now[1])

    failed, detail = step_loop(lambda a, n: model.advance(), check, record, steps, every)
    traj = _trajectory(
        scene, method, dt, steps, every, rec_step, rec_q, rec_v, UNSTABLE if failed else OK, detail, failed
    )
    traj.meta.loop = "harness: one advance() per step, state read after each"
    return traj


def _trajectory(
    scene: Scene,
    method: str,
    dt: float,
    steps: int,
    every: int,
    rec_step,
    rec_q,
    rec_v,
    status: str = OK,
    detail: str = "",
    failed: int | None = None,
) -> Trajectory:
    q_arr = np.asarray(rec_q)[:, None, :]
    v_arr = np.asarray(rec_v)[:, None, :]
    step_arr = np.array(rec_step, dtype=np.int64)
    with np.errstate(all="ignore"):
        energy = scene.energy(q_arr, v_arr)
    return Trajectory(
        scene=scene.id,
        method=method,
        dt=dt,
        steps=steps,
        every=every,
        step=step_arr,
        t=step_arr * dt,
        q=q_arr,
        v=v_arr,
        energy=energy,
        status=status,
        detail=detail,
        failed_step=failed,
        meta=RunMeta(steps_run=(failed - 1) if failed else steps, params=dict(scene.values)),
    )


def run_engine_loop(
    model: Model, scene: Scene, method: str, dt: float, steps: int, every: int = 1
) -> Trajectory | None:
    """The run through the engine's own loop (``model.run``), recorded as :func:`drive` records;
    None where the engine reported trouble or an output state diverged (the caller replays the
    run with :func:`drive`, which finds the step). A state that diverges and comes back within
    one output interval would be missed: blow-ups do not come back, and MuJoCo warns at the step
    after any state beyond 1e10."""
    q, v = model.state()
    if diverged(q, v):
        return None
    marks = output_marks(steps, every)
    states, clean = model.run(marks)
    if not clean or len(states) != len(marks) - 1:
        return None
    rec = {0: (q, v), **{int(n): s for n, s in zip(marks[1:], states)}}
    rec_step, rec_q, rec_v = [], [], []

    def record(n):
        rec_step.append(n)
        rec_q.append(rec[n][0])
        rec_v.append(rec[n][1])

    # The engine's loop ran to the end; the rule reads its states at the marks and stops at the
    # first diverged one (then the caller replays the run step by step to find the step), unless
    # the model's run asked that of every mark already.
    def check(n):
        return divergence_detail(n, n * dt) if diverged(*rec[n]) else ""

    failed, _ = step_loop(
        lambda a, b: None, (lambda n: "") if model.run_checks_divergence else check, record, steps, every, spans=True
    )
    if failed:
        return None
    traj = _trajectory(scene, method, dt, steps, every, rec_step, np.array(rec_q), np.array(rec_v))
    traj.meta.loop = "engine: the engine's own loop between output points, state read at output points only"
    return traj
