"""The question a robot's user brings to a model file: at my timestep, integrator and control step,
how far is each control step from the converged one, what would another integrator or a smaller
step change, and at what cost?

Contact-rich motion is chaotic: two accurate simulations of it part, so a trajectory error
long after they part measures the chaos, not the integrator. The study therefore measures,
after Erez, Tassa & Todorov (2015, "Simulation tools for model-based robotics"), **one control step
at a time** from states the motion visits, and a trajectory only inside its predictable horizon:

* **States**: each seed's start (``scenarios.control_setting``) run for ``horizon_s`` under its
  controls by the reference's coarsest level; ``states_per_seed`` control-step boundaries of that
  run, evenly spaced, with the control of the step that follows each.
* **Reference transition**: MuJoCo's RK4 over one control step at ``h / 2^k``, k from
  ``REF_FIRST`` (finer than every candidate) up, never coarser than the file's step ``h``. Its
  **error** is the difference of its own last two levels. It is refined until that error is at
  most ``REF_FRACTION`` of every candidate's (median and 95th percentile over the states), until
  ``REF_LAST``, or until it stops falling (a contact switching within the step limits RK4 to first
  order); it is **converged** when its error is at most ``REF_FRACTION`` of the baseline's, and
  only then is any candidate judged. A candidate within 1/``REF_FRACTION`` of the reference's error
  is "at the reference's resolution", an upper bound, not a figure.
* **Transition error** of a candidate: the same states and controls, one control step, against the
  reference: per state the RMS over coordinates of the difference divided by each coordinate's
  spread (its standard deviation over the visited states, floored at ``SPREAD_FLOOR`` of the median
  spread: a coordinate that never moves is not divided by zero), for the observation, qpos and
  qvel; median and 95th percentile over states and seeds. Relative to the spread is what a policy
  with normalised inputs sees.
* **Predictable horizon**: the reference run at two levels (``h / 2^REF_FIRST`` and half of it)
  from each start; the time their observation difference first exceeds ``HORIZON_FRACTION`` of the
  spread. A candidate's trajectory error (its own run against the finer reference, the largest over
  the control steps) is reported inside it only.
* **Contacts** along each candidate's own run, every physics step: contacts a step (mean, max),
  the share of steps in contact, the deepest penetration of a step (median over steps in contact,
  max); the reference's from its coarser run. A model with no collidable pair has no contact figure.
* **Cost**: MuJoCo's own loop (``adapters.mujoco.control``), seconds per control step, the ratio to
  the baseline's measured in the same run.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from adapters.mujoco.control import EVALUATIONS, Candidate, Stepper, available_integrators, full_state, integrator_name

#: The reference's first level: h / 2^3, finer than the finest candidate (h / 4).
REF_FIRST = 3
#: The finest level tried: h / 2^7.
REF_LAST = 7
#: The reference's error must be at most this share of the error it judges.
REF_FRACTION = 0.1
#: The references part when their observation difference reaches this share of the spread.
HORIZON_FRACTION = 0.1
#: A coordinate's spread is at least this share of the median coordinate's.
SPREAD_FLOOR = 1e-3
#: The reference stops refining when a halving cuts its error by less than this factor.
STALL = 0.7


@dataclass
class StudyConfig:
    horizon_s: float = 2.0
    states_per_seed: int = 40
    substeps: tuple[int, ...] = (1, 2, 4)
    integrators: tuple[str, ...] | None = None
    threads: int = 2
    timing_steps: int = 100
    repeats: int = 5
    budget_s: float = 40.0  # the reference's refinement stops past this wall time
    timings: dict | None = None  # injected seconds per control step by candidate name (tests)
    within_episode: bool = True  # judge only states before the environment's default termination
    min_sample_s: float = 0.005  # a timing sample runs its control steps again until it lasts this long


@dataclass
class Figures:
    median: float
    p95: float

    @staticmethod
    def of(x: np.ndarray) -> Figures:
        x = np.asarray(x, dtype=float)
        if x.size == 0 or not np.all(np.isfinite(x)):
            return Figures(math.nan, math.nan)
        return Figures(float(np.median(x)), float(np.percentile(x, 95)))


@dataclass
class ContactFigures:
    mean: float
    max: int
    share: float
    penetration_median: float
    penetration_max: float


@dataclass
class CandidateResult:
    candidate: Candidate
    baseline: bool
    physics_steps: int  # mj_step calls a control step
    evaluations: int  # force evaluations a control step
    obs: Figures | None = None  # transition error, relative to the spread
    qpos: Figures | None = None
    qvel: Figures | None = None
    resolved: bool = True  # above the reference's resolution
    unstable_transitions: int = 0
    run_status: str = "ok"  # ok, or unstable at t = ... (seed)
    trajectory_error: float | None = None  # the largest inside the predictable horizon (median over seeds)
    contacts: ContactFigures | None = None
    obs_errors: np.ndarray | None = field(default=None, repr=False)  # per state, the observation's error
    cost_s: float = math.nan  # seconds per control step: the fastest sample
    cost_samples: list = field(default_factory=list)  # one per repeat

    @property
    def cost_spread(self) -> float:
        """(second fastest - fastest) / fastest of the cost samples: how well the fastest, the
        figure, is pinned down (the median moves with every neighbour on a shared machine)."""
        x = np.sort(np.asarray(self.cost_samples, dtype=float))
        x = x[np.isfinite(x)]
        return float(x[1] / x[0] - 1.0) if x.size > 1 and x[0] > 0 else math.nan

    same_bits_as: str | None = None  # another candidate whose transitions are bit for bit these

    def row(self) -> dict:
        c = self.contacts
        return {
            "candidate": self.candidate.name,
            "integrator": self.candidate.integrator,
            "substeps": self.candidate.substeps,
            "baseline": self.baseline,
            "physics_steps_per_control": self.physics_steps,
            "evaluations_per_control": self.evaluations,
            "obs_err_median": _f(self.obs, "median"),
            "obs_err_p95": _f(self.obs, "p95"),
            "qpos_err_median": _f(self.qpos, "median"),
            "qpos_err_p95": _f(self.qpos, "p95"),
            "qvel_err_median": _f(self.qvel, "median"),
            "qvel_err_p95": _f(self.qvel, "p95"),
            "resolved": self.resolved,
            "unstable_transitions": self.unstable_transitions,
            "run_status": self.run_status,
            "trajectory_error_in_horizon": self.trajectory_error,
            "contacts_mean": c.mean if c else None,
            "contacts_max": c.max if c else None,
            "in_contact_share": c.share if c else None,
            "penetration_median_m": c.penetration_median if c else None,
            "penetration_max_m": c.penetration_max if c else None,
            "cost_s_per_control": self.cost_s,
            "cost_spread": self.cost_spread,
            "same_bits_as": self.same_bits_as,
        }


def _f(fig, name):
    return None if fig is None else getattr(fig, name)


@dataclass
class Reference:
    level: int  # h / 2^level
    h: float
    error: Figures  # the difference of its last two levels (observation)
    history: list = field(default_factory=list)  # (level, median, p95) per level compared
    converged: bool = False
    why: str = ""

    def describe(self) -> str:
        return (
            f"MuJoCo RK4 at h/{2**self.level} = {self.h:.3g} s, refined from h/{2**REF_FIRST}: its own last "
            f"halving differs by {self.error.median:.2g} (median; 95th percentile {self.error.p95:.2g}) of the "
            f"observation's spread a control step"
        )


@dataclass
class Study:
    file: str
    setting: dict
    timestep: float
    integrator: str
    frame_skip: int
    control_step: float
    pairs: int
    nstates: int
    reference: Reference
    horizon: list  # per seed: seconds until the references part (None: not within the run)
    horizon_s: float
    candidates: list
    contacts_reference: ContactFigures | None
    velocity_terms: str = ""
    past_termination: float = 0.0  # share of the states after the environment's default termination
    episodes: list | None = None  # per seed: when its episode ended (None: it lasted the run)
    switches: np.ndarray | None = None  # per state: a contact or a joint limit switches within the control step
    observation_lag: Figures | None = (
        None  # the extras as Gymnasium reads them, a physics step late, against the state's
    )
    within_episode: bool = True
    wall_s: float = 0.0
    spread_floor: float = SPREAD_FLOOR

    @property
    def baseline(self) -> CandidateResult:
        return next(c for c in self.candidates if c.baseline)

    def by_name(self, name: str) -> CandidateResult | None:
        return next((c for c in self.candidates if c.candidate.name == name), None)

    def frame(self):
        import pandas as pd

        return pd.DataFrame([c.row() for c in self.candidates])

    def predictable(self) -> tuple[float | None, float | None]:
        """(median, shortest) predictable horizon over the seeds; None where the references did not
        part within the run (the horizon is at least the run)."""
        parted = [h for h in self.horizon if h is not None]
        if len(parted) < len(self.horizon) / 2:
            return None, (min(parted) if parted else None)
        full = sorted(h if h is not None else math.inf for h in self.horizon)
        med = float(np.median(full))
        return (med if math.isfinite(med) else None), min(parted)


def _progress(stream, text):
    if stream is not None:
        print(text, file=stream, flush=True)


def _spread(x: np.ndarray) -> np.ndarray:
    s = np.std(x.reshape(-1, x.shape[-1]), axis=0)
    moving = s[s > 0]
    floor = SPREAD_FLOOR * float(np.median(moving)) if moving.size else 1.0
    return np.maximum(s, max(floor, 1e-300))


def _relative(a: np.ndarray, b: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    with np.errstate(all="ignore"):
        e = np.sqrt(np.mean(((a - b) / sigma) ** 2, axis=-1))
    return np.where(np.isfinite(e), e, np.inf)


def run_study(m, setting, config: StudyConfig | None = None, progress=sys.stderr, path: str = "") -> Study:
    """The study on the compiled model ``m`` (the file as written) at ``setting`` (module docstring)."""
    from scenarios import collidable_pairs

    config = config or StudyConfig()
    t_start = time.perf_counter()
    setting = setting.checked(m)
    h = float(m.opt.timestep)
    F = int(setting.frame_skip)
    Tc = F * h
    ncontrol = max(2, int(math.ceil(config.horizon_s / Tc - 1e-9)))
    base_integrator = integrator_name(m)
    integrators = tuple(config.integrators or available_integrators())
    if base_integrator not in integrators:
        integrators = (base_integrator, *integrators)
    stepper = Stepper(m, config.threads)
    pairs = len(collidable_pairs(m))
    seeds = list(setting.seeds)
    s0 = np.stack([full_state(m, *setting.start(m, s)) for s in seeds])
    U = np.stack([setting.sequence(m, s, ncontrol) for s in seeds])  # (nseed, ncontrol, nu)

    spec = setting.observation

    def obs_after(path):
        """The observation after the last of ``path``'s steps (nbatch, nstep, nstate) under ``u``."""
        return stepper.observe(path[:, -1], spec, u)

    def obs_run(run, per_step):
        """The observation at each control-step boundary of runs from ``s0`` under ``U``, the start
        first (its controls 0, as after a reset)."""
        start = stepper.observe(s0[:, None], spec, np.zeros((len(s0), 1, m.nu)))
        return np.concatenate([start, stepper.observe(run[:, per_step - 1 :: per_step], spec, U)], axis=1)

    # --- where each seed's episode ends: the environment's termination tested after every control
    # step of your own setting's run (not the reset state), as the environment tests it
    own_run = stepper.run(base_integrator, h, F, s0, U)
    own = own_run[:, F - 1 :: F]  # (nseed, ncontrol, nstate)
    ends = []  # control steps of each episode
    for i in range(len(seeds)):
        if setting.termination is None:
            ends.append(ncontrol)
            continue
        ended = np.nonzero(setting.termination.terminated(stepper.qpos(own[i]), stepper.qvel(own[i])))[0]
        ends.append(int(ended[0]) + 1 if ended.size else ncontrol)
    usable = ends if config.within_episode else [ncontrol] * len(seeds)

    # --- the reference's two runs: the states visited, and the predictable horizon
    _progress(
        progress,
        f"[model] reference runs: RK4 at h/{2**REF_FIRST} and h/{2 ** (REF_FIRST + 1)} over "
        f"{ncontrol} control steps x {len(seeds)} seeds",
    )
    per = F * 2**REF_FIRST
    coarse = stepper.run("rk4", h / 2**REF_FIRST, per, s0, U)
    fine = stepper.run("rk4", h / 2 ** (REF_FIRST + 1), 2 * per, s0, U)
    at_c = np.concatenate([s0[:, None], coarse[:, per - 1 :: per]], axis=1)  # (nseed, ncontrol + 1, nstate)
    obs_c, obs_f = obs_run(coarse, per), obs_run(fine, 2 * per)
    # each coordinate's spread over the states judged: inside the episodes unless asked otherwise
    judged = np.concatenate([at_c[i, : usable[i] + 1] for i in range(len(seeds))])
    judged_obs = np.concatenate([obs_c[i, : usable[i] + 1] for i in range(len(seeds))])
    finite = np.all(np.isfinite(judged), axis=-1)
    sig_obs = _spread(judged_obs[finite])
    sig_q = _spread(stepper.qpos(judged[finite]))
    sig_v = _spread(stepper.qvel(judged[finite]))
    apart = _relative(obs_c, obs_f, sig_obs)  # (nseed, ncontrol + 1)
    horizon = []
    for i in range(len(seeds)):
        over = np.nonzero(apart[i] > HORIZON_FRACTION)[0]
        horizon.append(float(over[0] * Tc) if over.size else None)

    # --- the states the transitions start from
    states, u, past, total = [], [], 0, 0
    for i in range(len(seeds)):
        n_i = max(1, usable[i])
        take = np.unique(np.linspace(0, n_i - 1, min(config.states_per_seed, n_i)).round().astype(int))
        ok = take[np.all(np.isfinite(at_c[i, take]), axis=-1)]
        states.append(at_c[i, ok])
        u.append(U[i, ok])
        past += int(np.count_nonzero(ok >= ends[i]))
        total += len(ok)
    states = np.concatenate(states)
    u = np.concatenate(u)

    # --- candidates' transitions
    _progress(
        progress,
        f"[model] transitions: {len(states)} states, {len(integrators)} integrators x substeps "
        f"{', '.join(map(str, config.substeps))}",
    )
    results, trans, obs_t, lagged = [], {}, {}, None
    for integ in integrators:
        for s in config.substeps:
            c = Candidate(integ, s)
            path_c = stepper.transition_path(integ, h / s, F * s, states, u)
            trans[c.name] = path_c[:, -1]
            obs_t[c.name] = obs_after(path_c)
            if integ == base_integrator and s == 1 and spec.extras:
                # Gymnasium reads the extras after mj_step from what that step's last forward pass
                # left (a physics step, or RK4's last stage, before): how far that alone moves them
                before = path_c[:, -2] if path_c.shape[1] > 1 else states
                lagged = stepper.observe(path_c[:, -1], spec, u, integ, h, before)
            results.append(CandidateResult(c, integ == base_integrator and s == 1, F * s, F * s * EVALUATIONS[integ]))
    for r in results:
        for other in results:
            if other is r:
                break
            if np.array_equal(trans[r.candidate.name], trans[other.candidate.name]):
                r.same_bits_as = other.candidate.name
                break

    # --- the reference transition, refined from h / 2^REF_FIRST down; the level after the first
    # kept step by step, where the contacts and limits that switch within a control step are read
    levels, obs_l = {}, {}

    def level(k):
        path_k = stepper.transition_path("rk4", h / 2**k, F * 2**k, states, u)
        levels[k], obs_l[k] = path_k[:, -1], obs_after(path_k)
        return path_k

    level(REF_FIRST)
    history, why, k, ref_path = [], "", REF_FIRST, None
    while True:
        k += 1
        _progress(progress, f"[model] reference transition at h/{2**k}")
        path_k = level(k)
        if ref_path is None:
            ref_path = path_k
        e = Figures.of(_relative(obs_l[k - 1], obs_l[k], sig_obs))
        history.append((k, e.median, e.p95))
        cand = [Figures.of(_relative(obs_t[r.candidate.name], obs_l[k], sig_obs)) for r in results]
        smallest_med = min((f.median for f in cand if f.median > 0), default=math.inf)
        smallest_p95 = min((f.p95 for f in cand if f.p95 > 0), default=math.inf)
        if e.median <= REF_FRACTION * smallest_med and e.p95 <= REF_FRACTION * smallest_p95:
            why = "its error is at most a tenth of every candidate's"
            break
        if k >= REF_LAST:
            why = f"the finest level tried (h/{2**REF_LAST})"
            break
        if len(history) >= 2 and e.median > STALL * history[-2][1] and e.p95 > STALL * history[-2][2]:
            why = "a halving no longer cuts its error (contact switching within a step limits it)"
            break
        if time.perf_counter() - t_start > config.budget_s:
            why = f"the refinement's time budget ({config.budget_s:g} s)"
            break
    ref_states = levels[k]
    ref_err = Figures.of(_relative(obs_l[k - 1], obs_l[k], sig_obs))
    reference = Reference(k, h / 2**k, ref_err, history, why=why)

    for r in results:
        T = trans[r.candidate.name]
        eo = _relative(obs_t[r.candidate.name], obs_l[k], sig_obs)
        eq = _relative(stepper.qpos(T), stepper.qpos(ref_states), sig_q)
        ev = _relative(stepper.qvel(T), stepper.qvel(ref_states), sig_v)
        r.unstable_transitions = int(np.count_nonzero(~np.isfinite(eo) | (eo == np.inf)))
        r.obs_errors = eo
        r.obs, r.qpos, r.qvel = (
            Figures.of(eo[np.isfinite(eo)]),
            Figures.of(eq[np.isfinite(eq)]),
            Figures.of(ev[np.isfinite(ev)]),
        )
        r.resolved = (r.obs.median > ref_err.median / REF_FRACTION) if math.isfinite(r.obs.median) else True
    base = next(r for r in results if r.baseline)
    lag = Figures.of(_relative(lagged, obs_t[base.candidate.name], sig_obs)) if lagged is not None else None
    switches = _switches(m, stepper, states, ref_path)
    reference.converged = bool(
        ref_err.median <= REF_FRACTION * base.obs.median and ref_err.p95 <= REF_FRACTION * base.obs.p95
    )

    # --- each candidate's own run: stability, trajectory error inside the horizon, contacts, cost
    _progress(progress, "[model] runs: each candidate from every start, its contacts and its cost")

    def in_episode(run, per_step):
        """The physics steps of each seed's run inside the states the study judges (``usable``)."""
        return [run[i, : max(1, usable[i] * per_step)] for i in range(len(seeds))]

    contacts_ref, timed = None, []
    if pairs:
        contacts_ref = _contact_figures(*map(np.concatenate, zip(*map(stepper.contacts, in_episode(coarse, per)))))
    for r in results:
        c = r.candidate
        per_c = F * c.substeps
        run = own_run if r.baseline else stepper.run(c.integrator, h / c.substeps, per_c, s0, U)
        obs_r = obs_run(run, per_c)
        bad = ~np.all(np.isfinite(run), axis=-1)
        if bad.any():
            i, j = np.argwhere(bad)[0]
            r.run_status = f"unstable at t = {(j + 1) * h / c.substeps:.4g} s (seed {seeds[i]})"
        worst = []
        for i in range(len(seeds)):
            end = usable[i] if horizon[i] is None else min(usable[i], int(round(horizon[i] / Tc)))
            e = _relative(obs_r[i, : end + 1], obs_f[i, : end + 1], sig_obs)
            worst.append(float(np.max(e)))
        r.trajectory_error = float(np.median(worst))
        if pairs:
            r.contacts = _contact_figures(*map(np.concatenate, zip(*map(stepper.contacts, in_episode(run, per_c)))))
        # timed over every seed's judged control steps up to its first non-finite state
        steps = [
            min(
                usable[i],
                int(np.argmax(bad[i])) // per_c if bad[i].any() else ncontrol,
                max(1, config.timing_steps // len(seeds)),
            )
            for i in range(len(seeds))
        ]
        timed.append((r, [U[i, : steps[i]] for i in range(len(seeds))]))
    # Repeats go round the candidates, so that each one's samples are drawn from across the
    # measurement, not from one moment of the machine; the fastest is the figure, the spread kept.
    for _ in range(max(1, config.repeats)):
        for r, controls in timed:
            c = r.candidate
            if config.timings and c.name in config.timings:
                r.cost_samples.append(float(config.timings[c.name]))
            else:
                r.cost_samples.append(
                    stepper.time_per_control_step(
                        c.integrator, h / c.substeps, F * c.substeps, s0, controls, config.min_sample_s
                    )
                )
    for r, _ in timed:
        r.cost_s = float(np.nanmin(r.cost_samples))
    return Study(
        file=path,
        setting=setting.describe(m),
        timestep=h,
        integrator=base_integrator,
        frame_skip=F,
        control_step=Tc,
        pairs=pairs,
        nstates=len(states),
        reference=reference,
        horizon=horizon,
        horizon_s=ncontrol * Tc,
        candidates=results,
        contacts_reference=contacts_ref,
        velocity_terms=velocity_terms(m),
        past_termination=past / max(1, total),
        switches=switches,
        observation_lag=lag,
        episodes=[e * Tc if e < ncontrol else None for e in ends] if setting.termination else None,
        within_episode=config.within_episode,
        wall_s=time.perf_counter() - t_start,
    )


def _switches(m, stepper, start: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Per transition, whether a constraint that is not smooth switches within it, at any step of
    ``path`` (nbatch, nstep, nstate): the number of contacts MuJoCo finds changes, or a limited
    hinge or slide joint crosses its range's end."""
    import mujoco

    seq = np.concatenate([start[:, None], path], axis=1)  # (nbatch, nstep + 1, nstate)
    n, _ = stepper.contacts(seq)
    out = np.any(n[:, 1:] != n[:, :-1], axis=1)
    lim = [
        j
        for j in range(m.njnt)
        if m.jnt_limited[j]
        and int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
    ]
    if lim:
        adr = np.asarray(m.jnt_qposadr)[lim]
        lo, hi = np.asarray(m.jnt_range)[lim].T
        q = stepper.qpos(seq)[..., adr]
        active = (q <= lo) | (q >= hi)
        out |= np.any(active[:, 1:] != active[:, :-1], axis=(1, 2))
    return out


def velocity_terms(m) -> str:
    """What of the model depends on velocity in a way MuJoCo's implicit integrators treat
    implicitly beyond Euler: Euler already integrates joint damping implicitly (eulerdamp)."""
    import mujoco

    found = []
    if np.any(m.tendon_damping):
        found.append("tendon damping")
    if m.opt.density or m.opt.viscosity:
        found.append("fluid drag")
    if m.nu and (np.any(np.asarray(m.actuator_biasprm)[:, 2]) or np.any(np.asarray(m.actuator_gainprm)[:, 2])):
        found.append("actuators with velocity gains")
    eulerdamp = not m.opt.disableflags & int(getattr(mujoco.mjtDisableBit, "mjDSBL_EULERDAMP", 0))
    if np.any(m.dof_damping) and not eulerdamp:
        found.append("joint damping (eulerdamp off)")
    if found:
        return ", ".join(found)
    if np.any(m.dof_damping):
        return "none beyond joint damping, which Euler integrates implicitly too (eulerdamp)"
    return "none"


def _contact_figures(n: np.ndarray, depth: np.ndarray) -> ContactFigures:
    ok = n >= 0
    n, depth = n[ok], depth[ok]
    touching = n > 0
    pen = depth[touching]
    return ContactFigures(
        mean=float(np.mean(n)) if n.size else math.nan,
        max=int(np.max(n)) if n.size else 0,
        share=float(np.mean(touching)) if n.size else math.nan,
        penetration_median=float(np.median(pen)) if pen.size else 0.0,
        penetration_max=float(np.max(pen)) if pen.size else 0.0,
    )


# ------------------------------------------------------------------ the verdict
def verdict(study: Study) -> list[str]:
    """The answer in words, each figure from the study (module docstring)."""
    b = study.baseline
    setting = (
        f"{study.integrator}, h = {study.timestep:g} s, {study.frame_skip} step"
        f"{'s' if study.frame_skip > 1 else ''} a control step of {study.control_step:g} s"
    )
    ref = study.reference
    if not ref.converged:
        return [
            f"At your setting ({setting}) no candidate is judged: the reference did not converge "
            f"({ref.describe()}; stopped at {ref.why}), which is more than a tenth of the baseline's own error "
            f"({b.obs.median:.2g} median, {b.obs.p95:.2g} 95th percentile)."
        ]
    lines = [
        f"At your setting ({setting}) each control step is {b.obs.median:.2g} off, median over "
        f"{study.nstates} states from {len(study.horizon)} seeds (95th percentile {b.obs.p95:.2g}), in units "
        f"of the observation's spread: {_share(b.obs.median)}."
    ]
    same = [r for r in study.candidates if r.candidate.substeps == 1 and not r.baseline]
    for r in same:
        if r.same_bits_as == b.candidate.name or (b.same_bits_as and r.same_bits_as == b.same_bits_as):
            lines.append(
                f"{r.candidate.integrator} is bit for bit {study.integrator} here: every transition the same "
                f"bits{_why_same(r.candidate.integrator, study.integrator, study.velocity_terms)}."
            )
            continue
        twin = study.by_name(r.same_bits_as) if r.same_bits_as else None
        if twin is not None and twin.candidate.substeps == 1:
            lines.append(
                f"{r.candidate.integrator} is bit for bit {twin.candidate.integrator} here"
                f"{_why_same(r.candidate.integrator, twin.candidate.integrator, study.velocity_terms)}."
            )
            continue
        lines.append(f"{r.candidate.integrator} at the same step {_change(b, r)}.")
    half = study.by_name(f"{study.integrator} x2")
    if half is not None:
        lines.append(f"A halved step ({study.integrator} x2) {_change(b, half)}.")
        why = _limited(b, half, study.switches)
        if why:
            lines.append(why)
    if study.within_episode and study.episodes is not None:
        ended = [e for e in study.episodes if e is not None]
        if ended:
            lines.append(
                f"States are taken inside each episode: under these controls the environment ends "
                f"{len(ended)} of {len(study.episodes)} episodes (terminate_when_unhealthy, on by default) "
                f"at {', '.join(f'{e:.3g} s' for e in ended)} of your own setting's run, so these figures "
                f"describe the first {max(ended):.2g} s after a reset at most; the fallen states after are "
                f"left out (--past-termination keeps them)."
            )
    elif study.past_termination > 0:
        lines.append(
            f"{100 * study.past_termination:.0f}% of these states come after the episode would have ended "
            f"(Gymnasium's terminate_when_unhealthy, on by default): the figures include the robot fallen "
            f"and lying in contact."
        )
    if study.observation_lag is not None:
        g = study.observation_lag
        lines.append(
            f"The observation's extras (contact forces, body quantities) are judged at each state; Gymnasium "
            f"reads them after mj_step from what that step's last forward pass left, up to a physics step "
            f"({study.timestep:g} s) earlier, which alone moves what your policy sees by {g.median:.2g} of the "
            "spread (median; 95th "
            f"percentile {g.p95:.2g}) at your setting: a lag no integrator removes, only a smaller step."
        )
    med, shortest = study.predictable()
    ended = [e for e in (study.episodes or []) if e is not None] if study.within_episode else []
    if (
        ended
        and len(ended) == len(study.horizon)
        and all(hz is None or hz >= e for hz, e in zip(study.horizon, study.episodes))
    ):
        lines.append(
            f"Predictable horizon: every episode ends before its two references (RK4 at h/{2**REF_FIRST} "
            f"and h/{2 ** (REF_FIRST + 1)}) part by {HORIZON_FRACTION:g} of the spread: within an episode "
            f"the motion is predictable, and trajectory errors are judged over all of it."
        )
    elif med is None and shortest is None:
        lines.append(
            f"Predictable horizon: the references (RK4 at h/{2**REF_FIRST} and h/{2 ** (REF_FIRST + 1)}) "
            f"stay within {HORIZON_FRACTION:g} of the spread over the whole run ({study.horizon_s:g} s): "
            f"trajectory errors are judged over all of it."
        )
    elif med is None:
        lines.append(
            f"Predictable horizon: most seeds' references stay within {HORIZON_FRACTION:g} of the spread "
            f"over the run ({study.horizon_s:g} s); the shortest parts at {shortest:.3g} s."
        )
    else:
        lines.append(
            f"Predictable horizon: the references part by {HORIZON_FRACTION:g} of the spread after "
            f"{med:.3g} s (median over seeds; shortest {shortest:.3g} s): trajectory errors are judged only "
            "before it (and before the episode's end), and past it a trajectory error measures the chaos of the "
            "motion, not the integrator."
        )
    return lines


def _share(x: float) -> str:
    if x >= 0.5:
        return "as large as the spread itself"
    for frac, words in (
        (0.2, "about a quarter"),
        (0.05, "about a tenth"),
        (0.02, "a few hundredths"),
        (0.005, "about a hundredth"),
    ):
        if x >= frac:
            return f"{words} of it"
    return "well under a hundredth of it"


def _why_same(a: str, b: str, terms: str) -> str:
    if {a, b} <= {"euler", "implicitfast", "implicit"} and terms.startswith("none"):
        return f" (velocity-dependent forces it would treat implicitly: {terms})"
    return ""


#: A contact or limit switch is named as what limits a halved step only where it is this much
#: (a share) more common on the steps that miss their order than on those that get it.
SWITCH_MARGIN = 0.25
#: A timing whose fastest two repeats differ by more than this is told beside the work it measures.
NOISY = 0.25
#: A median below this share of the spread is near roundoff for a ratio.
TINY = 1e-6
#: Each integrator's order on smooth motion: what a halved step would buy without contact.
ORDER = {"euler": 1, "implicitfast": 1, "implicit": 1, "rk4": 4, "discrete": 1}


def _x(f: float) -> str:
    return f"{f:,.0f}" if f >= 1000 else f"{f:.3g}"


def _cost(b: CandidateResult, r: CandidateResult) -> str:
    """The cost ratio in words; where the clock moved more than NOISY between repeats, the work
    ratio beside it (mj_step calls and force evaluations, which no load moves)."""
    ratio = r.cost_s / b.cost_s if b.cost_s > 0 else math.nan
    spread = float(np.nanmax([b.cost_spread, r.cost_spread, 0.0]))
    said = f"{ratio:.2g} x the cost"
    if spread > NOISY:
        said += (
            f" (the clock moved {100 * spread:.0f}% between repeats here; {r.physics_steps / b.physics_steps:.2g} "
            f"x the mj_step calls, {r.evaluations / b.evaluations:.2g} x the force evaluations)"
        )
    return said


def _change(b: CandidateResult, r: CandidateResult) -> str:
    cost = _cost(b, r)
    if r.run_status != "ok" and b.run_status == "ok":
        return f"its run is {r.run_status}, at {cost}"
    if not r.resolved:
        return (
            f"the error falls below the reference's resolution (under {r.obs.median:.2g}; "
            f"{b.obs.median / max(r.obs.median, 1e-300):.3g} x or more) for {cost}"
        )
    factor = b.obs.median / r.obs.median if r.obs.median > 0 else math.inf
    if min(b.obs.median, r.obs.median) < TINY and r.obs.p95 > 0:
        # Ratios of medians near roundoff say little: the 95th percentile leads.
        f95 = b.obs.p95 / r.obs.p95
        word = "cuts" if f95 > 1 else "raises"
        return (
            f"{word} the 95th percentile {_x(max(f95, 1 / f95))} x (medians {b.obs.median:.2g} and "
            f"{r.obs.median:.2g}: one is tiny, so the 95th percentile leads) "
            f"{'for' if f95 > 1 else 'at'} {cost}"
        )
    p95 = f"95th percentile {_x(b.obs.p95 / r.obs.p95)} x" if r.obs.p95 > 0 else "95th percentile 0"
    if 0.8 <= factor <= 1.25:
        return f"leaves the error about as it is ({factor:.3g} x; {p95}) for {cost}"
    if factor > 1:
        return f"cuts the error {_x(factor)} x (median; {p95}) for {cost}"
    return f"raises the error {_x(1 / factor)} x (median; 95th percentile {_x(r.obs.p95 / b.obs.p95)} x) at {cost}"


def _limited(b: CandidateResult, half: CandidateResult, switches) -> str | None:
    """Where a halved step buys less than the integrator's order promises: on how many control
    steps, by how much, and how often a contact or a joint limit switches within those steps and
    within the others (per state, the ratio of the two errors)."""
    p = ORDER.get(b.candidate.integrator)
    if p is None or not half.resolved or b.obs_errors is None or half.obs_errors is None:
        return None
    eb, eh = np.asarray(b.obs_errors), np.asarray(half.obs_errors)
    ok = np.isfinite(eb) & np.isfinite(eh) & (eh > 0)
    if not ok.any():
        return None
    ratio = eb[ok] / eh[ok]
    full = ratio >= 0.5 * 2**p
    if np.mean(full) >= 0.95:
        return None
    rest = ~full
    n, n_full, n_rest = len(ratio), int(full.sum()), int(rest.sum())
    gain = float(np.median(ratio[rest]))
    buys = f"buys {gain:.3g} x (median)" if gain >= 1 else f"makes the error {1 / gain:.3g} x worse (median)"
    there = f", a median {float(np.median(ratio[full])):.3g} x there" if n_full else ""
    out = (
        f"Per control step, a halved step buys at least half of what {b.candidate.integrator}'s order {p} "
        f"promises ({2**p} x) on {n_full} of {n}{there}; on the other {n_rest} it {buys}."
    )
    if switches is None:
        return out
    sw = np.asarray(switches)[ok]
    out += (
        f" A contact or a joint limit switches within {int(sw[rest].sum())} of those {n_rest} and within "
        f"{int(sw[full].sum())} of the {n_full} others (read at every h/{2 ** (REF_FIRST + 1)} step of the reference)"
    )
    on_rest, on_full = float(np.mean(sw[rest])), (float(np.mean(sw[full])) if n_full else 0.0)
    if on_rest >= on_full + SWITCH_MARGIN:
        return out + ": the steps that miss their order are mostly steps where the contact set changes."
    return out + ": switches are about as common where the order holds, so they do not tell what limits the rest."
    med, p95 = b.obs.median / half.obs.median, b.obs.p95 / half.obs.p95
    if med < 0.5 * 2**p:
        return (
            f"{b.candidate.integrator}'s order {p} would cut it {2**p} x on smooth motion; it cuts "
            f"{med:.3g} x here: contact, not the integrator's order, limits what a finer step buys."
        )
    if p95 < 0.5 * 2**p:
        return (
            f"The 95th percentile (the control steps in which a contact or a joint limit switches) falls only "
            f"{p95:.3g} x where the order promises {2**p} x: there contact limits what a finer step buys."
        )
    return None
