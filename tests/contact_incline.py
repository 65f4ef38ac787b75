"""A new contact scene, made as docs/contributing.md's recipe makes one: this one module (the
scene: its parameters, state, horizon, truth, figures and judge) plus one pose per engine that
poses it (here MuJoCo's: a box on a free joint, in the scene's gravity). Nothing else names it:
``harness contact``, its ``--json``, the nightly's cells, the report and its charts take it from
its declarations (tests/test_contact_recipe.py).

The box on an incline: the slide's box on a plane tilted by ``theta``, pushed down the slope at
``v0``; Coulomb friction ``mu`` above tan(theta) stops it after ``v0**2 / (2 g (mu cos(theta) -
sin(theta)))``. Posed in the incline's frame (x down the slope, z its normal): gravity is
(g sin(theta), 0, -g cos(theta)) on a level plane.

It is a ``HARNESS_PLUGINS`` module (a worker loads it before it steps a task that names it);
importing it registers the scene and the pose, ``unregister`` takes them away again.
"""

from __future__ import annotations

import math

from records import InvalidInput
from scenarios import ENGINE_SCENES, Param
from scenarios.contact import Figure, Slide

from adapters import BOX
from adapters.mujoco import contact as mujoco

FORMULA = "v0²/(2 g (μ cos θ − sin θ))"


class Incline(Slide):
    id = "incline"
    title = "a box sliding down an incline with Coulomb friction: it stops after v0^2/(2 g (mu cos θ - sin θ))"
    params = {
        **Slide.params,
        "theta": Param(0.2, "the incline's angle (rad); it must be below atan(mu)", lo=0.0, hi=1.0),
    }
    FIGURES = (
        Figure("stop", "stop distance (m)", truth="stop", chart="stop distance (m)", chart_truth=("stop", FORMULA)),
        Figure("stop_time", truth="stop_time"),
        Figure("creep", "creep (m)", truth="creep"),
    )
    STOP_FORMULA = FORMULA

    def _validate(self):
        super()._validate()
        if math.tan(self.theta) >= self.mu:
            raise InvalidInput(
                f"parameter theta={self.theta:g} never stops the box (allowed: below atan(mu) "
                f"= {math.atan(self.mu):.4g})"
            )

    @property
    def deceleration(self) -> float:
        return self.g * (self.mu * math.cos(self.theta) - math.sin(self.theta))

    @property
    def gravity(self):
        return (self.g * math.sin(self.theta), 0.0, -self.g * math.cos(self.theta))


#: Plugin modules declare methods or measures; this one declares neither (it registers a scene).
METHODS: dict = {}


def register() -> None:
    ENGINE_SCENES[Incline.id] = Incline
    mujoco.POSES[Incline.id] = BOX  # MuJoCo's one pose: a box on a free joint, in the scene's gravity


def unregister() -> None:
    ENGINE_SCENES.pop(Incline.id, None)
    mujoco.POSES.pop(Incline.id, None)


register()
