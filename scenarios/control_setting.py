"""The user's problem on a model file: the control step, the controls, the starts.

A robot is not a passive model from one start: a policy acts every control step (``frame_skip``
physics steps, the action held), from starts drawn by the environment's reset. ``ControlSetting``
states all of it, so that every figure of ``harness model`` can say what it was measured at:

* **control step** = ``frame_skip`` x the file's own ``timestep`` (the baseline), stepped by the
  file's own integrator;
* **controls** (``controls``): ``seeded``: ``u ~ U(ctrlrange)`` per actuator, a new draw each
  control step from ``numpy.random.default_rng((seed, 1))``, an actuator with no ``ctrlrange``
  drawn from ``U(-1, 1)`` (said in ``describe``); ``zero``: every control 0 (the passive model);
  a ``.npy`` or ``.csv`` FILE: one row per control step (``nu`` columns), repeated from its start
  when the run is longer;
* **starts** (``reset``): the model's first keyframe (else ``qpos0``) plus the environment's reset
  noise, one start per seed, drawn from ``numpy.random.default_rng((seed, 0))``; quaternions of free
  and ball joints normalised after the noise, as ``mj_step`` normalises them;
* **observation**: what a policy sees of the state (``scenarios.environments.Observation``):
  Gymnasium's default where an environment is named, else ``qpos`` less the root's x, then ``qvel``;
* **termination**: where an environment ends its episodes (``Termination``), none otherwise.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace

import numpy as np

from records import InvalidInput

from .environments import Observation, ResetNoise, Termination

CONTROL_MODES = ("seeded", "zero")
#: The reset noise where no environment sets one: small against a joint's range, as Gymnasium's
#: locomotion environments' (5e-3 to 0.1).
DEFAULT_RESET = ResetNoise(0.01, 0.01, "uniform")


@dataclass(frozen=True)
class ControlSetting:
    """How the model is run (module docstring)."""

    frame_skip: int = 1
    controls: str = "seeded"  # seeded, zero, or a path
    reset: ResetNoise = DEFAULT_RESET
    observation: Observation = Observation(1)
    termination: Termination | None = None
    seeds: tuple[int, ...] = (0, 1, 2)
    environment: str | None = None  # the preset it came from, if any
    source: str = "harness defaults"
    keyframe: bool = True  # start from the first keyframe where the file has one
    _table: np.ndarray | None = field(default=None, compare=False, repr=False)

    @staticmethod
    def read_controls(path: str) -> np.ndarray:
        if not os.path.isfile(path):
            raise InvalidInput(f"--controls {path!r}: no such file (valid: seeded, zero, or a .npy/.csv file)")
        try:
            table = np.load(path) if path.endswith(".npy") else np.loadtxt(path, delimiter=",", ndmin=2)
        except (ValueError, OSError) as exc:
            raise InvalidInput(f"--controls {path!r}: cannot be read as a table of controls ({exc})") from None
        table = np.atleast_2d(np.asarray(table, dtype=float))
        if not np.all(np.isfinite(table)) or table.size == 0:
            raise InvalidInput(f"--controls {path!r}: every control must be a finite number")
        return table

    def checked(self, m) -> ControlSetting:
        """This setting, its controls file checked against the model's actuators."""
        if self.controls in CONTROL_MODES:
            return self
        table = self.read_controls(self.controls)
        if table.shape[1] != m.nu:
            raise InvalidInput(
                f"--controls {self.controls!r}: {table.shape[1]} columns, the model has {m.nu} "
                f"actuators (one column each)"
            )
        return replace(self, _table=table)

    @classmethod
    def for_environment(cls, env, **overrides) -> ControlSetting:
        """An environment's own setting (``scenarios.environments``), fields overridden by name."""
        return cls(
            **{
                "frame_skip": env.frame_skip,
                "reset": env.reset,
                "observation": env.observation,
                "termination": env.termination,
                "environment": env.name,
                "source": env.source,
                "keyframe": env.keyframe,
                **overrides,
            }
        )

    def control_step(self, m) -> float:
        return self.frame_skip * float(m.opt.timestep)

    def sequence(self, m, seed: int, n: int) -> np.ndarray:
        """(n, nu) controls, one row per control step."""
        if m.nu == 0 or self.controls == "zero":
            return np.zeros((n, m.nu))
        if self.controls == "seeded":
            lo, hi = _control_range(m)
            return np.random.default_rng((seed, 1)).uniform(lo, hi, (n, m.nu))
        table = self._table if self._table is not None else self.read_controls(self.controls)
        return table[np.arange(n) % len(table)]

    def start(self, m, seed: int) -> tuple[np.ndarray, np.ndarray]:
        """(qpos, qvel) of the seed's start."""
        import mujoco

        rng = np.random.default_rng((seed, 0))
        key = m.nkey and self.keyframe
        q = (m.key_qpos[0] if key else m.qpos0).copy()
        v = (m.key_qvel[0] if key else np.zeros(m.nv)).copy()
        r = self.reset
        q += rng.uniform(-r.qpos_scale, r.qpos_scale, m.nq)
        v += (
            rng.uniform(-r.qvel_scale, r.qvel_scale, m.nv)
            if r.velocity == "uniform"
            else r.qvel_scale * rng.standard_normal(m.nv)
        )
        d = mujoco.MjData(m)
        d.qpos[:] = q
        mujoco.mj_normalizeQuat(m, d.qpos)
        return d.qpos.copy(), v

    def describe(self, m) -> dict:
        lo, hi = _control_range(m)
        unlimited = int(np.count_nonzero(~_ctrl_limited(m))) if m.nu else 0
        if self.controls == "seeded":
            controls = (
                "seeded: U(ctrlrange) per actuator, a new draw each control step, held for it "
                "(numpy default_rng((seed, 1)))"
                + (f"; {unlimited} actuators without a ctrlrange drawn from U(-1, 1)" if unlimited else "")
            )
        elif self.controls == "zero":
            controls = "zero: every control 0 (the passive model)"
        else:
            controls = f"from {self.controls}, one row per control step, repeated from its start"
        if m.nu == 0:
            controls = "none (the model has no actuators)"
        start = "the first keyframe" if m.nkey and self.keyframe else "qpos0"
        return {
            "control_step_s": self.control_step(m),
            "frame_skip": self.frame_skip,
            "timestep_s": float(m.opt.timestep),
            "controls": controls,
            "start": f"{self.reset.describe().replace('qpos0', start)} (numpy default_rng((seed, 0)))",
            "seeds": list(self.seeds),
            "observation": self.observation.describe(),
            "termination": _describe_termination(self.termination),
            "environment": self.environment,
            "source": self.source,
            "ctrl_low": lo.tolist(),
            "ctrl_high": hi.tolist(),
        }


def _ctrl_limited(m) -> np.ndarray:
    limited = np.asarray(m.actuator_ctrllimited).astype(bool)
    rng = np.asarray(m.actuator_ctrlrange)
    # MuJoCo's "auto" ctrllimited compiles to 1 where a range is given
    return limited & (rng[:, 1] > rng[:, 0])


def _control_range(m) -> tuple[np.ndarray, np.ndarray]:
    if m.nu == 0:
        return np.zeros(0), np.zeros(0)
    limited = _ctrl_limited(m)
    rng = np.asarray(m.actuator_ctrlrange, dtype=float)
    lo = np.where(limited, rng[:, 0], -1.0)
    hi = np.where(limited, rng[:, 1], 1.0)
    return lo, hi


def _describe_termination(t) -> str:
    if t is None:
        return "none (episodes end only by time)"
    out = f"qpos[{t.z}] (the root's height) {'in' if t.closed else 'strictly in'} {t.z_range}"
    if t.angle is not None:
        out += f", qpos[{t.angle}] (its angle) in {t.angle_range}"
    if t.state_range is not None:
        out += f", state_vector()[2:] in {t.state_range}"
    if t.finite:
        out += ", the state finite"
    return "healthy while " + out + " (Gymnasium's terminate_when_unhealthy)"
