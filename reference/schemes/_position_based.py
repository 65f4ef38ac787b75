"""What PBD and XPBD share: the substep's prediction and velocity update, and one constraint's
violation C and gradient (``scenarios.scene.Scene.constraints`` gives the constraints). Loops
written out, batch innermost, as the scenes' kernels are: they compile to straight loops."""
import numpy as np


def predict(x, u, x_old, gravity, hs):
    """v += hs g; x_old = x; x += hs v (the substep's prediction, entry by entry)."""
    d = gravity.shape[0]
    for r in range(x.shape[0]):
        g = gravity[r % d]
        for b in range(x.shape[1]):
            u[r, b] = u[r, b] + hs * g
            x_old[r, b] = x[r, b]
            x[r, b] = x[r, b] + hs * u[r, b]


def velocity(x, u, x_old, hs):
    """v = (x - x_old) / hs: the velocity from the substep's position change."""
    for r in range(x.shape[0]):
        for b in range(x.shape[1]):
            u[r, b] = (x[r, b] - x_old[r, b]) / hs


def point_inv_mass(inv_mass, i):
    """A point's inverse mass; an anchor's (i < 0) is 0."""
    if i >= 0:
        return inv_mass[i]
    return 0.0


def violation(x, anchors, ia, ib, b, rest, grad):
    """C of the constraint from point ia to ib (an anchor where negative) at batch member b, its
    gradient with respect to x_b into grad (the first d entries; -grad is x_a's). d = 1: the
    signed extension x_b - x_a - rest, gradient 1; else |x_b - x_a| - rest along the unit
    vector (0, with gradient 0, where the two points coincide)."""
    d = anchors.shape[1]
    length2 = 0.0
    for k in range(d):
        xa = x[ia * d + k, b] if ia >= 0 else anchors[-1 - ia, k]
        xb = x[ib * d + k, b] if ib >= 0 else anchors[-1 - ib, k]
        grad[k] = xb - xa
        length2 = length2 + grad[k] * grad[k]
    if d == 1:
        c = grad[0] - rest
        grad[0] = 1.0
        return c
    length = np.sqrt(length2)
    if length == 0.0:
        for k in range(d):
            grad[k] = 0.0
        return 0.0
    for k in range(d):
        grad[k] = grad[k] / length
    return length - rest


def move(x, ia, ib, b, wa, wb, dl, grad, d):
    """x_a -= w_a dl grad, x_b += w_b dl grad (anchors stay)."""
    for k in range(d):
        if ia >= 0:
            x[ia * d + k, b] = x[ia * d + k, b] - wa * dl * grad[k]
        if ib >= 0:
            x[ib * d + k, b] = x[ib * d + k, b] + wb * dl * grad[k]


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
