import numpy as np

from ..kinds import POSITION_BASED
from .._scheme import EVERY_SCENE, Floor, scheme
from ._position_based import point_inv_mass, project, row, spring_data

#: Substeps and Gauss-Seidel passes per step unless the caller sets ``substeps``/``iterations``.
DEFAULT_SUBSTEPS = 1
DEFAULT_ITERATIONS = 10


def floor(s, h, k, m):
    # The spring as the kernel reads it (``floor_start``): C = x - anchor - rest, compliance 1/k,
    # alpha~ and w_a + w_b + alpha~ computed once before the loop as the kernel's loop computes
    # them. One substep, the default passes.
    x, v, tilde, denominator, anchor, rest, wb, g = s
    x_old = x
    v = v + h * g
    x = x + h * v
    lam = 0.0
    for _ in range(DEFAULT_ITERATIONS):
        dl = (-(x - anchor - rest) - tilde * lam) / denominator
        lam = lam + dl
        x = x + wb * dl
    return (x, (x - x_old) / h, tilde, denominator, anchor, rest, wb, g)


def floor_start(x, v, h, k, m):
    anchor, rest, compliance, wa, wb, g = spring_data(k, m)
    tilde = compliance / (h * h)
    return (x, v, tilde, wa + wb + tilde, anchor, rest, wb, g)


@scheme(
    kind=POSITION_BASED,
    order=1,
    force_evals=0,
    symplectic=False,
    energy_claim="decays",
    homega_max=float("inf"),
    substeps=DEFAULT_SUBSTEPS,
    iterations=DEFAULT_ITERATIONS,
    floor=Floor(floor, floor_start, scene_data=6),
    # Every scene that gives distance constraints (the spring, the chain, the rope, the cloth).
    suites={"standard": EVERY_SCENE},
)
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
    # Computed from the constraints and h alone, before the state is read: the compiled loops
    # compute it once (``kinds.POSITION_BASED``). Each constraint's alpha~ and w_a + w_b + alpha~.
    ends, rest, compliance, inv_mass, anchors, gravity = constraints(p)
    hs = h / substeps
    tilde = np.empty(ends.shape[0])
    denominator = np.empty(ends.shape[0])
    for c in range(ends.shape[0]):
        tilde[c] = compliance[c] / (hs * hs)
        denominator[c] = point_inv_mass(inv_mass, ends[c, 0]) + point_inv_mass(inv_mass, ends[c, 1]) + tilde[c]
    q, v = state
    d = anchors.shape[1]
    nb = q.shape[1]
    n = q.shape[0]
    # One array a step: x (returned as q), the anchors' rows, the multipliers' rows, x_old, u
    # (returned as v); the state copied in, then only the array read (``_position_based``);
    # written out here, not through helpers taking the arrays.
    fixed = anchors.shape[0] * d
    lam = n + fixed  # the first multiplier's row
    x_old = lam + ends.shape[0]
    u = x_old + n
    work = np.empty((u + n, nb))
    work[:n] = q
    work[u : u + n] = v
    for a in range(anchors.shape[0]):
        for k in range(d):
            for b in range(nb):
                work[n + a * d + k, b] = anchors[a, k]
    for _ in range(substeps):
        # v~ = v + hs g, x~ = x + hs v~, x_old kept; v~ is not stored (the substep's velocity
        # is (x - x_old) / hs, written over it before it is read).
        for r in range(n):
            g = gravity[r % d]
            for b in range(nb):
                xr = work[r, b]
                work[x_old + r, b] = xr
                work[r, b] = xr + hs * (work[u + r, b] + hs * g)
        for c in range(ends.shape[0]):
            for b in range(nb):
                work[lam + c, b] = 0.0
        for _ in range(iterations):
            for c in range(ends.shape[0]):
                ra = row(ends[c, 0], n, d)
                rb = row(ends[c, 1], n, d)
                a_free = ends[c, 0] >= 0
                b_free = ends[c, 1] >= 0
                wa = point_inv_mass(inv_mass, ends[c, 0])
                wb = point_inv_mass(inv_mass, ends[c, 1])
                if d > 1:
                    project(
                        work, ra, a_free, rb, b_free, d, rest[c], wa, wb, lam + c, tilde[c], denominator[c], 0.0, 0, 1.0
                    )
                    continue
                # d = 1: C = x_b - x_a - rest, gradient 1; an anchor written back as read.
                for b in range(nb):
                    at_a = work[ra, b]
                    dl = (-(work[rb, b] - at_a - rest[c]) - tilde[c] * work[lam + c, b]) / denominator[c]
                    work[lam + c, b] = work[lam + c, b] + dl
                    work[ra, b] = at_a - wa * dl if a_free else at_a
                    at_b = work[rb, b]
                    work[rb, b] = at_b + wb * dl if b_free else at_b
        # v = (x - x_old) / hs
        for r in range(n):
            for b in range(nb):
                work[u + r, b] = (work[r, b] - work[x_old + r, b]) / hs
    return (work[:n], work[u : u + n])
