"""A stiff mass-spring cloth (Baraff and Witkin's scene): an n x m grid of point masses joined
by springs with rest lengths, under gravity, pinned at the two corners of its top edge (or
along the whole edge), released flat and at rest.

Grid node (i, j) (row i = 0..n-1, column j = 0..m-1) starts at x = j s, y = -i s (z = 0 in
3-D). Springs, each f = k (|d| - L) d/|d| on its ends:

* structural, stiffness ``k``: (i, j)-(i, j+1) and (i, j)-(i+1, j), rest length s;
* shear, ``k_shear``: (i, j)-(i+1, j+1) and (i, j)-(i+1, j-1), rest length s sqrt(2); with
  ``shear`` = 1 the first alone (the sheet triangulated along it, as a triangle mesh's edges);
* bending, ``k_bend``: (i, j)-(i, j+2) and (i, j)-(i+2, j), rest length 2 s.

Every mass is ``mass``/(n m); gravity g acts along the last axis (-z in 3-D, where the sheet
is released horizontal; -y in the planar variant, the scene ``net``: the same grid hanging in
its plane, for 2-D engines).
A pinned node is not a degree of freedom: it stays at its start. DOF: the free nodes in row
order, d = ``dim`` coordinates each (3; the net 2).

Energy = kinetic + springs + gravity, the height measured from the foot of the sheet hung
straight down at its rest lengths (-(n-1) s), so that E0 > 0 and a relative energy error reads.

The springs have rest lengths, so the force is nonlinear: there is no closed form, and
``reference_solution`` is a DOP853 run (rtol = atol = ``REFERENCE_RTOL``), computed once and
cached as the rope's is. Measured on the default cloth against an rtol = atol = 1e-13 run:
positions 5e-11 and velocities 3e-9 apart up to t = 2, 3e-6 and 2e-4 by t = 3 (the falling sheet
folds chaotically, differences growing about 100-fold per half second after t = 1.5), so
``reference_horizon`` = 2 (s). The stiffness matrix K = -df/dx (``hessian``) is, spring by spring,
k [(1 - L/|d|) I + (L/|d|) u u^T] with u = d/|d|; ``omega`` is sqrt(lambda_max(K)/m) at the
initial state, the frequency that sets every explicit scheme's step limit.

Implicit schemes solve (I + (beta/m) K) x = r (``solve``; the force does not depend on the
velocity): a banded LDL^T factorisation (bandwidth d (2m + 1), O(N m^2)) for at most
``DIRECT_MAX_DOF`` unknowns, else conjugate gradients, one pass over the springs' blocks per
iteration (O(N) each, and a number of iterations set by h omega, not by N). ``DIRECT_MAX_DOF``
sits where the two cost the same per step, compiled at h = 1/60 on square sheets of constant mass
per node: between 12 x 12 and 16 x 16 (docs/performance.md).
"""

import math

import numpy as np

from records import InvalidInput

from .scene import Param, Scene, SparseForm
from ._solutions import SegmentedSolution, cached

#: Where the dashpot coefficient ``d`` sits in ``pvec`` (after the ten parameters before it).
DAMPING_INDEX = 10
#: DOP853 tolerance (relative and absolute) of the reference solution.
REFERENCE_RTOL = 1e-12
#: The banded factorisation up to this many unknowns, conjugate gradients above.
DIRECT_MAX_DOF = 600
#: Conjugate gradients stop when the residual is below this, relative to the right-hand side.
CG_RTOL = 1e-14
#: ... or after this many iterations per unknown (a bound never met by a well-posed system).
CG_MAX_PER_DOF = 4


def _free(i, j, m, pins):
    """Index of grid node (i, j) among the free nodes (row order), -1 where it is pinned."""
    if i == 0:
        if pins == 1.0 or j == 0 or j == m - 1:
            return -1
        return j - 1
    if pins == 1.0:
        return (i - 1) * m + j
    return i * m + j - 2


def _spring_kind(o, p):
    """Spring family o (0..5) as (row offset, column offset, stiffness, rest length)."""
    s = p[2]
    if o == 0:
        return 0, 1, p[4], s
    if o == 1:
        return 1, 0, p[4], s
    if o == 2:
        return 1, 1, p[5], np.sqrt(2.0) * s
    if o == 3:
        return 1, -1, p[5], np.sqrt(2.0) * s
    if o == 4:
        return 0, 2, p[6], 2.0 * s
    return 2, 0, p[6], 2.0 * s


def _coordinate(q, b, i, j, c, f, p):
    """Coordinate c of node (i, j) (free index f) of batch member b: its start where pinned."""
    if f >= 0:
        return q[f * int(p[-1]) + c, b]
    if c == 0:
        return j * p[2]
    if c == 1:
        return -i * p[2]
    return 0.0


def _spring(i, j, o, p):
    """The o-th spring leaving mass (i, j): (free index of each end, k, rest length, the other
    end's i and j); k = 0 where there is none (off the grid, no stiffness, both ends pinned, the
    second diagonal where shear = 1)."""
    n, m = int(p[0]), int(p[1])
    di, dj, k, rest = _spring_kind(o, p)
    i2 = i + di
    j2 = j + dj
    if k == 0.0 or i2 >= n or j2 < 0 or j2 >= m or (o == 3 and p[9] == 1.0):
        return -1, -1, 0.0, rest, i2, j2
    fa = _free(i, j, m, p[8])
    fb = _free(i2, j2, m, p[8])
    if fa < 0 and fb < 0:
        return fa, fb, 0.0, rest, i2, j2
    return fa, fb, k, rest, i2, j2


def _difference(q, b, p, i, j, fa, i2, j2, fb, out):
    """The end-to-end vector of a spring into out (its first d entries); returns its length."""
    d = int(p[-1])
    length2 = 0.0
    for c in range(d):
        out[c] = _coordinate(q, b, i2, j2, c, fb, p) - _coordinate(q, b, i, j, c, fa, p)
        length2 = length2 + out[c] * out[c]
    return np.sqrt(length2)


def _closing(v, b, p, fa, fb, dx, length):
    """The rate a spring lengthens, (v_b - v_a) . dx / |dx| (a pinned end does not move)."""
    d = int(p[-1])
    rate = 0.0
    for c in range(d):
        w = 0.0
        if fb >= 0:
            w = w + v[fb * d + c, b]
        if fa >= 0:
            w = w - v[fa * d + c, b]
        rate = rate + w * dx[c]
    return rate / length


def accel(q, v, t, p):
    """Spring forces over the masses, plus gravity on the last axis, plus (``d`` > 0) each structural
    and shear spring's dashpot; O(N) per batch member. Loops written out (sums in a fixed order) so
    that numba computes numpy's bits; an undamped sheet's accelerations are those before the
    dashpots existed, bit for bit (the dashpot's term is added only where ``d`` > 0)."""
    n, m, d = int(p[0]), int(p[1]), int(p[-1])
    mass = p[3] / (n * m)
    damping = p[DAMPING_INDEX]
    nb = q.shape[1]
    a = np.zeros_like(q)
    dx = np.empty(3)
    for b in range(nb):
        for i in range(n):
            for j in range(m):
                for o in range(6):
                    fa, fb, k, rest, i2, j2 = _spring(i, j, o, p)
                    if k == 0.0:
                        continue
                    length = _difference(q, b, p, i, j, fa, i2, j2, fb, dx)
                    s = (k * (length - rest) / length) / mass
                    if damping != 0.0 and o < 4:
                        s = s + (damping * _closing(v, b, p, fa, fb, dx, length) / length) / mass
                    for c in range(d):
                        if fa >= 0:
                            a[fa * d + c, b] += s * dx[c]
                        if fb >= 0:
                            a[fb * d + c, b] -= s * dx[c]
        for f in range(q.shape[0] // d):
            a[f * d + d - 1, b] -= p[7]
    return a


def _anchor(i, j, m, pins):
    """Index of the pinned node (i, j) among the anchors: the top edge's columns in order."""
    if pins == 1.0:
        return j
    if j == 0:
        return 0
    return 1


def constraints(p):
    """The springs as distance constraints (``Scene.constraints``), in the kernels' order, each
    of compliance 1/k; the pinned nodes are the anchors, gravity on the last axis."""
    n, m, d = int(p[0]), int(p[1]), int(p[-1])
    pins = p[8]
    ends = np.empty((6 * n * m, 2), np.int64)
    rest = np.empty(6 * n * m)
    compliance = np.empty(6 * n * m)
    count = 0
    for i in range(n):
        for j in range(m):
            for o in range(6):
                fa, fb, k, length, i2, j2 = _spring(i, j, o, p)
                if k == 0.0:
                    continue
                ends[count, 0] = fa if fa >= 0 else -1 - _anchor(i, j, m, pins)
                ends[count, 1] = fb if fb >= 0 else -1 - _anchor(i2, j2, m, pins)
                rest[count] = length
                compliance[count] = 1.0 / k
                count += 1
    na = m if pins == 1.0 else 2
    anchors = np.zeros((na, d))
    for a in range(na):
        column = a if pins == 1.0 else a * (m - 1)
        anchors[a, 0] = column * p[2]
    inv_mass = np.empty(n * m - na)
    for f in range(n * m - na):
        inv_mass[f] = (n * m) / p[3]
    gravity = np.zeros(d)
    gravity[d - 1] = -p[7]
    return ends[:count], rest[:count], compliance[:count], inv_mass, anchors, gravity


def _blocks(q, b, p, ends, blocks, dashpot=0.0, stiffness=True):
    """Each spring's free end indices (-1: pinned) into ends and its stiffness block
    k [(1 - L/|d|) I + (L/|d|) u u^T] (d x d) into blocks, at batch member b; returns how many.
    ``dashpot`` != 0: each structural and shear spring's block plus ``dashpot`` d u u^T (its
    dashpot's, scaled as the caller scales the stiffness: alpha / beta). ``stiffness`` False: the
    dashpots' blocks alone (0 for a bending spring), the matrix of a step implicit in the velocity
    alone."""
    n, m, d = int(p[0]), int(p[1]), int(p[-1])
    u = np.empty(3)
    count = 0
    for i in range(n):
        for j in range(m):
            for o in range(6):
                fa, fb, k, rest, i2, j2 = _spring(i, j, o, p)
                if k == 0.0:
                    continue
                length = _difference(q, b, p, i, j, fa, i2, j2, fb, u)
                for c in range(d):
                    u[c] = u[c] / length
                ratio = rest / length
                for c in range(d):
                    for e in range(d):
                        blocks[count, c, e] = k * (ratio * u[c] * u[e]) if stiffness else 0.0
                    if stiffness:
                        blocks[count, c, c] = blocks[count, c, c] + k * (1.0 - ratio)
                if dashpot != 0.0 and o < 4:
                    for c in range(d):
                        for e in range(d):
                            blocks[count, c, e] = blocks[count, c, e] + dashpot * (u[c] * u[e])
                ends[count, 0] = fa
                ends[count, 1] = fb
                count += 1
    return count


def _matvec(ends, blocks, count, d, x, y, scale):
    """y = x + scale K x, K from the springs' blocks (pinned ends: no unknowns there)."""
    for r in range(x.shape[0]):
        y[r] = x[r]
    for s in range(count):
        fa = ends[s, 0]
        fb = ends[s, 1]
        for c in range(d):
            z = 0.0
            for e in range(d):
                w = 0.0
                if fa >= 0:
                    w = w + x[fa * d + e]
                if fb >= 0:
                    w = w - x[fb * d + e]
                z = z + blocks[s, c, e] * w
            z = scale * z
            if fa >= 0:
                y[fa * d + c] += z
            if fb >= 0:
                y[fb * d + c] -= z


def _cg(ends, blocks, count, d, r, b, scale, out):
    """Conjugate gradients on (I + scale K) x = r[:, b], from x = 0, into out[:, b]."""
    size = r.shape[0]
    x = np.zeros(size)
    res = np.empty(size)
    for i in range(size):
        res[i] = r[i, b]
    dirn = res.copy()
    ad = np.empty(size)
    rr = 0.0
    for i in range(size):
        rr = rr + res[i] * res[i]
    stop = (CG_RTOL * CG_RTOL) * rr
    for _ in range(CG_MAX_PER_DOF * size):
        if rr <= stop:
            break
        _matvec(ends, blocks, count, d, dirn, ad, scale)
        dad = 0.0
        for i in range(size):
            dad = dad + dirn[i] * ad[i]
        step = rr / dad
        rr_new = 0.0
        for i in range(size):
            x[i] = x[i] + step * dirn[i]
            res[i] = res[i] - step * ad[i]
            rr_new = rr_new + res[i] * res[i]
        ratio = rr_new / rr
        for i in range(size):
            dirn[i] = res[i] + ratio * dirn[i]
        rr = rr_new
    for i in range(size):
        out[i, b] = x[i]


def _banded(ends, blocks, count, d, m, r, b, scale, out):
    """Banded LDL^T of (I + scale K) (half-bandwidth d (2m + 1), the lower band stored), then
    the two triangular sweeps, into out[:, b]."""
    size = r.shape[0]
    bw = d * (2 * m + 1)
    low = np.zeros((size, bw + 1))  # low[i, k] = A[i, i - k], then L[i, i - k]
    for i in range(size):
        low[i, 0] = 1.0
    for s in range(count):
        fa = ends[s, 0]
        fb = ends[s, 1]
        for c in range(d):
            for e in range(c + 1):
                if fa >= 0:
                    low[fa * d + c, c - e] += scale * blocks[s, c, e]
                if fb >= 0:
                    low[fb * d + c, c - e] += scale * blocks[s, c, e]
            if fa >= 0 and fb >= 0:
                for e in range(d):  # the coupling block, below the diagonal (fb > fa)
                    low[fb * d + c, (fb - fa) * d + c - e] -= scale * blocks[s, c, e]
    diag = np.empty(size)
    for i in range(size):
        lo = max(0, i - bw)
        for j in range(lo, i):
            s = low[i, i - j]
            for l in range(lo, j):
                s = s - low[i, i - l] * diag[l] * low[j, j - l]
            low[i, i - j] = s / diag[j]
        s = low[i, 0]
        for l in range(lo, i):
            s = s - low[i, i - l] * low[i, i - l] * diag[l]
        diag[i] = s
    y = np.empty(size)
    for i in range(size):
        s = r[i, b]
        for l in range(max(0, i - bw), i):
            s = s - low[i, i - l] * y[l]
        y[i] = s
    for i in range(size - 1, -1, -1):
        s = y[i] / diag[i]
        for l in range(i + 1, min(size, i + bw + 1)):
            s = s - low[l, l - i] * out[l, b]
        out[i, b] = s


def solve(q, v, t, p, alpha, beta, r):
    """(I - alpha da/dv - beta da/dq) x = r with da/dq = -K/m at q and da/dv = -D/m (D the
    dashpots', d u u^T per structural and shear spring; 0 on an undamped sheet): the banded
    factorisation for at most DIRECT_MAX_DOF unknowns, conjugate gradients above. On a damped
    sheet each spring's block is k's + (alpha / beta) d u u^T, scaled by beta / m as K's (beta = 0,
    a step implicit in the velocity alone: the dashpots' blocks alone, scaled by alpha / m). K is
    the springs' alone: the dashpots' force depends on the positions too (through u), and that
    derivative, d/|x_b - x_a| ((dv . u)(I - u u^T) + u dv^T (I - u u^T)), is left out, so a
    Newton iteration on a damped sheet takes an inexact update (``reference.schemes.implicit_euler``
    counts the steps it leaves unconverged)."""
    n, m, d = int(p[0]), int(p[1]), int(p[-1])
    scale = beta / (p[3] / (n * m))
    dashpot = 0.0
    if p[DAMPING_INDEX] != 0.0 and alpha != 0.0:
        if beta != 0.0:
            dashpot = (alpha / beta) * p[DAMPING_INDEX]
        else:
            dashpot = p[DAMPING_INDEX]
            scale = alpha / (p[3] / (n * m))
    out = np.empty_like(r)
    ends = np.empty((6 * n * m, 2), dtype=np.int64)
    blocks = np.empty((6 * n * m, d, d))
    for b in range(r.shape[1]):
        # beta = 0 with dashpots: the stiffness does not enter, the dashpots' blocks alone
        count = _blocks(q, b, p, ends, blocks, dashpot, not (beta == 0.0 and dashpot != 0.0))
        if r.shape[0] <= DIRECT_MAX_DOF:
            _banded(ends, blocks, count, d, m, r, b, scale, out)
        else:
            _cg(ends, blocks, count, d, r, b, scale, out)
    return out


class _Sheet:
    """The cloth's springs as arrays, for its force and its solve's matrix in whole-array numpy
    (``Cloth.sparse_form``): the springs' end nodes (row-order grid indices), stiffness and rest
    length; each node's free index (-1: pinned) and start; and the matrix's pattern, fixed by the
    springs, so that a matrix at a state is its values summed into that pattern."""

    def __init__(self, scene: "Cloth"):
        n, m, d = scene.grid
        self.d, self.mass, self.g, self.size = d, scene.node_mass, float(scene.values["g"]), scene.ndof
        self.a, self.b, self.k, self.rest = scene.springs()
        self.c = scene.dashpots()
        self.damped = bool(np.any(self.c))
        self.base = scene.rest_positions()
        self.free_nodes = scene._free_index()
        self.free = np.full(n * m, -1)
        self.free[self.free_nodes] = np.arange(len(self.free_nodes))
        # Each spring's four d x d blocks (a a, b b: +; a b, b a: -) where both of its nodes are
        # free, then the identity's diagonal: every entry's (row, column) and where its value comes
        # from (an entry of the springs' blocks, its sign), summed into the compressed rows of the
        # distinct positions by one sparse product (``assemble``).
        c = np.arange(d)
        rows, cols, source, sign = [], [], [], []
        block = np.arange(len(self.k) * d * d).reshape(-1, d, d)
        for r_end, c_end, s in (
            (self.a, self.a, 1.0),
            (self.b, self.b, 1.0),
            (self.a, self.b, -1.0),
            (self.b, self.a, -1.0),
        ):
            fr, fc = self.free[r_end], self.free[c_end]
            keep = np.flatnonzero((fr >= 0) & (fc >= 0))
            shape = (len(keep), d, d)
            rows.append(np.broadcast_to(fr[keep, None, None] * d + c[None, :, None], shape).ravel())
            cols.append(np.broadcast_to(fc[keep, None, None] * d + c[None, None, :], shape).ravel())
            source.append(block[keep].ravel())
            sign.append(np.full(len(keep) * d * d, s))
        diagonal = np.arange(self.size)
        key = np.concatenate(rows + [diagonal]).astype(np.int64) * self.size + np.concatenate(cols + [diagonal])
        unique, slot = np.unique(key, return_inverse=True)
        self.indices = (unique % self.size).astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(unique // self.size, minlength=self.size))]).astype(
            np.int32
        )
        entries = len(np.concatenate(sign))
        from scipy.sparse import (
            coo_matrix,
        )  # here: scipy.sparse is a large import a process without a cloth never needs

        self.assemble = coo_matrix(
            (np.concatenate(sign), (slot[:entries], np.concatenate(source))), shape=(len(unique), block.size)
        ).tocsr()
        self.diagonal = slot[entries:]

    def positions(self, q: np.ndarray) -> np.ndarray:
        """Every node's position, (n m, d), from the free coordinates q (ndof,)."""
        x = self.base.copy()
        x[self.free_nodes] = q.reshape(-1, self.d)
        return x

    def velocities(self, v: np.ndarray) -> np.ndarray:
        """Every node's velocity, (n m, d), from the free coordinates' v (ndof,): 0 at a pin."""
        u = np.zeros_like(self.base)
        u[self.free_nodes] = v.reshape(-1, self.d)
        return u

    def accel(self, q, v, t, p):
        """The force over the masses plus gravity (and the dashpots' force), kernel layout (ndof, batch)."""
        out = np.empty_like(q)
        for col in range(q.shape[1]):
            x = self.positions(q[:, col])
            dx = x[self.b] - x[self.a]
            length = np.sqrt(np.sum(dx * dx, axis=1))
            tension = self.k * (length - self.rest)
            if self.damped:
                u = self.velocities(v[:, col])
                tension = tension + self.c * np.sum((u[self.b] - u[self.a]) * dx, axis=1) / length
            f = (tension / length)[:, None] * dx
            force = np.empty_like(x)
            for c in range(self.d):
                force[:, c] = np.bincount(self.a, f[:, c], minlength=len(x)) - np.bincount(
                    self.b, f[:, c], minlength=len(x)
                )
            acc = force[self.free_nodes] / self.mass
            acc[:, self.d - 1] -= self.g
            out[:, col] = acc.ravel()
        return out

    def matrix(self, q, v, t, alpha, beta):
        """I + (beta / m) K(q) + (alpha / m) D(q), K = -df/dq spring by spring k [(1 - L/|d|) I + (L/|d|) u u^T],
        D = -df/dv the dashpots' c u u^T (0 on an undamped sheet)."""
        from scipy.sparse import csr_matrix

        x = self.positions(q)
        dx = x[self.b] - x[self.a]
        length = np.sqrt(np.sum(dx * dx, axis=1))
        u = dx / length[:, None]
        ratio = self.rest / length
        blocks = (self.k * ratio)[:, None, None] * u[:, :, None] * u[:, None, :] + (self.k * (1.0 - ratio))[
            :, None, None
        ] * np.eye(self.d)
        data = self.assemble @ (blocks.ravel() * (beta / self.mass))
        if self.damped and alpha != 0.0:
            dash = self.c[:, None, None] * u[:, :, None] * u[:, None, :]
            data = data + self.assemble @ (dash.ravel() * (alpha / self.mass))
        data[self.diagonal] += 1.0
        return csr_matrix((data, self.indices, self.indptr), shape=(self.size, self.size))


class Cloth(Scene):
    id = "cloth"
    title = (
        "stiff mass-spring cloth, n x m masses, springs with rest lengths, gravity, pinned top corners; "
        "nonlinear; reference by DOP853"
    )
    params = {
        "n": Param(8, "rows of masses (row 0 holds the pins)", lo=2.0, hi=100.0, integer=True),
        "m": Param(8, "columns of masses", lo=2.0, hi=100.0, integer=True),
        "s": Param(0.1, "grid spacing = structural rest length", lo=0.0, lo_open=True),
        "mass": Param(1.0, "total mass of the n m masses", lo=0.0, lo_open=True),
        "k": Param(500.0, "structural spring stiffness", lo=0.0, lo_open=True),
        "k_shear": Param(50.0, "shear (diagonal) spring stiffness, 0: none", lo=0.0),
        "k_bend": Param(5.0, "bending (two apart) spring stiffness, 0: none", lo=0.0),
        "g": Param(9.81, "gravitational acceleration (along the last axis, downwards)", lo=0.0),
        "pins": Param(0, "0: the two top corners pinned; 1: the whole top edge", lo=0.0, hi=1.0, integer=True),
        "shear": Param(
            2,
            "shear diagonals per square: 2 both; 1 (i, j)-(i+1, j+1) alone (a triangulated sheet)",
            lo=1.0,
            hi=2.0,
            integer=True,
        ),
        "d": Param(
            0.0,
            "dashpot beside every structural and shear spring, N s/m along the spring (0: undamped; "
            "Drake's mass_spring_cloth ships 10)",
            lo=0.0,
        ),
    }
    #: Coordinates per mass (the kernels read it as the last entry of ``pvec``, ``p[-1]``).
    dim = 3
    accel = staticmethod(accel)
    solve = staticmethod(solve)
    constraints = staticmethod(constraints)
    reference_horizon = 2.0

    # ------------------------------------------------------------ the grid
    @property
    def grid(self) -> tuple[int, int, int]:
        return int(self.values["n"]), int(self.values["m"]), int(self.dim)

    @property
    def pvec(self) -> np.ndarray:
        return np.append(super().pvec, float(self.dim))

    @property
    def length_scale(self) -> float:
        """The sheet's width: its longer side at rest, (max(n, m) - 1) s (0.3 for the 4 x 4 sheet)."""
        n, m, _ = self.grid
        return (max(n, m) - 1) * self.values["s"]

    @property
    def solve_text(self) -> str:
        """The sheet's own solve (``solve``), which its size picks."""
        if self.ndof <= DIRECT_MAX_DOF:
            return f"the scene's banded LDL^T, compiled ({self.ndof} unknowns)"
        return (
            f"the scene's unpreconditioned conjugate gradients to a relative residual of {CG_RTOL:g}, compiled "
            f"({self.ndof} unknowns, past the banded solve's {DIRECT_MAX_DOF})"
        )

    @property
    def node_mass(self) -> float:
        n, m, _ = self.grid
        return self.values["mass"] / (n * m)

    def free_nodes(self) -> list[tuple[int, int]]:
        """The free nodes (i, j), in DOF order."""
        n, m, _ = self.grid
        return [(i, j) for i in range(n) for j in range(m) if _free(i, j, m, float(self.values["pins"])) >= 0]

    def rest_positions(self) -> np.ndarray:
        """Every node's start, (n m, d), row order."""
        n, m, d = self.grid
        s = self.values["s"]
        x = np.zeros((n * m, d))
        x[:, 0] = np.tile(np.arange(m) * s, n)
        x[:, 1] = np.repeat(-np.arange(n) * s, m)
        return x

    def springs(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(a, b, k, L): every spring's end nodes (row-order grid indices), stiffness and rest
        length, in the kernels' order; springs between two pinned nodes left out."""
        n, m, _ = self.grid
        p = self.pvec
        out = []
        for i in range(n):
            for j in range(m):
                for o in range(6):
                    _, _, k, rest, i2, j2 = _spring(i, j, o, p)
                    if k == 0.0:
                        continue
                    out.append((i * m + j, i2 * m + j2, float(k), float(rest)))
        a, b, k, rest = (np.array(c) for c in zip(*out))
        return a.astype(int), b.astype(int), k, rest

    def stretching(self) -> np.ndarray:
        """Which springs, in ``springs``' order, hold the sheet's stretch: the structural and shear
        springs (True), not the bending ones (False), whose length changes as the sheet folds."""
        return self._family() < 2

    def dashpots(self) -> np.ndarray:
        """Each spring's dashpot coefficient, in ``springs``' order: ``d`` beside a structural or shear
        spring, 0 beside a bending one."""
        return np.where(self.stretching(), float(self.values["d"]), 0.0)

    #: The spring families ``strain_by_family`` measures, in its order.
    STRAIN_FAMILIES = ("structural", "shear")

    def _family(self) -> np.ndarray:
        """Each spring's family, in ``springs``' order: 0 structural, 1 shear, 2 bending."""
        n, m, _ = self.grid
        p = self.pvec
        out = []
        for i in range(n):
            for j in range(m):
                for o in range(6):
                    if _spring(i, j, o, p)[2] != 0.0:
                        out.append(o // 2)
        return np.array(out, dtype=int)

    def strain_by_family(self, q) -> np.ndarray:
        """Each stretching family's largest strain, max (length - rest) / rest over its springs (0 where
        none is longer than its rest, or the family has none), API layout (..., ndof) ->
        (..., len(STRAIN_FAMILIES)): structural, then shear. Judged apart, because the families'
        stiffnesses differ: on a stiff sheet the soft shear diagonals stretch far more than the
        structural springs, and a largest strain over both would read the shear's alone."""
        a, b, _, rest = self.springs()
        family = self._family()
        x = self.positions(q)
        strain = (np.linalg.norm(x[..., b, :] - x[..., a, :], axis=-1) - rest) / rest
        cols = []
        for f in range(len(self.STRAIN_FAMILIES)):
            mine = family == f
            cols.append(np.max(strain[..., mine], axis=-1) if np.any(mine) else np.zeros(strain.shape[:-1]))
        return np.maximum(np.stack(cols, axis=-1), 0.0)

    def strain(self, q) -> np.ndarray:
        """The sheet's largest strain, max (length - rest) / rest over its structural and shear springs
        (how far it stretches; 0 where none is longer than its rest), API layout (..., ndof) -> (...)."""
        return np.max(self.strain_by_family(q), axis=-1)

    # ------------------------------------------------------------ the dashpots
    @property
    def velocity_dependent(self) -> bool:
        return self.values["d"] != 0.0

    @property
    def conservative(self) -> bool:
        return self.values["d"] == 0.0

    @property
    def kind(self) -> str:
        """The engines pose the undamped sheet; a damped one is a kind of its own, which no engine
        poses yet (each then says it has no model of it, rather than run it without its dashpots)."""
        return type(self).id if self.values["d"] == 0.0 else f"{type(self).id}_damped"

    def position_based_why(self) -> str:
        if self.values["d"] != 0.0:
            return (
                f"scene {self.id} has dashpots (d = {self.values['d']:g}), which the position-based schemes "
                "do not model: their constraints are its springs alone"
            )
        return super().position_based_why()

    def _validate(self) -> None:
        super()._validate()
        if self.values["d"] != 0.0 and not self.has_kernels:
            raise InvalidInput(
                f"parameter d={self.values['d']:g} is out of range for scene {self.id} (allowed: 0; the "
                "dashpots are the spring cloth's, which this scene's model does not have)"
            )

    def exact_energy(self, t):
        """The initial energy on an undamped sheet; on a damped one the reference's energy at t (the
        dashpots take it out as the true motion does)."""
        if self.values["d"] == 0.0:
            return super().exact_energy(t)
        q, v = self.reference_solution(np.atleast_1d(np.asarray(t, dtype=float)))
        return np.reshape(self.energy(q, v), np.shape(t))

    def _free_index(self) -> np.ndarray:
        n, m, _ = self.grid
        return np.array([i * m + j for i, j in self.free_nodes()], dtype=int)

    def positions(self, q: np.ndarray) -> np.ndarray:
        """Every node's position for states q (API layout, (..., ndof)) -> (..., n m, d)."""
        _, _, d = self.grid
        q = np.asarray(q, dtype=float)
        x = np.broadcast_to(self.rest_positions(), q.shape[:-1] + self.rest_positions().shape).copy()
        x[..., self._free_index(), :] = q.reshape(q.shape[:-1] + (-1, d))
        return x

    def sparse_form(self) -> SparseForm:
        """The force and the solve's matrix I + (beta/m) K(q) as whole-array numpy and scipy CSR
        (``Scene.sparse_form``), built once per scene."""
        if "_sparse" not in self.__dict__:
            sheet = _Sheet(self)
            self._sparse = SparseForm(sheet.accel, sheet.matrix, self.grid[2])
        return self._sparse

    @property
    def dof_names(self):
        axes = "xyz"[: self.grid[2]]
        return tuple(f"{c}{i}_{j}" for i, j in self.free_nodes() for c in axes)

    def initial_state(self):
        q = self.rest_positions()[self._free_index()].ravel()
        return q, np.zeros_like(q)

    def energy(self, q, v):
        n, _, d = self.grid
        a, b, k, rest = self.springs()
        x = self.positions(q)
        stretch = np.linalg.norm(x[..., b, :] - x[..., a, :], axis=-1) - rest
        height = q[..., d - 1 :: d] + (n - 1) * self.values["s"]
        mass = self.node_mass
        return (
            0.5 * mass * np.sum(v * v, axis=-1)
            + 0.5 * np.sum(k * stretch * stretch, axis=-1)
            + mass * self.values["g"] * np.sum(height, axis=-1)
        )

    def constraint_error(self, q):
        """The springs' largest relative stretch max |length - rest| / rest, API layout (..., ndof) -> (...)."""
        a, b, _, rest = self.springs()
        x = self.positions(q)
        return np.max(np.abs(np.linalg.norm(x[..., b, :] - x[..., a, :], axis=-1) - rest) / rest, axis=-1)

    def hessian(self, q: np.ndarray):
        """The stiffness matrix K = -df/dq at the state q (ndof,), sparse (scipy CSR)."""
        _, _, d = self.grid
        a, b, k, rest = self.springs()
        x = self.positions(q)
        dx = x[b] - x[a]
        length = np.linalg.norm(dx, axis=-1)
        u = dx / length[:, None]
        ratio = rest / length
        blocks = (k * ratio)[:, None, None] * u[:, :, None] * u[:, None, :] + (k * (1.0 - ratio))[
            :, None, None
        ] * np.eye(d)
        free = np.full(self.grid[0] * self.grid[1], -1)
        free[self._free_index()] = np.arange(len(self._free_index()))
        rows, cols, vals = [], [], []
        c = np.arange(d)
        for r_end, c_end, sign in ((a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)):
            fr, fc = free[r_end], free[c_end]
            keep = (fr >= 0) & (fc >= 0)
            shape = (int(keep.sum()), d, d)
            rr = np.broadcast_to(fr[keep, None, None] * d + c[None, :, None], shape)
            cc = np.broadcast_to(fc[keep, None, None] * d + c[None, None, :], shape)
            rows.append(rr.ravel())
            cols.append(cc.ravel())
            vals.append(sign * blocks[keep].ravel())
        size = self.ndof
        from scipy.sparse import coo_matrix

        return coo_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(size, size)
        ).tocsr()

    def omega_max_at(self, q: np.ndarray) -> float:
        """sqrt(lambda_max(K(q)) / m): the highest frequency of the motion linearised at q."""
        hess = self.hessian(q)
        if hess.shape[0] <= 600:
            lam = float(np.linalg.eigvalsh(hess.toarray())[-1])
        else:
            from scipy.sparse.linalg import eigsh

            lam = float(eigsh(hess, k=1, which="LA", return_eigenvectors=False, tol=1e-10)[0])
        return math.sqrt(max(lam, 0.0) / self.node_mass)

    @property
    def omega(self):
        """omega_max at the initial state (see ``omega_max_at``), computed once per scene."""
        if "_omega" not in self.__dict__:
            self._omega = self.omega_max_at(self.initial_state()[0])
        return self._omega

    #: The identification run's length (``identification_run``): within the sheet's first half
    #: second, before it folds (past 1.5 s differences grow 100-fold a half second).
    IDENTIFY_SPAN = 0.5

    def identification_run(self):
        """One step of h*omega = 1 over IDENTIFY_SPAN: at the default 100 steps a period of the
        stiffest mode (h*omega 0.063) a step solves the springs almost exactly however it sweeps
        them (parallel and sequential XPBD passes 6e-5 apart after 1000 steps), and a float32
        engine's velocity, recovered from positions as (x_new - x)/h, resolves only ulp(x)/h = 1.6e-4
        there (its sub-ulp motions lost each step): no scheme matches within float32 rounding. At
        h*omega = 1 (1/240 s on the 4 x 4 sheet) the sweeps part (Jacobi and Gauss-Seidel XPBD
        3.8e-2 apart over 120 steps) and float32 resolves the velocity 16 times finer."""
        dt = 1.0 / self.omega
        return dt, max(1, int(round(self.IDENTIFY_SPAN / dt)))

    # ------------------------------------------------------------ reference
    def _rhs(self):
        _, _, d = self.grid
        a, b, k, rest = self.springs()
        c = self.dashpots()
        damped = bool(np.any(c))
        free = self._free_index()
        mass, g, size = self.node_mass, self.values["g"], self.ndof
        base = self.rest_positions()
        ends = self._incidence(a, b, free)

        def rhs(t, y):
            x = base.copy()
            x[free] = y[:size].reshape(-1, d)
            dx = x[b] - x[a]
            length = np.linalg.norm(dx, axis=-1)
            if damped:
                u = np.zeros_like(base)
                u[free] = y[size:].reshape(-1, d)
                tension = k * (length - rest) + c * np.sum((u[b] - u[a]) * dx, axis=-1) / length
                f = (tension / length)[:, None] * dx
            else:
                f = (k * (length - rest) / length)[:, None] * dx
            acc = (ends @ f) / mass
            acc[:, d - 1] -= g
            return np.concatenate([y[size:], acc.ravel()])

        return rhs

    @staticmethod
    def _incidence(a, b, free):  # -> a scipy CSR matrix
        """The free nodes' rows of the springs' incidence (+1 where a spring starts at the node,
        -1 where it ends), each row's springs stored in the order a node-by-node accumulation
        takes them (first those it starts, then those it ends, each in spring order): its product
        with the springs' forces adds each node's forces in the same order, to the same bits, as
        ``np.add.at`` over the starts and then the ends, in one sparse product instead of
        ``add.at``'s element-by-element loop (the reference solve's dearest part on a large sheet)."""
        spring = np.arange(len(a))
        cols, vals, indptr = [], [], [0]
        for node in free:
            starts, ends = spring[a == node], spring[b == node]
            cols += [starts, ends]
            vals += [np.ones(len(starts)), -np.ones(len(ends))]
            indptr.append(indptr[-1] + len(starts) + len(ends))
        from scipy.sparse import csr_matrix

        return csr_matrix((np.concatenate(vals), np.concatenate(cols), np.array(indptr)), shape=(len(free), len(a)))

    def _reference(self, rtol=REFERENCE_RTOL, perturbation: float = 0.0) -> SegmentedSolution:
        q0, v0 = self.initial_state()
        key = (self.id, tuple(self.values.items()), rtol, perturbation)
        if perturbation:
            q0 = q0 + perturbation * self.length_scale * self.perturbation_pattern()
        return cached(
            key, lambda: SegmentedSolution(self._rhs(), np.concatenate([q0, v0]), segment=0.5, rtol=rtol, atol=rtol)
        )

    def reference_solution(self, t, rtol=REFERENCE_RTOL):
        """(q, v) at times t, shape (len(t), ndof), from the DOP853 run (cached)."""
        y = self._reference(rtol)(t)
        return y[:, : self.ndof], y[:, self.ndof :]

    def perturbation_pattern(self) -> np.ndarray:
        """The signs a perturbed start moves each coordinate by (+1 or -1, ndof): a fixed draw (seed
        0), so that every mode of the sheet is stirred and every run of it is the same."""
        return np.random.default_rng(0).choice([-1.0, 1.0], self.ndof)

    def perturbed_reference(self, t, perturbation: float):
        """(q, v) at times t of the same DOP853 run started with every position coordinate moved by
        ``perturbation`` x the length scale (signs ``perturbation_pattern``), at rest: how far two
        starts that no viewer could tell apart part (``harness.measures.horizon``); cached."""
        y = self._reference(REFERENCE_RTOL, float(perturbation))(t)
        return y[:, : self.ndof], y[:, self.ndof :]


class Net(Cloth):
    """The cloth's planar variant: the same grid, springs and pins in the vertical plane, gravity
    along -y, 2 coordinates a mass (a net hanging in its plane, released at its rest lengths)."""

    id = "net"
    title = (
        "planar mass-spring net, n x m masses, springs with rest lengths, gravity in the plane, pinned top "
        "corners; nonlinear; reference by DOP853"
    )
    dim = 2
