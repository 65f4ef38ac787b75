from dataclasses import dataclass, replace

import numpy as np

from records import InvalidInput
from records.method_id import Option

from ..kinds import COUNT_BASE, PositionBased
from .._scheme import Floor, scheme
from ._position_based import point_inv_mass, project, row, spring_data

#: Substeps and Jacobi passes per step unless the caller sets ``substeps``/``iterations``: the
#: passes are Newton's SolverXPBD default (``iterations=2``), the solver this scheme is the
#: float64 form of.
DEFAULT_SUBSTEPS = 1
DEFAULT_ITERATIONS = 2
#: The relaxation factor unless the caller sets ``relaxation``: the summed corrections applied whole,
#: as SolverXPBD applies its springs'.
DEFAULT_RELAXATION = 1.0
#: The relaxation is a decimal of at most three places in (0, 2]: the compiled loops pass the
#: step one integer (``kinds.pack_counts``), which carries it in thousandths above the two counts;
#: the step divides by 1000, the correctly rounded quotient being the double the decimal names.
RELAXATION_STEPS = 1000
RELAXATION_MAX = 2.0
#: Where the relaxation sits in the packed integer: above substeps * COUNT_BASE + iterations.
RELAXATION_BASE = COUNT_BASE * COUNT_BASE


@dataclass(frozen=True, eq=False)
class JacobiPositionBased(PositionBased):
    """Position-based dynamics with Jacobi passes: the position-based kind's step and counts, and
    a relaxation factor (an option that sets a constant of the step, not a count the loops pass
    by name), carried by the kind the scheme is bound to (``with_parameters``) into the one
    integer every compiled loop passes (``count``: thousandths above the two counts)."""

    relaxation: float | None = None

    def _relaxation(self) -> float:
        return DEFAULT_RELAXATION if self.relaxation is None else self.relaxation

    def count(self, scheme, scene, iterations=None, substeps=None) -> int:
        code = int(round(self._relaxation() * RELAXATION_STEPS))
        return code * RELAXATION_BASE + super().count(scheme, scene, iterations, substeps)

    def advance(self, scheme, scene, dt, kernels, iterations=None, substeps=None):
        p, step = scene.pvec, scheme.step
        relaxation = int(round(self._relaxation() * RELAXATION_STEPS)) / RELAXATION_STEPS
        args = (kernels["accel"], kernels["constraints"], *self._counts(scheme, iterations, substeps), relaxation)
        return lambda state, t: step(*args, state, t, dt, p)

    def count_args(self, count="k"):
        return [
            f"({count} // {COUNT_BASE}) % {COUNT_BASE}",
            f"{count} % {COUNT_BASE}",
            f"({count} // {RELAXATION_BASE}) / {RELAXATION_STEPS:.1f}",
        ]

    def in_memory_loop(self, jit, step, accel, scene_cls):
        constraints = jit(scene_cls.constraints)

        def advance_n(state, t0, h, i0, n, p, k):
            for i in range(i0, i0 + n):
                state = step(
                    accel,
                    constraints,
                    (k // COUNT_BASE) % COUNT_BASE,
                    k % COUNT_BASE,
                    (k // RELAXATION_BASE) / RELAXATION_STEPS,
                    state,
                    t0 + i * h,
                    h,
                    p,
                )
            return state

        return jit(advance_n)

    def parameters(self, scheme) -> dict:
        return {
            "relaxation": Option(
                "relaxation",
                float,
                1.0 / RELAXATION_STEPS,
                RELAXATION_MAX,
                "the factor the summed corrections of a pass are applied by (thousandths)",
                default=DEFAULT_RELAXATION,
            )
        }

    def with_parameters(self, scheme, values: dict):
        if "relaxation" not in values:
            return scheme
        r = float(values["relaxation"])
        code = round(r * RELAXATION_STEPS)
        if code / RELAXATION_STEPS != r:
            raise InvalidInput(
                f"method {scheme.id}: option relaxation={values['relaxation']} is not a multiple of "
                f"{1.0 / RELAXATION_STEPS:g} (allowed: number from {1.0 / RELAXATION_STEPS:g} to "
                f"{RELAXATION_MAX:g} in thousandths)"
            )
        return replace(scheme, kind=replace(self, relaxation=r))

    def parameter_values(self, scheme) -> dict:
        return {} if self.relaxation is None else {"relaxation": self.relaxation}

    def evals_text(self, scheme) -> str:
        return (
            f"{scheme.force_evals} (the forces are constraints: {scheme.substeps} substep(s) x "
            f"{scheme.iterations} Jacobi pass(es) over them)"
        )


JACOBI = JacobiPositionBased()


def floor(s, h, k, m):
    # The spring as the kernel reads it (``floor_start``), one constraint: a Jacobi pass is its
    # correction, summed from 0 and then applied, times the relaxation the kernel reads (1000
    # thousandths, divided as the scheme divides them), gradient 1. One substep, the default passes.
    x, v, tilde, denominator, relaxation, anchor, rest, wb, g = s
    x_old = x
    v = v + h * g
    x = x + h * v
    lam = 0.0
    for _ in range(DEFAULT_ITERATIONS):
        dl = relaxation * ((-(x - anchor - rest) - tilde * lam) / denominator)
        lam = lam + dl
        x = x + (0.0 + wb * dl * 1.0)
    return (x, (x - x_old) / h, tilde, denominator, relaxation, anchor, rest, wb, g)


def floor_start(x, v, h, k, m):
    anchor, rest, compliance, wa, wb, g = spring_data(k, m)
    tilde = compliance / (h * h)
    relaxation = round(DEFAULT_RELAXATION * RELAXATION_STEPS) / RELAXATION_STEPS
    return (x, v, tilde, wa + wb + tilde, relaxation, anchor, rest, wb, g)


@scheme(
    kind=JACOBI,
    order=1,
    force_evals=0,
    symplectic=False,
    energy_claim="decays",
    homega_max=float("inf"),
    substeps=DEFAULT_SUBSTEPS,
    iterations=DEFAULT_ITERATIONS,
    floor=Floor(floor, floor_start, scene_data=7),
    # No scene of the standard suite: it is there to identify Newton's XPBD, which the identity
    # cells hold every scheme against; the full suite runs it wherever it can.
    suites={},
)
def xpbd_jacobi(accel, constraints, substeps, iterations, relaxation, state, t, h, p):
    """XPBD with Jacobi passes (Macklin, Mueller and Chentanez 2016, projected in parallel as
    Newton's SolverXPBD projects particle springs): in each of ``substeps`` substeps of hs,

        v~ = v + hs g,  x~ = x + hs v~,  lambda = 0
        ``iterations`` Jacobi passes, alpha~ = alpha / hs^2, every constraint from the same x:
            dlambda = omega (-C(x) - alpha~ lambda) / (w_a + w_b + alpha~),  lambda += dlambda,
            dx_a -= w_a dlambda grad C,  dx_b += w_b dlambda grad C;  then x += dx
        v = (x - x_old) / hs

    omega the ``relaxation`` factor (1: the corrections summed and applied whole). On one spring a
    pass is XPBD's Gauss-Seidel pass (implicit Euler on the unit spring); on coupled springs each
    point takes every correction computed from the same positions, which overshoots where a point
    has several (omega < 1 damps that) and converges more slowly than Gauss-Seidel, if at all.
    First order, damps like implicit Euler where it converges. No force evaluation.
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
    # One array a step, as XPBD's: x (returned as q), the anchors' rows, the multipliers' rows,
    # x_old, u (returned as v), then a pass's summed corrections, a row per row of x (an anchor's
    # correction would never be applied: it is not summed); the state copied in, then only the
    # array read (``_position_based``).
    fixed = anchors.shape[0] * d
    lam = n + fixed  # the first multiplier's row
    x_old = lam + ends.shape[0]
    u = x_old + n
    delta = u + n
    work = np.empty((delta + n, nb))
    work[:n] = q
    work[u : u + n] = v
    # The anchors' rows, read by the projection where d > 1; a 1-D pass reads an anchor from
    # ``anchors`` itself (one value for the whole batch), so there they are not filled (written
    # each step in the compiled loop, they would be a row stored for nothing).
    if d > 1:
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
            for r in range(n):
                for b in range(nb):
                    work[delta + r, b] = 0.0
            for c in range(ends.shape[0]):
                ra = row(ends[c, 0], n, d)
                rb = row(ends[c, 1], n, d)
                wa = point_inv_mass(inv_mass, ends[c, 0])
                wb = point_inv_mass(inv_mass, ends[c, 1])
                if d > 1:
                    # Summed into the corrections' rows, from delta on.
                    project(
                        work,
                        ra,
                        ends[c, 0] >= 0,
                        rb,
                        ends[c, 1] >= 0,
                        d,
                        rest[c],
                        wa,
                        wb,
                        lam + c,
                        tilde[c],
                        denominator[c],
                        0.0,
                        delta,
                        relaxation,
                    )
                    continue
                # d = 1: C = x_b - x_a - rest, gradient 1, written out (no call, no branch in the
                # loop over the batch: it vectorises). An anchored end's correction is not summed
                # (it would never be applied), and its position, the same for every spring of the
                # batch, is read once, from ``anchors`` (an anchor i < 0 is anchors[-1 - i]).
                if ends[c, 0] >= 0 and ends[c, 1] >= 0:
                    for b in range(nb):
                        dl = relaxation * (
                            (-(work[rb, b] - work[ra, b] - rest[c]) - tilde[c] * work[lam + c, b]) / denominator[c]
                        )
                        work[lam + c, b] = work[lam + c, b] + dl
                        work[delta + ra, b] = work[delta + ra, b] - wa * dl * 1.0
                        work[delta + rb, b] = work[delta + rb, b] + wb * dl * 1.0
                elif ends[c, 1] >= 0:
                    at_a = anchors[-1 - ends[c, 0], 0]
                    for b in range(nb):
                        dl = relaxation * (
                            (-(work[rb, b] - at_a - rest[c]) - tilde[c] * work[lam + c, b]) / denominator[c]
                        )
                        work[lam + c, b] = work[lam + c, b] + dl
                        work[delta + rb, b] = work[delta + rb, b] + wb * dl * 1.0
                elif ends[c, 0] >= 0:
                    at_b = anchors[-1 - ends[c, 1], 0]
                    for b in range(nb):
                        dl = relaxation * (
                            (-(at_b - work[ra, b] - rest[c]) - tilde[c] * work[lam + c, b]) / denominator[c]
                        )
                        work[lam + c, b] = work[lam + c, b] + dl
                        work[delta + ra, b] = work[delta + ra, b] - wa * dl * 1.0
            for r in range(n):
                for b in range(nb):
                    work[r, b] = work[r, b] + work[delta + r, b]
        # v = (x - x_old) / hs
        for r in range(n):
            for b in range(nb):
                work[u + r, b] = (work[r, b] - work[x_old + r, b]) / hs
    return (work[:n], work[u : u + n])
