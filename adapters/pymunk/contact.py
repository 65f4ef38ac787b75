"""pymunk's contact poses: ``pymunk:sequential_impulse``, Chipmunk2D's one solver, in the plane.

Chipmunk solves each contact with sequential impulses (``space.iterations`` passes): the normal
impulse turns the approach speed u into the rebound ``e u`` exactly (no threshold, no speculative
gap), friction bounds the tangent impulse by ``mu`` times the normal one, and an overlap deeper
than ``collision_slop`` is pushed out by a separate bias velocity (``collision_bias``: the fraction
of the overlap left after a second) that adds no momentum.

The pose is 2-D: the scene's x and z (y filled with 0), gravity (0, -g). The ball is a ``Circle``,
each box a ``Poly.create_box`` with the box's moment, the plane a static ``Segment`` along x.
Every setting is set and stated (docs/engines.md has each default's measured effect):

* restitution is ``elasticity``, combined by product: the plane 1, the ball e, the boxes 0;
* friction is combined by product: the plane 1, each box mu (1 for rest and stack), the ball 0;
* ``collision_slop`` 0 (default 0.1: an overlap of up to that much is left alone, so a body rests
  sunk in the plane or in the box below);
* ``space.iterations`` 100 (default 10: a box at rest sinks g h^2-deep into the plane and stays);
* ``collision_bias`` at Chipmunk's value, set explicitly; ``space.damping`` 1 (none) and sleeping
  off (``sleep_time_threshold`` infinite), Chipmunk's defaults, set explicitly.

The rebound is an exact velocity impulse: at the step the ball turns, its velocity is -e times
the velocity before the step, to roundoff.

The engine's loop is a Python loop of ``space.step(dt)`` alone (Chipmunk has none of its own).
"""

from __future__ import annotations

import math

import numpy as np

from .._contact import BOX, SPHERE, ContactMode, record_loop, timed_loop
from .._engine import engine_version, import_engine

#: Half the plane's length along x (m): far beyond where any scene's body goes.
PLANE_HALF_LENGTH = 50.0

#: How pymunk poses each contact scene in the plane (the scene's kind -> its ``ContactPose``): the
#: ball a Circle, each box a Poly.create_box. A new contact scene is one entry here.
POSES = {"ball": SPHERE, "slide": BOX, "rest": BOX, "stack": BOX}

SETTINGS = {
    "collision_slop": 0.0,
    "collision_bias": (1.0 - 0.1) ** 60,
    "iterations": 100,
    "damping": 1.0,
    "sleep_time_threshold": math.inf,
    "plane elasticity": 1.0,
    "plane friction": 1.0,
}


def _pose(pymunk, scene, settings: dict):
    space = pymunk.Space()
    space.gravity = (float(scene.gravity[0]), float(scene.gravity[2]))
    for name in ("collision_slop", "collision_bias", "iterations", "damping", "sleep_time_threshold"):
        if settings[name] is not None:
            setattr(space, name, settings[name])
    plane = pymunk.Segment(space.static_body, (-PLANE_HALF_LENGTH, 0.0), (PLANE_HALF_LENGTH, 0.0), 0.0)
    plane.elasticity, plane.friction = settings["plane elasticity"], settings["plane friction"]
    space.add(plane)
    bodies = []
    sphere = POSES[scene.kind] is SPHERE
    for x, _, z in scene.initial_centres():
        if sphere:
            body = pymunk.Body(scene.mass, pymunk.moment_for_circle(scene.mass, 0.0, scene.radius))
            shape = pymunk.Circle(body, scene.radius)
            shape.elasticity, shape.friction = scene.e, 0.0
        else:
            side = 2.0 * scene.half
            body = pymunk.Body(scene.mass, pymunk.moment_for_box(scene.mass, (side, side)))
            shape = pymunk.Poly.create_box(body, (side, side), 0.0)
            shape.elasticity, shape.friction = 0.0, getattr(scene, "mu", 1.0)
        body.position = (x, z)
        space.add(body, shape)
        bodies.append(body)
    for body, (vx, _, vz) in zip(bodies, scene.initial_velocities()):
        if vx or vz:
            body.velocity = (vx, vz)
    return space, bodies


def run(mode: ContactMode, scene, dt: float):
    pymunk = import_engine("pymunk")
    settings = dict(mode.settings)
    space, bodies = _pose(pymunk, scene, settings)

    def step():
        space.step(dt)

    def read():
        c = np.array([(b.position.x, 0.0, b.position.y) for b in bodies])
        v = np.array([(b.velocity.x, 0.0, b.velocity.y) for b in bodies])
        return c, v

    def time_again(steps: int) -> float:
        space2, _ = _pose(pymunk, scene, settings)
        return timed_loop(lambda: space2.step(dt), steps)

    stated = {
        "solver": "Chipmunk2D sequential impulses",
        "pymunk": engine_version("pymunk"),
        "bodies": "2-D: x and z of the scene; Circle / Poly.create_box on a static Segment",
        **{k: v for k, v in settings.items()},
        "restitution combining": "product of elasticities: plane 1 x body's",
        "friction combining": "product: plane 1 x body's",
        "collision_slop (read back)": space.collision_slop,
        "collision_bias (read back)": space.collision_bias,
        "iterations (read back)": space.iterations,
    }
    return record_loop(
        mode, scene, dt, step, read, stated, loop="a Python loop of space.step(dt)", time_again=time_again
    )


MODES = {
    "pymunk:sequential_impulse": ContactMode(
        "pymunk",
        "sequential_impulse",
        "pymunk",
        run,
        poses=POSES,
        settings=SETTINGS,
        dims=2,
        doc="Chipmunk2D's sequential impulses in the plane; elasticity and friction combined by product, "
        "collision_slop 0",
    ),
}
