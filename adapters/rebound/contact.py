"""REBOUND's contact pose: the ball as a hard sphere dropped on a planet, REBOUND's own hard-sphere
collision (``collision = "direct"``, ``collision_resolve = "hardsphere"``) with its
``coefficient_of_restitution`` callback returning the requested e.

REBOUND has no plane and no constant field, only particles of a radius and their Newtonian
gravity, so the minimal honest model is a planet: a sphere of radius ``PLANET_RADIUS`` (1e7 m)
whose own attraction is the scene's gravity at its surface (G = 1, mass g R^2), the ball a
particle of the scene's radius and mass whose lowest point starts h0 above it. No force of ours
enters (an ``additional_forces`` callback would be a Python force). Over the 1 m of the drop the
planet's gravity differs from the scene's g by 2 h0 / R = 2e-7 of it, and its surface from a
plane by h0^2 / 2R: nothing the apexes can see. The planet is the only active particle
(``N_active = 1``, the ball a test particle of type 0): it never moves, and the ball's impulse
is taken by a body that does not recoil. The recorded centre is the ball's height over the
planet's surface (z up), so the plane is at z = 0.

The hard-sphere law is an exact velocity impulse: after each step (leapfrog, drift-kick-drift,
exact on a constant field) REBOUND searches for overlapping, approaching pairs and reverses the
normal relative velocity times e; it moves no position, so a collision is found up to one step's
fall inside the planet. With e = 1 the apex is then kept exactly; with e < 1 the rebound starts
that little deeper (measured in docs/engines.md). ``minimum_collision_velocity`` is REBOUND's
default 0 (a larger one would lift every slow rebound), set and stated.

The boxes are not posed: REBOUND's particles are spheres, without orientation, friction or
resting contact (a hard sphere on a plane at rest collides at every step). Nor are the scenes
whose bodies turn (edge, corner, tip, roll): a REBOUND particle has no orientation, spin or
moment of inertia, and its hard-sphere impulse acts along the line of centres only, so nothing
turns it and no friction rolls it.

This pose is already REBOUND's documented practice for bouncing spheres, so the engine has one
contact mode and no ``?contact=default`` beside it. REBOUND's collisions page
(https://rebound.readthedocs.io/en/latest/collisions/, docs/collisions.md) sets a hard-sphere
bounce as ``sim.collision = "direct"`` with ``sim.collision_resolve = "hardsphere"`` and a
``coefficient_of_restitution`` function of the normal impact speed (its example returns a
constant), and its bouncing-balls example (examples/bouncing_balls/problem.c) steps them with
``"leapfrog"`` and ``REB_GRAVITY_BASIC``, detection direct and resolve hardsphere, as here. The
other detections the page lists change nothing for one ball on a planet: ``"line"`` also
finds pairs that passed through each other within a step (a ball cannot pass through a planet
1e7 m across), ``"tree"`` and ``"linetree"`` are the same searches on an oct-tree, for many
particles. Leapfrog is the integrator the example pairs with it: exact on a constant field (the
planet's is one to 2e-7 over the drop), stepping at the harness's dt, where IAS15 (REBOUND's
default) chooses its own adaptive steps and WHFast's Kepler drift is made for orbits. The setting
REBOUND leaves to the user is stated: ``minimum_collision_velocity``, its default 0.
"""

from __future__ import annotations

import numpy as np

from .._contact import SPHERE, ContactMode, record_loop, timed_loop
from .._engine import import_engine

#: The planet's radius (m): the ground's curvature and the change of gravity over the drop are 1e-7 of them.
PLANET_RADIUS = 1.0e7
INTEGRATOR = "leapfrog"

_NOT_A_SPHERE = (
    "REBOUND's particles are spheres without orientation or friction, and a hard sphere resting on "
    "a plane collides at every step: no box slides, rests or stacks"
)
_NO_TURNING = (
    "REBOUND's particles are spheres without orientation, spin or moment of inertia, their hard-sphere "
    "impulse along the line of centres only: no body turns, topples or rolls"
)
UNSUPPORTED = {
    "slide": _NOT_A_SPHERE,
    "rest": _NOT_A_SPHERE,
    "stack": _NOT_A_SPHERE,
    **dict.fromkeys(("edge", "corner", "tip", "roll"), _NO_TURNING),
}
#: Where REBOUND's documentation sets a hard-sphere bounce as this pose does.
SOURCE = (
    "https://rebound.readthedocs.io/en/latest/collisions/ (docs/collisions.md: 'Direct', 'Hard-sphere'); "
    "examples/bouncing_balls/problem.c (leapfrog, gravity basic, collision direct, collision_resolve hardsphere)"
)
#: How REBOUND poses each contact scene (the scene's kind -> its ``ContactPose``): the ball alone.
POSES = {"ball": SPHERE}


class _Pose:
    def __init__(self, rebound, scene, dt: float):
        self.sim = sim = rebound.Simulation()
        sim.G = 1.0
        sim.integrator = INTEGRATOR
        sim.integrator.order = 2
        sim.gravity = "basic"
        sim.collision = "direct"
        sim.collision_resolve = "hardsphere"
        sim.minimum_collision_velocity = 0.0
        e = float(scene.e)
        sim.coefficient_of_restitution = lambda _sim, _speed: e
        sim.dt = dt
        R = PLANET_RADIUS
        self.planet_mass = -float(scene.gravity[2]) * R * R  # the field along -z (``gravity_along_z``)
        sim.add(m=self.planet_mass, r=R)
        # held to z (``holds_ball_to_z``): the scene's height and vertical speed
        (_, _, z0), (_, _, vz0) = scene.initial_centres()[0], scene.initial_velocities()[0]
        sim.add(m=scene.mass, r=scene.radius, z=R + float(z0), vz=float(vz0))
        sim.N_active = 1
        sim.testparticle_type = 0
        self.scene, self.data = scene, np.zeros((2, 6))
        self.settings = {
            "model": (
                f"a planet of radius {R:g} m and mass g R^2 (G = 1), its gravity the scene's g at its surface; "
                "the ball a test particle of the scene's radius and mass"
            ),
            "integrator": f"{INTEGRATOR} (order {int(sim.integrator.order)}, drift-kick-drift), sim.steps(1) a step",
            "collision": "direct",
            "collision_resolve": "hardsphere",
            "coefficient_of_restitution": f"callback returning e = {e:g}",
            "minimum_collision_velocity": float(sim.minimum_collision_velocity),
            "gravity": "basic",
            "N_active": 1,
            "testparticle_type": 0,
            "additional_forces": "none",
            "planet_radius (m)": R,
            "practice": f"REBOUND's documented hard-sphere bounce, as set here: {SOURCE}",
        }

    def read(self):
        self.sim.serialize_particle_data(xyzvxvyvz=self.data)
        d = self.data
        # Heights over the planet's surface: the ball's centre less the planet's radius.
        c = np.array([[d[1, 0] - d[0, 0], d[1, 1] - d[0, 1], d[1, 2] - d[0, 2] - PLANET_RADIUS]])
        return c, (d[1:2, 3:6] - d[0:1, 3:6]).copy()


def run(mode: ContactMode, scene, dt: float):
    rebound = import_engine("rebound")
    pose = _Pose(rebound, scene, dt)

    def time_again(steps: int) -> float:
        again = _Pose(rebound, scene, dt)
        return timed_loop(lambda: again.sim.steps(steps), 1)

    return record_loop(
        mode,
        scene,
        dt,
        lambda: pose.sim.steps(1),
        pose.read,
        pose.settings,
        loop="sim.steps(steps), one call",
        time_again=time_again,
    )


MODES = {
    "rebound:hardsphere": ContactMode(
        "rebound",
        "hardsphere",
        "rebound",
        run,
        poses=POSES,
        holds_ball_to_z=True,
        gravity_along_z=True,
        unsupported=UNSUPPORTED,
        settings={"integrator": INTEGRATOR, "collision": "direct", "collision_resolve": "hardsphere"},
        doc="REBOUND's hard-sphere collision of the ball with a planet whose gravity is g; leapfrog; "
        "coefficient_of_restitution the requested e. This is REBOUND's documented practice (collision "
        f"'direct', collision_resolve 'hardsphere', leapfrog): no other contact mode beside it. {SOURCE}",
    )
}
