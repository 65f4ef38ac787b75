"""A stiff spring chain, the 1-D analogue of taut cloth: N masses m in a line, springs k between
neighbours and from each end mass to a fixed wall (N + 1 springs). q_i is the displacement of
mass i from its rest position:

    a_i = (k/m) (q_{i-1} - 2 q_i + q_{i+1}),   q_{-1} = q_N = 0 (the walls).

Normal modes (j = 1..N): shape sin(i j pi/(N+1)) (i = 1..N), frequency
w_j = 2 sqrt(k/m) sin(j pi/(2(N+1))). omega is the highest, w_N, which sets every explicit
scheme's stability limit (h w_N <= 2 for Verlet-type, 2 sqrt(2) for RK4).

Initial state: the middle mass (index (N-1)//2, 0-based) displaced by x0, everything at rest.
A single displaced mass excites every mode it does not sit on a node of; in the middle it
excites the highest mode with nearly the largest possible amplitude (its modal weight
|sin(i N pi/(N+1))| >= cos(pi/(2(N+1))), 0.9989 at N = 32), so stiffness matters from step one.

Exact solution: the modal (DST-I) transform of the initial state, each mode a cosine at w_j.

Damping (``c``, default 0: undamped): a dashpot c beside every spring, acting on the relative
velocity of its ends as the spring acts on their relative position (a cloth's spring damping):

    a_i += (c/m) (v_{i-1} - 2 v_i + v_{i+1}),   v_{-1} = v_N = 0.

The damping matrix is c/k times the stiffness matrix, so the normal modes stay uncoupled: mode j
is a damped oscillator at w_j with damping ratio zeta_j = c w_j / (2 k) (the highest mode the
most damped: zeta_N = c omega / (2 k)), each in closed form (``scenarios._oscillator``).
"""

import math

import numpy as np

from .scene import DampedByC, Param, Scene
from ._oscillator import damped_oscillator


def accel(q, v, t, p):
    """O(N) per batch member; the wall springs are the missing neighbours of the end masses.

    The loops are written out (batch innermost, over the contiguous axis) rather than as
    whole-batch row expressions on slices (``a[1:] += c * q[:-1]``): numba compiles those
    many times slower than the loops, and every (scheme, scene) pair compiles its
    own copy. The additions keep the row version's order, ((-2c q_i) + c q_{i-1}) + c q_{i+1},
    so results are bitwise the same. The dashpots add the same stencil on v, only where c > 0
    (an undamped chain's accelerations stay bitwise those before damping existed)."""
    c = p[1] / p[2]
    d = p[4] / p[2]
    n = q.shape[0]
    nb = q.shape[1]
    a = np.empty_like(q)
    for i in range(n):
        for b in range(nb):
            x = (-2.0 * c) * q[i, b]
            if i > 0:
                x = x + c * q[i - 1, b]
            if i < n - 1:
                x = x + c * q[i + 1, b]
            if d != 0.0:
                y = (-2.0 * d) * v[i, b]
                if i > 0:
                    y = y + d * v[i - 1, b]
                if i < n - 1:
                    y = y + d * v[i + 1, b]
                x = x + y
            a[i, b] = x
    return a


def solve(q, v, t, p, alpha, beta, r):
    """(I - alpha da/dv - beta da/dq) x = r: da/dq = (k/m) tridiag(1, -2, 1) and da/dv = (c/m) times
    the same, so with s = beta k/m + alpha c/m the matrix is tridiagonal with diagonal 1 + 2 s and
    off-diagonals -s, the same for every batch member. Thomas algorithm, O(N) per member; the matrix
    is strictly diagonally dominant, so no pivoting is needed. Loops written out, as in ``accel``,
    for the same reason: they compile several times faster."""
    c = beta * (p[1] / p[2])
    if p[4] != 0.0:
        c = c + alpha * (p[4] / p[2])
    d = 1.0 + 2.0 * c
    e = -c
    n = r.shape[0]
    nb = r.shape[1]
    cp = np.empty(n)
    x = np.empty_like(r)
    cp[0] = e / d
    for b in range(nb):
        x[0, b] = r[0, b] / d
    for i in range(1, n):
        denom = d - e * cp[i - 1]
        cp[i] = e / denom
        for b in range(nb):
            x[i, b] = (r[i, b] - e * x[i - 1, b]) / denom
    for i in range(n - 2, -1, -1):
        for b in range(nb):
            x[i, b] = x[i, b] - cp[i] * x[i + 1, b]
    return x


def constraints(p):
    """The N + 1 springs as 1-D distance constraints (``Scene.constraints``) on the displacements,
    from the left wall (an anchor at displacement 0) through the masses to the right wall, rest
    extension 0, compliance 1/k: C = q_b - q_a, whose force is the spring's. The dashpots are
    not constraints (``position_based_why``)."""
    n = int(p[0])
    ends = np.empty((n + 1, 2), np.int64)
    for i in range(n + 1):
        ends[i, 0] = i - 1
        ends[i, 1] = i
    ends[0, 0] = -1
    ends[n, 1] = -1
    compliance = np.empty(n + 1)
    for i in range(n + 1):
        compliance[i] = 1.0 / p[1]
    inv_mass = np.empty(n)
    for i in range(n):
        inv_mass[i] = 1.0 / p[2]
    return ends, np.zeros(n + 1), compliance, inv_mass, np.zeros((1, 1)), np.zeros(1)


class Chain(DampedByC, Scene):
    id = "chain"
    title = "stiff spring chain between two walls, N DOF, linear; exact solution from the normal modes"
    params = {
        # At most a million (a few arrays of N doubles, the Thomas solve O(N)): a billion masses
        # asked for on the command line exhausted 24 GiB before the first step.
        "N": Param(32, "number of masses", lo=1.0, hi=1e6, integer=True),
        "k": Param(1.0e4, "stiffness of every spring (neighbours and walls)", lo=0.0, lo_open=True),
        "m": Param(1.0, "mass of each body", lo=0.0, lo_open=True),
        "x0": Param(1.0, "initial displacement of the middle mass (index (N-1)//2), all at rest"),
        "c": Param(
            0.0, "dashpot beside every spring, on the relative velocity (mode j's damping ratio c w_j / (2 k))", lo=0.0
        ),
    }
    linear = True
    has_modes = True
    accel = staticmethod(accel)
    solve = staticmethod(solve)
    constraints = staticmethod(constraints)

    def position_based_why(self) -> str:
        if self.values["c"] != 0.0:
            return (
                f"scene chain has dashpots (c = {self.values['c']:g}), which the position-based "
                "schemes do not model: their constraints are its springs alone"
            )
        return super().position_based_why()

    def constraint_error(self, q):
        """The springs' largest extension relative to the initial displacement x0 (the chain's
        coordinates are displacements, with no rest spacing): max |q_b - q_a| / |x0| over the
        N + 1 springs (the walls at 0), API layout (..., N) -> (...)."""
        q = np.asarray(q, dtype=float)
        pad = np.zeros(q.shape[:-1] + (1,))
        ext = np.diff(np.concatenate([pad, q, pad], axis=-1), axis=-1)
        return np.max(np.abs(ext), axis=-1) / abs(self.values["x0"])

    def mode_damping_ratios(self) -> np.ndarray:
        """zeta_j = c w_j / (2 k), j = 1..N."""
        return self.values["c"] * self.mode_frequencies() / (2.0 * self.values["k"])

    @property
    def dof_names(self):
        return tuple(f"x{i}" for i in range(self.values["N"]))

    @property
    def middle(self) -> int:
        return (self.values["N"] - 1) // 2

    def initial_state(self):
        n = self.values["N"]
        q = np.zeros(n)
        q[self.middle] = self.values["x0"]
        return q, np.zeros(n)

    def mode_frequencies(self) -> np.ndarray:
        """w_j, j = 1..N."""
        n = self.values["N"]
        j = np.arange(1, n + 1)
        return 2.0 * math.sqrt(self.values["k"] / self.values["m"]) * np.sin(j * math.pi / (2.0 * (n + 1)))

    @property
    def omega(self):
        n = self.values["N"]
        return 2.0 * math.sqrt(self.values["k"] / self.values["m"]) * math.sin(n * math.pi / (2.0 * (n + 1)))

    def energy(self, q, v):
        k, m = self.values["k"], self.values["m"]
        kinetic = 0.5 * m * np.sum(v * v, axis=-1)
        stretch = np.diff(q, axis=-1)
        springs = np.sum(stretch * stretch, axis=-1) + q[..., 0] ** 2 + q[..., -1] ** 2
        return kinetic + 0.5 * k * springs

    def modal(self, q: np.ndarray) -> np.ndarray:
        """Modal coordinates: the orthonormal DST-I (its matrix is symmetric and its own inverse)."""
        from scipy.fft import dst  # here: a large import, which only the closed form needs

        return dst(q, type=1, norm="ortho", axis=-1)

    def closed_form(self, t):
        from scipy.fft import idst

        t = np.asarray(t, dtype=float)
        q0, v0 = self.initial_state()
        w = self.mode_frequencies()
        a, b = self.modal(q0), self.modal(v0)
        if self.values["c"] == 0.0:
            wt = t[:, None] * w
            cos, sin = np.cos(wt), np.sin(wt)
            q = idst(a * cos + (b / w) * sin, type=1, norm="ortho", axis=-1)
            v = idst(-a * w * sin + b * cos, type=1, norm="ortho", axis=-1)
            return q, v
        modes = [damped_oscillator(t, wj, zj, aj, bj) for wj, zj, aj, bj in zip(w, self.mode_damping_ratios(), a, b)]
        qm = np.stack([m[0] for m in modes], axis=-1)
        vm = np.stack([m[1] for m in modes], axis=-1)
        return idst(qm, type=1, norm="ortho", axis=-1), idst(vm, type=1, norm="ortho", axis=-1)

    def exact_energy(self, t):
        if self.values["c"] == 0.0:
            return super().exact_energy(t)
        q, v = self.closed_form(t)
        return self.energy(q, v)
