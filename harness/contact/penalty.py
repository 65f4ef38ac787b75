"""The reference schemes on a penalty ground (``scenarios.penalty_ball``): what ONE impact keeps of
the speed against h*omega_c, beside the analytic truth; how many bounces a dropped ball makes before
it rests, apart; the seed's "lively bounces go dead" judged on them.

**One impact** (the table's figure). Each phase starts the ball in flight just above the ground,
x0 = s h v_in with s = (j + 1/2) / ``PHASES`` (j = 0 ... PHASES - 1), moving down at v_in = ``V_IN``: the
first contact falls at the fraction s of a step, evenly over the step. The scheme steps it (every
phase in one batch, on its compiled loop) until the ball is back above the surface moving up (x >= 0,
v > 0, at the end of a step); v_out is the speed there, and the figure is v_out / v_in, its mean over
the phases and its range (min, max). A phase that has not left after ``IMPACT_WINDOW`` contact
durations keeps 0 (it rests in the ground), or blew up where its motion in the ground grew. Gravity
and the flight are made negligible: g = ``G_IMPACT``, so g / (omega_c v_in) = 1e-9 and g h / v_in <=
1e-7 on the grid (stated with the table): the flight's speed after the exit is the speed at the
surface to that share, and no correction for gravity over the last partial flight is made. The truth
is the exact motion's e = exp(-pi zeta / sqrt(1 - zeta^2)) (gravity's share of it, 1e-9, is below
the printing).

**Closed forms.** On the contact's linear system (y'' = -omega^2 y - 2 zeta omega y', gravity
neglected) a one-step scheme is a linear map with eigenvalues lambda, conj(lambda): y_n = Re(c
lambda^n) and v_n = Re(d lambda^n), so over pi / arg(lambda) steps both turn over and shrink by
|lambda|^(pi / arg lambda): the discrete restitution, the contact entered and left at y = 0 of the
interpolating motion. With mu = omega (-zeta + i sqrt(1 - zeta^2)) the contact's eigenvalue, explicit
Euler has lambda = 1 + h mu and implicit Euler lambda = 1 / (1 - h mu); at zeta = 0 these are
(1 + (h omega)^2)^(+pi / (2 atan(h omega))) and (1 + (h omega)^2)^(-pi / (2 atan(h omega))). The exact
motion's own lambda, exp(h mu), gives e at every h. For RK4, Verlet, midpoint and semi-implicit
Euler the truth is the exact motion (the symplectic three have |lambda| = 1 at zeta = 0 below their
limits, so their half turn keeps e; what they do besides is the step that straddles the kink).

Where the phase mean differs from the closed form, it is the partial steps at entry and exit: the
closed form enters and leaves at y = 0 of the interpolating motion, a step enters at s h into a step
and the ball is read at the end of the first step that ends above the surface (for implicit Euler
that step is a free flight; explicit Euler's entering step is one). Where the half turn is a whole
number N of steps (arg lambda = pi / N) the phase does not matter: N steps map the entering state to
-|lambda|^N times itself, and the closed form holds at every phase. So implicit and explicit Euler
at h omega_c = 1 (arg lambda = pi / 4, zeta = 0): 0.2500 and 4.000, range 0.2500-0.2500 and
4.000-4.000. Measured at 64 phases (``tests/test_penalty.py`` checks them): implicit Euler, zeta = 0,
equals its closed form to 1e-4 at h omega_c <= 1 and exceeds it past that, 0.1055 against 0.1019 at
2 (+3.5%), 0.0592 against 0.0553 at 3, where the contact is 2 to 3 steps and the step that
straddles the surface is a large share of it; explicit Euler, zeta = 0, matches to 1e-3 at h omega_c
<= 0.3 (1.170 at 0.1) and scatters widely past 2 (201 against 138 at 10, range 104-297). At zeta > 0
the closed forms hold to the same degree at h omega_c <= 1 (implicit Euler 0.2021 against 0.2029 at
1, e = 0.8; explicit Euler 0.937 against 0.937 at 0.1).

**Implicit Euler, solved exactly** (``implicit_euler_step``): x1 = x0 + h v1, v1 = v0 + h a(x1, v1)
is piecewise linear in x1: outside (x1 >= 0) a = -g, inside (x1 < 0) a = -g - omega^2 x1 - 2 zeta
omega v1. Each branch is solved in closed form and kept where its x1 is on its side (consistent).
Where neither is (only entering the ground with zeta > 0: the dashpot's force jumps on at the surface,
to 2 zeta omega |v|), the solution is the complementarity point x1 = 0, v1 = -x0 / h, whose
acceleration (v1 - v0) / h then lies between the two branches' accelerations at x = 0 (Filippov's
convex hull). With gravity negligible that happens where s >= 1 / (1 + 2 zeta h omega): a share
2 zeta h omega / (1 + 2 zeta h omega) of impacts (1.4% at h omega_c = 0.1, 12.4% at 1, at e = 0.8).
Leaving the ground with zeta > 0 the step can have two solutions (both branches consistent: the
dashpot's pull switches off at the surface); the one taken is the one continued from the start
state, h grown from 0: the start's branch while it is consistent. Taking the other instead moves no
phase mean of the grid by more than 0.002. This is implicit Euler's row; the harness's generic
``ref:implicit_euler`` (Newton from w = v0, on the same equation) is run too, each of its steps'
residuals checked (``unsolved_steps``): where a step's solve failed (at e = 0.8 Newton flips between
the two inconsistent branches until its cap) its figure is not printed, only the count of unsolved
steps. Implicit midpoint, Newton only, likewise.

**Bounces to rest** (apart). The ball is dropped from ``DROP`` m at the scene's g and run as long as
its own motion needs: until it rests (in the ground for ``REST_CONTACTS`` contact durations
without leaving), blows up (a state not finite), runs away (an apex past ``RUNAWAY`` drop heights)
or reaches ``BOUNCE_CAP`` bounces; never cut at the exact motion's length. Flights are stepped in one
compiled call each to three steps before the ballistic landing; contacts are recorded at every step
(a Newton scheme's, its residuals checked) or at every sixteenth of a contact (the others); a
bounce is a contact the ball leaves (x >= 0, v > 0). Each bounce's ratio is the surface speeds' (each
from the state next to the surface, sqrt(v^2 + 2 g x): the flight's energy, exact for a ballistic
flight). The exact motion's count is solved in closed form (``exact_bounces``).

**Verdicts**, on the phase mean against the exact e: "gains energy" where it exceeds 1 by more than
``GAIN`` (the ball leaves faster than it came: energy gained, whatever e); "too lively" where it
exceeds e by more than ``TOLERANCE`` (0.05) without that; "dead" under ``DEAD`` of e; "loses energy"
below e by more than the tolerance; "within" where every phase is within the tolerance; "scatters"
where the mean is and a phase is not; "blows up" where a phase's run diverged (or grew in the ground
without leaving); "unsolved" where a Newton solve failed.

The rows travel as dicts (``penalty_rows``) or a tidy DataFrame (``penalty_table``), one per
(scheme, e, h*omega_c).
"""

from __future__ import annotations

import functools
import math

import numpy as np

#: The log grid of h*omega_c the issue asks for, 0.01 to 100 through 0.1, 0.3, 1, 2 and 10.
GRID = (0.01, 0.03, 0.1, 0.3, 1.0, 2.0, 3.0, 10.0, 30.0, 100.0)
#: The schemes of the table: the five the seed names (explicit, semi-implicit Euler, Verlet, RK4,
#: implicit Euler) and implicit midpoint, the implicit scheme that keeps energy.
SCHEMES = (
    "ref:explicit_euler",
    "ref:semi_implicit_euler",
    "ref:velocity_verlet",
    "ref:rk4",
    "ref:implicit_midpoint",
    "ref:implicit_euler",
)
RESTITUTIONS = (1.0, 0.8)
#: The ground's natural frequency of the table (rad/s).
OMEGA_C = 1000.0
#: Offsets of the first contact within a step, evenly spaced.
PHASES = 64
#: The impact's speed (m/s) and the gravity of the impact runs (m/s^2): g / (omega_c v_in) = 1e-9.
V_IN = 1.0
G_IMPACT = 1e-6
#: A phase not out of the ground after this many contact durations (pi / omega_d) keeps 0.
IMPACT_WINDOW = 4
#: A phase's v_out / v_in must be within this of the exact e to be within.
TOLERANCE = 0.05
#: An impact gains energy where its phase mean exceeds 1 by more than this (the ball leaves faster
#: than it came, whatever e).
GAIN = 0.01
#: An impact is dead where it keeps less than this fraction of the exact e.
DEAD = 0.1
#: The drop of the bounces-to-rest run (m), and its cap of bounces (the exact motion makes 23 at
#: e = 0.8 and never rests at e = 1).
DROP = 1.0
BOUNCE_CAP = 30
#: A ball in the ground this many contact durations without leaving rests.
REST_CONTACTS = 20
#: An apex past this many drop heights runs away.
RUNAWAY = 1e3
#: A step's solve failed where its residual exceeds this times ``V_IN`` (m/s).
SOLVE_RTOL = 1e-9
#: How implicit Euler's row is solved (here, exactly; its Newton run is beside it).
EXACT_SOLVE = "exact nonsmooth solve (branches and complementarity point)"


# ----------------------------------------------------------------------------- closed forms
def discrete_restitution(lam: complex) -> float:
    """|lambda|^(pi / arg lambda): what a linear step map with eigenvalue lambda (Im > 0) keeps of
    the speed over the half turn of a contact; 0 where lambda is real (the map does not turn: the
    ball never comes back out)."""
    lam = complex(lam)
    if lam.imag == 0.0:
        return 0.0
    theta = abs(math.atan2(lam.imag, lam.real))
    return math.exp(math.log(abs(lam)) * math.pi / theta)


def contact_eigenvalue(zeta: float, omega: float = 1.0) -> complex:
    """mu = omega (-zeta + i sqrt(1 - zeta^2)): the contact's eigenvalue (underdamped)."""
    return complex(-zeta * omega, omega * math.sqrt(1.0 - zeta * zeta))


def closed_form(method_id: str, zeta: float, homega: float) -> float | None:
    """The discrete restitution of the schemes that have one on the contact: explicit Euler
    (lambda = 1 + h mu), implicit Euler (lambda = 1 / (1 - h mu)); None for the others."""
    mu = contact_eigenvalue(zeta, homega)
    if method_id == "ref:explicit_euler":
        return discrete_restitution(1.0 + mu)
    if method_id == "ref:implicit_euler":
        return discrete_restitution(1.0 / (1.0 - mu))
    return None


def no_branch_share(zeta: float, homega: float) -> float:
    """The share of impacts (over where the contact falls in the step) at which implicit Euler's
    step has no consistent branch, gravity negligible: 2 zeta h omega / (1 + 2 zeta h omega)."""
    d = 2.0 * zeta * homega
    return d / (1.0 + d)


# ----------------------------------------------------------------------------- the exact motion
def exact_exit_speed(v_in: float, g: float, omega: float, zeta: float) -> float | None:
    """The exact motion's speed leaving the ground after meeting it at v_in, gravity kept in the
    contact; None where it does not leave (it rests in its sag). In the ground y = x + g / omega^2
    is a damped oscillator from y = g / omega^2, y' = -v_in: y = R e^(-zeta omega t) cos(omega_d t -
    phi); after its first minimum (omega_d t - phi = pi - asin zeta) it leaves where y returns to
    g / omega^2 before its next maximum, half a turn on."""
    from scipy.optimize import brentq  # here: only the exact count needs it, and it is a large import

    eq = g / (omega * omega)
    wd = omega * math.sqrt(1.0 - zeta * zeta)
    a = zeta * omega
    big_a, big_b = eq, (-v_in + a * eq) / wd
    phi = math.atan2(big_b, big_a)
    t_min = (math.pi - math.asin(zeta) + phi) / wd
    t_max = t_min + math.pi / wd

    def y(t):
        return math.exp(-a * t) * (big_a * math.cos(wd * t) + big_b * math.sin(wd * t))

    if y(t_max) <= eq:
        return None
    t = brentq(lambda s: y(s) - eq, t_min, t_max, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=200)
    c, s = math.cos(wd * t), math.sin(wd * t)
    return math.exp(-a * t) * (-a * (big_a * c + big_b * s) + wd * (big_b * c - big_a * s))


@functools.lru_cache(maxsize=64)
def exact_bounces(omega: float, zeta: float, g: float = 9.81, drop: float = DROP, cap: int = BOUNCE_CAP) -> tuple:
    """(bounces, how it ends) of the exact motion from the drop: "rests" after that many bounces,
    or "cap" (zeta = 0 conserves energy: it never rests)."""
    v = math.sqrt(2.0 * g * drop)
    for n in range(cap):
        v = exact_exit_speed(v, g, omega, zeta)
        if v is None:
            return n, "rests"
    return cap, "cap"


# ----------------------------------------------------------------------------- implicit Euler, exact
def implicit_euler_step(x0, v0, h: float, g: float, omega: float, zeta: float):
    """One implicit Euler step of the penalty ball solved exactly, on floats or numpy arrays:
    ``(x1, v1, kind)``, kind 0 outside (x1 >= 0, a = -g), 1 inside (x1 < 0), 2 the complementarity
    point x1 = 0 where neither branch is consistent. Where both are (leaving the ground with
    zeta > 0) the start state's branch is kept."""
    vo = v0 - g * h
    xo = x0 + h * vo
    vi = (v0 - g * h - omega * omega * h * x0) / (1.0 + 2.0 * zeta * h * omega + (h * omega) ** 2)
    xi = x0 + h * vi
    ok_o, ok_i = xo >= 0.0, xi < 0.0
    if np.ndim(x0) == 0:
        if ok_i and (x0 < 0.0 or not ok_o):
            return xi, vi, 1
        if ok_o:
            return xo, vo, 0
        return 0.0, -x0 / h, 2
    use_i = ok_i & ((x0 < 0.0) | ~ok_o)
    use_o = ok_o & ~use_i
    x1 = np.where(use_i, xi, np.where(use_o, xo, 0.0))
    v1 = np.where(use_i, vi, np.where(use_o, vo, -x0 / h))
    kind = np.where(use_i, 1, np.where(use_o, 0, 2))
    return x1, v1, kind


class _ExactImplicitEuler:
    """Implicit Euler on the penalty ball by ``implicit_euler_step``: ``run(x, v, n, every)`` as the
    compiled stepper's (a batch of states), and the complementarity steps it took."""

    solve = EXACT_SOLVE

    def __init__(self, scene, dt: float):
        self.h = dt
        self.g, self.w, self.z = scene.values["g"], scene.values["omega_c"], scene.values["zeta"]

    def run(self, x, v, n: int, every: int = 1):
        x, v = np.array(x, dtype=float), np.array(v, dtype=float)
        h, g = self.h, self.g
        if every == n and n > 0:
            # A flight in one go where it stays outside: n outside steps are v_n = v0 - n g h,
            # x_n = x0 + n h v0 - g h^2 n (n + 1) / 2, concave in n, so x_n >= 0 keeps every step outside.
            xn = x + n * h * v - g * h * h * n * (n + 1) / 2.0
            if np.all(x >= 0.0) and np.all(xn >= 0.0):
                return np.stack([x, xn]), np.stack([v, v - n * g * h]), True, 0, np.zeros(x.shape, bool)
        if x.size == 1:  # one state (the drop): the step on floats
            xf, vf = float(x.ravel()[0]), float(v.ravel()[0])
            xs, vs, took = [xf], [vf], False
            for _ in range(n):
                xf, vf, kind = implicit_euler_step(xf, vf, h, g, self.w, self.z)
                took |= kind == 2
                xs.append(xf)
                vs.append(vf)
            xs, vs, comp = (
                np.array(xs).reshape(-1, *x.shape),
                np.array(vs).reshape(-1, *x.shape),
                np.full(x.shape, took),
            )
        else:
            xs, vs = [x], [v]
            comp = np.zeros(x.shape, bool)
            for _ in range(n):
                x, v, kind = implicit_euler_step(x, v, h, g, self.w, self.z)
                comp |= kind == 2
                xs.append(x)
                vs.append(v)
            xs, vs = np.stack(xs), np.stack(vs)
        keep = slice(None, None, every)
        return xs[keep], vs[keep], True, 0, comp


#: The implicit equations each implicit scheme of the table solves, as a residual of two
#: consecutive states (x0, v0) -> (x1, v1) of one step h: zero where the step's solve converged.
def _residual_implicit_euler(accel, p, x0, v0, x1, v1, h):
    return np.maximum(np.abs(x1 - x0 - h * v1), np.abs(v1 - v0 - h * accel(x1, v1, 0.0, p)))


def _residual_implicit_midpoint(accel, p, x0, v0, x1, v1, h):
    xm, vm = 0.5 * (x0 + x1), 0.5 * (v0 + v1)
    return np.maximum(np.abs(x1 - x0 - h * vm), np.abs(v1 - v0 - h * accel(xm, vm, 0.0, p)))


RESIDUALS = {"ref:implicit_euler": _residual_implicit_euler, "ref:implicit_midpoint": _residual_implicit_midpoint}


def unsolved_steps(method_id: str, scene, x, v, dt: float, scale: float) -> np.ndarray | None:
    """Per column of consecutive states x, v (steps along axis 0): how many steps do not satisfy
    the scheme's implicit equation to ``SOLVE_RTOL`` of ``scale`` (its Newton iteration stopped at
    its cap); None where the scheme solves nothing."""
    residual = RESIDUALS.get(method_id)
    if residual is None:
        return None
    from scenarios.penalty_ball import accel

    x, v = np.asarray(x, dtype=float), np.asarray(v, dtype=float)
    if len(x) < 2:
        return np.zeros(x.shape[1:], dtype=int)
    r = residual(accel, scene.pvec, x[:-1], v[:-1], x[1:], v[1:], dt)
    return np.sum(~(r <= SOLVE_RTOL * scale), axis=0)


class _Compiled:
    """A reference scheme on the scene's compiled loop (``reference.integrate_compiled``, the loop
    ``simulate`` takes for it) from any batch of states: ``run(x, v, n, every) -> (xs, vs, ok,
    unsolved, None)``, unsolved the steps whose implicit solve failed (every=1 runs only)."""

    def __init__(self, method_id: str, scene, dt: float):
        from harness.methods import get_method

        method = get_method(method_id, compiled_where_bitwise=True)
        self.scheme, self.scene, self.h, self.id = method.scheme, scene, dt, method_id
        self.solve = "Newton" if method_id in RESIDUALS else None
        self.scale = V_IN

    def run(self, x, v, n: int, every: int = 1):
        import reference

        x, v = np.atleast_1d(np.asarray(x, dtype=float)), np.atleast_1d(np.asarray(v, dtype=float))
        tr = reference.integrate_compiled(self.scheme, self.scene, self.h, n, every, q0=x[:, None], v0=v[:, None])
        xs, vs = tr.q[:, :, 0], tr.v[:, :, 0]
        ok = tr.status == "ok" and bool(np.all(np.isfinite(xs)) and np.all(np.isfinite(vs)))
        unsolved = 0
        if every == 1 and self.solve:
            unsolved = unsolved_steps(self.id, self.scene, xs, vs, self.h, self.scale)
        return xs, vs, ok, unsolved, None


def _stepper(method_id: str, scene, dt: float, exact: bool = True):
    if exact and method_id == "ref:implicit_euler":
        return _ExactImplicitEuler(scene, dt)
    return _Compiled(method_id, scene, dt)


def _impact_scene(zeta: float, omega_c: float):
    from scenarios import make_scene

    return make_scene("penalty_ball", g=G_IMPACT, omega_c=omega_c, zeta=zeta, h0=DROP)


def _contact_steps(homega: float, zeta: float) -> int:
    """Steps of one exact contact, pi / omega_d, at least one."""
    return max(1, math.ceil(math.pi / (homega * math.sqrt(1.0 - zeta * zeta))))


# ----------------------------------------------------------------------------- one impact
def impact(method_id: str, e: float, homega: float, omega_c: float = OMEGA_C, phases: int = PHASES, exact=True):
    """One impact of each phase: v_out / v_in per phase (0 where the ball has not left), whether
    each phase's run stayed finite, the unsolved steps per phase (None: nothing solved) and, for
    implicit Euler's exact solve, whether a phase's impact took a complementarity step."""
    from scenarios.penalty_ball import zeta_for

    zeta = zeta_for(e)
    scene = _impact_scene(zeta, omega_c)
    h = homega / omega_c
    stepper = _stepper(method_id, scene, h, exact)
    s = (np.arange(phases) + 0.5) / phases
    x, v = s * h * V_IN, np.full(phases, -V_IN)
    out = np.zeros(phases)
    left = np.zeros(phases, bool)
    finite = np.ones(phases, bool)
    unsolved = np.zeros(phases, dtype=int) if method_id in RESIDUALS and stepper.solve == "Newton" else None
    comp = np.zeros(phases, bool)
    chunk = _contact_steps(homega, zeta) + 8
    for _ in range(IMPACT_WINDOW):
        xs, vs, ok, bad, took = stepper.run(x, v, chunk, 1)
        if took is not None:
            comp |= took & ~left
        if unsolved is not None:
            # Counted until the phase leaves (its flight after is linear: never unsolved).
            unsolved += np.where(left, 0, bad)
        for j in np.flatnonzero(~left):
            up = np.flatnonzero((xs[1:, j] >= 0.0) & (vs[1:, j] > 0.0))
            if len(up):
                out[j], left[j] = vs[1 + up[0], j] / V_IN, True
        if not ok:
            finite[~left] = False
            break
        if left.all():
            break
        x, v = xs[-1], vs[-1]
    else:
        # Not out after the window: resting (0) where its motion in the ground has shrunk below
        # the entry's; where it grew (an unstable step oscillating in the ground) it blew up.
        grown = np.hypot(v, omega_c * x) > V_IN
        finite[~left & grown] = False
    return {"ratio": out, "left": left, "finite": finite, "unsolved": unsolved, "complementarity": comp}


def _summary(ratio: np.ndarray, finite: np.ndarray) -> dict:
    if not finite.all():
        return {"impact_mean": None, "impact_min": None, "impact_max": None}
    return {"impact_mean": float(ratio.mean()), "impact_min": float(ratio.min()), "impact_max": float(ratio.max())}


def verdict(mean: float | None, lo: float | None, hi: float | None, e: float, blown: bool, unsolved: int) -> str:
    """The impact's verdict against the exact e (the module's rule)."""
    if blown:
        return "blows up"
    if unsolved:
        return "unsolved"
    if mean > 1.0 + GAIN:
        return "gains energy"
    if mean > e + TOLERANCE:
        return "too lively"
    if mean < DEAD * e:
        return "dead"
    if mean < e - TOLERANCE:
        return "loses energy"
    if lo >= e - TOLERANCE and hi <= e + TOLERANCE:
        return "within"
    return "scatters"


# ----------------------------------------------------------------------------- bounces to rest
def _speed(x: float, v: float, g: float) -> float:
    """The speed at the surface of a ballistic flight through (x >= 0, v)."""
    return math.sqrt(v * v + 2.0 * g * max(x, 0.0))


def drop_run(stepper, g: float, homega: float, zeta: float, drop: float = DROP, cap: int = BOUNCE_CAP) -> dict:
    """The ball dropped from ``drop`` and run until it rests, blows up, runs away or reaches
    ``cap`` bounces: the bounces, how the run ended, each bounce's ratio of surface speeds, and
    the steps whose solve failed (in the contacts, where the kink is)."""
    h = stepper.h
    contact = _contact_steps(homega, zeta)
    # A Newton scheme's contacts are recorded at every step (its residuals are checked on
    # consecutive states); the others' at a sixteenth of a contact: a flight shorter than that (a
    # bounce of under g pi / (32 omega_c), 1 mm/s at omega_c = 1000) is not seen.
    every = 1 if stepper.solve == "Newton" else max(1, contact // 16)
    window = every * math.ceil((contact + 16) / every)
    rest_steps = REST_CONTACTS * contact + 40
    x, v = drop, 0.0
    ratios: list[float] = []
    unsolved = 0
    end = "cap"
    while len(ratios) < cap:
        # The flight, in one call to three steps before the ballistic landing (fewer where the
        # scheme's own flight lands sooner).
        n = int((v + math.sqrt(v * v + 2.0 * g * max(x, 0.0))) / g / h) - 3
        while n >= 1:
            xs, vs, ok, _, _ = stepper.run([x], [v], n, n)
            if not ok:
                return _drop_out(ratios, "blows up", unsolved)
            if xs[-1, 0] >= 0.0:
                x, v = float(xs[-1, 0]), float(vs[-1, 0])
                break
            n -= max(3, n // 50)
        # The contact, step by step: entered at the first step below the surface or turned up, left
        # at the first step above it moving up.
        phase = "up" if v > 0.0 else "down"
        v_in, inside = None, 0
        while True:
            xs, vs, ok, bad, _ = stepper.run([x], [v], window, every)
            xs, vs = xs[:, 0].tolist(), vs[:, 0].tolist()
            unsolved += int(np.sum(bad))
            i_out = None
            for i in range(1, len(xs)):
                xi, vi = xs[i], vs[i]
                if phase == "contact":
                    inside += every
                    if xi >= 0.0 and vi > 0.0:
                        i_out = i
                        break
                elif xi < 0.0 or (phase == "down" and vi > 0.0):
                    phase, v_in = "contact", _speed(xs[i - 1], vs[i - 1], g)
                    inside = every
                    if xi >= 0.0 and vi > 0.0:  # in and out within the step
                        i_out = i
                        break
                elif vi <= 0.0:
                    phase = "down"
            if not ok:
                return _drop_out(ratios, "blows up", unsolved)
            if i_out is not None:
                x, v = xs[i_out], vs[i_out]
                ratios.append(_speed(x, v, g) / v_in)
                break
            if inside > rest_steps:
                return _drop_out(ratios, "rests", unsolved)
            x, v = xs[-1], vs[-1]
        if x + v * v / (2.0 * g) > RUNAWAY * drop:
            end = "runaway"
            break
    return _drop_out(ratios, end, unsolved)


def _drop_out(ratios, end, unsolved) -> dict:
    return {
        "bounces": len(ratios),
        "bounces_end": end,
        "bounce_ratios": [float(r) for r in ratios],
        "drop_unsolved": unsolved,
    }


# ----------------------------------------------------------------------------- the table
def row(method_id: str, e: float, homega: float, omega_c: float = OMEGA_C, phases: int = PHASES) -> dict:
    """One scheme at one h*omega_c and e: one impact's v_out / v_in over the phases (mean, range),
    beside the closed form and the exact e, its verdict; the bounces of a drop to rest, apart.
    Implicit Euler's figures are the exact solve's; its Newton run's are ``newton_*`` (None where a
    solve failed: ``newton_unsolved`` says at how many steps)."""
    from scenarios import make_scene
    from scenarios.penalty_ball import restitution_of, zeta_for

    zeta = zeta_for(e)
    exact_e = restitution_of(zeta)
    h = homega / omega_c
    imp = impact(method_id, e, homega, omega_c, phases)
    summary = _summary(imp["ratio"], imp["finite"])
    blown = not imp["finite"].all()
    unsolved = int(np.sum(imp["unsolved"])) if imp["unsolved"] is not None else None
    if unsolved:
        summary = {k: None for k in summary}
    out = {
        "method": method_id,
        "e": e,
        "zeta": zeta,
        "omega_c": omega_c,
        "homega": homega,
        "dt": h,
        "phases": phases,
        "v_in": V_IN,
        "g_impact": G_IMPACT,
        "gravity_share": G_IMPACT / (omega_c * V_IN),
        "step_gravity": G_IMPACT * h / V_IN,
        **summary,
        "phases_resting": int(np.sum(~imp["left"] & imp["finite"])),
        "exact": exact_e,
        "closed_form": closed_form(method_id, zeta, homega),
        "solve": EXACT_SOLVE if method_id == "ref:implicit_euler" else ("Newton" if method_id in RESIDUALS else None),
        "unsolved": unsolved,
        "verdict": verdict(
            summary["impact_mean"], summary["impact_min"], summary["impact_max"], exact_e, blown, unsolved or 0
        ),
    }
    if method_id == "ref:implicit_euler":
        out["no_branch_share"] = float(np.mean(imp["complementarity"]))
        out["no_branch_expected"] = no_branch_share(zeta, homega)
        newton = impact(method_id, e, homega, omega_c, phases, exact=False)
        n_unsolved = int(np.sum(newton["unsolved"]))
        ns = _summary(newton["ratio"], newton["finite"])
        if n_unsolved:
            ns = {k: None for k in ns}
        out.update({f"newton_{k.split('_')[1]}": val for k, val in ns.items()}, newton_unsolved=n_unsolved)
    scene = make_scene("penalty_ball", omega_c=omega_c, zeta=zeta, h0=DROP)
    drop = drop_run(_stepper(method_id, scene, h), scene.values["g"], homega, zeta)
    if drop["drop_unsolved"]:
        drop["bounce_ratios"] = []
    exact_n, exact_end = exact_bounces(omega_c, zeta, scene.values["g"], DROP, BOUNCE_CAP)
    out.update(drop, g=scene.values["g"], drop=DROP, bounce_cap=BOUNCE_CAP, exact_bounces=exact_n, exact_end=exact_end)
    return out


def penalty_rows(schemes=SCHEMES, restitutions=RESTITUTIONS, grid=GRID, omega_c: float = OMEGA_C) -> list[dict]:
    """Every (scheme, e, h*omega_c) as a row (``row``)."""
    return [row(m, e, hw, omega_c) for m in schemes for e in restitutions for hw in grid]


def penalty_table(schemes=SCHEMES, restitutions=RESTITUTIONS, grid=GRID, omega_c: float = OMEGA_C):
    """Every (scheme, e, h*omega_c) as a tidy DataFrame (a scheme's missing keys NaN)."""
    import pandas as pd

    return pd.DataFrame(penalty_rows(schemes, restitutions, grid, omega_c))


def _mean(r) -> float | None:
    """A row's restitution: one impact's phase mean; a row stored before the per-impact table, its
    mean of five bounces."""
    x = r.get("impact_mean") if "impact_mean" in r else r.get("mean_restitution")
    return None if x is None or x != x else float(x)


def seed_claim(rows) -> dict:
    """The seed's claim that implicit Euler makes lively bounces go dead, judged on the per-impact
    table (rows: dicts or a DataFrame): it holds where, at a step where semi-implicit Euler (the
    games' symplectic default) keeps a perfectly elastic impact within the tolerance, implicit
    Euler's keeps under half the speed. Returns the verdict, the steps where it holds, and the
    figures it rests on."""
    if hasattr(rows, "to_dict"):
        rows = rows.to_dict(orient="records")
    elastic = [r for r in rows if r["e"] == 1.0]
    sym = {r["homega"]: r for r in elastic if r["method"] == "ref:semi_implicit_euler"}
    imp = {r["homega"]: r for r in elastic if r["method"] == "ref:implicit_euler"}
    where = [
        hw
        for hw in sorted(imp)
        if hw in sym and sym[hw]["verdict"] == "within" and _mean(imp[hw]) is not None and _mean(imp[hw]) < 0.5
    ]
    return {
        "holds": bool(where),
        "where": where,
        "implicit": {hw: _mean(r) for hw, r in sorted(imp.items())},
        "symplectic": {hw: _mean(r) for hw, r in sorted(sym.items())},
        "newton_unsolved": {hw: r.get("newton_unsolved") for hw, r in sorted(imp.items()) if r.get("newton_unsolved")},
    }
