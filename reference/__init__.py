"""Reference integrators: ``METHODS[id]`` is a :class:`Scheme`; ``integrate`` steps one on a scene
(interpreted, every force evaluation counted), ``integrate_compiled`` on the pair's compiled loop,
the one its timings time too, which computes ``integrate``'s bits wherever ``bitwise_why`` finds
nothing (its counts then declared or probed: ``counted=True``; ``RefMethod(...,
compiled_where_bitwise=True)`` takes it there); ``RefMethod`` is a scheme as a method (``records.Method``).

Timing, for the harness's cost measures and benches: ``step_timer`` / ``time_per_step`` time a
scheme's compiled kernel on ``CLOCKS[name]``, ``KERNEL_STATS`` counts the kernels compiled and
loaded in this process, ``kernel_opt_level()`` the LLVM level they compile at,
``compile_notices(tell)`` says each compile before it starts, ``cache_state`` says what the disk
cache (``kernel_cache_dir()``) holds of a pair before a run; ``run_floor`` / ``floor_timer`` run
and time a scheme's hand-written floor (``Scheme.floor``; imported, with numba, on first use).

A scheme is one file of ``schemes/`` (or one tableau entry): its step and everything declared of
it (``Scheme``: its claims, ``Floor``, its recurrence on the damped ``oscillator``, the scenes it
joins in a suite, ``EVERY_SCENE``). A splitting is declared as its drifts and kicks (``Splitting``,
``splitting_scheme``), a scheme taken n times at h/n as ``substepped(scheme, n)``: the step, floor,
recurrence and claims follow.
"""

from __future__ import annotations

from ._compiled import CLOCKS, bitwise_why, cache_state, integrate_compiled, step_timer, time_per_step
from ._integrate import carried_map, integrate
from ._kernels import STATS as KERNEL_STATS
from ._kernels import cache_dir as kernel_cache_dir
from ._kernels import compile_notices
from ._numba_config import opt_level as kernel_opt_level
from ._scheme import EVERY_SCENE, Floor, Scheme
from .kinds import KINDS, Kind
from .tableau import Tableau, tableau_scheme
from .splitting import DRIFT, KICK, Splitting, splitting_scheme
from .substepped import substepped
from .method import RefMethod
from .schemes.forest_ruth import forest_ruth
from .schemes.implicit_euler import implicit_euler
from .schemes.implicit_euler_doubled import implicit_euler_doubled
from .schemes.implicit_midpoint import implicit_midpoint
from .schemes.leapfrog import leapfrog
from .schemes.linearly_implicit_euler import linearly_implicit_euler
from .schemes.pbd import pbd
from .schemes.position_first_euler_decay import (
    position_first_euler_decay_after_kick,
    position_first_euler_decay_before_kick,
)
from .schemes.radau_iia2 import radau_iia2
from .schemes.runge_kutta import TABLEAUS, explicit_euler, rk4
from .schemes.semi_implicit_euler import semi_implicit_euler
from .schemes.semi_implicit_euler_position_first import semi_implicit_euler_position_first
from .schemes.semi_implicit_euler_velocity_implicit import semi_implicit_euler_velocity_implicit
from .schemes.velocity_verlet import velocity_verlet
from .schemes.verlet import verlet
from .schemes.verlet_constrained import verlet_constrained
from .schemes.xpbd import xpbd
from .schemes.xpbd_jacobi import xpbd_jacobi

METHODS: dict[str, Scheme] = {
    s.id: s
    for s in (
        explicit_euler,
        semi_implicit_euler,
        semi_implicit_euler_position_first,
        verlet,
        velocity_verlet,
        leapfrog,
        rk4,
        implicit_euler,
        implicit_midpoint,
        forest_ruth,
        verlet_constrained,
        semi_implicit_euler_velocity_implicit,
        position_first_euler_decay_after_kick,
        position_first_euler_decay_before_kick,
        linearly_implicit_euler,
        implicit_euler_doubled,
        radau_iia2,
        pbd,
        xpbd,
        xpbd_jacobi,
    )
}
#: Every explicit Runge-Kutta tableau (``schemes/runge_kutta.py``): a new entry there is a new scheme.
METHODS.update({s.id: s for s in TABLEAUS if s.id not in METHODS})

#: Public names of ``_floors``, imported on first use: the floors compile with numba, which a
#: harness command that times nothing need not import.
_FLOOR_NAMES = ("run_floor", "floor_timer")


def __getattr__(name: str):
    if name in _FLOOR_NAMES:
        from . import _floors

        return getattr(_floors, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [  # noqa: PLE0604
    "METHODS",
    "Scheme",
    "Floor",
    "EVERY_SCENE",
    "Kind",
    "KINDS",
    "Tableau",
    "tableau_scheme",
    "Splitting",
    "splitting_scheme",
    "DRIFT",
    "KICK",
    "substepped",
    "RefMethod",
    "carried_map",
    "integrate",
    "integrate_compiled",
    "bitwise_why",
    "cache_state",
    "compile_notices",
    "kernel_cache_dir",
    "kernel_opt_level",
    "CLOCKS",
    "step_timer",
    "time_per_step",
    "KERNEL_STATS",
    *_FLOOR_NAMES,  # names loaded on first use by __getattr__
]
