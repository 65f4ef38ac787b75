"""Engine adapters: one module per engine; ``ENGINE_METHODS[id]`` is an engine mode.

Importing this package imports no engine: each engine is imported when a mode is asked
whether it is available or is stepped (and then with its import-time output silenced,
``import_engine``). A plugin's mode is an ``EngineMode`` whose ``build`` returns a ``Model``;
``drive`` and ``output_marks`` are how every mode's run is stepped and recorded.

What every adapter shares, by idea: ``_mode.py`` (the engine mode, a ``records.Method``),
``_model.py`` (what a built engine model declares), ``_loops.py`` (the two loops that turn a model
into a trajectory), ``_engine.py`` (an engine's quiet import, its release and the releases an
adapter supports) and ``_posing.py`` (what several poses compute alike).
"""
from __future__ import annotations

from records.trajectory import output_marks

from . import drake, mujoco, newton, pybullet, pymunk, rebound
from ._engine import EngineVersions, engine_version, import_engine, version_key
from ._loops import drive
from ._mode import EngineMode
from ._model import EngineModel, Model, SteppedModel, declared

ENGINE_METHODS: dict[str, EngineMode] = {**mujoco.METHODS, **pybullet.METHODS, **pymunk.METHODS, **rebound.METHODS, **drake.METHODS, **newton.METHODS}

__all__ = ["ENGINE_METHODS", "EngineMode", "EngineModel", "EngineVersions", "Model", "SteppedModel", "declared",
           "drive", "engine_version", "import_engine", "output_marks", "version_key"]
