"""pymunk (Chipmunk2D): three ways users write a scene, three methods.

* ``pymunk:spring_force`` - the force computed inside ``body.velocity_func``, the way Chipmunk
  means forces to be applied: Chipmunk moves positions first, then velocities, so the force
  sees the new position (position-first semi-implicit Euler).
* ``pymunk:applied_force`` - the force set on ``body.force`` before each ``space.step``, the way
  many users write it: the force sees the old position, so this is explicit Euler.
* ``pymunk:pin_joint`` - the pendulum as users build it: a ``PinJoint`` from a static pivot to
  the bob, with the joint's default error correction (which bleeds energy) and gravity.

Minimal models: a body with the scene's exact mass and infinite moment (no rotation to couple),
no shapes, ``space.damping`` 1, sleeping off; gravity only where the scene has it, along -y.
Every setting is read back into the result.
"""
from __future__ import annotations

import math

import numpy as np

from scenarios import Scene

from ._base import EngineMode, unwrap

_FORCE_SCENES = ("spring", "damped_spring", "projectile")
_FORCE_UNSUPPORTED = {
    "pendulum": "a pendulum in Chipmunk is a joint, not a force: see pymunk:pin_joint",
    "kepler": "not posed: Chipmunk has no gravity between bodies, and a 1/r^2 force from Python would only "
              "repeat what the spring shows (same force path, same scheme); Kepler is REBOUND's scene",
}
_JOINT_UNSUPPORTED = {
    "spring": "a pin joint poses only the pendulum; see pymunk:spring_force",
    "damped_spring": "a pin joint poses only the pendulum; see pymunk:spring_force",
    "projectile": "a pin joint poses only the pendulum; see pymunk:applied_force",
    "kepler": "a pin joint poses only the pendulum",
}


class _Model:
    def __init__(self, pymunk, mode: str, scene: Scene, dt: float):
        self.dt = dt
        self.scene_id = scene.id
        values = scene.values
        self.space = space = pymunk.Space()
        space.gravity = (0.0, -values.get("g", 0.0))
        space.damping = 1.0
        space.sleep_time_threshold = math.inf
        self.body = body = pymunk.Body(values["m"], math.inf)
        q0, v0 = scene.initial_state()
        self.joint = None
        if scene.id == "pendulum":
            L, theta = values["L"], float(q0[0])
            body.position = (L * math.sin(theta), -L * math.cos(theta))
            body.velocity = (0.0, 0.0)
            space.add(body)
            self.joint = pymunk.PinJoint(space.static_body, body, (0.0, 0.0), (0.0, 0.0))
            space.add(self.joint)
            self.theta = theta
        else:
            body.position = (float(q0[0]), float(q0[1]) if scene.ndof == 2 else 0.0)
            body.velocity = (float(v0[0]), float(v0[1]) if scene.ndof == 2 else 0.0)
            space.add(body)
        k, c = values.get("k", 0.0), values.get("c", 0.0)
        self.apply_before_step = None
        if mode == "spring_force":
            update_velocity = pymunk.Body.update_velocity

            def velocity_func(b, gravity, damping, h):
                (x, y), (vx, vy) = b.position, b.velocity
                b.force = (-k * x - c * vx, -k * y - c * vy)
                update_velocity(b, gravity, damping, h)

            body.velocity_func = velocity_func
        elif mode == "applied_force":
            def apply_before_step():
                (x, y), (vx, vy) = body.position, body.velocity
                body.force = (-k * x - c * vx, -k * y - c * vy)

            self.apply_before_step = apply_before_step
        self.settings = {
            "gravity": list(space.gravity), "damping": space.damping,
            "sleep_time_threshold": "inf" if math.isinf(space.sleep_time_threshold) else space.sleep_time_threshold,
            "iterations": space.iterations, "mass": body.mass,
            "moment": "inf" if math.isinf(body.moment) else body.moment, "shapes": 0,
            "force": {"spring_force": "set in body.velocity_func (sees the new position)",
                      "applied_force": "set on body.force before each space.step (sees the old position)",
                      "pin_joint": "none: gravity and the pin joint"}[mode],
        }
        if self.joint is not None:
            j = self.joint
            self.settings.update({"joint": "PinJoint, static pivot at the origin to the bob's centre",
                                  "distance": j.distance, "error_bias": j.error_bias,
                                  "max_bias": "inf" if math.isinf(j.max_bias) else j.max_bias,
                                  "max_force": "inf" if math.isinf(j.max_force) else j.max_force})

    def advance(self) -> None:
        if self.apply_before_step is not None:
            self.apply_before_step()
        self.space.step(self.dt)

    def state(self):
        (x, y), (vx, vy) = self.body.position, self.body.velocity
        if self.scene_id == "pendulum":
            # The bob's angle from the downward vertical and its angular rate about the pivot.
            theta = math.atan2(x, -y)
            self.theta = unwrap(self.theta, theta) if math.isfinite(theta) else theta
            return np.array([self.theta]), np.array([(x * vy - y * vx) / (x * x + y * y)])
        if self.scene_id == "projectile":
            return np.array([x, y]), np.array([vx, vy])
        return np.array([x]), np.array([vx])

    def trouble(self) -> str | None:
        return None

    def close(self) -> None:
        # A sleeping body attached to a constraint can segfault at interpreter exit: take
        # everything out of the space first.
        if self.joint is not None:
            self.space.remove(self.joint)
        self.space.remove(self.body)


def build(pymunk, mode: str, scene: Scene, dt: float) -> _Model:
    return _Model(pymunk, mode, scene, dt)


def _mode(mode: str, scenes, unsupported, doc: str, settings: dict) -> EngineMode:
    return EngineMode(engine="pymunk", mode=mode, module="pymunk", dist="pymunk", build=build,
                      scenes=scenes, unsupported=unsupported, doc=doc,
                      settings={"damping": 1, "sleeping": "disabled", "moment": "inf", "shapes": 0, **settings})


METHODS = {m.id: m for m in (
    _mode("spring_force", _FORCE_SCENES, _FORCE_UNSUPPORTED,
          """position-first semi-implicit Euler (force in velocity_func, as Chipmunk intends)
          Measured: equals ref:semi_implicit_euler_position_first bitwise on the spring.""",
          {"force": "body.velocity_func"}),
    _mode("applied_force", _FORCE_SCENES, _FORCE_UNSUPPORTED,
          """explicit Euler (force set on body.force before each step, as many users write it)
          Measured: equals ref:explicit_euler bitwise on the spring: energy x(1 + h^2) per step.""",
          {"force": "body.force before each step"}),
    _mode("pin_joint", ("pendulum",), _JOINT_UNSUPPORTED,
          """pendulum on a PinJoint with Chipmunk's default error correction (loses energy)
          Measured: no reference scheme; the joint's bias correction bleeds energy.""",
          {"joint": "PinJoint, default error_bias and max_bias"}),
)}
