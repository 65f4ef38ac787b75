import numpy as np

from ..kinds import POSITION_BASED
from .._scheme import scheme
from ._position_based import move, point_inv_mass, predict, velocity, violation

#: Substeps and Gauss-Seidel passes per step unless the caller sets ``substeps``/``iterations``.
DEFAULT_SUBSTEPS = 1
DEFAULT_ITERATIONS = 10


@scheme(kind=POSITION_BASED, order=1, force_evals=0, symplectic=False, energy_claim="decays",
        homega_max=float("inf"), substeps=DEFAULT_SUBSTEPS, iterations=DEFAULT_ITERATIONS)
def xpbd(accel, constraints, substeps, iterations, state, t, h, p):
    """Extended position-based dynamics (Macklin, Mueller and Chentanez 2016): each spring a
    distance constraint C with compliance alpha = 1/k and a Lagrange multiplier lambda, in each
    of ``substeps`` substeps of hs = h/substeps:

        v~ = v + hs g,  x~ = x + hs v~,  lambda = 0
        ``iterations`` Gauss-Seidel passes over the constraints, alpha~ = alpha / hs^2:
            dlambda = (-C(x) - alpha~ lambda) / (w_a + w_b + alpha~),  lambda += dlambda,
            x_a -= w_a dlambda grad C,  x_b += w_b dlambda grad C
        v = (x - x_old) / hs

    The passes converge to the implicit Euler step of the springs (M (x - x~) = -hs^2 grad C^T
    K C(x)); on linear springs one pass over a single one is it exactly (on the unit spring
    ``ref:implicit_euler`` to roundoff). First order; damps like implicit Euler, more where the
    passes stop short; never explodes on linear springs. A rigid link is alpha = 0 (PBD's
    projection). No force evaluation: the springs are constraints, gravity the scene's field.
    """
    q, v = state
    ends, rest, compliance, inv_mass, anchors, gravity = constraints(p)
    d = anchors.shape[1]
    nb = q.shape[1]
    hs = h / substeps
    x = q.copy()
    u = v.copy()
    x_old = np.empty_like(q)
    lam = np.empty((ends.shape[0], nb))
    grad = np.empty(3)
    for _ in range(substeps):
        predict(x, u, x_old, gravity, hs)
        for c in range(ends.shape[0]):
            for b in range(nb):
                lam[c, b] = 0.0
        for _ in range(iterations):
            for c in range(ends.shape[0]):
                ia = ends[c, 0]
                ib = ends[c, 1]
                wa = point_inv_mass(inv_mass, ia)
                wb = point_inv_mass(inv_mass, ib)
                tilde = compliance[c] / (hs * hs)
                for b in range(nb):
                    cv = violation(x, anchors, ia, ib, b, rest[c], grad)
                    dl = (-cv - tilde * lam[c, b]) / (wa + wb + tilde)
                    lam[c, b] = lam[c, b] + dl
                    move(x, ia, ib, b, wa, wb, dl, grad, d)
        velocity(x, u, x_old, hs)
    return (x, u)
