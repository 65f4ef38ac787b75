"""The outer solar system: the Sun (with the inner planets' mass), Jupiter, Saturn, Uranus,
Neptune and Pluto as point masses under Newtonian gravity, 3-D, 6 bodies, 18 DOF. Data and
units from Hairer, Lubich & Wanner, Geometric Numerical Integration, Sect. I.2.4 (see
``data/outer_solar_system.csv``): AU, days, solar masses, G = 2.95912208286e-4. The initial state
is the book's, heliocentric (the Sun at rest at the origin), not moved to the centre of mass.

    a_i = sum_{j != i} G m_j (q_j - q_i) / |q_j - q_i|^3

O(N^2) pairs, summed as REBOUND's ``gravity="basic"`` sums them (pairs (i, j < i) in order,
``r = sqrt(dx*dx+dy*dy+dz*dz); pre = G/(r*r*r)``), so a leapfrog can match REBOUND's bitwise.

No closed form: ``reference_solution(t)`` is a DOP853 solve at rtol = 1e-13, cached. Against a
solve at rtol = 3e-14 it agrees to 6e-12 AU up to 1e4 days and 7e-10 AU up to 2e5 days (velocities
1e-12 AU/day), and keeps |dE/E| below 1.3e-12: ``reference_horizon`` = 2e5 days, the span measured.
omega is Jupiter's mean motion (the fastest orbit; period about 4332 days). The study the
issue asks for runs 2e5 days at dt = 10 days (SUGGESTED_DT, SUGGESTED_T_END).
"""

import math
from importlib import resources

import numpy as np

from .scene import Scene
from ._solutions import SegmentedSolution, cached

#: G in AU^3 / (solar mass day^2), the value the data set is given with.
G = 2.95912208286e-4
SUGGESTED_DT = 10.0
SUGGESTED_T_END = 2.0e5


def load_bodies() -> tuple[tuple[str, ...], np.ndarray, np.ndarray, np.ndarray]:
    """(names, masses (6,), positions (6, 3), velocities (6, 3)) from the packaged CSV."""
    text = resources.files(__package__).joinpath("data/outer_solar_system.csv").read_text()
    rows = [line.split(",") for line in text.splitlines() if line.strip() and not line.startswith("#")]
    header, body = rows[0], rows[1:]
    assert header == ["name", "mass", "x", "y", "z", "vx", "vy", "vz"], header
    names = tuple(r[0] for r in body)
    data = np.array([[float(x) for x in r[1:]] for r in body])
    return names, data[:, 0].copy(), data[:, 1:4].copy(), data[:, 4:7].copy()


def accel(q, v, t, p):
    # p = (G, m_0, ..., m_{n-1}); body i occupies rows 3i, 3i+1, 3i+2. Scalar updates in a loop
    # over the batch, not whole-row array expressions: the same operations in the same order
    # (bitwise the same accelerations), but row expressions allocate a temporary per operation,
    # which made the row form several times slower to compile, to run compiled and to run
    # interpreted (docs/performance.md).
    g = p[0]
    n = q.shape[0] // 3
    a = np.zeros_like(q)
    for i in range(n):
        for j in range(i):
            mi, mj = p[1 + i], p[1 + j]
            for b in range(q.shape[1]):
                dx = q[3 * i, b] - q[3 * j, b]
                dy = q[3 * i + 1, b] - q[3 * j + 1, b]
                dz = q[3 * i + 2, b] - q[3 * j + 2, b]
                r = np.sqrt(dx * dx + dy * dy + dz * dz)
                pre = g / (r * r * r)
                prej = -pre * mj
                prei = pre * mi
                a[3 * i, b] = a[3 * i, b] + prej * dx
                a[3 * i + 1, b] = a[3 * i + 1, b] + prej * dy
                a[3 * i + 2, b] = a[3 * i + 2, b] + prej * dz
                a[3 * j, b] = a[3 * j, b] + prei * dx
                a[3 * j + 1, b] = a[3 * j + 1, b] + prei * dy
                a[3 * j + 2, b] = a[3 * j + 2, b] + prei * dz
    return a


def solve(q, v, t, p, alpha, beta, r):
    """(I - beta da/dq) x = r (gravity has no da/dv), a dense 3n x 3n system per batch member.
    With d = q_i - q_j and B = G (I/|d|^3 - 3 d d^T/|d|^5), the Jacobian has blocks
    da_i/dq_j = m_j B, da_j/dq_i = m_i B, da_i/dq_i -= m_j B, da_j/dq_j -= m_i B."""
    g = p[0]
    ndof, nb = r.shape
    n = ndof // 3
    x = np.empty_like(r)
    for b in range(nb):
        jac = np.zeros((ndof, ndof))
        for i in range(n):
            for j in range(i):
                d = q[3 * i : 3 * i + 3, b] - q[3 * j : 3 * j + 3, b]
                r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
                rr = np.sqrt(r2)
                blk = (-3.0 * g / (r2 * r2 * rr)) * np.outer(d, d)
                for k in range(3):
                    blk[k, k] += g / (r2 * rr)
                jac[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] += p[1 + j] * blk
                jac[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] -= p[1 + j] * blk
                jac[3 * j : 3 * j + 3, 3 * i : 3 * i + 3] += p[1 + i] * blk
                jac[3 * j : 3 * j + 3, 3 * j : 3 * j + 3] -= p[1 + i] * blk
        mat = np.eye(ndof) - beta * jac
        x[:, b] = np.linalg.solve(mat, np.ascontiguousarray(r[:, b]))
    return x


def _rhs_vectorised(masses: np.ndarray):
    """dy/dt for y = (q, v) flattened, for the reference solve: the same forces, vectorised over
    pairs (the kernel's row loops are too slow for the tens of thousands of calls DOP853 makes)."""
    n = masses.size
    gm = G * masses

    def rhs(t, y):
        q = y[: 3 * n].reshape(n, 3)
        d = q[None, :, :] - q[:, None, :]  # d[i, j] = q_j - q_i
        r2 = np.einsum("ijk,ijk->ij", d, d)
        np.fill_diagonal(r2, 1.0)
        inv3 = r2**-1.5
        np.fill_diagonal(inv3, 0.0)
        a = np.einsum("ij,ijk->ik", inv3 * gm[None, :], d)
        return np.concatenate([y[3 * n :], a.reshape(-1)])

    return rhs


class SolarSystem(Scene):
    id = "solar_system"
    title = "outer solar system (Sun + 4 giants + Pluto), 3-D, 18 DOF; reference by DOP853"
    params = {}
    reference_horizon = 2.0e5

    def __init__(self, **overrides):
        super().__init__(**overrides)
        self.names, self.masses, self._q0, self._v0 = load_bodies()

    accel = staticmethod(accel)
    solve = staticmethod(solve)

    @property
    def dof_names(self):
        return tuple(f"{name}_{c}" for name in self.names for c in "xyz")

    @property
    def pvec(self):
        return np.concatenate([[G], self.masses])

    def initial_state(self):
        return self._q0.reshape(-1).copy(), self._v0.reshape(-1).copy()

    @property
    def omega(self):
        # Jupiter's mean motion n = sqrt(mu / a^3), a from the osculating heliocentric orbit
        # (vis-viva: 1/a = 2/r - v^2/mu).
        mu = G * (self.masses[0] + self.masses[1])
        dq = self._q0[1] - self._q0[0]
        dv = self._v0[1] - self._v0[0]
        a = 1.0 / (2.0 / np.linalg.norm(dq) - dv @ dv / mu)
        return float(math.sqrt(mu / a**3))

    def energy(self, q, v):
        n = self.masses.size
        m = self.masses
        vv = v.reshape(v.shape[:-1] + (n, 3))
        qq = q.reshape(q.shape[:-1] + (n, 3))
        e = 0.5 * np.sum(m * np.sum(vv * vv, axis=-1), axis=-1)
        for i in range(n):
            for j in range(i):
                d = qq[..., i, :] - qq[..., j, :]
                e = e - G * m[i] * m[j] / np.sqrt(np.sum(d * d, axis=-1))
        return e

    def escaped(self, q, v):
        """Per state (API layout (..., 18)), whether a planet is on an unbound orbit about the
        Sun: its heliocentric two-body energy v^2/2 - G (M_sun + m)/r >= 0 (it leaves the system)."""
        n = self.masses.size
        qq = q.reshape(q.shape[:-1] + (n, 3))
        vv = v.reshape(v.shape[:-1] + (n, 3))
        dq, dv = qq[..., 1:, :] - qq[..., :1, :], vv[..., 1:, :] - vv[..., :1, :]
        mu = G * (self.masses[0] + self.masses[1:])
        e = 0.5 * np.sum(dv * dv, axis=-1) - mu / np.sqrt(np.sum(dq * dq, axis=-1))
        return np.any(e >= 0.0, axis=-1)

    def events(self, step, t, q, v):
        """Each planet's ejection (heliocentric two-body energy no longer negative, as ``escaped``),
        at the first recorded state it happens, with its distance from the Sun."""
        n = self.masses.size
        qq, vv = q.reshape(-1, n, 3), v.reshape(-1, n, 3)
        dq, dv = qq[:, 1:, :] - qq[:, :1, :], vv[:, 1:, :] - vv[:, :1, :]
        mu = G * (self.masses[0] + self.masses[1:])
        with np.errstate(all="ignore"):
            r = np.sqrt(np.sum(dq * dq, axis=-1))
            e = 0.5 * np.sum(dv * dv, axis=-1) - mu / r
        out = []
        for k, name in enumerate(self.names[1:]):
            unbound = np.flatnonzero(~(e[:, k] < 0.0))
            if unbound.size:
                i = int(unbound[0])
                out.append(
                    {
                        "kind": "ejected",
                        "body": name,
                        "step": int(step[i]),
                        "t": float(t[i]),
                        "r": float(r[i, k]),
                        "text": f"{name} ejected (unbound from the Sun) by step {int(step[i])}, at {r[i, k]:.3g} AU",
                    }
                )
        return sorted(out, key=lambda ev: ev["step"])

    # ------------------------------------------------------------ reference
    def _reference(self, rtol) -> SegmentedSolution:
        q0, v0 = self.initial_state()
        key = (self.id, rtol)
        # atol: far below the smallest velocity that matters (the Sun's wobble, ~1e-6 AU/day).
        return cached(
            key,
            lambda: SegmentedSolution(
                _rhs_vectorised(self.masses), np.concatenate([q0, v0]), segment=1.0e4, rtol=rtol, atol=rtol * 1e-4
            ),
        )

    def reference_solution(self, t, rtol=1e-13):
        """(q, v) at times t (days) from DOP853 at rtol = 1e-13, shape (len(t), 18)."""
        y = self._reference(rtol)(t)
        return y[:, :18].copy(), y[:, 18:].copy()
