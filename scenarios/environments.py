"""The settings the robots' users run them at: an environment's model file, its control step and
its reset distribution, as the environment's own source sets them.

A reinforcement-learning environment fixes more than the model file says: Gymnasium's
``MujocoEnv`` steps ``frame_skip`` physics steps per action (``mj_step(model, data,
nstep=frame_skip)``) with the action held, and resets to ``init_qpos + U(-s, s)`` (``init_qpos`` is
MuJoCo's ``qpos0``) with the velocity noise uniform or Gaussian by environment; its observation
leaves out the root's x (and y) position. dm_control's suite sets a control timestep that is a
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
        vel = (f"U(-{self.qvel_scale:g}, {self.qvel_scale:g})" if self.velocity == "uniform"
               else f"{self.qvel_scale:g} N(0, 1)")
        return f"qpos0 + U(-{self.qpos_scale:g}, {self.qpos_scale:g}) per qpos entry, qvel {vel}"


@dataclass(frozen=True)
class Environment:
    """One environment's setting of its model (module docstring)."""

    name: str
    package: str          # the registry package that ships the file
    file: str             # the file's name in that package's assets
    frame_skip: int       # physics steps per control step, the action held
    reset: ResetNoise
    root_position: int    # leading qpos entries the observation leaves out (the root's x, y)
    source: str           # where in the package each number was read
    keyframe: bool = True  # starts from the first keyframe where the file has one (Gymnasium: qpos0)
    #: Gymnasium's default termination (terminate_when_unhealthy): (qpos index of the root's
    #: height, its healthy range, qpos index of its angle or None, that range); None: never ends.
    healthy: tuple | None = None

    def terminated(self, qpos) -> "np.ndarray":
        """Whether each state (rows of qpos) is past the environment's default termination."""
        import numpy as np

        qpos = np.asarray(qpos)
        if self.healthy is None:
            return np.zeros(qpos.shape[:-1], dtype=bool)
        zi, (zlo, zhi), ai, arange = self.healthy
        ok = (qpos[..., zi] > zlo) & (qpos[..., zi] < zhi)
        if ai is not None:
            ok &= (qpos[..., ai] > arange[0]) & (qpos[..., ai] < arange[1])
        return ~ok

    def path(self) -> str:
        return packaged_model(self.package, self.file)


def _gym(name, file, frame_skip, noise, velocity, root, module, healthy=None):
    return Environment(name, "gymnasium", file, frame_skip, ResetNoise(noise, noise, velocity), root,
                       f"gymnasium 1.4.0 envs/mujoco/{module}.py: frame_skip={frame_skip}, reset_noise_scale={noise:g}, "
                       f"qvel noise {velocity}", keyframe=False, healthy=healthy)


def _dmc(name, file, frame_skip, control_timestep):
    return Environment(name, "dm_control", file, frame_skip, ResetNoise(0.01, 0.01, "uniform"), 1,
                       f"dm_control 1.0.50 suite/{name.split('/')[1]}.py: control timestep "
                       f"{control_timestep:g} s = {frame_skip} x the file's timestep; its reset (random joint angles, "
                       f"a fall to the floor) is not reproduced: the harness starts from qpos0 with U(-0.01, 0.01)")


ENVIRONMENTS: dict[str, Environment] = {e.name: e for e in (
    _gym("Hopper-v5", "hopper.xml", 4, 5e-3, "uniform", 1, "hopper_v5", (1, (0.7, float("inf")), 2, (-0.2, 0.2))),
    _gym("Walker2d-v5", "walker2d_v5.xml", 4, 5e-3, "uniform", 1, "walker2d_v5", (1, (0.8, 2.0), 2, (-1.0, 1.0))),
    _gym("HalfCheetah-v5", "half_cheetah.xml", 5, 0.1, "normal", 1, "half_cheetah_v5"),
    _gym("Ant-v5", "ant.xml", 5, 0.1, "normal", 2, "ant_v5", (2, (0.2, 1.0), None, None)),
    _gym("Humanoid-v5", "humanoid.xml", 5, 1e-2, "uniform", 2, "humanoid_v5", (2, (1.0, 2.0), None, None)),
    _gym("Swimmer-v5", "swimmer.xml", 4, 0.1, "uniform", 2, "swimmer_v5"),
    _gym("InvertedDoublePendulum-v5", "inverted_double_pendulum.xml", 5, 0.1, "normal", 0,
         "inverted_double_pendulum_v5"),
    _gym("InvertedPendulum-v5", "inverted_pendulum.xml", 2, 0.01, "uniform", 0, "inverted_pendulum_v5"),
    _dmc("dm_control/cartpole", "cartpole.xml", 1, 0.01),
    _dmc("dm_control/walker", "walker.xml", 10, 0.025),
    _dmc("dm_control/cheetah", "cheetah.xml", 1, 0.01),
    _dmc("dm_control/hopper", "hopper.xml", 4, 0.02),
    _dmc("dm_control/humanoid", "humanoid.xml", 5, 0.025),
)}


def packaged_model(package: str, file: str) -> str:
    """The path of ``file`` among ``package``'s model files, found without importing the package;
    InvalidInput naming the extra to install where the package is absent."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise InvalidInput(f"model file {file!r} ships in the package {package!r}, which is not installed "
                           f"(pip install 'integrator-harness[models]')")
    path = os.path.join(list(spec.submodule_search_locations)[0], PACKAGE_ASSETS[package], file)
    if not os.path.isfile(path):
        raise InvalidInput(f"model file {file!r}: not in {package}'s model files ({os.path.dirname(path)})")
    return path


def environment(name: str) -> Environment:
    if name not in ENVIRONMENTS:
        raise InvalidInput(f"unknown --env {name!r} (valid: {', '.join(ENVIRONMENTS)})")
    return ENVIRONMENTS[name]
