"""Engine adapters: one module per engine; ``ENGINE_METHODS[id]`` is an engine mode.

Importing this package imports no engine: each engine is imported when a mode is asked
whether it is available or is stepped (and then with its import-time output silenced,
``import_engine``). A plugin's mode is an ``EngineMode`` whose ``build`` returns a ``Model``;
``drive`` and ``output_marks`` are how every mode's run is stepped and recorded.
"""
from __future__ import annotations

from . import drake, mujoco, newton, pybullet, pymunk, rebound
from ._base import (EngineMode, EngineModel, Model, SteppedModel, declared, drive, engine_version, import_engine,
                    output_marks, version_key)

ENGINE_METHODS: dict[str, EngineMode] = {**mujoco.METHODS, **pybullet.METHODS, **pymunk.METHODS, **rebound.METHODS, **drake.METHODS, **newton.METHODS}

__all__ = ["ENGINE_METHODS", "EngineMode", "EngineModel", "Model", "SteppedModel", "declared", "drive", "engine_version", "import_engine", "output_marks",
           "version_key"]
