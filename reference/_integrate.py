"""Interpreted driver: steps a scheme on a scene with every force evaluation counted.

This is the accuracy path (what ``harness run`` prints and what the measurements use);
``_compiled`` runs the same step functions compiled, for timing.
"""

from __future__ import annotations

import numpy as np

from records import Trajectory

from scenarios import Scene
from records.trajectory import OK, UNSTABLE, RunMeta, divergence_detail, diverged, step_loop


class Counted:
    """Wraps a kernel and counts its calls (as scipy's ``_ivp`` wraps ``fun`` for ``nfev``)."""

    def __init__(self, fn):
        self.fn = fn
        self.calls = 0

    def __call__(self, *args):
        self.calls += 1
        return self.fn(*args)


def _kernels(scene: Scene, accel=None, solve=None, project=None) -> dict:
    """The scene's kernels by name, for a kind to take its own (``Kind.advance``): the force,
    solve and projection as given (counted), the others as the scene has them."""
    return {
        "accel": accel or scene.accel,
        "solve": solve or scene.solve,
        "project": project or scene.project,
        "damping_rate": scene.damping_rate,
        "constraints": scene.constraints,
    }


def carried_map(scheme, scene: Scene, dt: float) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """``(M, c, names)``: one step of ``scheme`` on a linear ``scene`` as the affine map
    y_1 = M y_0 + c of the state it carries between steps (``Scheme.carries``: (q, v), or with
    the previous position or the last acceleration for the Verlet forms), measured by stepping
    the zero state and each unit state of that carried state. Its spectral radius is the
    recurrence's: a Verlet form restarted from (q, v) would evaluate its carried acceleration
    afresh, another map where the force depends on the velocity."""
    q0, v0 = scene.batch_state(1)
    q = np.ascontiguousarray(np.atleast_2d(q0).T, dtype=np.float64)
    v = np.ascontiguousarray(np.atleast_2d(v0).T, dtype=np.float64)
    p = scene.pvec
    template = scheme.start(scene.accel, q, v, 0.0, dt, p)
    shapes = [np.shape(a) for a in template]
    sizes = [int(np.prod(s)) for s in shapes]
    d = sum(sizes)
    advance = scheme.kind.advance(scheme, scene, dt, _kernels(scene))

    def run(y):
        parts = np.split(np.asarray(y, dtype=np.float64), np.cumsum(sizes)[:-1])
        state = tuple(np.ascontiguousarray(part.reshape(shape)) for part, shape in zip(parts, shapes))
        with np.errstate(all="ignore"):
            return np.concatenate([np.ravel(a) for a in advance(state, 0.0)])

    c = run(np.zeros(d))
    M = np.column_stack([run(e) - c for e in np.eye(d)])
    n = scene.ndof
    names = tuple(f"{name}[{i}]" if n > 1 else name for name in scheme.carries for i in range(n))
    return M, c, names


def integrate(
    scheme,
    scene: Scene,
    dt: float,
    steps: int,
    every: int = 1,
    q0: np.ndarray | None = None,
    v0: np.ndarray | None = None,
    t0: float = 0.0,
    iterations: int | None = None,
    substeps: int | None = None,
    solver=None,
) -> Trajectory:
    """Step ``scheme`` on ``scene`` for ``steps`` steps of ``dt``, recording every ``every`` steps
    (and always the last). ``q0``/``v0`` may be batched (API layout, (batch, ndof)).
    ``iterations``: projection passes per step of a constrained scheme (default: the scheme's);
    ``substeps``: the substeps a position-based scheme cuts each step into (default: the scheme's);
    ``solver``: a library solve an implicit scheme takes instead of the scene's kernel
    (``reference.solvers.Choice``), its iterations, unconverged solves and factorizations counted;
    a line-searched Newton iteration's counts in ``meta.settings``.

    A step whose state is not finite, or exceeds ``DIVERGED`` in magnitude, stops the run:
    status ``unstable`` with that step, the arrays ending at the last good recorded state.
    """
    if q0 is None or v0 is None:
        q0, v0 = scene.batch_state(1)
    q = np.ascontiguousarray(np.atleast_2d(q0).T, dtype=np.float64)
    v = np.ascontiguousarray(np.atleast_2d(v0).T, dtype=np.float64)
    p = scene.pvec
    meta = RunMeta(
        backend="interpreted", params=dict(scene.values), iterations=scheme.kind.run_iterations(scheme, iterations)
    )
    if solver is None:
        accel, solve, project = Counted(scene.accel), Counted(scene.solve), Counted(scene.project)
        advance = scheme.kind.advance(
            scheme, scene, dt, _kernels(scene, accel, solve, project), iterations, substeps=substeps
        )
    else:
        prepared = solver.prepare(scheme, scene, dt)
        accel, solve, project = Counted(prepared.accel), Counted(prepared.solve), Counted(scene.project)
        advance = prepared.advance(accel, solve)
        meta.linear_solver = prepared.text
    state = scheme.start(accel, q, v, t0, dt, p)
    start_evals = accel.calls
    accel.calls = 0
    rec_step, rec_q, rec_v = [], [], []

    def record(n, state):
        qo, vo = scheme.observe(accel, state, t0 + n * dt, dt, p)
        rec_step.append(n)
        rec_q.append(qo.T.copy())
        rec_v.append(vo.T.copy())

    def step(a, n):
        nonlocal state
        state = advance(state, t0 + a * dt)

    def check(n) -> str:
        return divergence_detail(n, t0 + n * dt) if diverged(state[0], state[1]) else ""

    with np.errstate(all="ignore"):
        failed, detail = step_loop(step, check, lambda n: record(n, state), steps, every)
    status = UNSTABLE if failed else OK
    meta.steps_run = (failed - 1) if failed else steps
    meta.start_force_evals = start_evals
    if "project" in scheme.kind.kernels:
        meta.projections = project.calls
    if solver is not None:
        meta.solver_iterations = prepared.iterations
        meta.unconverged_solves = prepared.unconverged
        meta.factorizations = prepared.factorizations
        if prepared.unconverged:  # an unconverged solve is said with the run, whatever its status
            short = f"{prepared.unconverged} of {solve.calls} solves stopped short of their tolerance ({prepared.text})"
            detail = f"{detail}; {short}" if detail else short
        # A line-searched Newton iteration's counts, and its unconverged steps said with the run.
        meta.settings = prepared.settings()
        short = prepared.shortfall()
        if short:
            detail = f"{detail}; {short}" if detail else short
    q_arr, v_arr = np.array(rec_q), np.array(rec_v)
    step_arr = np.array(rec_step, dtype=np.int64)
    with np.errstate(over="ignore", invalid="ignore"):  # the last states of a blow-up are finite but huge
        energy = scene.energy(q_arr, v_arr)
    return Trajectory(
        scene=scene.id,
        method=f"ref:{scheme.id}",
        dt=dt,
        steps=steps,
        every=every,
        step=step_arr,
        t=t0 + step_arr * dt,
        q=q_arr,
        v=v_arr,
        energy=energy,
        status=status,
        detail=detail,
        failed_step=failed,
        force_evals=accel.calls,
        solves=solve.calls,
        meta=meta,
    )
