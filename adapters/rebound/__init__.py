"""REBOUND: ``rebound:leapfrog``, ``whfast``, ``ias15`` and ``saba`` on the Kepler problem and
the outer solar system.

Minimal models, each the scene's own problem and nothing else: ``gravity="basic"`` (direct
summation, no tree, no softening), no collisions, no boundaries, no exit conditions (both exit
distances 0), no additional forces, every particle active.

* ``kepler``: a central body of mass 1 with ``G`` = the scene's GM, and a massless test
  particle at the scene's initial state; the central body then never moves, so the particle's
  coordinates are the scene's relative coordinates.
* ``solar_system``: the scene's six bodies in its order (Sun, Jupiter, ..., Pluto), its masses
  and G, at its initial state, which is heliocentric at t = 0 (the Sun at rest at the origin).
  The scene does not move to the centre of mass, so neither does the simulation
  (no ``sim.move_to_com()``): the state read back is the scene's 18 coordinates in the same
  inertial frame. WHFast's Jacobi coordinates are internal; they do not change that frame.

The fixed-step integrators advance with ``sim.steps(n)``, n steps in one C call between
output points (the engine's own loop; ``sim.steps(1)`` per step on the per-step path, the same
states bitwise): ``integrate(t)`` inserts extra steps to finish exactly on t, and never returns
when dt = 0. The state is read in bulk, one ``serialize_particle_data`` call into one buffer.
IAS15 is adaptive by design: there ``dt`` is the output interval, the integrator chooses its
own steps between outputs (``integrate(n dt)`` with ``exact_finish_time`` = 1, called at every
multiple of dt on both paths), and their count is recorded.

Force evaluations are counted in a counting run (``count=True``) by a no-op
``sim.additional_forces`` callback, which REBOUND calls once per force evaluation; it is a
Python function, so runs that are timed leave it out.
"""

from __future__ import annotations

import numpy as np

from records.method import Behaviour
from records.method_id import TOLERANCE, Option
from scenarios import Scene

from .._engine import Engine, EngineVersions
from .._mode import EngineMode
from .._model import SteppedModel
from . import bench

_NOT_GRAVITY = "not a gravitational N-body problem (an additional_forces callback would be our force, not REBOUND's)"
UNSUPPORTED = {
    s: _NOT_GRAVITY for s in ("spring", "damped_spring", "pendulum", "projectile", "chain", "rope", "cloth", "net")
}

#: Our mode name (REBOUND's integrator name) -> what it selects in REBOUND: that integrator, its
#: settings set explicitly so that a new REBOUND default cannot change what runs. Each is REBOUND
#: 5.2.2's default.
MODES = {
    "leapfrog": {"order": 2},
    "whfast": {"corrector": 0, "safe_mode": 1, "coordinates": "JACOBI", "kernel": "DEFAULT", "keep_unsynchronized": 0},
    "ias15": {"epsilon": 1e-9, "min_dt": 0.0, "adaptive_mode": "PRS23"},
    "saba": {"type": "10_6_4", "safe_mode": 1, "keep_unsynchronized": 0},
}

ADAPTIVE = ("ias15",)

#: The releases this adapter supports: from 4.0, whose ``sim.steps(n)``, ``serialize_particle_data``
#: and ``additional_forces`` the poses use. Before 5 an integrator's settings live on
#: ``sim.ri_<name>`` (``sim.integrator`` is its name) and some are not there yet (leapfrog's
#: ``order``, IAS15's ``adaptive_mode``): asked for, not assumed (``integrator_config``).
#: 4.0.0's wheel lacks its ``rebound.integrators`` package and cannot be imported.
VERSIONS = EngineVersions(low="4.0", below="6", tested=("4.4.0", "5.2.2"))


def integrator_config(sim, mode: str):
    """The object holding the integrator's settings: ``sim.integrator`` (REBOUND 5), else
    ``sim.ri_<mode>`` (REBOUND 4, where ``sim.integrator`` is the name); None where there is none."""
    config = sim.integrator
    return getattr(sim, f"ri_{mode}", None) if isinstance(config, str) else config


def has_mode(mode: str):
    """Whether the imported REBOUND runs ``mode`` with its ``MODES`` settings as this adapter spells it (a
    setting the release lacks is left out and recorded; one it refuses, such as REBOUND 4.4's
    integer IAS15 ``adaptive_mode`` or its SABA type names, leaves the mode unavailable)."""

    def present(rebound) -> bool | str:
        sim = rebound.Simulation()
        try:
            sim.integrator = mode
        except (TypeError, ValueError, AttributeError):
            return False
        config = integrator_config(sim, mode)
        for name, value in MODES[mode].items():
            if config is not None and hasattr(config, name):
                try:
                    setattr(config, name, value)
                except (TypeError, ValueError, AttributeError) as exc:
                    return (
                        f"rebound {rebound.__version__} refuses {mode}'s {name} = {value!r} "
                        f"({type(exc).__name__}: {' '.join(str(exc).split())[:80]})"
                    )
        return True

    return present


#: Simulation-wide settings, set explicitly and read back into each run's settings.
SIM = {
    "gravity": "basic",
    "collision": "none",
    "boundary": "none",
    "softening": 0.0,
    "exit_max_distance": 0.0,
    "exit_min_distance": 0.0,
    "exact_finish_time": 1,
}

#: How each kind of mode advances (recorded with every run).
ADVANCE = {
    "adaptive": "integrate(n dt) at every multiple n of dt, adaptive steps between them",
    "fixed": "steps(n) between output points (steps(1) per step as stepped by the harness)",
}


class _Simulation(SteppedModel):
    """What both poses share: the simulation's settings, the integrator, the counter and the
    loop. A pose sets G and adds its particles (``_add``) and reads the state back."""

    #: The model, in words (each run's ``model`` setting).
    WHAT: str = ""
    #: What the pose adds to the settings (kepler's: the keys its stored runs were recorded with).
    EXTRA_SETTINGS: dict = {}

    def __init__(
        self, rebound, mode: str, scene: Scene, dt: float, count: bool = False, tolerance: float | None = None
    ):
        self.sim = sim = rebound.Simulation()
        self.adaptive = mode in ADAPTIVE
        self.dt, self.n = dt, 0
        sim.G = self._G(scene)
        for name, value in SIM.items():
            setattr(sim, name, value)
        sim.integrator = mode
        config = integrator_config(sim, mode)
        # A setting this release does not have is recorded as missing (its one behaviour runs).
        missing = [name for name in MODES[mode] if config is None or not hasattr(config, name)]
        # IAS15's tolerance is its epsilon (the method id's ``@``: ``rebound:ias15@1e-6``).
        chosen = {**MODES[mode], **({"epsilon": tolerance} if tolerance is not None else {})}
        for name, value in chosen.items():
            if name not in missing:
                setattr(config, name, value)
        sim.dt = dt
        masses = self._add(sim, scene, *scene.initial_state())
        # One (N, 6) buffer, filled in one call: every array handed to serialize_particle_data
        # pays a ctypes conversion of its own, so one array for all particles pays it once.
        self._data = np.zeros((sim.N, 6))
        self.settings = {
            "integrator": str(sim.integrator),
            "dt": float(sim.dt),
            "G": float(sim.G),
            **{name: _plain(getattr(sim, name)) for name in SIM},
            "N": int(sim.N),
            "N_active": "all" if sim.N_active in (-1, 2**64 - 1) else int(sim.N_active),
            "masses": masses,
            "additional_forces": "none",
            "move_to_com": False,
            "model": self.WHAT,
            "advance": ADVANCE["adaptive" if self.adaptive else "fixed"],
            **{
                name: (f"not in rebound {rebound.__version__}" if name in missing else _plain(getattr(config, name)))
                for name in MODES[mode]
            },
        }
        self.settings.update(self.EXTRA_SETTINGS)
        self.force_passes = None
        if count:
            self.force_passes = 0

            def count_force_pass(_simulation_pointer):
                self.force_passes += 1

            sim.additional_forces = count_force_pass  # adds nothing: only counts
            sim.force_is_velocity_dependent = 0
            self.settings["additional_forces"] = "a no-op callback counting force evaluations"

    def advance(self) -> None:
        self.n += 1
        if self.adaptive:
            self.sim.integrate(self.n * self.dt)
        else:
            self.sim.steps(1)

    def steps(self, n: int) -> None:
        if self.adaptive:
            for _ in range(n):
                self.n += 1
                self.sim.integrate(self.n * self.dt)
        else:
            self.n += n
            self.sim.steps(n)

    def evaluations(self):
        if self.force_passes is None:
            return None, (
                "counted only in a counting run: REBOUND calls a no-op additional_forces callback "
                "once per force evaluation, a Python call that would slow the timed loop"
            )
        return self.force_passes, "REBOUND force evaluations (calls of a no-op sim.additional_forces callback)"

    def close(self) -> None:
        self.settings["steps_done"] = int(self.sim.steps_done)


class _Kepler(_Simulation):
    """A central body of mass 1 with G = GM, and a massless test particle at the scene's state."""

    WHAT = "central mass 1, G = GM, massless test particle"
    EXTRA_SETTINGS = {"central_mass": 1.0, "particle_mass": 0.0}

    def _G(self, scene: Scene) -> float:
        return scene.values["GM"]

    def _add(self, sim, scene: Scene, q0, v0) -> list[float]:
        sim.add(m=1.0)
        sim.add(m=0.0, x=float(q0[0]), y=float(q0[1]), vx=float(v0[0]), vy=float(v0[1]))
        return [1.0, 0.0]

    def state(self):
        self.sim.serialize_particle_data(xyzvxvyvz=self._data)
        return self._data[1, 0:2].copy(), self._data[1, 3:5].copy()


class _SolarSystem(_Simulation):
    """The scene's bodies, masses and G in its order and frame (module docstring)."""

    WHAT = (
        "the scene's 6 bodies, masses and G; heliocentric initial state as the scene's, not moved to the centre of mass"
    )

    def _G(self, scene: Scene) -> float:
        return float(scene.pvec[0])  # the scene packs p = (G, m_0, ..., m_5)

    def _add(self, sim, scene: Scene, q0, v0) -> list[float]:
        masses = [float(m) for m in scene.masses]
        for i, m in enumerate(masses):
            sim.add(
                m=m,
                x=float(q0[3 * i]),
                y=float(q0[3 * i + 1]),
                z=float(q0[3 * i + 2]),
                vx=float(v0[3 * i]),
                vy=float(v0[3 * i + 1]),
                vz=float(v0[3 * i + 2]),
            )
        return masses

    def state(self):
        self.sim.serialize_particle_data(xyzvxvyvz=self._data)
        return self._data[:, :3].flatten(), self._data[:, 3:].flatten()


#: How REBOUND poses each scene it poses (the model class); a new scene is one entry here.
POSES: dict[str, type[_Simulation]] = {"kepler": _Kepler, "solar_system": _SolarSystem}
SCENES = tuple(POSES)


def _plain(value):
    """REBOUND hands integrator fields back as ctypes-backed subclasses of int/float (which do
    not pickle) or as enum names: record plain values."""
    for kind in (float, int):
        if isinstance(value, kind):
            return kind(value)
    return str(value)


def build(
    rebound, mode: str, scene: Scene, dt: float, count: bool = False, tolerance: float | None = None
) -> _Simulation:
    """``tolerance``: IAS15's epsilon (``rebound:ias15@1e-6``); the fixed-step modes take none."""
    return POSES[scene.kind](rebound, mode, scene, dt, count, tolerance)


_DOCS = {
    "leapfrog": """leapfrog, drift-kick-drift (order 2)
        Measured: equals ref:leapfrog bitwise with sim.steps(): Kepler, and the solar system over
        2e5 days at dt = 10 days (|dE/E| bounded, 4.1e-6).""",
    "whfast": """Wisdom-Holman symplectic map: exact Kepler drift (two-body: exact to roundoff)
        Measured on the solar system at dt = 10 days: |dE/E| bounded, 5.3e-9 over 2e5 days; at equal
        cost per simulated day its global error is 2.4e-5 of leapfrog's.""",
    "ias15": """IAS15, adaptive 15th-order Gauss-Radau; dt is the output interval
        Measured: |dE/E| ~ 1e-14 over 1000 Kepler orbits; 2.1e-15 over 2e5 days of the solar system
        (outputs every 10 days).""",
    "saba": """SABA(10,6,4) symplectic splitting (Blanes et al. 2013); two-body: exact to roundoff
        Measured on the solar system: |dE/E| 5e-14 over 2e5 days at dt = 10 days; its global error over
        one Jupiter orbit stays at the reference solve's floor (1e-11) up to dt = 540 days, an eighth
        of the orbit, so no order is measurable there.""",
}

#: What each mode was measured to do that its name does not say (``records.method.Behaviour``).
_BEHAVIOUR = {
    "leapfrog": Behaviour(integrates_as={"solar_system": "ref:leapfrog"}, symplectic=True),
    "whfast": Behaviour(symplectic=True, beats_at_equal_cost=("rebound:leapfrog", "ref:leapfrog")),
    "ias15": Behaviour(roundoff=True),
    "saba": Behaviour(symplectic=True),
}

METHODS = {
    f"rebound:{mode}": EngineMode(
        engine="rebound",
        mode=mode,
        module="rebound",
        dist="rebound",
        build=build,
        scenes=SCENES,
        unsupported=UNSUPPORTED,
        doc=_DOCS[mode],
        adaptive=mode in ADAPTIVE,
        counting_run=True,
        versions=VERSIONS,
        present=has_mode(mode),
        behaviour=_BEHAVIOUR[mode],
        options_declared=(
            {TOLERANCE: Option(TOLERANCE, float, 1e-16, 1.0, "IAS15's epsilon")} if mode in ADAPTIVE else {}
        ),
        adaptive_with=TOLERANCE if mode in ADAPTIVE else None,
        settings={
            "integrator": mode,
            **MODES[mode],
            **SIM,
            "models": {kind: pose.WHAT for kind, pose in POSES.items()},
        },
    )
    for mode in MODES
}

from . import contact  # noqa: E402  (its contact poses, joined to its entry below)

#: The engine, declared once: ``adapters.ENGINES`` and every list of engines the harness keeps read it.
ENGINE = Engine(
    id="rebound",
    module="rebound",
    dists=("rebound",),
    versions=VERSIONS,
    methods=METHODS,
    poses=POSES,
    build=build,
    bare_loops=bench.bare_loops,
    contact_modes=contact.MODES,
)
