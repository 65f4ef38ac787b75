"""Scene registry: ``SCENES[id]`` is a Scene class; ``make_scene`` validates parameters."""

from __future__ import annotations

from records import InvalidInput

from .scene import Param, Scene, no_solve, no_velocity_dependence
from .penalty_ball import PenaltyBall
from .chain import Chain
from .cloth import Cloth, Net
from .cloth_flex import ClothFlex
from .contact import ContactScene
from .contact import SCENES as _CONTACT
from .contact_turning import SCENES as _TURNING
from .damped_spring import DampedSpring
from .kepler import Kepler
from .model import FEATURES, SUFFIXES, VARIANTS, ModelScene, read_model_file, variant
from ._bullet_model import BulletModelScene, open_model
from ._mass_matrix import full_mass_matrix
from ._contact_pairs import collidable_pairs
from ._model_reference import REFERENCE_JUDGES
from .pendulum import Pendulum
from .projectile import Projectile
from .rope import Rope
from .solar_system import SolarSystem
from .spring import Spring

SCENES: dict[str, type[Scene]] = {
    cls.id: cls
    for cls in (
        Spring,
        DampedSpring,
        Pendulum,
        Kepler,
        Projectile,
        Chain,
        Rope,
        SolarSystem,
        Cloth,
        Net,
        PenaltyBall,
    )
}


#: Scenes built from a file (``harness model PATH``): not in SCENES, whose every scene is
#: built from its parameters alone. ``make_scene("model")`` is the shipped unit-spring file.
FILE_SCENES: dict[str, type[Scene]] = {ModelScene.id: ModelScene}

#: Scenes whose force is one engine's own model posed on a built-in scene's grid (``cloth_flex``:
#: MuJoCo's flexcomp membrane on the cloth's): not in SCENES, whose every scene has kernels the
#: reference schemes step; each carries a ``model_note`` saying what it is not.
#: The contact scenes (``scenarios.contact``: the ball, the slide, the box at rest, the stack;
#: ``scenarios.contact_turning``: the edge, corner, tipping and rolling drops) are engine scenes
#: too: only engines pose them (each engine's ``adapters/<engine>/contact.py``).
ENGINE_SCENES: dict[str, type[Scene]] = {cls.id: cls for cls in (ClothFlex, *_CONTACT, *_TURNING)}


def contact_scenes() -> dict[str, type[ContactScene]]:
    """The contact scenes: the engine scenes of the contact kind (``scenarios.contact.ContactScene``),
    in registry order. Derived, never kept: a scene registered later (``ENGINE_SCENES[id] = cls``)
    is one of them."""
    return {sid: cls for sid, cls in ENGINE_SCENES.items() if issubclass(cls, ContactScene)}


def make_scene(scene_id: str, source: str | None = None, **overrides) -> Scene:
    """The scene ``scene_id`` with these parameters; ``source``: the file of a scene built from
    one (a model file), whose id must still be ``scene_id`` (the file unchanged)."""
    if source is not None:
        scene = open_model(source, **overrides)
        if scene.id != scene_id:
            raise InvalidInput(
                f"model file {source!r} is now {scene.id}, not {scene_id}: it changed since the run was planned"
            )
        return scene
    if scene_id in FILE_SCENES:
        return FILE_SCENES[scene_id](**overrides)
    if scene_id in ENGINE_SCENES:
        return ENGINE_SCENES[scene_id](**overrides)
    if scene_id.lower().endswith(tuple(SUFFIXES)):  # a model file's path: every command takes one
        return open_model(scene_id, **overrides)
    try:
        cls = SCENES[scene_id]
    except KeyError:
        raise InvalidInput(
            f"unknown scene {scene_id!r} (valid: {', '.join([*SCENES, *ENGINE_SCENES])}; a model file: "
            "harness model PATH)"
        ) from None
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


__all__ = [
    "SCENES",
    "FILE_SCENES",
    "ENGINE_SCENES",
    "ContactScene",
    "contact_scenes",
    "ModelScene",
    "BulletModelScene",
    "open_model",
    "full_mass_matrix",
    "collidable_pairs",
    "REFERENCE_JUDGES",
    "FEATURES",
    "VARIANTS",
    "read_model_file",
    "variant",
    "Scene",
    "Param",
    "make_scene",
    "parse_overrides",
    "no_solve",
    "no_velocity_dependence",
]
