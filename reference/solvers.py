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

``line_search=armijo`` (``ref:implicit_euler`` alone) runs backward Euler's Newton iteration with an
Armijo backtracking line search on the step's incremental potential (``reference.schemes.
implicit_euler``: why it is an option and not the default, what it counts), with the scene's own
solve (its compiled kernels, where they compute the interpreted bits) or ``direct``, ``pcg_jacobi``,
``pcg_amg`` (local/global passes are an iteration of their own). ``hessian=projected`` (with a library
solve, on a scene of springs) solves each Newton system with every spring's block projected to be
positive semi-definite: its eigenvalue across the spring, k (1 - L/|d|), negative where the spring is
compressed, clamped to 0 (Teran et al. 2005's per-element projection, exact for a spring). The
projected matrix differs from the Newton matrix only where a spring is compressed; elsewhere it is
that matrix, to the bit. On the 16 x 16 sheet at k = 1e6 and one substep both reach the same steps
(an energy error of 0.295 over 2 s), the exact Hessian in 1133 Newton iterations, the projected one
in 1693: near the root a clamped Hessian is not the equation's Jacobian, and Newton's quadratic
convergence is lost. ``ref:implicit_euler`` itself stays the full-step Newton (``line_search=none``);
with a library solve it runs counted (its iterations and unconverged steps in ``meta.settings``).

Each runs in Python: the scheme's own step function (the one the compiled kernels run), the
scene's force and matrix in numpy, the solve in the library, which numba cannot compile. Counted
on every run: force evaluations and solves as for every scheme (``reference._integrate``), and
here the solver's iterations (conjugate-gradient iterations, local/global passes), its
unconverged solves and its factorizations. Timed (``step_timer``) on the same Python loop, which
its timing says (``LOOP``).
"""

from __future__ import annotations

import math
import sys
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
#: ... and of a line search on the scene's own kernels.
SCENE_LOOP = (
    "interpreted: a Python loop over the scheme's step, the scene's force and solve kernels compiled where they "
    "compute the interpreted bits, {solve}; min of repeats after warm-up"
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

#: Backward Euler's Newton iteration: a line search (``reference.schemes.implicit_euler``) and the
#: Hessian its updates solve with. Options of the schemes ``LINE_SEARCH`` names, with any solve but
#: local/global passes (their own iteration).
LINE_SEARCH = ("implicit_euler",)
NEWTON_OPTIONS = {
    "line_search": Option(
        "line_search",
        str,
        doc="backward Euler's Newton updates: none (full steps), armijo (backtracking on the step's objective)",
        default="none",
        choices=("none", "armijo"),
    ),
    "hessian": Option(
        "hessian",
        str,
        doc="the Newton systems' matrix: exact, or projected (each spring's negative eigenvalue clamped to 0)",
        default="exact",
        choices=("exact", "projected"),
    ),
}

#: The scene's own solve kernel, as a line-searched run names it.
SCENE_SOLVE = Solver(SCENE, "the scene's own solve kernel")


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
        **(NEWTON_OPTIONS if scheme.id in LINE_SEARCH else {}),
    }


@dataclass(frozen=True)
class Choice:
    """A solve chosen with its settings (:func:`choice`)."""

    solver: Solver
    tol: float = TOL
    maxiter: int = MAXITER
    iterations: int = PASSES
    line_search: str = "none"
    hessian: str = "exact"

    @property
    def text(self) -> str:
        """What it is, with its settings: what a timing and a run record say."""
        settings = {
            "tol": f"tol {self.tol:g}",
            "maxiter": f"at most {self.maxiter} iterations",
            "iterations": f"{self.iterations} passes a step",
        }
        newton = []
        if self.line_search == "armijo":
            projected = " (each spring's block projected positive semi-definite)" if self.hessian == "projected" else ""
            newton = [f"Newton{projected} with an Armijo backtracking line search"]
        return "; ".join([self.solver.text] + [settings[o] for o in self.solver.takes] + newton)

    def supports(self, scene) -> str:
        """Why this solve does not run on ``scene`` ("" where it does)."""
        if self.hessian == "projected":
            why = _projection_why(scene)
            if why:
                return why
        if self.solver is SCENE_SOLVE:
            return ""
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
        if self.line_search != "none":
            return _LineSearch(scheme, scene, dt, self)
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
    line_search = str(options.get("line_search", "none"))
    hessian = str(options.get("hessian", "exact"))
    if hessian == "projected" and line_search == "none":
        raise InvalidInput(f"method ref:{scheme.id}: option hessian=projected applies with line_search=armijo")
    if line_search != "none" and solver is not None and solver.schemes is not None:
        raise InvalidInput(
            f"method ref:{scheme.id}: option line_search applies to a Newton iteration, and solver={name} is its "
            "own iteration (not Newton's)"
        )
    if hessian == "projected" and solver is None:
        raise InvalidInput(
            f"method ref:{scheme.id}: option hessian=projected applies with a library solve (solver=direct, "
            "pcg_jacobi or pcg_amg): the scene's own solve kernel builds its own matrix, which the step cannot project"
        )
    if line_search != "none":
        return Choice(solver or SCENE_SOLVE, line_search=line_search, hessian=hessian, **{o: options[o] for o in given})
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

    def settings(self) -> dict | None:
        """What the run's ``meta.settings`` carries of it (None: nothing)."""
        return None

    def shortfall(self) -> str:
        """What the run says of steps it could not converge ("" where none)."""
        return ""


class _Linear(Prepared):
    """An implicit scheme's own step with a library's linear solve in place of the scene's kernel.
    Backward Euler's full-step Newton (``LINE_SEARCH``) runs as ``newton_line_search`` without a
    line search, the same operations, counted: its iterations and its unconverged steps (one
    batch member at a time; a batch runs the scheme's step, uncounted)."""

    def __init__(self, scheme, scene, dt, chosen: Choice, text: str):
        from .schemes.implicit_euler import NewtonCounts

        super().__init__()
        self.scheme, self.scene, self.dt, self.chosen, self.text = scheme, scene, dt, chosen, text
        self.form = scene.sparse_form()
        self.accel = self.form.accel
        self.one = {"direct": self._direct, "pcg_jacobi": self._pcg, "pcg_amg": self._pcg}[chosen.solver.name]
        self.projection = SpringProjection(scene) if chosen.hessian == "projected" else None
        #: Systems whose matrix the projection changed (a spring compressed).
        self.projected = 0
        self.newton = NewtonCounts() if scheme.id in LINE_SEARCH else None
        self.newton_max = scheme.kind.count(scheme, scene)

    def advance(self, accel, solve):
        from .schemes.implicit_euler import newton_line_search

        kernels = {"accel": accel, "solve": solve}
        step = self.scheme.kind.advance(self.scheme, self.scene, self.dt, kernels)
        if self.newton is None:
            return step
        h, p, cap, counts = float(self.dt), self.scene.pvec, self.newton_max, self.newton

        def counted(state, t):
            if state[0].shape[1] != 1:
                return step(state, t)
            return newton_line_search(accel, solve, cap, state, t, h, p, None, counts)

        return counted

    def settings(self) -> dict | None:
        if self.newton is None or not self.newton.steps:
            return None
        return {
            "line_search": "none",
            "newton_max": self.newton_max,
            **{
                f"newton_{k}": v
                for k, v in self.newton.as_dict().items()
                if k not in ("backtracks", "not_descent", "objective_evals")
            },
        }

    def shortfall(self) -> str:
        return _unconverged(self.newton, self.newton_max)

    def solve(self, q, v, t, p, alpha, beta, r):
        """(I - alpha da/dv - beta da/dq) x = r, batch member by batch member (the scene's
        ``solve`` kernel's contract)."""
        out = np.empty_like(r)
        for col in range(r.shape[1]):
            matrix = self.form.matrix(q[:, col], v[:, col], t, alpha, beta)
            if self.projection is not None:
                clamp = self.projection.correction(q[:, col], beta)
                if clamp is not None:
                    matrix = matrix + clamp
                    self.projected += 1
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


class SpringProjection:
    """Each spring's block of the Newton matrix projected to be positive semi-definite: a spring's
    stiffness block k [(1 - L/l) I + (L/l) u u^T] (l = |d|, u = d/l) has the eigenvalue k along u
    and k (1 - L/l) across it, negative where the spring is compressed (l < L); the projection
    clamps that one to 0, adding k (L/l - 1)(I - u u^T) to the spring's four blocks (+ on its two
    ends' diagonal blocks, - between them), times beta M^-1 as the matrix I + beta M^-1 K has it.
    The springs are the scene's distance constraints (``Scene.constraints``: the springs its force
    sums, in a 1-D scene linear, so never clamped)."""

    def __init__(self, scene):
        ends, rest, compliance, inv_mass, anchors, _ = scene.constraints(scene.pvec)
        self.d, self.size = anchors.shape[1], scene.ndof
        self.a, self.b, self.rest, self.k = ends[:, 0], ends[:, 1], rest, 1.0 / compliance
        self.anchors = anchors
        self.row_scale = np.repeat(inv_mass, self.d)

    def _ends(self, x, e):
        out = np.empty((len(e), self.d))
        free = e >= 0
        out[free] = x[e[free]]
        out[~free] = self.anchors[-1 - e[~free]]
        return out

    def correction(self, q, beta):
        """The projection's change to I + beta M^-1 K at positions q (ndof,), CSR; None where no
        spring is compressed (the matrix is left as it is)."""
        if self.d == 1:
            return None
        x = q.reshape(-1, self.d)
        span = self._ends(x, self.b) - self._ends(x, self.a)
        length = np.sqrt(np.sum(span * span, axis=1))
        short = np.flatnonzero(length < self.rest)
        if len(short) == 0:
            return None
        from scipy.sparse import coo_matrix

        u = span[short] / length[short, None]
        lift = self.k[short] * (self.rest[short] / length[short] - 1.0)
        blocks = lift[:, None, None] * (np.eye(self.d)[None] - u[:, :, None] * u[:, None, :])
        c = np.arange(self.d)
        rows, cols, vals = [], [], []
        for r_end, c_end, sign in (
            (self.a, self.a, 1.0),
            (self.b, self.b, 1.0),
            (self.a, self.b, -1.0),
            (self.b, self.a, -1.0),
        ):
            fr, fc = r_end[short], c_end[short]
            keep = np.flatnonzero((fr >= 0) & (fc >= 0))
            shape = (len(keep), self.d, self.d)
            rows.append(np.broadcast_to(fr[keep, None, None] * self.d + c[None, :, None], shape).ravel())
            cols.append(np.broadcast_to(fc[keep, None, None] * self.d + c[None, None, :], shape).ravel())
            vals.append(sign * blocks[keep].ravel())
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        vals = np.concatenate(vals) * (beta * self.row_scale[rows])
        return coo_matrix((vals, (rows, cols)), shape=(self.size, self.size)).tocsr()


def _projection_why(scene) -> str:
    """Why ``hessian=projected`` does not run on ``scene`` ("" where it does)."""
    if scene.position_based_why():
        return f"scene {scene.id} gives no springs (Scene.constraints) whose blocks hessian=projected could clamp"
    if np.any(scene.constraints(scene.pvec)[2] == 0.0):
        return (
            f"scene {scene.id} holds rigid links (compliance 0): hessian=projected clamps springs of finite stiffness"
        )
    if not scene.conservative:
        return (
            f"scene {scene.id}'s force has no potential (it depends on the velocity): the projected Hessian is the "
            "step's incremental potential's, which it has not"
        )
    return ""


# ----------------------------------------------------------------------------- the line search
#: How closely the scene's energy must give its mass matrix and its force's potential for the line
#: search to take it as the step's objective (relative: a check of the scene, not of roundoff).
POTENTIAL_RTOL = 1e-6


def objective_for(scene):
    """(the line search's objective on ``scene``, why it is not the incremental potential: "" where
    it is). The incremental potential needs the force to have a potential and the kinetic energy to
    be 1/2 v^T M v with M constant and diagonal (``reference.schemes.implicit_euler``); both are read
    from the scene's ``energy`` at its initial state and checked against its ``accel`` there, along
    one fixed direction; the force must not change with the velocity there. Else the residual's norm."""
    from .schemes.implicit_euler import IncrementalPotential, ResidualNorm

    moving = f"scene {scene.id}'s force depends on the velocity: it has no potential"
    if not scene.conservative or scene.velocity_dependent:
        return ResidualNorm(), moving
    q0, v0 = scene.initial_state()
    q0 = np.asarray(q0, dtype=float)
    n = len(q0)
    u = np.sin(np.arange(1, n + 1) * 1.7)  # one fixed direction, every coordinate in it
    still = scene.accel(q0[:, None], np.zeros((n, 1)), 0.0, scene.pvec)
    if not np.array_equal(scene.accel(q0[:, None], u[:, None], 0.0, scene.pvec), still):
        return ResidualNorm(), moving  # whatever the scene declares
    at_rest = float(scene.energy(q0, np.zeros(n)))
    # 1/2 M_ii c^2 from a velocity c e_i, c large enough that the potential's bits do not blur it.
    c = 1e4 * (1.0 + math.sqrt(abs(at_rest)))
    mass = np.empty(n)
    for lo in range(0, n, 256):
        rows = np.eye(n)[lo : lo + 256] * c
        mass[lo : lo + len(rows)] = 2.0 * (scene.energy(np.tile(q0, (len(rows), 1)), rows) - at_rest) / (c * c)
    kinetic = float(scene.energy(q0, c * u)) - at_rest
    if not (np.all(mass > 0.0) and math.isclose(kinetic, 0.5 * c * c * float(np.sum(mass * u * u)), rel_tol=1e-9)):
        return ResidualNorm(), f"scene {scene.id}'s kinetic energy is not 1/2 v^T M v with a diagonal M"
    # The potential's change from q0 - eps u to q0 + eps u against the force's work over that segment
    # (Simpson's rule: exact to the fifth power of eps, so a stiff spring's curvature does not blur it).
    eps = 1e-5 * (1.0 + float(np.max(np.abs(q0))))
    ends = [float(scene.energy(q0 + s * eps * u, np.zeros(n))) for s in (-1.0, 1.0)]
    pulls = [
        float(np.dot(mass * scene.accel((q0 + s * eps * u)[:, None], np.zeros((n, 1)), 0.0, scene.pvec)[:, 0], u))
        for s in (-1.0, 0.0, 1.0)
    ]
    change, work = ends[1] - ends[0], -(2.0 * eps / 6.0) * (pulls[0] + 4.0 * pulls[1] + pulls[2])
    slack = POTENTIAL_RTOL * abs(work) + 1e3 * np.finfo(float).eps * (abs(ends[0]) + abs(ends[1]))
    if not abs(change - work) <= slack:
        return ResidualNorm(), f"scene {scene.id}'s energy is not its force's potential"
    return IncrementalPotential(scene.energy, mass), ""


def scene_kernels(scheme, scene):
    """(accel, solve): the scene's kernels compiled (its pair's kernel file), where the pair's
    compiled loop computes the interpreted bits (``reference.bitwise_why``), else as written."""
    from ._compiled import _nstate, bitwise_why, compiled_as
    from . import _kernels

    if bitwise_why(scheme, scene):
        return scene.accel, scene.solve
    loop = compiled_as(scheme, type(scene))
    kernels = _kernels.load(loop, type(scene), _nstate(loop, scene))
    if kernels.path is None:
        return scene.accel, scene.solve
    module = sys.modules[f"_harness_kernels.{kernels.path.stem}"]
    return module.scene_accel, module.scene_solve


class _LineSearch(Prepared):
    """Backward Euler's Newton iteration with an Armijo line search
    (``reference.schemes.implicit_euler.newton_line_search``) on a linear solve: the scene's own
    kernel, or a library's (``_Linear``, its Hessian projected where ``hessian=projected``)."""

    def __init__(self, scheme, scene, dt, chosen: Choice):
        from .schemes.implicit_euler import NewtonCounts

        self.scheme, self.scene, self.h, self.chosen = scheme, scene, float(dt), chosen
        text = chosen.text
        if chosen.solver is SCENE_SOLVE:
            self.linear = None
            self.accel, self.solve = scene_kernels(scheme, scene)
            text = text.replace(SCENE_SOLVE.text, scene.solve_text, 1)
        else:
            self.linear = _Linear(scheme, scene, dt, chosen, chosen.text)
            self.accel, self.solve = self.linear.accel, self.linear.solve
        self.objective, self.why = objective_for(scene)
        self.newton_max = scheme.kind.count(scheme, scene)
        self.counts = NewtonCounts()
        self.text = f"{text} on {self.objective.name}"

    # The linear solve's own counts (none where it is the scene's kernel).
    iterations = property(lambda self: self.linear.iterations if self.linear else 0)
    unconverged = property(lambda self: self.linear.unconverged if self.linear else 0)
    factorizations = property(lambda self: self.linear.factorizations if self.linear else 0)

    def advance(self, accel, solve):
        from .schemes.implicit_euler import newton_line_search

        h, p, cap, objective, counts = self.h, self.scene.pvec, self.newton_max, self.objective, self.counts
        return lambda state, t: newton_line_search(accel, solve, cap, state, t, h, p, objective, counts)

    def settings(self) -> dict:
        out = {
            "line_search": self.chosen.line_search,
            "hessian": self.chosen.hessian,
            "objective": self.objective.name,
            "newton_max": self.newton_max,
            **{f"newton_{k}": v for k, v in self.counts.as_dict().items()},
        }
        if self.why:
            out["objective_why"] = self.why
        if self.linear is not None and self.linear.projection is not None:
            out["projected_systems"] = self.linear.projected
        return out

    def shortfall(self) -> str:
        return _unconverged(self.counts, self.newton_max, searched=True)


def _unconverged(counts, cap: int, searched: bool = False) -> str:
    """A run's unconverged Newton steps, in words ("" where none)."""
    if counts is None or not counts.failures:
        return ""
    why = f"the cap of {cap} iterations reached" + (
        ", or no step of the line search decreased its objective" if searched else ""
    )
    return f"{counts.failures} of {counts.steps} steps ended their Newton iteration unconverged ({why})"


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

    if chosen.solver is SCENE_SOLVE:
        return warmup, once, SCENE_LOOP.format(solve=chosen.text)
    return warmup, once, LOOP.format(solve=chosen.text)
