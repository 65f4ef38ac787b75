"""What PBD and XPBD share: where a constraint's end lies in a step's array (``row``), a point's
inverse mass, and one pass of one constraint over the batch where d > 1
(``scenarios.scene.Scene.constraints`` gives the constraints). Loops written out, batch
innermost, as the scenes' kernels are: they compile to straight loops. A step makes one array,
``work``: the positions x, then the anchors' coordinates along the batch (a row per coordinate:
a projection reads an anchored end as it reads a point), then the step's other rows (XPBD's
multipliers, x_old, the velocities); so the 1-D loops over the batch read both ends alike, write
an anchor back as read, have no branch, and vectorise. The step copies its state (q, v) into the
rows of x and the velocities, reads only ``work`` after that and returns views of those rows, so
the compiled loops carry the state in one such array from step to step and make none
(``reference._codegen``: ``_Source.add_loop_in_place``). (Jacobi XPBD's 1-D pass reads an
anchor from the scene's anchors, one value for the batch, and sums no correction into it: its
step fills no anchor row there.) Each scheme writes its prediction and
velocity loops out in its step rather than calling helpers with the arrays: a compiled call
passes every array it is given with a reference count taken and dropped, a cost per step beside
which the single spring's step is small."""

import numpy as np


def row(i, points, d):
    """The first row in a step's ``work`` of the constraint end i: a point's, or an
    anchor's (i < 0) after the ``points`` rows of x."""
    if i >= 0:
        return i * d
    return points + (-1 - i) * d


def point_inv_mass(inv_mass, i):
    """A point's inverse mass; an anchor's (i < 0) is 0."""
    if i >= 0:
        return inv_mass[i]
    return 0.0


def project(work, ra, a_free, rb, b_free, d, rest, wa, wb, lam, tilde, denominator, share, into, relaxation):
    """One pass of one constraint over the batch, d > 1, its ends' rows ``ra``, ``rb`` in
    ``work`` (``row``; an anchor's not ``free``, never written): C = |x_b - x_a| - rest and its
    gradient g = (x_b - x_a)/|x_b - x_a| (C = 0 and g = 0 where the points coincide), then XPBD's
    dl = relaxation (-C - alpha~ lambda) / (w_a + w_b + alpha~), lambda += dl where ``lam`` is a
    row of work, else (lam < 0) PBD's dl = -share C; then the corrections -w_a dl g and w_b dl g
    added into the ends' rows ``into`` rows on: the positions themselves (``into`` 0, Gauss-Seidel:
    the next constraint reads them), or a pass's summed corrections (Jacobi XPBD, applied after the
    pass). Relaxation 1 where the scheme has none (a product with 1 is exact). (The 1-D case,
    C = x_b - x_a - rest with g = 1, the schemes write out.)"""
    for b in range(work.shape[1]):
        g0 = work[rb, b] - work[ra, b]
        g1 = work[rb + 1, b] - work[ra + 1, b]
        g2 = 0.0
        # Sums of squares from the first: 0 + g0^2 is g0^2 (a square is never -0).
        length2 = g0 * g0 + g1 * g1
        if d == 3:
            g2 = work[rb + 2, b] - work[ra + 2, b]
            length2 = length2 + g2 * g2
        length = np.sqrt(length2)
        cv = 0.0
        if length == 0.0:
            g0 = 0.0
            g1 = 0.0
            g2 = 0.0
        else:
            cv = length - rest
            g0 = g0 / length
            g1 = g1 / length
            g2 = g2 / length
        if lam >= 0:
            dl = relaxation * ((-cv - tilde * work[lam, b]) / denominator)
            work[lam, b] = work[lam, b] + dl
        else:
            dl = -share * cv
        for k in range(d):
            g = g0 if k == 0 else (g1 if k == 1 else g2)
            if a_free:
                work[into + ra + k, b] = work[into + ra + k, b] - wa * dl * g
            if b_free:
                work[into + rb + k, b] = work[into + rb + k, b] + wb * dl * g


def spring_data(k, m):
    """The unit spring's constraint as ``scenarios.spring.constraints`` gives it, for a floor's
    ``start`` (``reference._scheme.Floor.scene_data``): the anchor's position, the rest length,
    the compliance 1/k, the anchor's and the point's inverse masses, the gravity."""
    return 0.0, 0.0, 1.0 / k, 0.0, 1.0 / m, 0.0


def nth_root(a, n):
    """a^(1/n) for 0 <= a <= 1 by Newton's method from 1 (monotone from above: y^n - a is
    convex), integer powers by squaring: + - * / only, so compiled and interpreted agree to the bit."""
    if n == 1 or a == 0.0 or a == 1.0:
        return a
    y = 1.0
    for _ in range(200):
        power = 1.0
        base = y
        e = n - 1
        while e > 0:
            if e % 2 == 1:
                power = power * base
            base = base * base
            e = e // 2
        y_new = y - (power * y - a) / (n * power)
        if not y_new < y:
            break
        y = y_new
    return y
