"""pymunk's contact poses, Chipmunk2D's one solver (sequential impulses) in the plane, in two modes:

* ``pymunk:sequential_impulse``, the controlled comparison: stiff and converged. Every overlap is
  pushed out (``collision_slop`` 0) and the solver makes 100 passes;
* ``pymunk:sequential_impulse?contact=default``, as pymunk's documentation tells a game programmer
  to set contact in a scene in metres: every setting at Chipmunk's default except ``collision_slop``,
  set to the overlap that is not noticeable (``DEFAULT_SETTINGS`` says where each comes from).

Chipmunk solves each contact with sequential impulses (``space.iterations`` passes): the normal
impulse turns the approach speed u into the rebound ``e u`` exactly (no threshold, no speculative
gap), friction bounds the tangent impulse by ``mu`` times the normal one, and an overlap deeper
than ``collision_slop`` is pushed out by a separate bias velocity (``collision_bias``: the fraction
of the overlap left after a second) that adds no momentum.

The pose is 2-D: the scene's x and z are pymunk's x and y (y filled with 0), its gravity
(g_x, g_z) (an incline's tilted field too). The ball is a ``Circle``, each box a
``Poly.create_box`` with the box's moment (m (w^2 + h^2) / 12 = 2/3 m half^2, the cube's about
any axis), the plane a static ``Segment`` along x. A turn about the scene's y is the body's angle:
a rotation about +y by phi maps z to x (body z -> (sin phi, 0, cos phi)), which in pymunk's
(x, y) plane is clockwise, so ``body.angle`` = -phi, and the world angular velocity is
(0, -angular_velocity, 0). The rolling ball's moment is set to the solid sphere's 2/5 m r^2
(``pymunk.moment_for_circle`` gives a disc's 1/2 m r^2). Restitution is ``elasticity`` and both
it and friction combine by product: the plane 1, the ball e (friction 0), each box mu (1 for rest
and stack) and e where its scene asks one (else 0), the rolling ball mu (elasticity 0).

The rebound is an exact velocity impulse: at the step the ball turns, its velocity is -e times
the velocity before the step, to roundoff. The engine's loop is a Python loop of
``space.step(dt)`` alone (Chipmunk has none of its own).
"""

from __future__ import annotations

import math

import numpy as np

from .._contact import BOX, ROLLING_SPHERE, SPHERE, TURNING_BOX, ContactMode, record_loop, timed_loop
from .._engine import engine_version, import_engine

#: Half the plane's length along x (m): far beyond where any scene's body goes.
PLANE_HALF_LENGTH = 50.0

#: How pymunk poses each contact scene in the plane (the scene's kind -> its ``ContactPose``): the
#: ball a Circle, each box a Poly.create_box, the rolling ball a Circle with a sphere's moment. The
#: corner is refused by its state (a turn about x: ``ContactMode.state_why``). A new contact scene
#: is one entry here.
POSES = {
    "ball": SPHERE,
    "slide": BOX,
    "rest": BOX,
    "stack": BOX,
    "edge": TURNING_BOX,
    "corner": TURNING_BOX,
    "tip": TURNING_BOX,
    "roll": ROLLING_SPHERE,
}

#: The space's settings each mode may set (None: left at Chipmunk's default, read back).
SPACE_SETTINGS = (
    "collision_slop",
    "collision_bias",
    "collision_persistence",
    "iterations",
    "damping",
    "sleep_time_threshold",
)

#: The controlled comparison: every overlap pushed out, the solver converged.
SETTINGS = {
    # Default 0.1: an overlap up to that much is left alone, so a body rests sunk in what holds it.
    "collision_slop": 0.0,
    "collision_bias": (1.0 - 0.1) ** 60,
    "collision_persistence": None,
    # Default 10: a box at rest sinks into the plane at the start before the bias pushes it out.
    "iterations": 100,
    "damping": 1.0,
    "sleep_time_threshold": math.inf,
    "plane elasticity": 1.0,
    "plane friction": 1.0,
}

#: The overlap a game leaves on purpose, in metres: Box2D's linear slop (b2_linearSlop 0.005 m,
#: "numerically significant, but visually insignificant"), the same length the game profile
#: judges by.
UNNOTICEABLE_OVERLAP = 0.005

#: As pymunk's documentation tells a user to set contact (pymunk 7.3 API reference,
#: https://www.pymunk.org/en/latest/pymunk.html#pymunk.Space, the same text as Chipmunk's manual,
#: http://chipmunk-physics.net/release/ChipmunkLatest-Docs/#cpSpace-Properties):
#:
#: * ``collision_slop``: "Amount of overlap between shapes that is allowed. To improve stability,
#:   set this as high as you can without noticeable overlapping. It defaults to 0.1." pymunk "is
#:   unit-less" (Overview, "Mass, weight and units"): 0.1 is 0.1 m here, half a box's side, a
#:   plainly noticeable overlap; the highest unnoticeable one is ``UNNOTICEABLE_OVERLAP``;
#: * ``iterations``: "Pymunk's default of 10 iterations is sufficient for most simple games": left;
#: * ``collision_bias``: "Very very few games will need to change this value" (its default
#:   (1 - 0.1)^60, 10% of an overlap corrected every 1/60 s; a rate per second, so the same at
#:   every step): left;
#: * ``collision_persistence`` (3 steps, "Very very few games will need to change this value"),
#:   ``damping`` (1: none) and ``sleep_time_threshold`` (infinite: sleeping off): left;
#: * a fixed step (``Space.step``: "Using a fixed time step is highly recommended"): the harness's.
#:
#: The shapes' ``radius`` stays 0: ``Poly.create_box``'s bevel is for boxes caught on the seams
#: between segments, and the plane is one segment.
DEFAULT_SETTINGS = {
    "collision_slop": UNNOTICEABLE_OVERLAP,
    "collision_bias": None,
    "collision_persistence": None,
    "iterations": None,
    "damping": None,
    "sleep_time_threshold": None,
    "plane elasticity": 1.0,
    "plane friction": 1.0,
}


def pymunk_angle(q) -> float:
    """pymunk's body angle of the scene's orientation ``q`` (w, x, y, z), a turn about y only: a
    rotation about +y by phi is clockwise in pymunk's (x, y) = the scene's (x, z) plane, -phi."""
    w, _, y, _ = (float(c) for c in q)
    return -2.0 * math.atan2(y, w)


def scene_orientation(angle: float) -> tuple[float, float, float, float]:
    """The scene's orientation (w, x, y, z) of pymunk's body ``angle``: a turn by phi = -angle
    about y."""
    phi = -angle
    return (math.cos(0.5 * phi), 0.0, math.sin(0.5 * phi), 0.0)


def _body(pymunk, scene, shape_kind: str):
    """The body and shape of one body of ``scene`` as its pose says."""
    if shape_kind in ("sphere", "rolling_sphere"):
        r, m = scene.radius, scene.mass
        rolls = shape_kind == "rolling_sphere"
        # The rolling ball's moment is the solid sphere's (the 3-D truth's); the frictionless ball
        # never turns, so a disc's is as good.
        moment = 0.4 * m * r * r if rolls else pymunk.moment_for_circle(m, 0.0, r)
        body = pymunk.Body(m, moment)
        shape = pymunk.Circle(body, r)
        shape.elasticity, shape.friction = (0.0, scene.mu) if rolls else (scene.e, 0.0)
        return body, shape
    side = 2.0 * scene.half
    body = pymunk.Body(scene.mass, pymunk.moment_for_box(scene.mass, (side, side)))
    shape = pymunk.Poly.create_box(body, (side, side), 0.0)
    e = getattr(scene, "e", 0.0) if shape_kind == "turning_box" else 0.0
    shape.elasticity, shape.friction = e, getattr(scene, "mu", 1.0)
    return body, shape


def _pose(pymunk, scene, settings: dict):
    space = pymunk.Space()
    space.gravity = (float(scene.gravity[0]), float(scene.gravity[2]))
    for name in SPACE_SETTINGS:
        if settings.get(name) is not None:
            setattr(space, name, settings[name])
    plane = pymunk.Segment(space.static_body, (-PLANE_HALF_LENGTH, 0.0), (PLANE_HALF_LENGTH, 0.0), 0.0)
    plane.elasticity, plane.friction = settings["plane elasticity"], settings["plane friction"]
    space.add(plane)
    bodies = []
    kind = POSES[scene.kind].shape
    starts = zip(
        scene.initial_centres(),
        scene.initial_velocities(),
        scene.initial_orientations(),
        scene.initial_angular_velocities(),
    )
    for (x, _, z), (vx, _, vz), q, (_, wy, _) in starts:
        body, shape = _body(pymunk, scene, kind)
        body.position = (x, z)
        body.angle = pymunk_angle(q)
        if vx or vz:
            body.velocity = (vx, vz)
        if wy:
            body.angular_velocity = -wy
        space.add(body, shape)
        bodies.append(body)
    return space, bodies


def _bodies_text(kind: str) -> str:
    if kind == "rolling_sphere":
        return (
            "2-D: x and z of the scene; a Circle with the solid sphere's moment 2/5 m r^2, set (moment_for_circle "
            "gives a disc's 1/2 m r^2), on a static Segment"
        )
    if kind == "turning_box":
        return (
            "2-D: x and z of the scene; a Poly.create_box (moment_for_box, 2/3 m half^2 as the cube's), turned "
            "by body.angle = -phi (a turn about +y is clockwise in pymunk's plane), on a static Segment"
        )
    return "2-D: x and z of the scene; Circle / Poly.create_box on a static Segment"


def run(mode: ContactMode, scene, dt: float):
    pymunk = import_engine("pymunk")
    settings = dict(mode.settings)
    space, bodies = _pose(pymunk, scene, settings)
    kind = POSES[scene.kind].shape
    turns = kind in ("turning_box", "rolling_sphere")

    def step():
        space.step(dt)

    def read():
        c = np.array([(b.position.x, 0.0, b.position.y) for b in bodies])
        v = np.array([(b.velocity.x, 0.0, b.velocity.y) for b in bodies])
        if not turns:
            return c, v
        q = np.array([scene_orientation(b.angle) for b in bodies])
        w = np.array([(0.0, -b.angular_velocity, 0.0) for b in bodies])
        return c, v, q, w

    def time_again(steps: int) -> float:
        space2, _ = _pose(pymunk, scene, settings)
        return timed_loop(lambda: space2.step(dt), steps)

    stated = {
        "solver": "Chipmunk2D sequential impulses",
        "pymunk": engine_version("pymunk"),
        "bodies": _bodies_text(kind),
        **{k: ("Chipmunk's default, not set" if v is None else v) for k, v in settings.items()},
        "restitution combining": "product of elasticities: plane 1 x body's",
        "friction combining": "product: plane 1 x body's",
        **{f"{name} (read back)": getattr(space, name) for name in (*SPACE_SETTINGS, "idle_speed_threshold")},
        "gravity (read back)": tuple(space.gravity),
        "moment (read back)": bodies[0].moment,
        "elasticity, friction (read back)": tuple((s.elasticity, s.friction) for s in bodies[0].shapes),
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
        "collision_slop 0, 100 iterations",
    ),
    "pymunk:sequential_impulse?contact=default": ContactMode(
        "pymunk",
        "sequential_impulse?contact=default",
        "pymunk",
        run,
        poses=POSES,
        settings=DEFAULT_SETTINGS,
        dims=2,
        doc="Chipmunk2D's sequential impulses in the plane as pymunk's documentation tells a game to set them: "
        "Chipmunk's defaults (10 iterations, collision_bias (1 - 0.1)^60) and collision_slop 5 mm, the overlap "
        "not noticeable in metres",
    ),
}
