"""A rope of N rigid links in 2-D under gravity, pinned at the origin: point masses m at the N
link ends, every link of rest length l. DOF: (x1, y1, ..., xN, yN), mass 1 at the end of the
pinned link, mass N at the free end; gravity is -g along y.

The links are constraints, not forces: ``accel`` is gravity alone and a constrained scheme
(``ref:verlet_constrained``) holds the lengths with ``project``, the position-based (Jakobsen)
projection: ``iterations`` Gauss-Seidel passes over the links from the pin outwards, each link
moved back to length l along itself, both ends by half the correction (equal masses), or the
free one by all of it for the link at the pin. An unconstrained scheme would integrate N
particles in free fall.

Initial configuration: the rope straight and horizontal along +x (x_i = i l, y_i = 0),
released from rest. Energy = kinetic + gravitational, the potential measured from the rope
hanging straight down at rest (y_i = -i l), so E >= 0 and E0 = m g l N(N+1)/2.

No closed form: ``reference_solution(t)`` integrates the reduced model (the N absolute link
angles theta_j from the downward vertical) with DOP853 at rtol = atol = 1e-12 and maps it to
Cartesian positions and velocities. With c_jk = N - max(j, k) (0-based: how many masses hang at
or beyond link max(j, k)), the Lagrange equations are

    sum_k c_jk cos(theta_j - theta_k) theta_k'' = -sum_k c_jk sin(theta_j - theta_k) theta_k'^2
                                                  - (g/l) c_jj sin(theta_j).

Measured accuracy of the default rope (N = 10) against an rtol = atol = 1e-13 solve: positions
5e-13, velocities 6e-12 up to t = 2; 6e-10 and 8e-9 up to t = 3. The released rope whips and is
chaotic (differences grow about 1000-fold per second), so two accurate solves part completely by
t = 5: ``reference_horizon`` = 3 (s) is how far it may be used as the truth. ``exact`` stays None.
"""

import math

import numpy as np
from scipy.linalg import eigh

from .scene import Param, Scene
from ._solutions import SegmentedSolution, cached


def accel(q, v, t, p):
    a = np.zeros_like(q)
    a[1::2] = -p[3]
    return a


def solve(q, v, t, p, alpha, beta, r):
    # Gravity does not depend on the state: the implicit matrix is the identity.
    return r.copy()


def project(q, p, iterations):
    """Jakobsen projection of the link lengths, Gauss-Seidel from the pin (fixed at the origin)
    outwards, ``iterations`` passes, O(N) per pass and batch member.

    The batch loop is written out (innermost, over the contiguous axis) rather than as
    whole-batch row expressions: a link update is ten scalar operations, and row expressions
    allocate a temporary for each, which at batch 1 made a compiled pass 7x slower and the
    interpreted one 3x slower (docs/performance.md)."""
    l = p[1]
    n = q.shape[0] // 2
    nb = q.shape[1]
    q = q.copy()
    for _ in range(iterations):
        for b in range(nb):
            # The pinned link: only its outer end moves.
            dx = q[0, b]
            dy = q[1, b]
            d = np.sqrt(dx * dx + dy * dy)
            s = (d - l) / d
            q[0, b] = dx - s * dx
            q[1, b] = dy - s * dy
        for i in range(1, n):
            for b in range(nb):
                dx = q[2 * i, b] - q[2 * i - 2, b]
                dy = q[2 * i + 1, b] - q[2 * i - 1, b]
                d = np.sqrt(dx * dx + dy * dy)
                s = 0.5 * (d - l) / d
                q[2 * i - 2, b] += s * dx
                q[2 * i - 1, b] += s * dy
                q[2 * i, b] -= s * dx
                q[2 * i + 1, b] -= s * dy
    return q


def constraints(p):
    """The links as rigid distance constraints (``Scene.constraints``: compliance 0, rest length
    l) from the pin (the anchor at the origin) outwards, as ``project`` takes them; gravity -g
    along y."""
    n = int(p[0])
    ends = np.empty((n, 2), np.int64)
    for i in range(n):
        ends[i, 0] = i - 1
        ends[i, 1] = i
    rest = np.empty(n)
    inv_mass = np.empty(n)
    for i in range(n):
        rest[i] = p[1]
        inv_mass[i] = 1.0 / p[2]
    gravity = np.zeros(2)
    gravity[1] = -p[3]
    return ends, rest, np.zeros(n), inv_mass, np.zeros((1, 2)), gravity


#: DOP853 tolerance (relative and absolute, on angles and angular velocities) of the reference.
REFERENCE_RTOL = 1e-12


class Rope(Scene):
    id = "rope"
    title = "pinned rope of N rigid links under gravity, 2-D, released horizontal; reference by DOP853"
    params = {
        "N": Param(10, "number of links (= point masses)", lo=1.0, hi=1e6, integer=True),  # as the chain's
        "l": Param(0.1, "rest length of each link", lo=0.0, lo_open=True),
        "m": Param(0.1, "mass at each link end", lo=0.0, lo_open=True),
        "g": Param(9.81, "gravitational acceleration", lo=0.0),
    }
    accel = staticmethod(accel)
    solve = staticmethod(solve)
    project = staticmethod(project)
    constraints = staticmethod(constraints)
    reference_horizon = 3.0

    @property
    def dof_names(self):
        return tuple(f"{c}{i}" for i in range(1, self.values["N"] + 1) for c in "xy")

    def initial_state(self):
        n, l = self.values["N"], self.values["l"]
        q = np.zeros(2 * n)
        q[0::2] = l * np.arange(1, n + 1)
        return q, np.zeros(2 * n)

    @property
    def omega(self):
        """The highest normal-mode frequency of the rope linearised about hanging straight down:
        the stiffest motion a scheme has to resolve (it grows like sqrt(N g / l))."""
        n, l, g = self.values["N"], self.values["l"], self.values["g"]
        c = n - np.maximum.outer(np.arange(n), np.arange(n)).astype(float)
        if g == 0.0:
            return 1.0 / math.sqrt(n)  # no restoring force: any scale will do; keep it finite
        w2 = eigh((g / l) * np.diag(np.diag(c)), c, eigvals_only=True)
        return float(math.sqrt(w2[-1]))

    def energy(self, q, v):
        n, l, m, g = self.values["N"], self.values["l"], self.values["m"], self.values["g"]
        kinetic = 0.5 * m * np.sum(v * v, axis=-1)
        height = q[..., 1::2] + l * np.arange(1, n + 1)
        return kinetic + m * g * np.sum(height, axis=-1)

    def constraint_error(self, q) -> np.ndarray:
        """Largest relative stretch max_j |d_j - l| / l over the links, API layout (..., 2N) -> (...)."""
        l = self.values["l"]
        x = np.concatenate([np.zeros(q.shape[:-1] + (1,)), q[..., 0::2]], axis=-1)
        y = np.concatenate([np.zeros(q.shape[:-1] + (1,)), q[..., 1::2]], axis=-1)
        d = np.hypot(np.diff(x, axis=-1), np.diff(y, axis=-1))
        return np.max(np.abs(d - l), axis=-1) / l

    # ------------------------------------------------------------ reference
    def _angles_rhs(self):
        n, l, g = self.values["N"], self.values["l"], self.values["g"]
        c = n - np.maximum.outer(np.arange(n), np.arange(n)).astype(float)
        gl = (g / l) * np.diag(c)

        def rhs(t, y):
            th, om = y[:n], y[n:]
            diff = th[:, None] - th[None, :]
            mass = c * np.cos(diff)
            force = -(c * np.sin(diff)) @ (om * om) - gl * np.sin(th)
            return np.concatenate([om, np.linalg.solve(mass, force)])

        return rhs

    def _reference(self, rtol=REFERENCE_RTOL) -> SegmentedSolution:
        n = self.values["N"]
        y0 = np.concatenate([np.full(n, 0.5 * math.pi), np.zeros(n)])
        key = (self.id, tuple(self.values.items()), rtol)
        return cached(key, lambda: SegmentedSolution(self._angles_rhs(), y0, segment=1.0, rtol=rtol, atol=rtol))

    def angles_to_state(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(theta, theta') of shape (..., 2N) -> Cartesian (q, v) of shape (..., 2N)."""
        n, l = self.values["N"], self.values["l"]
        th, om = y[..., :n], y[..., n:]
        s, c = np.sin(th), np.cos(th)
        q = np.empty(y.shape[:-1] + (2 * n,))
        v = np.empty_like(q)
        q[..., 0::2] = l * np.cumsum(s, axis=-1)
        q[..., 1::2] = -l * np.cumsum(c, axis=-1)
        v[..., 0::2] = l * np.cumsum(c * om, axis=-1)
        v[..., 1::2] = l * np.cumsum(s * om, axis=-1)
        return q, v

    def reference_solution(self, t, rtol=REFERENCE_RTOL):
        """(q, v) at times t from the reduced (joint-angle) model, shape (len(t), 2N); see the
        module docstring for its accuracy."""
        return self.angles_to_state(self._reference(rtol)(t))
