"""How far ahead a scene's motion can be predicted at all: its **predictable horizon**, and what a
cloth programmer judges past it.

A falling sheet folds, and folding is chaotic: two accurate solutions of it part, so a trajectory
error taken long after they part measures the chaos, not the integrator. The measure is the model
files' (``harness.control_step``, after Erez, Tassa & Todorov 2015): two reference runs, and the
time they part by HORIZON_FRACTION of what is judged.

* **The two references**: the scene's own (DOP853, ``Scene.reference_solution``) and the same
  solve started PERTURBATION of the scene's length scale away on every position coordinate
  (``Scene.perturbed_reference``: a fixed draw of signs, at rest), a difference no viewer could see.
* **The horizon**: at every frame t_n = n / hz up to the asked horizon (and the reference's own,
  ``Scene.reference_horizon``), the two references' largest coordinate difference; the horizon is
  the last frame before it first exceeds HORIZON_FRACTION of the position tolerance (the asked
  horizon where it never does). A position error is judged up to the horizon only.
* **Past it**, what a cloth programmer looks at, each against the reference, each with its
  tolerance and source:

  - the **centre of mass** (the mean of the nodes' positions, every node's mass the same), within the
    position tolerance: where a viewer sees the sheet. It has its own horizon by the same rule, and
    is judged up to it (the references' centres of mass part far later than their nodes);
  - the **largest strain** of each family of springs that holds the sheet's stretch, max (l - L) / L
    over its springs and the frames (``Scene.strain_by_family``: the cloth's structural springs and
    its shear springs, apart: their stiffnesses differ, and on a stiff sheet a largest strain over
    both would read the soft shear diagonals alone): the run's at most STRAIN_TOL above the
    reference's in every family. STRAIN_TOL is after Provot (1995, "Deformation constraints in a
    mass-spring model to describe rigid cloth behavior"), whose constraints cap a spring's
    deformation rate at 10%, past which a mass-spring cloth reads as super-elastic; Provot's cap
    is absolute, and a sheet whose reference already stretches past it (the default soft sheet's
    shear diagonals, 30%) is judged here by what the run adds to the true motion's stretch;
  - the **energy**, judged over the whole horizon as the advice judges it (the initial energy on a
    conservative scene, the reference's on a damped one, whose two references' spread is stated
    with the horizon).

A scene without a perturbed reference (an exact solution is predictable throughout) has no horizon
here (None): its positions are judged at every frame. Measured once per scene, frame rate, horizon
and tolerance, and kept on the scene, so that the workers a sweep or an advice sends it to read it
instead of solving both references again.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

#: The references part when their largest coordinate difference passes this share of the position
#: tolerance (``harness.control_step.HORIZON_FRACTION``: the same share of a different spread).
HORIZON_FRACTION = 0.1
#: The second reference starts this share of the scene's length scale away on every position coordinate.
PERTURBATION = 1e-9
#: Past the horizon each spring family's largest strain may pass the reference's by this much
#: (after Provot 1995's 10% cap, module docstring).
STRAIN_TOL = 0.10
#: Where the tolerances come from, as the verdicts say it.
STRAIN_SOURCE = "after Provot 1995's 10% cap on a spring's deformation"


@dataclass(frozen=True)
class Horizon:
    """The predictable horizon of a scene at ``hz`` over ``asked`` (module docstring); times in the
    scene's unit, distances in its units, ``energy_spread`` relative to the initial energy."""

    hz: float
    asked: float  # the horizon judged: the request's, within the reference's own
    until: float  # the positions are predictable up to this frame's time (``asked`` where the references never part)
    com_until: float  # the centre of mass likewise
    tol: float  # the position tolerance HORIZON_FRACTION is a share of
    perturbation: float  # each coordinate's move at the second reference's start, absolute
    spread: float  # the references' largest coordinate difference over ``asked``
    com_spread: float  # ... of their centres of mass
    energy_spread: float  # ... of their energies, relative to the initial energy
    strain: float  # the references' largest strain over ``asked`` (the larger of the two)
    #: ... each stretching family's (``Scene.strain_by_family``), None where the scene has none
    strain_by_family: tuple | None = None

    @property
    def frames(self) -> int:
        """The last frame (index) the positions are judged at."""
        return int(round(self.until * self.hz))

    @property
    def com_frames(self) -> int:
        return int(round(self.com_until * self.hz))

    @property
    def short(self) -> bool:
        """Whether the references part before the asked horizon."""
        return self.frames < int(round(self.asked * self.hz))

    def text(self) -> str:
        """The horizon in words, as every verdict states it."""
        start = f"two DOP853 references started {self.perturbation:.2g} apart on every coordinate"
        bound = f"{HORIZON_FRACTION * self.tol:.2g} ({HORIZON_FRACTION:g} of the position tolerance)"
        if not self.short:
            return f"predictable over the whole {self.asked:g} s ({start} stay within {self.spread:.2g}, under {bound})"
        com = (
            f"the centre of mass to {self.com_until:.3g} s"
            if self.com_until < self.asked
            else f"the centre of mass throughout ({self.com_spread:.2g} apart at most)"
        )
        return (
            f"predictable only to {self.until:.3g} s of the {self.asked:g} s asked ({start} part by more than {bound} "
            f"after it, {self.spread:.2g} by {self.asked:g} s; their energies within {self.energy_spread:.2g} of the "
            f"initial), {com}"
        )

    def past_text(self) -> str:
        """What is judged past the horizon, in words (empty where the horizon is the asked one)."""
        if not self.short:
            return ""
        return (
            f"positions judged to {self.until:.3g} s; past it the centre of mass (within the position tolerance"
            f"{'' if self.com_until >= self.asked else f', to {self.com_until:.3g} s'}), each spring family's "
            f"largest strain (at most {STRAIN_TOL * 100:.0f} points above the reference's, {STRAIN_SOURCE}) "
            "and the energy"
        )

    def as_dict(self) -> dict:
        return {**asdict(self), "frames": self.frames, "short": self.short, "text": self.text()}

    @classmethod
    def from_dict(cls, d: dict | None) -> Horizon | None:
        if not d:
            return None
        out = cls(**{k: d[k] for k in cls.__dataclass_fields__ if k in d})
        if out.strain_by_family is not None and not isinstance(out.strain_by_family, tuple):
            out = cls(**{**asdict(out), "strain_by_family": tuple(out.strain_by_family)})
        return out


def supported(scene) -> bool:
    """Whether the scene has the second reference the horizon needs."""
    return callable(getattr(scene, "perturbed_reference", None)) and not getattr(scene, "own_run_reference", False)


def asked(scene, hz: float, horizon: float) -> int:
    """The last frame (index) of the asked horizon that the scene's reference reaches."""
    from harness.measures.error import trusted_until

    return int(math.floor(min(horizon, trusted_until(scene)) * hz + 1e-9))


def truth(scene, hz: float, horizon: float) -> tuple[np.ndarray, np.ndarray]:
    """(q, v) true at every frame n / hz up to the asked horizon (``harness.measures.error.true_state``),
    kept on the scene (its copies in workers carry it)."""
    from harness.measures.error import true_state

    frames = asked(scene, hz, horizon)
    store = scene.__dict__.setdefault("_frame_truth", {})
    key = (float(hz), frames)
    if key not in store:
        q, v, _ = true_state(scene, np.arange(frames + 1) / hz)
        store[key] = (q, v)
    return store[key]


def has_strain(scene) -> bool:
    """Whether the scene says how far it stretches (``strain``: the cloth)."""
    return callable(getattr(scene, "strain", None))


def centre_of_mass(scene, q: np.ndarray) -> np.ndarray:
    """The mean of every node's position (pins included: every node's mass is the same), (..., d)."""
    return scene.positions(q).mean(axis=-2)


def _last_within(apart: np.ndarray, bound: float) -> int:
    over = np.flatnonzero(~(apart <= bound))
    return len(apart) - 1 if not over.size else max(int(over[0]) - 1, 0)


def measure(scene, hz: float, horizon: float, tol: float) -> Horizon | None:
    """The scene's predictable horizon at ``hz`` over ``horizon`` for the position tolerance ``tol``
    (module docstring); None where the scene has no perturbed reference. Kept on the scene."""
    if not supported(scene):
        return None
    store = scene.__dict__.setdefault("_horizons", {})
    key = (float(hz), float(horizon), float(tol))
    if key in store:
        return store[key]
    q, v = truth(scene, hz, horizon)
    t = np.arange(len(q)) / hz
    size = PERTURBATION * scene.length_scale
    qp, vp = scene.perturbed_reference(t, PERTURBATION)
    apart = np.max(np.abs(q - qp), axis=-1)
    com_apart = np.max(np.abs(centre_of_mass(scene, q) - centre_of_mass(scene, qp)), axis=-1)
    e0 = float(np.max(np.abs(scene.energy(q[:1], v[:1]))))
    energy = np.abs(scene.energy(q, v) - scene.energy(qp, vp)) / (e0 if e0 > 0 else 1.0)
    strain = max(float(np.max(scene.strain(q))), float(np.max(scene.strain(qp)))) if has_strain(scene) else 0.0
    families = None
    if has_strain(scene) and callable(getattr(scene, "strain_by_family", None)):
        both = np.maximum(np.max(scene.strain_by_family(q), axis=0), np.max(scene.strain_by_family(qp), axis=0))
        families = tuple(float(x) for x in both)
    bound = HORIZON_FRACTION * tol
    out = Horizon(
        hz=float(hz),
        asked=float(t[-1]),
        until=float(t[_last_within(apart, bound)]),
        com_until=float(t[_last_within(com_apart, bound)]),
        tol=float(tol),
        perturbation=float(size),
        spread=float(np.max(apart)),
        com_spread=float(np.max(com_apart)),
        energy_spread=float(np.max(energy)),
        strain=strain,
        strain_by_family=families,
    )
    store[key] = out
    return out


@dataclass(frozen=True)
class Judged:
    """A run's figures against the reference at the frames (``judge_frames``): the position error
    inside the horizon, the centre of mass's error past it (None where the horizon is the asked
    one), the run's largest strain less the reference's (None on a scene without springs)."""

    position_error: float | None
    com_error: float | None
    strain_excess: float | None


def judge_frames(scene, q_run: np.ndarray, q_true: np.ndarray, h: Horizon | None) -> Judged:
    """``q_run`` (the run's positions at frames 0, 1, ..., API layout, as many as it reached) against
    ``q_true`` at the same frames, inside the horizon ``h`` and past it (module docstring)."""
    n = min(len(q_run), len(q_true))
    q_run, q_true = q_run[:n], q_true[:n]
    with np.errstate(all="ignore"):
        err = np.max(np.abs(q_run - q_true), axis=-1) if n else np.zeros(0)
    if not n or not np.all(np.isfinite(err)):
        return Judged(None, None, None)
    inside = n if h is None else min(n, h.frames + 1)
    position = float(np.max(err[:inside]))
    com = None
    if h is not None and h.short:
        to = min(n, h.com_frames + 1)
        past = slice(inside, to)
        if to > inside:
            diff = np.abs(centre_of_mass(scene, q_run[past]) - centre_of_mass(scene, q_true[past]))
            com = float(np.max(diff))
        else:
            com = 0.0
    strain = None
    if h is not None and has_strain(scene):
        if h.strain_by_family is not None and callable(getattr(scene, "strain_by_family", None)):
            run = np.max(scene.strain_by_family(q_run), axis=0)
            strain = float(np.max(run - np.asarray(h.strain_by_family)))  # the family that adds the most
        else:
            strain = float(np.max(scene.strain(q_run))) - h.strain
    return Judged(position, com, strain)


def moved(scene, q_a: np.ndarray, q_b: np.ndarray, h: Horizon | None) -> tuple[float, float | None]:
    """How far two runs' positions at the frames part: (the largest coordinate difference inside
    the horizon, that of their centres of mass past it, None where nothing lies past it)."""
    n = min(len(q_a), len(q_b))
    with np.errstate(all="ignore"):
        apart = np.max(np.abs(q_a[:n] - q_b[:n]), axis=-1)
    if not n or not np.all(np.isfinite(apart)):
        return math.inf, None
    inside = n if h is None else min(n, h.frames + 1)
    com = None
    if h is not None and h.short and min(n, h.com_frames + 1) > inside:
        past = slice(inside, min(n, h.com_frames + 1))
        com = float(np.max(np.abs(centre_of_mass(scene, q_a[past]) - centre_of_mass(scene, q_b[past]))))
    return float(np.max(apart[:inside])), com
