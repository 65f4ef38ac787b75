"""The solves practitioners ship, as options of the implicit schemes' method ids:

    ref:implicit_euler?solver=direct
    ref:linearly_implicit_euler?solver=pcg_amg&tol=1e-3&maxiter=100
    ref:implicit_euler?solver=local_global&iterations=10

By default an implicit scheme's step calls its scene's ``solve`` kernel, compiled with the step
(the cloth: a banded LDL^T up to 600 unknowns, unpreconditioned conjugate gradients to a relative
residual of 1e-14 above). ``solver`` takes one of these instead, on a scene that gives its force and
its solve's matrix as whole-array numpy and scipy sparse (``Scene.sparse_form``: the cloth, the net):

* ``direct``: each system A x = r, A = I - alpha da/dv - beta da/dq, factored and solved by SuperLU
  (``scipy.sparse.linalg.splu``) with a minimum-degree ordering of A^T + A (fill-reducing) in its
  symmetric mode (diagonal pivots: A is symmetric, and indefinite where springs are compressed,
  which a Cholesky factorization refuses); exact to roundoff. Chosen over CHOLMOD (cholespy) and
  QDLDL by measurement (docs/findings.md).
* ``pcg_jacobi``, ``pcg_amg``: conjugate gradients from x = 0, preconditioned by the inverses of
  A's d x d diagonal blocks (block Jacobi, a point's coordinates a block) or by one V-cycle of
  smoothed-aggregation algebraic multigrid (pyamg, set up for each matrix, the d translations its
  near-null space); stopped where the residual is at most ``tol`` times the right-hand side's norm,
  or after ``maxiter`` iterations, or where p^T A p <= 0 (A not positive definite there). A solve
  that stops short of ``tol`` is counted (``RunMeta.unconverged_solves``), never hidden.
* ``local_global`` (backward Euler's step alone): Liu, Bargteil, O'Brien and Kavan, "Fast
  simulation of mass-spring systems" (SIGGRAPH Asia 2013). The step is the minimiser of
  g(x) = |x - y|_M^2 / (2 h^2) + sum_s k_s/2 (|x_b - x_a| - L_s)^2, y = x_n + h v_n + h^2 g, and
  with each spring's vector d_s (|d_s| = L_s) as an unknown of its own, ``iterations`` passes of

      local:  d_s = L_s (x_b - x_a) / |x_b - x_a|
      global: (M + h^2 L) x = M y + h^2 J d      (L the springs' Laplacian, the same for each coordinate)

  from x = y, then v_{n+1} = (x - x_n) / h. Each pass lowers g; where the passes converge, x is
  backward Euler's step (grad g = 0 is its equation). M + h^2 L does not change with the state:
  it is factored once per step size (SuperLU, as ``direct``) and each pass is one pair of
  triangular solves. Springs of finite stiffness only (a rigid link has no k to weigh it by).

Each runs in Python: the scheme's own step function (the one the compiled kernels run), the
scene's force and matrix in numpy, the solve in the library, which numba cannot compile. Counted
on every run: force evaluations and solves as for every scheme (``reference._integrate``), and
here the solver's iterations (conjugate-gradient iterations, local/global passes), its
unconverged solves and its factorizations. Timed (``step_timer``) on the same Python loop, which
its timing says (``LOOP``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from records import InvalidInput
from records.method_id import Option

#: The option that names the solve; its default, the scene's own compiled kernel.
SOLVER = "solver"
SCENE = "scene"
#: Conjugate gradients' defaults: an animation tolerance (relative residual) and an iteration cap.
TOL = 1e-3
MAXITER = 100
#: Local/global passes per step unless the method sets ``iterations``.
PASSES = 10
#: The most iterations an option takes (as ``harness.methods.MAX_ITERATIONS``).
MOST = 10**6

#: SuperLU's settings for a symmetric matrix: a minimum-degree ordering of A^T + A, and the
#: diagonal taken as the pivot (no row interchanges, which would break the symmetric ordering).
SUPERLU = {"permc_spec": "MMD_AT_PLUS_A", "diag_pivot_thresh": 0.0, "options": {"SymmetricMode": True}}

#: What a timing of these solves runs, for the cost cell to say beside its clock.
LOOP = (
    "interpreted: a Python loop over the scheme's step, the scene's force and matrix in numpy, "
    "{solve}; min of repeats after warm-up"
)


@dataclass(frozen=True)
class Solver:
    """One solve a method may choose: its name, what it is (``text``: the timing says it), the
    options it takes besides ``solver``, and the schemes it solves (None: every implicit scheme,
    whose step it gives a linear solve; else it replaces those schemes' whole step)."""

    name: str
    text: str
    takes: tuple[str, ...] = ()
    schemes: tuple[str, ...] | None = None


SOLVERS = {
    s.name: s
    for s in (
        Solver("direct", "SuperLU (scipy) factoring each system, minimum-degree ordering on A^T + A"),
        Solver("pcg_jacobi", "conjugate gradients (numpy) with a block-Jacobi preconditioner", ("tol", "maxiter")),
        Solver(
            "pcg_amg",
            "conjugate gradients (numpy) with a smoothed-aggregation multigrid V-cycle (pyamg)",
            ("tol", "maxiter"),
        ),
        Solver(
            "local_global",
            "Liu et al. 2013 local/global passes on one SuperLU factorization per step size",
            ("iterations",),
            schemes=("implicit_euler",),
        ),
    )
}

#: Every option a solve takes, declared once.
#: The tolerance and the passes are the solves' convergence knobs (``Option.tighten``): a verdict a
#: solve wins is checked again a hundred times tighter, or at ten times the passes
#: (``harness.methods.tightened``); the iteration cap stays, so a capped solve is checked as capped.
OPTIONS = {
    "tol": Option(
        "tol",
        float,
        1e-16,
        0.5,
        "conjugate gradients stop at this residual, relative to the right-hand side",
        default=TOL,
        tighten=0.01,
    ),
    "maxiter": Option(
        "maxiter", int, 1, MOST, "conjugate gradients stop after this many iterations (flagged)", default=MAXITER
    ),
    "iterations": Option("iterations", int, 1, MOST, "local/global passes per step", default=PASSES, tighten=10),
}


def solvers_for(scheme) -> tuple[str, ...]:
    """The solves ``scheme`` may take (empty where it makes no implicit solve)."""
    if not scheme.implicit:
        return ()
    return tuple(s.name for s in SOLVERS.values() if s.schemes is None or scheme.id in s.schemes)


def options_for(scheme) -> dict[str, Option]:
    """The options ``scheme`` takes for its solve: ``solver`` (its own kernel, ``scene``, or one of
    ``solvers_for``) and those its solves take."""
    names = solvers_for(scheme)
    if not names:
        return {}
    takes = {o for name in names for o in SOLVERS[name].takes}
    return {
        SOLVER: Option(
            SOLVER, str, doc="the implicit solve: the scene's own kernel, or a library's", choices=(SCENE, *names)
        ),
        **{name: option for name, option in OPTIONS.items() if name in takes},
    }


@dataclass(frozen=True)
class Choice:
    """A solve chosen with its settings (:func:`choice`)."""

    solver: Solver
    tol: float = TOL
    maxiter: int = MAXITER
    iterations: int = PASSES

    @property
    def text(self) -> str:
        """What it is, with its settings: what a timing and a run record say."""
        settings = {
            "tol": f"tol {self.tol:g}",
            "maxiter": f"at most {self.maxiter} iterations",
            "iterations": f"{self.iterations} passes a step",
        }
        return "; ".join([self.solver.text] + [settings[o] for o in self.solver.takes])

    def supports(self, scene) -> str:
        """Why this solve does not run on ``scene`` ("" where it does)."""
        if self.solver.name == "local_global":
            why = scene.position_based_why()
            if why:
                return why.replace("a position-based scheme", "local/global passes")
            compliance = scene.constraints(scene.pvec)[2]
            if np.any(compliance == 0.0):
                return (
                    f"scene {scene.id} holds rigid links (compliance 0): local/global passes weigh each "
                    "spring by its stiffness, which a rigid link does not have"
                )
            return ""
        if scene.sparse_form() is None:
            return (
                f"scene {scene.id} gives no sparse form of its force and solve (Scene.sparse_form) for "
                f"solver={self.solver.name}"
            )
        return ""

    def prepare(self, scheme, scene, dt: float) -> Prepared:
        """The pieces of a run of ``scheme`` on ``scene`` at ``dt`` with this solve."""
        if self.solver.name == "local_global":
            return _LocalGlobal(scene, dt, self.iterations, self.text)
        return _Linear(scheme, scene, dt, self, self.text)


def choice(scheme, options: dict) -> Choice | None:
    """The solve ``options`` choose for ``scheme`` (None: the scene's own kernel), the options
    checked together (each alone is checked by its ``Option``): an option of a solve is refused
    with another solve."""
    names = options_for(scheme)
    if not names:
        return None
    name = str(options.get(SOLVER, SCENE))
    given = [o for o in OPTIONS if o in options]
    solver = SOLVERS.get(name)
    takes = solver.takes if solver is not None else ()
    stray = [o for o in given if o not in takes]
    if stray:
        which = [s.name for s in SOLVERS.values() if stray[0] in s.takes and s.name in names[SOLVER].choices]
        raise InvalidInput(
            f"method ref:{scheme.id}: option {stray[0]} applies with solver={' or '.join(which)} (solver is {name})"
        )
    if solver is None:
        return None
    return Choice(solver, **{o: options[o] for o in given})


def split(scheme, options: dict) -> tuple[Choice | None, dict]:
    """(the solve chosen, the other options: those the kernels take)."""
    mine = options_for(scheme)
    return choice(scheme, options), {k: v for k, v in options.items() if k not in mine}


# ----------------------------------------------------------------------------- the runs
class Prepared:
    """A run's pieces: ``accel`` and ``solve`` (to be wrapped and counted by the driver),
    ``advance(accel, solve)`` the step as a function of the state and the time, and the solve's
    own counts."""

    text: str

    def __init__(self):
        self.iterations = 0
        self.unconverged = 0
        self.factorizations = 0

    def advance(self, accel, solve):
        raise NotImplementedError


class _Linear(Prepared):
    """An implicit scheme's own step with a library's linear solve in place of the scene's kernel."""

    def __init__(self, scheme, scene, dt, chosen: Choice, text: str):
        super().__init__()
        self.scheme, self.scene, self.dt, self.chosen, self.text = scheme, scene, dt, chosen, text
        self.form = scene.sparse_form()
        self.accel = self.form.accel
        self.one = {"direct": self._direct, "pcg_jacobi": self._pcg, "pcg_amg": self._pcg}[chosen.solver.name]

    def advance(self, accel, solve):
        kernels = {"accel": accel, "solve": solve}
        return self.scheme.kind.advance(self.scheme, self.scene, self.dt, kernels)

    def solve(self, q, v, t, p, alpha, beta, r):
        """(I - alpha da/dv - beta da/dq) x = r, batch member by batch member (the scene's
        ``solve`` kernel's contract)."""
        out = np.empty_like(r)
        for col in range(r.shape[1]):
            matrix = self.form.matrix(q[:, col], v[:, col], t, alpha, beta)
            out[:, col] = self.one(matrix, np.ascontiguousarray(r[:, col]))
        return out

    def _failed(self, size: int) -> np.ndarray:
        """A solve the library could not make (a singular or non-finite matrix): counted, and not
        a number, so that the run stops there as diverged."""
        self.unconverged += 1
        return np.full(size, np.nan)

    def _direct(self, matrix, r):
        from scipy.sparse.linalg import splu

        if not np.all(np.isfinite(matrix.data)):
            return self._failed(len(r))
        try:
            lu = splu(matrix.tocsc(), **SUPERLU)
        except RuntimeError:  # SuperLU: "Factor is exactly singular"
            return self._failed(len(r))
        self.factorizations += 1
        return lu.solve(r)

    def _preconditioner(self, matrix):
        d = self.form.block
        if self.chosen.solver.name == "pcg_jacobi":
            return _block_jacobi(matrix, d)
        import pyamg

        points = matrix.shape[0] // d
        translations = np.kron(np.ones((points, 1)), np.eye(d))
        hierarchy = pyamg.smoothed_aggregation_solver(matrix.tobsr((d, d)), B=translations, symmetry="symmetric")
        cycle = hierarchy.aspreconditioner(cycle="V")
        return lambda r: cycle @ r

    def _pcg(self, matrix, r):
        if not np.all(np.isfinite(matrix.data)) or not np.all(np.isfinite(r)):
            return self._failed(len(r))
        try:
            precondition = self._preconditioner(matrix)
        except (ValueError, np.linalg.LinAlgError):  # a singular diagonal block, a hierarchy that cannot be built
            return self._failed(len(r))
        x, iterations, converged = pcg(matrix, r, precondition, self.chosen.tol, self.chosen.maxiter)
        self.iterations += iterations
        self.unconverged += not converged
        return x


def _block_jacobi(matrix, d: int):
    """z = D^-1 r, D the d x d blocks on the diagonal of ``matrix`` (a point's coordinates)."""
    blocks = matrix.tobsr((d, d))
    rows = np.repeat(np.arange(blocks.shape[0] // d), np.diff(blocks.indptr))
    inverse = np.linalg.inv(blocks.data[blocks.indices == rows])
    return lambda r: np.einsum("nij,nj->ni", inverse, r.reshape(-1, d)).ravel()


def pcg(matrix, b, precondition, tol: float, maxiter: int) -> tuple[np.ndarray, int, bool]:
    """Preconditioned conjugate gradients on matrix x = b from x = 0: (x, iterations, converged),
    converged where |r| <= tol |b| within ``maxiter`` iterations (False where p^T A p <= 0: the
    matrix is not positive definite along p, and the iteration stops there)."""
    x = np.zeros_like(b)
    r = b.copy()
    stop = tol * math.sqrt(float(b @ b))
    if stop == 0.0:
        return x, 0, True
    z = precondition(r)
    p = z.copy()
    rz = float(r @ z)
    for it in range(1, maxiter + 1):
        ap = matrix @ p
        curvature = float(p @ ap)
        if not curvature > 0.0:
            return x, it, False
        step = rz / curvature
        x += step * p
        r -= step * ap
        if math.sqrt(float(r @ r)) <= stop:
            return x, it, True
        z = precondition(r)
        rz_new = float(r @ z)
        p = z + (rz_new / rz) * p
        rz = rz_new
    return x, maxiter, False


class _LocalGlobal(Prepared):
    """Liu et al.'s step (module docstring) from the scene's springs as distance constraints
    (``Scene.constraints``: end points, rest lengths, compliance 1/k, masses, anchors, gravity)."""

    def __init__(self, scene, dt: float, iterations: int, text: str):
        from scipy.sparse import coo_matrix
        from scipy.sparse.linalg import splu

        super().__init__()
        self.text, self.h, self.passes = text, float(dt), int(iterations)
        ends, rest, compliance, inv_mass, anchors, gravity = scene.constraints(scene.pvec)
        self.d = anchors.shape[1]
        self.points = len(inv_mass)
        self.rest, self.k = rest, 1.0 / compliance
        self.mass = 1.0 / inv_mass
        self.gravity = gravity
        a, b = ends[:, 0], ends[:, 1]
        self.a_free, self.b_free = np.flatnonzero(a >= 0), np.flatnonzero(b >= 0)
        self.a, self.b = a, b
        # Where an end is an anchor, its position in every pass (the anchors do not move).
        self.x_anchor = np.zeros((len(rest), 2, self.d))
        self.x_anchor[a < 0, 0] = anchors[-1 - a[a < 0]]
        self.x_anchor[b < 0, 1] = anchors[-1 - b[b < 0]]
        # M + h^2 L: k on the diagonal at each free end, -k between two free ends.
        both = np.flatnonzero((a >= 0) & (b >= 0))
        h2 = self.h * self.h
        rows = np.concatenate([np.arange(self.points), a[self.a_free], b[self.b_free], a[both], b[both]])
        cols = np.concatenate([np.arange(self.points), a[self.a_free], b[self.b_free], b[both], a[both]])
        vals = np.concatenate(
            [self.mass, h2 * self.k[self.a_free], h2 * self.k[self.b_free], -h2 * self.k[both], -h2 * self.k[both]]
        )
        system = coo_matrix((vals, (rows, cols)), shape=(self.points, self.points)).tocsc()
        self.lu = splu(system, **SUPERLU)
        self.factorizations = 1
        # The anchors' share of the right-hand side, h^2 k x_anchor at the free end, every pass alike.
        self.anchored = np.zeros((self.points, self.d))
        for free, other, end in ((a, b, 1), (b, a, 0)):
            held = np.flatnonzero((free >= 0) & (other < 0))
            np.add.at(self.anchored, free[held], h2 * self.k[held, None] * self.x_anchor[held, end])
        self.accel = _no_force
        self.solve = self.lu.solve

    def advance(self, accel, solve):
        h, d = self.h, self.d

        def step(state, t):
            q, v = state
            q_new = np.empty_like(q)
            for col in range(q.shape[1]):
                x0 = q[:, col].reshape(self.points, d)
                y = x0 + h * v[:, col].reshape(self.points, d) + (h * h) * self.gravity
                x = y.copy()
                inertia = self.mass[:, None] * y + self.anchored
                for _ in range(self.passes):
                    x = solve(inertia + (h * h) * self._pulls(x))
                    self.iterations += 1
                q_new[:, col] = x.ravel()
            return (q_new, (q_new - q) / h)

        return step

    def _pulls(self, x):
        """J d: each spring's k d_s at its free ends (+ at b, - at a), d_s its rest length along
        the spring as the positions x have it (the local step)."""
        ends = self.x_anchor.copy()
        ends[self.a_free, 0] = x[self.a[self.a_free]]
        ends[self.b_free, 1] = x[self.b[self.b_free]]
        span = ends[:, 1] - ends[:, 0]
        if self.d == 1:  # the 1-D spring: C = x_b - x_a - L, signed, so d_s = L
            pull = (self.k * self.rest)[:, None] * np.ones_like(span)
        else:
            length = np.sqrt(np.sum(span * span, axis=1))
            pull = (self.k * self.rest / length)[:, None] * span
        out = np.zeros((self.points, self.d))
        for c in range(self.d):
            out[:, c] = np.bincount(self.b[self.b_free], pull[self.b_free, c], minlength=self.points) - np.bincount(
                self.a[self.a_free], pull[self.a_free, c], minlength=self.points
            )
        return out


def _no_force(q, v, t, p):  # pragma: no cover - local/global passes evaluate no force
    raise AssertionError("local/global passes evaluate no force")


# ----------------------------------------------------------------------------- timing
def step_timer(chosen: Choice, scheme, scene, dt: float, steps: int, clock: str = "wall"):
    """``(warm-up seconds, once, what is timed)``: the Python loop of the chosen solve's run,
    called once on 2 steps (imports, a first factorization), then ``once(n=steps)`` timing n
    steps from the scene's initial state on ``clock``, in seconds per step."""
    from ._compiled import CLOCKS

    now = CLOCKS[clock]
    q0, v0 = scene.batch_state(1)
    q = np.ascontiguousarray(np.atleast_2d(q0).T, dtype=np.float64)
    v = np.ascontiguousarray(np.atleast_2d(v0).T, dtype=np.float64)
    h = float(dt)

    def run(n: int) -> None:
        prepared = chosen.prepare(scheme, scene, h)  # a factorization a step size keeps is part of the run
        advance = prepared.advance(prepared.accel, prepared.solve)
        state = scheme.start(prepared.accel, q, v, 0.0, h, scene.pvec)
        with np.errstate(all="ignore"):
            for i in range(n):
                state = advance(state, i * h)

    t = now()
    run(2)
    warmup = now() - t

    def once(n: int = steps) -> float:
        t = now()
        run(int(n))
        return (now() - t) / n

    return warmup, once, LOOP.format(solve=chosen.text)
