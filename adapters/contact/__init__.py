"""Contact poses: each engine's ball, slide, rest and stack (``scenarios.contact``), one module per
engine, each with its ``MODES`` (``{mode id: ContactMode}``) joined here into ``CONTACT_MODES``.

A mode is an engine integrator with its contact model: MuJoCo's integrators in each friction cone,
pybullet's one solver, pymunk's, Drake's discrete (TAMSI, SAP) and continuous plants, Newton's
semi-implicit and XPBD solvers, REBOUND's hard-sphere collisions. Its ``run(mode, scene, dt)``
(a module-level function, so that a worker can call it) poses the scene with every default that
would change the answer set and stated (``ContactRun.settings``), steps it for
``scene.duration``, recording each body's centre and velocity at every step, then steps it again
from the start with nothing recorded and times that loop alone (``ContactRun.loop_cpu_s``).

Importing this package imports no engine.
"""
from __future__ import annotations

from ._mode import ContactMode, record_loop, timed_loop
from . import drake, mujoco, newton, pybullet, pymunk, rebound

CONTACT_MODES: dict[str, ContactMode] = {**mujoco.MODES, **pybullet.MODES, **pymunk.MODES, **drake.MODES,
                                         **newton.MODES, **rebound.MODES}

__all__ = ["CONTACT_MODES", "ContactMode", "record_loop", "timed_loop"]
