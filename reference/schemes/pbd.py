import numpy as np

from ..kinds import POSITION_BASED
from .._scheme import EVERY_SCENE, Floor, scheme
from ._position_based import nth_root, point_inv_mass, project, row, spring_data

#: Substeps and projection passes per step unless the caller sets ``substeps``/``iterations``.
DEFAULT_SUBSTEPS = 1
DEFAULT_ITERATIONS = 10


def floor(s, h, k, m):
    # The spring as the kernel reads it (``floor_start``): each pass removes the share
    # s' = 1 - (1 - s)^(1/passes) of C = x - anchor - rest, s = w / (w + alpha/h^2), computed once
    # before the loop as the kernel's loop computes it and divided by w = w_a + w_b as the scheme
    # keeps it, then times the point's w. One substep, the default passes.
    x, v, share, anchor, rest, wb, g = s
    x_old = x
    v = v + h * g
    x = x + h * v
    for _ in range(DEFAULT_ITERATIONS):
        x = x + wb * (-share * (x - anchor - rest))
    return (x, (x - x_old) / h, share, anchor, rest, wb, g)


def floor_start(x, v, h, k, m):
    anchor, rest, compliance, wa, wb, g = spring_data(k, m)
    w = wa + wb
    share = (1.0 - nth_root(1.0 - w / (w + compliance / (h * h)), DEFAULT_ITERATIONS)) / w
    return (x, v, share, anchor, rest, wb, g)


@scheme(
    kind=POSITION_BASED,
    order=1,
    force_evals=0,
    symplectic=False,
    energy_claim="decays",
    homega_max=float("inf"),
    substeps=DEFAULT_SUBSTEPS,
    iterations=DEFAULT_ITERATIONS,
    floor=Floor(floor, floor_start, scene_data=5),
    # Every scene that gives distance constraints (the spring, the chain, the rope, the cloth).
    suites={"standard": EVERY_SCENE},
)
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
    # Computed from the constraints and h alone, before the state is read: the compiled loops
    # compute it once (``kinds.POSITION_BASED``). Each constraint's share s' / (w_a + w_b).
    ends, rest, compliance, inv_mass, anchors, gravity = constraints(p)
    hs = h / substeps
    share = np.empty(ends.shape[0])
    for c in range(ends.shape[0]):
        w = point_inv_mass(inv_mass, ends[c, 0]) + point_inv_mass(inv_mass, ends[c, 1])
        share[c] = (1.0 - nth_root(1.0 - w / (w + compliance[c] / (hs * hs)), iterations)) / w
    q, v = state
    d = anchors.shape[1]
    nb = q.shape[1]
    n = q.shape[0]
    # One array a step: x (returned as q), the anchors' rows, x_old, u (returned as v); the state
    # copied in, then only the array read (``_position_based``); written out here, not through
    # helpers taking the arrays.
    fixed = anchors.shape[0] * d
    x_old = n + fixed
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
        for _ in range(iterations):
            for c in range(ends.shape[0]):
                ra = row(ends[c, 0], n, d)
                rb = row(ends[c, 1], n, d)
                a_free = ends[c, 0] >= 0
                b_free = ends[c, 1] >= 0
                wa = point_inv_mass(inv_mass, ends[c, 0])
                wb = point_inv_mass(inv_mass, ends[c, 1])
                if d > 1:
                    project(work, ra, a_free, rb, b_free, d, rest[c], wa, wb, -1, 0.0, 0.0, share[c], 0, 1.0)
                    continue
                # d = 1: C = x_b - x_a - rest, gradient 1; an anchor written back as read.
                for b in range(nb):
                    at_a = work[ra, b]
                    dl = -share[c] * (work[rb, b] - at_a - rest[c])
                    work[ra, b] = at_a - wa * dl if a_free else at_a
                    at_b = work[rb, b]
                    work[rb, b] = at_b + wb * dl if b_free else at_b
        # v = (x - x_old) / hs
        for r in range(n):
            for b in range(nb):
                work[u + r, b] = (work[r, b] - work[x_old + r, b]) / hs
    return (work[:n], work[u : u + n])
