"""A ``HARNESS_PLUGINS`` module for the tests: engine modes that fail the way real engines do.

``faulty:abort`` aborts the process in its first step (as pymunk does on a negative mass);
``faulty:hang`` never returns from its first step, spinning (as REBOUND does with dt = 0). Both are
engine modes like any adapter's, stepped by the same loop (``adapters.drive``), so
the nightly meets them exactly where it meets a real engine's failure::

    HARNESS_PLUGINS=tests.faulty_plugin harness nightly --suite smoke --cell-timeout 5
"""

from __future__ import annotations

import os
import time

import numpy as np

from adapters import EngineMode

HANG_S = 3600.0


class _FaultyModel:
    def __init__(self, mode: str, scene):
        self.mode = mode
        q, v = scene.initial_state()
        self._q, self._v = np.array(q, dtype=float), np.array(v, dtype=float)
        self.settings = {"fault": mode, "fault_at": "first step"}

    def advance(self) -> None:
        if self.mode == "abort":
            os.abort()  # SIGABRT: no Python exception, the process is gone
        end = time.monotonic() + HANG_S
        while time.monotonic() < end:  # spends CPU as a hung engine loop does, until its limit
            pass

    def state(self):
        return self._q.copy(), self._v.copy()

    def trouble(self):
        return None

    def close(self) -> None:
        pass


def _build(engine_module, mode, scene, dt):
    return _FaultyModel(mode, scene)


def _mode(mode: str, doc: str) -> EngineMode:
    return EngineMode(
        engine="faulty",
        mode=mode,
        module="os",
        dist="integrator-harness",
        build=_build,
        scenes=("spring",),
        unsupported={},
        settings={"fault": mode},
        doc=doc,
    )


METHODS = {
    "faulty:abort": _mode("abort", "Aborts the process (SIGABRT) in its first step."),
    "faulty:hang": _mode("hang", "Never returns from its first step."),
}
