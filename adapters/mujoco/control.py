"""MuJoCo stepping a model file at a control step: what ``harness model``'s control-step study
needs of the engine, and nothing of the harness.

* **A candidate** is one of MuJoCo's integrators at ``substeps`` physics steps of ``h / substeps``
  per file step ``h``: a control step of ``frame_skip`` file steps is ``frame_skip x substeps`` calls
  of ``mj_step``, the control held (as Gymnasium's ``do_simulation``). Autoreset is off
  (``mjDSBL_AUTORESET``), so a blow-up stays a blow-up instead of a silent reset.
* **Transitions and runs** go through ``mujoco.rollout`` (MuJoCo's own C loop over ``mj_step``,
  threaded over the batch): full physics states (``mjSTATE_FULLPHYSICS``: time, qpos, qvel, act,
  ...) in and out. The solver's warm start is not part of that state: every transition starts cold,
  the reference's too.
* **Contacts** of a state are MuJoCo's own: ``mj_kinematics`` + ``mj_collision`` on it, the contacts
  the next step would use (``ncon``; penetration ``max(0, -dist)``).
* **Cost** is the engine's own loop: ``mj_step(m, d, nstep=frame_skip x substeps)`` per control
  step from the candidate's own run, timed with ``time.perf_counter``, the fastest of ``repeats``.
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass

import numpy as np

from . import MODES

#: MuJoCo's integrators (the adapter's mode names), in the order tables list them.
INTEGRATOR_NAMES = ("euler", "implicitfast", "implicit", "rk4", "discrete")
_ENUM = {name: f"mjINT_{MODES[name].upper()}" for name in INTEGRATOR_NAMES}
#: Force (acceleration) evaluations per mj_step.
EVALUATIONS = {"euler": 1, "implicitfast": 1, "implicit": 1, "rk4": 4, "discrete": 1}


def available_integrators() -> tuple[str, ...]:
    """The integrators the installed MuJoCo has (``discrete`` arrived in 3.13): asked of its enum."""
    import mujoco

    return tuple(n for n in INTEGRATOR_NAMES if hasattr(mujoco.mjtIntegrator, _ENUM[n]))


def integrator_name(m) -> str:
    import mujoco

    for n in available_integrators():
        if int(m.opt.integrator) == int(getattr(mujoco.mjtIntegrator, _ENUM[n])):
            return n
    return f"integrator {int(m.opt.integrator)}"


@dataclass(frozen=True)
class Candidate:
    integrator: str
    substeps: int

    @property
    def name(self) -> str:
        return f"{self.integrator} x{self.substeps}"


def candidate_model(base, integrator: str, h: float):
    """A copy of ``base`` stepping ``integrator`` at ``h``, autoreset off."""
    import mujoco

    m = copy.copy(base)
    m.opt.integrator = int(getattr(mujoco.mjtIntegrator, _ENUM[integrator]))
    m.opt.timestep = h
    m.opt.disableflags |= int(getattr(mujoco.mjtDisableBit, "mjDSBL_AUTORESET", 0))
    return m


def state_spec() -> int:
    import mujoco

    return int(mujoco.mjtState.mjSTATE_FULLPHYSICS)


def full_state(m, qpos, qvel) -> np.ndarray:
    """The full physics state of (qpos, qvel) at time 0 (act and the rest at their defaults)."""
    import mujoco

    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    d.qvel[:] = qvel
    out = np.empty(mujoco.mj_stateSize(m, state_spec()))
    mujoco.mj_getState(m, d, out, state_spec())
    return out


class Stepper:
    """Rollouts of one base model (the file as compiled) with MuJoCo's threads."""

    def __init__(self, base, threads: int = 2):
        import mujoco

        self.base = base
        self.threads = max(1, int(threads))
        self.nq, self.nv = base.nq, base.nv
        self.nstate = mujoco.mj_stateSize(base, state_spec())
        self._models: dict = {}

    def model(self, integrator: str, h: float):
        key = (integrator, h)
        if key not in self._models:
            import mujoco

            m = candidate_model(self.base, integrator, h)
            self._models[key] = (m, [mujoco.MjData(m) for _ in range(self.threads)])
        return self._models[key]

    def qpos(self, states):
        return states[..., 1 : 1 + self.nq]

    def qvel(self, states):
        return states[..., 1 + self.nq : 1 + self.nq + self.nv]

    def rollout(self, integrator: str, h: float, states: np.ndarray, controls: np.ndarray) -> np.ndarray:
        """States after each step: (nbatch, nstep, nstate) from ``states`` (nbatch, nstate) with
        ``controls`` (nbatch, nstep, nu)."""
        from mujoco import rollout

        m, datas = self.model(integrator, h)
        nbatch, nstep = controls.shape[0], controls.shape[1]
        if nstep == 0:
            return np.empty((nbatch, 0, self.nstate))
        with np.errstate(all="ignore"):
            out = rollout.rollout(
                m,
                datas[: min(self.threads, nbatch)],
                np.ascontiguousarray(states),
                np.ascontiguousarray(controls),
                nstep=nstep,
            )[0]
        return out

    def transition(self, integrator: str, h: float, nstep: int, states: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Each state (nbatch, nstate) after ``nstep`` steps of ``h`` with its control row ``u``
        (nbatch, nu) held: (nbatch, nstate)."""
        controls = np.repeat(u[:, None, :], nstep, axis=1)
        return self.rollout(integrator, h, states, controls)[:, -1, :]

    def transition_path(self, integrator: str, h: float, nstep: int, states: np.ndarray, u: np.ndarray) -> np.ndarray:
        """As ``transition``, every step's state: (nbatch, nstep, nstate)."""
        return self.rollout(integrator, h, states, np.repeat(u[:, None, :], nstep, axis=1))

    def run(self, integrator: str, h: float, per_control: int, s0: np.ndarray, U: np.ndarray) -> np.ndarray:
        """A run from ``s0`` (nbatch, nstate) under the control sequences ``U`` (nbatch, ncontrol, nu),
        ``per_control`` steps a control step: the states after every step (nbatch, ncontrol x per_control, nstate)."""
        controls = np.repeat(U, per_control, axis=1)
        return self.rollout(integrator, h, s0, controls)

    def observe(
        self,
        states: np.ndarray,
        spec,
        controls: np.ndarray,
        integrator: str | None = None,
        h: float | None = None,
        before: np.ndarray | None = None,
    ) -> np.ndarray:
        """What a policy sees of each state (rows of ``states``, each with the control that was held
        into it, rows of ``controls``), by ``spec`` (``scenarios.environments.Observation``): qpos
        less the root's position, qvel (clipped where the spec says), then the spec's extras after
        ``mj_forward`` and ``mj_rnePostConstraint`` at the state itself (the actuator forces under
        its control). Where ``before`` (the states one physics step earlier) is given, the extras are
        Gymnasium's instead: read after ``mj_step`` of ``integrator`` at ``h`` from ``before``, from
        what that step's last forward pass left (for Euler the state before; for RK4 its last stage)."""
        import mujoco

        q, v = self.qpos(states), self.qvel(states)
        if spec.qvel_clip:
            v = np.clip(v, -spec.qvel_clip, spec.qvel_clip)
        parts = [q[..., spec.root_position :], v]
        if spec.extras:
            m, datas = self.model(integrator or "euler", h or float(self.base.opt.timestep))
            d = datas[0]
            flat = (states if before is None else before).reshape(-1, self.nstate)
            u = np.asarray(controls, dtype=float).reshape(len(flat), -1)
            rows = []
            for n, st in enumerate(flat):
                if not np.all(np.isfinite(st)):
                    rows.append(None)
                    continue
                mujoco.mj_setState(m, d, st, state_spec())
                d.ctrl[:] = u[n]
                if before is None:
                    mujoco.mj_forward(m, d)
                else:
                    mujoco.mj_step(m, d)
                mujoco.mj_rnePostConstraint(m, d)
                row = []
                for name, first, clip in spec.extras:
                    x = np.asarray(getattr(d, name))[first:].ravel()
                    row.append(np.clip(x, *clip) if clip else x)
                rows.append(np.concatenate(row))
            width = next((len(r) for r in rows if r is not None), 0)
            extra = np.array([r if r is not None else np.full(width, np.nan) for r in rows])
            parts.append(extra.reshape(*states.shape[:-1], width))
        return np.concatenate(parts, axis=-1)

    def contacts(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(contacts, deepest penetration in m) of each state (rows of ``states``)."""
        import mujoco

        m, datas = self.model("euler", float(self.base.opt.timestep))
        d = datas[0]
        flat = states.reshape(-1, self.nstate)
        ncon = np.zeros(len(flat), dtype=int)
        depth = np.zeros(len(flat))
        spec = state_spec()
        for i, s in enumerate(flat):
            if not np.all(np.isfinite(s)):
                ncon[i], depth[i] = -1, math.nan
                continue
            mujoco.mj_setState(m, d, s, spec)
            mujoco.mj_kinematics(m, d)
            mujoco.mj_collision(m, d)
            n = int(d.ncon)
            ncon[i] = n
            if n:
                depth[i] = max(0.0, -float(np.min(d.contact.dist[:n])))
        return ncon.reshape(states.shape[:-1]), depth.reshape(states.shape[:-1])

    def time_per_control_step(
        self, integrator: str, h: float, per_control: int, starts, controls, min_s: float = 0.0
    ) -> float:
        """Seconds per control step of MuJoCo's own loop, ``mj_step(m, d, nstep=per_control)`` once a
        control step: from each of ``starts`` over the rows of its ``controls``, all of them, and
        again from the starts until the sample has run ``min_s`` (a clock tick is no measurement)."""
        import mujoco

        m, _ = self.model(integrator, h)
        d = mujoco.MjData(m)
        spec = state_spec()
        total, n = 0.0, 0
        if not any(len(U) for U in controls):
            return math.nan
        while n == 0 or total < min_s:
            for s0, U in zip(starts, controls):
                if len(U) == 0:
                    continue
                mujoco.mj_setState(m, d, s0, spec)
                t0 = time.perf_counter()
                for u in U:
                    d.ctrl[:] = u
                    mujoco.mj_step(m, d, nstep=per_control)
                total += time.perf_counter() - t0
                n += len(U)
        return total / n
