"""A ``HARNESS_PLUGINS`` module for the tests: an engine mode whose step slows on demand.

``slowtest:semi_implicit`` steps the spring by semi-implicit Euler in Python (as a user's
``velocity_func`` would), through the adapters' own loop (``adapters.drive``). With
``HARNESS_TEST_SLOWDOWN=N`` in the nightly's environment, each step computes its update N times
on the CPU (the clock the nightly times cost on) and keeps the last: its states, and so every
accuracy figure, stay bitwise the same while its cost grows. Measured here: the loop's own ~8 us
a step dominate a single update; N = 300 adds ~30 us (cost ratio to explicit Euler 48 -> 211).
The variable is read where the model is built, in a worker; workers fork from a server that
keeps the environment of the process that started it, so a new value needs a new nightly
process::

    HARNESS_PLUGINS=tests.slow_plugin HARNESS_TEST_SLOWDOWN=300 harness nightly --suite smoke
"""

from __future__ import annotations

import os

import numpy as np

from adapters import EngineMode

SLOWDOWN_VAR = "HARNESS_TEST_SLOWDOWN"
#: The plugin's version, as a run records it (``harness.execution.environment.plugin_versions``):
#: a slowed step is a changed plugin, which the history sees as it sees an engine's upgrade.
__version__ = f"1.0+repeat{max(1, int(os.environ.get(SLOWDOWN_VAR, '1')))}"


class _SpringModel:
    def __init__(self, scene, dt):
        q, v = scene.initial_state()
        self.x, self.v = float(q[0]), float(v[0])
        self.k_over_m = scene.values["k"] / scene.values["m"]
        self.dt = dt
        self.repeat = max(1, int(os.environ.get(SLOWDOWN_VAR, "1")))
        self.settings = {"update": "v += -k/m x dt; x += v dt", "repeat": self.repeat}

    def advance(self) -> None:
        for _ in range(self.repeat):
            v = self.v - self.k_over_m * self.x * self.dt
            x = self.x + v * self.dt
        self.x, self.v = x, v

    def state(self):
        return np.array([self.x]), np.array([self.v])

    def trouble(self):
        return None

    def close(self) -> None:
        pass


def _build(engine_module, mode, scene, dt):
    return _SpringModel(scene, dt)


METHODS = {
    "slowtest:semi_implicit": EngineMode(
        engine="slowtest",
        mode="semi_implicit",
        module="os",
        dist="integrator-harness",
        build=_build,
        scenes=("spring",),
        unsupported={},
        settings={"update": "semi-implicit Euler in Python"},
        doc=f"Semi-implicit Euler stepped in Python; each step repeated ${SLOWDOWN_VAR} times.",
    ),
}
