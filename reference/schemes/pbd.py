import numpy as np

from ..kinds import POSITION_BASED
from .._scheme import scheme
from ._position_based import move, nth_root, point_inv_mass, predict, velocity, violation

#: Substeps and projection passes per step unless the caller sets ``substeps``/``iterations``.
DEFAULT_SUBSTEPS = 1
DEFAULT_ITERATIONS = 10


@scheme(kind=POSITION_BASED, order=1, force_evals=0, symplectic=False, energy_claim="decays",
        homega_max=float("inf"), substeps=DEFAULT_SUBSTEPS, iterations=DEFAULT_ITERATIONS)
def pbd(accel, constraints, substeps, iterations, state, t, h, p):
    """Position-based dynamics (Mueller, Heidelberger, Hennix and Ratcliff 2007): predict,
    project, velocity from the position change, in each of ``substeps`` substeps of hs:

        v~ = v + hs g,  x~ = x + hs v~
        ``iterations`` Gauss-Seidel passes: s' = 1 - (1 - s)^(1/iterations),
            x_a -= s' w_a C grad C / (w_a + w_b),  x_b += -s' w_b C grad C / (w_a + w_b)
        v = (x - x_old) / hs

    with each spring's stiffness s = (w_a + w_b) / (w_a + w_b + alpha / hs^2), alpha = 1/k: the
    share of its violation one implicit Euler substep of that spring alone removes, and the
    paper's correction for the passes. Alone, a spring is then XPBD's (implicit Euler's); joined
    to others, its stiffness still grows with the passes and the substep, which XPBD's
    multiplier removes. First order, damps, never explodes on linear springs; a rigid link
    (alpha = 0, s = 1) is projected fully. No force evaluation.
    """
    q, v = state
    ends, rest, compliance, inv_mass, anchors, gravity = constraints(p)
    d = anchors.shape[1]
    nb = q.shape[1]
    hs = h / substeps
    x = q.copy()
    u = v.copy()
    x_old = np.empty_like(q)
    share = np.empty(ends.shape[0])
    for c in range(ends.shape[0]):
        w = point_inv_mass(inv_mass, ends[c, 0]) + point_inv_mass(inv_mass, ends[c, 1])
        share[c] = (1.0 - nth_root(1.0 - w / (w + compliance[c] / (hs * hs)), iterations)) / w
    grad = np.empty(3)
    for _ in range(substeps):
        predict(x, u, x_old, gravity, hs)
        for _ in range(iterations):
            for c in range(ends.shape[0]):
                ia = ends[c, 0]
                ib = ends[c, 1]
                wa = point_inv_mass(inv_mass, ia)
                wb = point_inv_mass(inv_mass, ib)
                for b in range(nb):
                    cv = violation(x, anchors, ia, ib, b, rest[c], grad)
                    move(x, ia, ib, b, wa, wb, -share[c] * cv, grad, d)
        velocity(x, u, x_old, hs)
    return (x, u)
