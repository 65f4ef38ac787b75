"""Engine adapters: one package per engine (``adapters/<engine>/``), each declaring its ``Engine``
entry (``ENGINE``: its modes, poses, model builder, bare loops, releases and distributions), joined
here in ``ENGINES``; ``ENGINE_METHODS[id]`` is an engine mode, and ``ENGINE_DISTS`` the
distributions whose release an engine's numbers depend on. Every list of engines the harness keeps
(packages recorded and compared, the fingerprint, the version tables, the model-file loaders, the
bench's bare loops) is read from ``ENGINES``.

Importing this package imports no engine: each engine is imported when a mode is asked
whether it is available or is stepped (and then with its import-time output silenced,
``import_engine``). A plugin's mode is an ``EngineMode`` whose ``build`` returns a ``Model``;
``drive`` and ``output_marks`` are how every mode's run is stepped and recorded.

What every adapter shares, by idea: ``_mode.py`` (the engine mode, a ``records.Method``),
``_model.py`` (what a built engine model declares), ``_contact.py`` (a contact mode, a pose of a
contact scene and the two loops every contact pose runs), ``_loops.py`` (the two loops that turn a model
into a trajectory), ``_engine.py`` (an engine's quiet import, its release, the releases an adapter
supports and the ``Engine`` entry) and ``_posing.py`` (what several poses compute alike).
"""

from __future__ import annotations

from records.trajectory import output_marks

from . import drake, mujoco, newton, pybullet, pymunk, rebound
from ._contact import BOX, ROLLING_SPHERE, SPHERE, TURNING_BOX, ContactMode, ContactPose, record_loop, timed_loop
from ._engine import Engine, EngineVersions, engine_version, import_engine, version_key
from ._loops import drive
from ._mode import EngineMode
from ._model import EngineModel, Model, SteppedModel, declared

#: Every built-in engine by id, each package's ``ENGINE``, one line.
ENGINES: dict[str, Engine] = {
    e.id: e for e in (mujoco.ENGINE, pybullet.ENGINE, pymunk.ENGINE, rebound.ENGINE, drake.ENGINE, newton.ENGINE)
}
ENGINE_METHODS: dict[str, EngineMode] = {mid: mode for e in ENGINES.values() for mid, mode in e.methods.items()}
#: Every engine's contact modes (each engine's ``contact.py``): an integrator with its contact model.
CONTACT_MODES: dict[str, ContactMode] = {mid: m for e in ENGINES.values() for mid, m in e.contact_modes.items()}
#: Every engine's distributions, each engine's own first: what the harness records and compares.
ENGINE_DISTS: tuple[str, ...] = tuple(dict.fromkeys(d for e in ENGINES.values() for d in e.dists))

__all__ = [
    "BOX",
    "CONTACT_MODES",
    "ROLLING_SPHERE",
    "SPHERE",
    "TURNING_BOX",
    "ContactMode",
    "ContactPose",
    "ENGINES",
    "ENGINE_DISTS",
    "ENGINE_METHODS",
    "Engine",
    "EngineMode",
    "EngineModel",
    "EngineVersions",
    "Model",
    "SteppedModel",
    "declared",
    "drive",
    "engine_version",
    "import_engine",
    "output_marks",
    "record_loop",
    "timed_loop",
    "version_key",
]
