"""Implicit (backward) Euler, and its Newton iteration with a line search.

The scheme's step (``implicit_euler``, what the compiled kernels copy) solves backward Euler's
equation by Newton from the old velocity, taking each full Newton update. On a stiff nonlinear
scene that iteration can fail: on the 16 x 16 cloth sheet (node mass 1/64) at k = 1e6 and one
substep (h = 1/60) 18 of its 120 steps, from step 102 on, reach the iteration cap unconverged, and
the run's energy error reaches 1.7e8 over 2 s. With the line search below every step converges and
the error is 0.295 (1133 Newton iterations, 89 backtracks; tests/test_newton_line_search.py).

``newton_line_search`` is the same iteration with a backtracking line search, as cloth codes that
ship backward Euler run it (Baraff and Witkin, SIGGRAPH 1998, took one Newton step; projected
Newton codes line-search each one). Backward Euler's step minimises its incremental potential

    E(x) = 1/(2 h^2) |x - x_pred|_M^2 + U(x),      x_pred = x_n + h v_n + h^2 M^-1 f_ext,

(U the springs' and gravity's potential), which in the step's unknown w = v_{n+1}, x = x_n + h w,
is Phi(w) = 1/2 |w - v_n|_M^2 + U(x_n + h w) = energy(x_n + h w, w - v_n): the scene's own energy
at the new position with the velocity change as its velocity. Its gradient is -M r, r = v_n +
h a(x_n + h w) - w the step's residual, so the Newton update dw of the step solves grad Phi = 0,
and Phi descends along it wherever -r^T M dw < 0. Each update is taken as w + alpha dw with
alpha = 1, 1/2, 1/4, ... the first that meets Armijo's sufficient decrease

    Phi(w + alpha dw) <= Phi(w) + c1 alpha grad Phi . dw,      c1 = 1e-4

(Nocedal and Wright, "Numerical Optimization", 2nd ed., 2006, Algorithm 3.1, and the c1 they
suggest), with the objective's roundoff allowed (``OBJECTIVE_ROUNDOFF``: near the root an update
lowers Phi far below its last bit). Where the update does not descend (the Newton matrix
indefinite along it), the iteration takes the residual r instead, the steepest descent of Phi in
the metric M (counted). ``reference.solvers`` may give the update from the projected Hessian
instead (``hessian=projected``: each spring's block with its negative eigenvalues clamped to 0,
Teran, Sifakis, Irving and Fedkiw, SCA 2005, "projected Newton"), whose update always descends.

Where the scene's force has no potential (a velocity-dependent force: damping, drag) there is no
Phi, and the line search takes the residual's norm as its merit function instead:
|r(w + alpha dw)| <= (1 - c1 alpha) |r(w)|, along which an exact Newton update always descends
(Dennis and Schnabel, "Numerical Methods for Unconstrained Optimization and Nonlinear Equations",
1983, section 6.3). Each trial then costs a force evaluation (the accepted one's residual is the
next iteration's). The damped cloth's Newton matrix is not the residual's exact derivative (it
leaves the dashpots' dependence on the positions out, ``scenarios.cloth``): its update need not
descend, and on a stiff damped sheet some steps' searches find no decrease while their residual is
far from roundoff. Those steps are counted as failures and said with the run, and the advice does
not count a row whose steps did not converge as met on its own terms (it is marked as resting on
its solve). A search that finds no decrease with the residual at its roundoff (``STALL_RTOL``) has
stalled at the root: converged, counted apart (``stalls``).

**Option, not default.** The line search is ``ref:implicit_euler?line_search=armijo``
(``reference.solvers``): ``ref:implicit_euler`` stays the full-step Newton, compiled with every
scene's kernels and bit for bit what every existing verdict measured. A line-searched step reads
the scene's energy, which scenes give in numpy and not as a compiled kernel, so it runs in Python
(the scene's force and solve compiled where they compute the interpreted bits). Where every full
update is accepted it computes the full-step Newton's bits: the update is taken as w + dw, the
stopping test is the same, and the test is made before the line search (a converged update is
never searched). The seed's cloth verdicts should name ``?line_search=armijo``: that is backward
Euler as practitioners ship it.

Counted on every line-searched run (``NewtonCounts``, carried in the run's ``meta.settings``):
its Newton iterations, its backtracks, the iterations whose update did not descend, and its
failures, steps whose iteration reached the cap (``reference.kinds.NEWTON_MAX``) without passing
the stopping test or whose line search found no step, each said with the run. The full-step
Newton is counted too where it runs in Python (with a library solve: ``objective`` None here).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from ..kinds import IMPLICIT
from .._scheme import Floor, largest_magnitude, scheme
from ..oscillator import oscillator, unbounded

#: Newton stops when the update is below this, relative to the iterate.
NEWTON_RTOL = 1e-13


def floor(s, h, k, m):
    # The spring is linear: one Newton iteration from w = v_n solves for v_{n+1} exactly, and
    # the harness takes one (newton_max = 1 on a linear scene).
    x, v = s
    dw = (h * (-k * (x + h * v) / m)) / (1.0 + h * h * (k / m))
    w = v + dw
    return (x + h * w, w)


def amplification(y, z):
    return np.linalg.inv(np.eye(2) - y * oscillator(z))


@scheme(
    kind=IMPLICIT,
    order=1,
    force_evals=1,
    symplectic=False,
    energy_claim="decays",
    homega_max=float("inf"),
    floor=Floor(floor),
    amplification=amplification,
    damping_limit=unbounded,
    # Not the solar system, where the issue names the schemes it runs against REBOUND's modes.
    suites={"standard": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "chain", "cloth")},
)
def implicit_euler(accel, solve, newton_max, state, t, h, p):
    """Implicit (backward) Euler: both updates from the new state.

        x_{n+1} = x_n + h v_{n+1}
        v_{n+1} = v_n + h a(x_{n+1}, v_{n+1}, t_{n+1})

    Solved for w = v_{n+1} by Newton from w = v_n with the scene's solve of
    (I - h da/dv - h^2 da/dx) dw = v_n + h a(x_n + h w, w) - w: one force evaluation and
    one solve per iteration; one iteration is exact for linear forces. First order,
    never explodes, damps everything (a spring loses a factor 1/(1 + h^2 w^2) per step).
    """
    q, v = state
    w = v
    for _ in range(newton_max):
        q_new = q + h * w
        r = v + h * accel(q_new, w, t + h, p) - w
        dw = solve(q_new, w, t + h, p, h, h * h, r)
        w = w + dw
        if largest_magnitude(dw) <= NEWTON_RTOL * (1.0 + largest_magnitude(w)):
            break
    return (q + h * w, w)


# ----------------------------------------------------------------------------- the line search
#: Armijo's sufficient-decrease constant (Nocedal and Wright, Algorithm 3.1: c1 = 1e-4) and the
#: factor each backtrack shortens the step by.
ARMIJO_C1 = 1e-4
BACKTRACK = 0.5
#: Backtracks an iteration may make before its line search gives up (a step of 2^-40 of the update).
MOST_BACKTRACKS = 40
#: What a trial may exceed the Armijo bound by, relative to the objective's size: a thousand times
#: its last bit, which a sum over the scene's springs and masses rounds in.
OBJECTIVE_ROUNDOFF = 1e3 * 2.0**-52
#: A step whose line search finds no decrease while its residual is below this, relative to the
#: iterate, has stalled at the root (the residual's own roundoff: the springs' forces it sums, at
#: k = 1e6 on the cloth, are nine orders above it), not failed: counted apart.
STALL_RTOL = 1e-9


@dataclass
class NewtonCounts:
    """What a line-searched run's Newton iterations did, summed over its steps."""

    steps: int = 0
    iterations: int = 0
    backtracks: int = 0
    #: Iterations whose Newton update did not descend the objective, replaced by the residual.
    not_descent: int = 0
    #: Steps that reached the iteration cap without passing the stopping test, or whose line
    #: search found no step that decreased the objective, their residual above roundoff.
    failures: int = 0
    #: Steps that ended without passing the update's test (the cap reached, or a search with no
    #: decrease) with the residual at roundoff (``STALL_RTOL``): at the root, converged.
    stalls: int = 0
    #: Evaluations of the incremental potential (the scene's energy): not force evaluations.
    objective_evals: int = 0

    def as_dict(self) -> dict:
        return asdict(self)


class IncrementalPotential:
    """Phi(w) = 1/2 |w - v|_M^2 + U(q + h w) = energy(q + h w, w - v) for one batch member
    (kernel-layout columns (ndof, 1)), ``mass`` the diagonal of M (ndof,): grad Phi = -M r."""

    name = "the step's incremental potential (the scene's energy)"

    def __init__(self, energy, mass):
        self.energy, self.mass = energy, mass

    def __call__(self, q, v, h, w) -> float:
        return float(self.energy((q + h * w)[:, 0], (w - v)[:, 0]))


class ResidualNorm:
    """The merit function |r| (Euclidean) where the force has no potential."""

    name = "the residual's norm (merit function: the force has no potential)"


def newton_line_search(accel, solve, newton_max, state, t, h, p, objective, counts: NewtonCounts):
    """One backward Euler step, ``implicit_euler``'s Newton iteration with a backtracking line
    search on ``objective`` (an ``IncrementalPotential``, a ``ResidualNorm``, or None: every full
    update, the plain iteration, counted), batch member by batch member; ``counts`` accumulates.
    With one iteration allowed (a linear scene, where one is exact) a full update converges."""
    q, v = state
    if q.shape[1] == 1:
        return _newton_one(accel, solve, newton_max, q, v, t, h, p, objective, counts)
    ends = [
        _newton_one(
            accel,
            solve,
            newton_max,
            np.ascontiguousarray(q[:, b : b + 1]),
            np.ascontiguousarray(v[:, b : b + 1]),
            t,
            h,
            p,
            objective,
            counts,
        )
        for b in range(q.shape[1])
    ]
    return (np.concatenate([e[0] for e in ends], axis=1), np.concatenate([e[1] for e in ends], axis=1))


def _newton_one(accel, solve, newton_max, q, v, t, h, p, objective, counts):
    counts.steps += 1
    w = v
    r = None  # the residual at w, where the line search has computed it
    value = None  # the objective at w, likewise
    converged = False
    for _ in range(newton_max):
        q_new = q + h * w
        if r is None:
            r = v + h * accel(q_new, w, t + h, p) - w
        dw = solve(q_new, w, t + h, p, h, h * h, r)
        counts.iterations += 1
        full = w + dw
        if largest_magnitude(dw) <= NEWTON_RTOL * (1.0 + largest_magnitude(full)):
            w = full
            converged = True
            break
        r_here = r
        if objective is None:
            w, r, alpha = full, None, 1.0
        elif isinstance(objective, IncrementalPotential):
            if value is None:
                value = objective(q, v, h, w)
                counts.objective_evals += 1
            w, value, alpha = _armijo_potential(objective, q, v, h, w, r, dw, full, value, counts)
            r = None
        else:
            w, r, alpha = _armijo_residual(accel, q, v, t, h, p, w, r, dw, full, counts)
        if alpha == 0.0:  # no step decreased the objective: the iteration stops here
            r = r_here
            break
        converged = newton_max == 1 and alpha == 1.0
    if not converged and objective is not None:
        # The cap reached, or a search with no decrease: at the root to the residual's roundoff
        # (the update's test cannot pass where the residual's last bits move it), a stall.
        if r is None:
            r = v + h * accel(q + h * w, w, t + h, p) - w
        if largest_magnitude(r) <= STALL_RTOL * (1.0 + largest_magnitude(w)):
            counts.stalls += 1
            converged = True
    counts.failures += not converged
    return (q + h * w, w)


def _armijo_potential(objective, q, v, h, w, r, dw, full, value, counts):
    """(w after the line search, Phi there, the step taken: 0 where none was found)."""
    g = objective.mass * r[:, 0]  # -grad Phi
    slope = -float(np.dot(g, dw[:, 0]))
    if not slope < 0.0:  # the update does not descend: the steepest descent in the metric M
        counts.not_descent += 1
        dw, full = r, w + r
        slope = -float(np.dot(g, r[:, 0]))
    alpha = 1.0
    for _ in range(MOST_BACKTRACKS + 1):
        trial = full if alpha == 1.0 else w + alpha * dw
        f = objective(q, v, h, trial)
        counts.objective_evals += 1
        bound = value + ARMIJO_C1 * alpha * slope + OBJECTIVE_ROUNDOFF * (abs(value) + abs(f))
        if math.isfinite(f) and f <= bound:
            return trial, f, alpha
        alpha *= BACKTRACK
        counts.backtracks += 1
    return w, value, 0.0


def _armijo_residual(accel, q, v, t, h, p, w, r, dw, full, counts):
    """(w after the line search, its residual, the step taken: 0 where none was found)."""
    size = float(np.linalg.norm(r))
    alpha = 1.0
    for _ in range(MOST_BACKTRACKS + 1):
        trial = full if alpha == 1.0 else w + alpha * dw
        r_trial = v + h * accel(q + h * trial, trial, t + h, p) - trial
        f = float(np.linalg.norm(r_trial))
        slack = OBJECTIVE_ROUNDOFF * (float(np.linalg.norm(v)) + float(np.linalg.norm(trial)))
        if math.isfinite(f) and f <= (1.0 - ARMIJO_C1 * alpha) * size + slack:
            return trial, r_trial, alpha
        alpha *= BACKTRACK
        counts.backtracks += 1
    return w, r, 0.0
