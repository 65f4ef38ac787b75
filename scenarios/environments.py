"""The settings the robots' users run them at: an environment's model file, its control step and
its reset distribution, as the environment's own source sets them.

A reinforcement-learning environment fixes more than the model file says: Gymnasium's
``MujocoEnv`` steps ``frame_skip`` physics steps per action (``mj_step(model, data,
nstep=frame_skip)``) with the action held, and resets to ``init_qpos + U(-s, s)`` (``init_qpos`` is
MuJoCo's ``qpos0``) with the velocity noise uniform or Gaussian by environment; its observation
leaves out the root's x (and y) position and adds, for Ant and Humanoid, body quantities and contact
forces (``Observation``); an episode ends where the robot is unhealthy (``Termination``).
dm_control's suite sets a control timestep that is a
whole number of the file's physics steps. ``ENVIRONMENTS`` holds these per environment, each with
the line of the source it was read from; ``harness model --env NAME`` runs a model at them.

The model files come from the environments' own packages in the registry (``pip install
integrator-harness[models]``: Gymnasium 1.4.0, dm_control 1.0.50); they are located, never
imported (dm_control's Python does not load against MuJoCo 4, its XML does).
"""

from __future__ import annotations

import importlib.util
import os
from dataclasses import dataclass

from records import InvalidInput

#: Where each package keeps its model files, relative to the package's directory.
PACKAGE_ASSETS = {"gymnasium": os.path.join("envs", "mujoco", "assets"), "dm_control": "suite"}


@dataclass(frozen=True)
class ResetNoise:
    """The start: ``qpos0 + U(-qpos_scale, qpos_scale)`` per qpos entry and ``qvel`` drawn from
    ``velocity`` ("uniform": ``U(-qvel_scale, qvel_scale)``; "normal": ``qvel_scale N(0, 1)``)."""

    qpos_scale: float
    qvel_scale: float
    velocity: str = "uniform"

    def describe(self) -> str:
        vel = (
            f"U(-{self.qvel_scale:g}, {self.qvel_scale:g})"
            if self.velocity == "uniform"
            else f"{self.qvel_scale:g} N(0, 1)"
        )
        return f"qpos0 + U(-{self.qpos_scale:g}, {self.qpos_scale:g}) per qpos entry, qvel {vel}"


@dataclass(frozen=True)
class Observation:
    """What a policy sees, as Gymnasium's ``_get_obs`` builds it by default: ``qpos`` less its
    ``root_position`` leading entries (the root's x, and y), ``qvel`` (clipped to ``qvel_clip`` where
    set: Hopper, Walker2d), then ``extras``: fields of ``mjData`` read after ``mj_rnePostConstraint``,
    each ``(field, first row, clip or None)`` (Ant: ``clip(cfrc_ext, -1, 1)``; Humanoid: ``cinert``,
    ``cvel``, ``qfrc_actuator[6:]``, ``cfrc_ext``, rows from 1, the world's left out)."""

    root_position: int = 1
    qvel_clip: float | None = None
    extras: tuple = ()

    def describe(self) -> str:
        parts = [
            f"qpos less its first {self.root_position} entries (the root's position)",
            "qvel" + (f" clipped to +-{self.qvel_clip:g}" if self.qvel_clip else ""),
        ]
        for name, first, clip in self.extras:
            parts.append(f"{name}[{first}:]" + (f" clipped to [{clip[0]:g}, {clip[1]:g}]" if clip else ""))
        return ", ".join(parts)


@dataclass(frozen=True)
class Termination:
    """Gymnasium's default termination (``terminate_when_unhealthy``) as its ``is_healthy`` tests
    it after each step: the root's height ``qpos[z]`` within ``z_range`` (open, or ``closed`` as
    Ant's), its angle ``qpos[angle]`` within ``angle_range`` where set, every entry of
    ``state_vector()[2:]`` within ``state_range`` where set (Hopper), the state finite (Ant)."""

    z: int
    z_range: tuple
    angle: int | None = None
    angle_range: tuple | None = None
    state_range: tuple | None = None
    closed: bool = False
    finite: bool = False

    def terminated(self, qpos, qvel):
        import numpy as np

        qpos, qvel = np.asarray(qpos), np.asarray(qvel)
        z = qpos[..., self.z]
        lo, hi = self.z_range
        ok = (lo <= z) & (z <= hi) if self.closed else (lo < z) & (z < hi)
        if self.angle is not None:
            a = qpos[..., self.angle]
            ok &= (self.angle_range[0] < a) & (a < self.angle_range[1])
        state = np.concatenate([qpos, qvel], axis=-1)
        if self.state_range is not None:
            rest = state[..., 2:]
            ok &= np.all((self.state_range[0] < rest) & (rest < self.state_range[1]), axis=-1)
        if self.finite:
            ok &= np.all(np.isfinite(state), axis=-1)
        return ~ok


@dataclass(frozen=True)
class Environment:
    """One environment's setting of its model (module docstring)."""

    name: str
    package: str  # the registry package that ships the file
    file: str  # the file's name in that package's assets
    frame_skip: int  # physics steps per control step, the action held
    reset: ResetNoise
    observation: Observation
    source: str  # where in the package each number was read
    keyframe: bool = True  # starts from the first keyframe where the file has one (Gymnasium: qpos0)
    termination: Termination | None = None  # None: episodes end only by time

    def path(self) -> str:
        return packaged_model(self.package, self.file)


def _gym(name, file, frame_skip, noise, velocity, observation, module, termination=None, note=""):
    return Environment(
        name,
        "gymnasium",
        file,
        frame_skip,
        ResetNoise(noise, noise, velocity),
        observation,
        f"gymnasium 1.4.0 envs/mujoco/{module}.py: frame_skip={frame_skip}, reset_noise_scale={noise:g}, "
        f"qvel noise {velocity}{note}",
        keyframe=False,
        termination=termination,
    )


def _dmc(name, file, frame_skip, control_timestep):
    return Environment(
        name,
        "dm_control",
        file,
        frame_skip,
        ResetNoise(0.01, 0.01, "uniform"),
        Observation(1),
        f"dm_control 1.0.50 suite/{name.split('/')[1]}.py: control timestep "
        f"{control_timestep:g} s = {frame_skip} x the file's timestep; its reset (random joint angles, "
        f"a fall to the floor) and its observation (body orientations, heights) are not reproduced: "
        f"the harness starts from qpos0 with U(-0.01, 0.01) and observes qpos less the root's x, qvel",
    )


_WALKING = Observation(1, qvel_clip=10.0)
_INF = float("inf")
ENVIRONMENTS: dict[str, Environment] = {
    e.name: e
    for e in (
        _gym(
            "Hopper-v5",
            "hopper.xml",
            4,
            5e-3,
            "uniform",
            _WALKING,
            "hopper_v5",
            Termination(1, (0.7, _INF), 2, (-0.2, 0.2), state_range=(-100.0, 100.0)),
        ),
        _gym(
            "Walker2d-v5",
            "walker2d_v5.xml",
            4,
            5e-3,
            "uniform",
            _WALKING,
            "walker2d_v5",
            Termination(1, (0.8, 2.0), 2, (-1.0, 1.0)),
        ),
        _gym("HalfCheetah-v5", "half_cheetah.xml", 5, 0.1, "normal", Observation(1), "half_cheetah_v5"),
        _gym(
            "Ant-v5",
            "ant.xml",
            5,
            0.1,
            "normal",
            Observation(2, extras=(("cfrc_ext", 1, (-1.0, 1.0)),)),
            "ant_v5",
            Termination(2, (0.2, 1.0), closed=True, finite=True),
        ),
        _gym(
            "Humanoid-v5",
            "humanoid.xml",
            5,
            1e-2,
            "uniform",
            Observation(
                2, extras=(("cinert", 1, None), ("cvel", 1, None), ("qfrc_actuator", 6, None), ("cfrc_ext", 1, None))
            ),
            "humanoid_v5",
            Termination(2, (1.0, 2.0)),
        ),
        _gym("Swimmer-v5", "swimmer.xml", 4, 0.1, "uniform", Observation(2), "swimmer_v5"),
        _gym(
            "InvertedDoublePendulum-v5",
            "inverted_double_pendulum.xml",
            5,
            0.1,
            "normal",
            Observation(0),
            "inverted_double_pendulum_v5",
            note="; its observation (sines, cosines, constraint forces) and termination "
            "(the tip's height) not reproduced: qpos, qvel observed, no termination",
        ),
        _gym(
            "InvertedPendulum-v5",
            "inverted_pendulum.xml",
            2,
            0.01,
            "uniform",
            Observation(0),
            "inverted_pendulum_v5",
            note="; its termination (|pole angle| > 0.2) not reproduced",
        ),
        _dmc("dm_control/cartpole", "cartpole.xml", 1, 0.01),
        _dmc("dm_control/walker", "walker.xml", 10, 0.025),
        _dmc("dm_control/cheetah", "cheetah.xml", 1, 0.01),
        _dmc("dm_control/hopper", "hopper.xml", 4, 0.02),
        _dmc("dm_control/humanoid", "humanoid.xml", 5, 0.025),
    )
}


def packaged_model(package: str, file: str) -> str:
    """The path of ``file`` among ``package``'s model files, found without importing the package;
    InvalidInput naming the extra to install where the package is absent."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise InvalidInput(
            f"model file {file!r} ships in the package {package!r}, which is not installed "
            f"(pip install 'integrator-harness[models]')"
        )
    path = os.path.join(list(spec.submodule_search_locations)[0], PACKAGE_ASSETS[package], file)
    if not os.path.isfile(path):
        raise InvalidInput(f"model file {file!r}: not in {package}'s model files ({os.path.dirname(path)})")
    return path


def environment(name: str) -> Environment:
    if name not in ENVIRONMENTS:
        raise InvalidInput(f"unknown --env {name!r} (valid: {', '.join(ENVIRONMENTS)})")
    return ENVIRONMENTS[name]
