"""Scene registry: ``SCENES[id]`` is a Scene class; ``make_scene`` validates parameters."""
from __future__ import annotations

from records import InvalidInput

from .scene import Param, Scene, no_solve, no_velocity_dependence
from .chain import Chain
from .cloth import Cloth, Net
from .damped_spring import DampedSpring
from .kepler import Kepler
from .pendulum import Pendulum
from .projectile import Projectile
from .rope import Rope
from .solar_system import SolarSystem
from .spring import Spring

SCENES: dict[str, type[Scene]] = {cls.id: cls for cls in (
    Spring, DampedSpring, Pendulum, Kepler, Projectile, Chain, Rope, SolarSystem, Cloth, Net,
)}


def make_scene(scene_id: str, **overrides) -> Scene:
    try:
        cls = SCENES[scene_id]
    except KeyError:
        raise InvalidInput(f"unknown scene {scene_id!r} (valid: {', '.join(SCENES)})") from None
    return cls(**overrides)


def parse_overrides(items: list[str] | None) -> dict[str, float]:
    """``["e=0.9", "k=2"]`` -> ``{"e": 0.9, "k": 2.0}``; values are checked by the scene."""
    out: dict[str, float] = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise InvalidInput(f"--set {item!r} is not of the form key=value")
        out[name.strip()] = value.strip()
    return out


__all__ = ["SCENES", "Scene", "Param", "make_scene", "parse_overrides",
           "no_solve", "no_velocity_dependence"]
