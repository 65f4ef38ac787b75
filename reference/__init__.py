"""Reference integrators: ``METHODS[id]`` is a :class:`Scheme`; ``integrate`` steps one on a scene."""
from __future__ import annotations

from ._compiled import integrate_compiled
from ._integrate import integrate
from ._scheme import Scheme
from .explicit_euler import explicit_euler
from .forest_ruth import forest_ruth
from .implicit_euler import implicit_euler
from .implicit_midpoint import implicit_midpoint
from .leapfrog import leapfrog
from .position_first_euler_decay import position_first_euler_decay_after_kick, position_first_euler_decay_before_kick
from .rk4 import rk4
from .semi_implicit_euler import semi_implicit_euler
from .semi_implicit_euler_position_first import semi_implicit_euler_position_first
from .semi_implicit_euler_velocity_implicit import semi_implicit_euler_velocity_implicit
from .velocity_verlet import velocity_verlet
from .verlet import verlet
from .verlet_constrained import verlet_constrained

METHODS: dict[str, Scheme] = {s.id: s for s in (
    explicit_euler, semi_implicit_euler, semi_implicit_euler_position_first, verlet, velocity_verlet,
    leapfrog, rk4, implicit_euler, implicit_midpoint, forest_ruth, verlet_constrained,
    semi_implicit_euler_velocity_implicit, position_first_euler_decay_after_kick,
    position_first_euler_decay_before_kick,
)}

__all__ = ["METHODS", "Scheme", "integrate", "integrate_compiled"]
