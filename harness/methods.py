"""Method ids, one namespace for reference schemes and engine modes.

``ref:NAME`` is a reference scheme; ``ENGINE:MODE`` (``mujoco:euler``, ``rebound:whfast``, ...)
is an engine mode from ``adapters``. Every method answers the same questions: is it
available, does it support a scene (and if not, why), and ``simulate(scene, dt, steps, every)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import adapters
import reference
from scenarios import InvalidInput, Scene, Trajectory
from scenarios._base import no_solve


@dataclass(frozen=True)
class RefMethod:
    scheme: reference.Scheme

    @property
    def id(self) -> str:
        return f"ref:{self.scheme.id}"

    family = "ref"
    engine = "reference"
    isolated = False

    def available(self) -> tuple[bool, str]:
        return True, ""

    def supports(self, scene: Scene) -> tuple[bool, str]:
        if self.scheme.implicit and type(scene).solve is no_solve:
            return False, f"scene {scene.id} provides no implicit solve"
        return True, ""

    def simulate(self, scene: Scene, dt: float, steps: int, every: int = 1) -> Trajectory:
        return reference.integrate(self.scheme, scene, dt, steps, every)

    def describe(self) -> dict:
        return {"id": self.id, "family": "ref", **{k: v for k, v in self.scheme.describe().items() if k != "id"}}


def all_methods() -> dict[str, object]:
    """Every method id, reference schemes first, then engine modes (available or not)."""
    out: dict[str, object] = {f"ref:{sid}": RefMethod(s) for sid, s in reference.METHODS.items()}
    out.update(adapters.ENGINE_METHODS)
    return out


def get_method(method_id: str):
    methods = all_methods()
    if method_id not in methods:
        raise InvalidInput(f"unknown method {method_id!r} (valid: {', '.join(methods)})")
    return methods[method_id]


def check_supported(method, scene: Scene) -> None:
    ok, why = method.available()
    if not ok:
        raise InvalidInput(f"method {method.id} is unavailable: {why}")
    ok, why = method.supports(scene)
    if not ok:
        raise InvalidInput(f"method {method.id} does not support scene {scene.id}: {why}")
