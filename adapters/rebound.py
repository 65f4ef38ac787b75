"""REBOUND: ``rebound:leapfrog``, ``whfast``, ``ias15`` and ``saba`` on the Kepler problem.

Minimal model: a central body of mass 1 with ``G`` = the scene's GM, and a massless test
particle at the scene's initial state; the central body then never moves, so the particle's
coordinates are the scene's relative coordinates. ``gravity="basic"`` (direct summation, no
softening), no collisions, no boundaries. The fixed-step integrators advance with
``sim.steps(1)``: ``integrate(t)`` inserts extra steps to finish exactly on t, and never
returns when dt = 0. IAS15 is adaptive: there ``dt`` is the output interval and the
integrator chooses its own steps between outputs (their count is recorded).
"""
from __future__ import annotations

import numpy as np

from scenarios import Scene

from ._base import EngineMode

SCENES = ("kepler",)
_NOT_GRAVITY = "not a gravitational N-body problem (an additional_forces callback would be our force, not REBOUND's)"
UNSUPPORTED = {s: _NOT_GRAVITY for s in ("spring", "damped_spring", "pendulum", "projectile")}

#: Integrator settings set explicitly, so that a new REBOUND default cannot change what runs.
#: Each is REBOUND 5.2.2's default except where noted.
CONFIG = {
    "leapfrog": {"order": 2},
    "whfast": {"corrector": 0, "safe_mode": 1, "coordinates": "JACOBI", "kernel": "DEFAULT",
               "keep_unsynchronized": 0},
    "ias15": {"epsilon": 1e-9, "min_dt": 0.0, "adaptive_mode": "PRS23"},
    "saba": {"type": "10_6_4", "safe_mode": 1, "keep_unsynchronized": 0},
}

ADAPTIVE = ("ias15",)


class _Model:
    def __init__(self, rebound, mode: str, scene: Scene, dt: float):
        self.sim = sim = rebound.Simulation()
        self.adaptive = mode in ADAPTIVE
        self.dt, self.n = dt, 0
        sim.G = scene.values["GM"]
        sim.gravity = "basic"
        sim.collision = "none"
        sim.boundary = "none"
        sim.softening = 0.0
        sim.integrator = mode
        for name, value in CONFIG[mode].items():
            setattr(sim.integrator, name, value)
        sim.dt = dt
        q0, v0 = scene.initial_state()
        sim.add(m=1.0)
        sim.add(m=0.0, x=float(q0[0]), y=float(q0[1]), vx=float(v0[0]), vy=float(v0[1]))
        self._xyz = np.zeros((2, 3))
        self._vxvyvz = np.zeros((2, 3))
        self.settings = {
            "integrator": str(sim.integrator), "dt": float(sim.dt), "G": float(sim.G),
            "gravity": str(sim.gravity), "collision": str(sim.collision), "boundary": str(sim.boundary),
            "softening": float(sim.softening), "central_mass": 1.0, "particle_mass": 0.0,
            "advance": "integrate(n dt), adaptive steps between outputs" if self.adaptive else "steps(1)",
            **{name: _plain(getattr(sim.integrator, name)) for name in CONFIG[mode]},
        }

    def advance(self) -> None:
        self.n += 1
        if self.adaptive:
            self.sim.integrate(self.n * self.dt)
        else:
            self.sim.steps(1)

    def state(self):
        self.sim.serialize_particle_data(xyz=self._xyz, vxvyvz=self._vxvyvz)
        return self._xyz[1, :2].copy(), self._vxvyvz[1, :2].copy()

    def trouble(self) -> str | None:
        return None

    def close(self) -> None:
        self.settings["steps_done"] = int(self.sim.steps_done)


def _plain(value):
    """REBOUND hands integrator fields back as ctypes-backed subclasses of int/float (which do
    not pickle) or as enum names: record plain values."""
    for kind in (float, int):
        if isinstance(value, kind):
            return kind(value)
    return str(value)


def build(rebound, mode: str, scene: Scene, dt: float) -> _Model:
    return _Model(rebound, mode, scene, dt)


_DOCS = {
    "leapfrog": """leapfrog, drift-kick-drift (order 2)
        Measured: equals ref:leapfrog bitwise on Kepler with sim.steps().""",
    "whfast": """Wisdom-Holman symplectic map: exact Kepler drift (two-body: exact to roundoff)""",
    "ias15": """IAS15, adaptive 15th-order Gauss-Radau; dt is the output interval
        Measured: |dE/E| ~ 1e-14 over 1000 Kepler orbits.""",
    "saba": """SABA(10,6,4) symplectic splitting (Blanes et al. 2013); two-body: exact to roundoff""",
}

METHODS = {
    f"rebound:{mode}": EngineMode(
        engine="rebound", mode=mode, module="rebound", dist="rebound", build=build,
        scenes=SCENES, unsupported=UNSUPPORTED, doc=_DOCS[mode],
        settings={"integrator": mode, **CONFIG[mode], "gravity": "basic", "softening": 0,
                  "model": "central mass 1, G = GM, massless test particle"},
    )
    for mode in CONFIG
}
