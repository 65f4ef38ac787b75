"""pymunk (Chipmunk2D): the ways users write a scene, one method each.

* ``pymunk:spring_force`` - the force computed inside ``body.velocity_func``, as Chipmunk means
  forces to be applied: positions move first, so the force sees the new position (position-first
  semi-implicit Euler; on the chain each body reads its neighbours' moved positions).
* ``pymunk:applied_force`` - the force set on ``body.force`` before each ``space.step``, as many
  users write it: the force sees the old position (explicit Euler).
* ``pymunk:damped_spring`` - Chipmunk's own ``DampedSpring``: on the chain between neighbours and
  to static walls (damping 0), on the planar net one per spring (pins on the static body), on
  the damped spring with the scene's c, applied as an exact decay e^{-c h/m} after the kick.
* ``pymunk:space_damping`` - the damping as Chipmunk's global ``space.damping`` = e^{-c/m}, the
  rest of the force in ``body.velocity_func``: an exact decay before a position-first kick.
* ``pymunk:pin_joint`` - the pendulum and the rope on ``PinJoint``s with the joints' default
  error correction (which bleeds energy) and gravity.

Minimal models: bodies with the scene's exact mass and infinite moment (no rotation to couple),
no shapes, ``space.damping`` 1, sleeping off; gravity only where the scene has it, along -y.
Every setting is read back into the result.

Chipmunk has no loop of its own to call: the engine's loop (``steps(n)``) is a Python loop of
``space.step`` alone (a mode's force is a Python ``velocity_func`` Chipmunk calls inside the step),
except ``applied_force``, whose force is set from Python before each step (that is the mode), and
the pin-jointed pendulum, whose angle is followed in chunks of steps too short for a half turn
unseen. The state is read only at output points. Force evaluations are counted, in a counting
run, by wrapping the Python force functions; Chipmunk's own constraints (DampedSpring, PinJoint)
compute their impulses inside the step with no counter or callback, so they are not counted.
"""

from __future__ import annotations

import math

import numpy as np

from records.method import NO_BEHAVIOUR, Behaviour
from scenarios import Scene

from .._engine import Engine, EngineVersions
from .._mode import EngineMode
from .._model import SteppedModel
from .._posing import chain_force, unwrap
from . import bench

# ----------------------------------------------------------------------------- which scenes each mode poses
# Which scenes each pymunk mode poses, and why not the others: the reasons ``harness list`` and
# every refusal print.
_FORCE_SCENES = ("spring", "damped_spring", "projectile", "chain")
_SHEET = "Chipmunk is 2-D: the cloth is posed in its plane as the scene net (pymunk:damped_spring)"
_NET = "the net's springs as Chipmunk's own DampedSprings: see pymunk:damped_spring"
_FORCE_UNSUPPORTED = {
    "cloth": _SHEET,
    "net": _NET,
    "pendulum": "a pendulum in Chipmunk is a joint, not a force: see pymunk:pin_joint",
    "rope": "a rope in Chipmunk is pin joints, not forces: see pymunk:pin_joint",
    "kepler": "not posed: Chipmunk has no gravity between bodies, and a 1/r^2 force from Python would only "
    "repeat what the spring shows (same force path, same scheme); Kepler is REBOUND's scene",
}
_PINS = "pin joints pose only the pendulum and the rope"
_JOINT_UNSUPPORTED = {
    "kepler": _PINS,
    "cloth": _SHEET,
    "net": _NET,
    **{
        scene: f"{_PINS}; see pymunk:{mode}"
        for scene, mode in (
            ("spring", "spring_force"),
            ("damped_spring", "spring_force"),
            ("projectile", "applied_force"),
            ("chain", "damped_spring"),
        )
    },
}
_SPRING_UNSUPPORTED = {
    "cloth": _SHEET,
    "spring": "not posed: a DampedSpring to a static body integrates the 1-DOF spring as pymunk:spring_force "
    "does (position-first semi-implicit Euler, 5e-14 in docs/engines.md); Chipmunk's springs link bodies "
    "on the chain, and damp on the damped spring",
    "pendulum": "a pendulum in Chipmunk is a joint: see pymunk:pin_joint",
    "rope": "a rope in Chipmunk is pin joints: see pymunk:pin_joint",
    "projectile": "no spring in the projectile: see pymunk:applied_force",
    "kepler": "no spring in the Kepler problem",
}

_SPACE_DAMPING_SCENES = ("damped_spring", "projectile")
_SPACE_DAMPING_UNSUPPORTED = {
    "cloth": _SHEET,
    "net": "no damping in the net",
    "spring": "no damping to give space.damping: see pymunk:spring_force",
    "chain": "the chain's damping acts between neighbours; space.damping damps each body against the world",
    **{
        scene: f"no damping in the {name}"
        for scene, name in (("pendulum", "pendulum"), ("rope", "rope"), ("kepler", "Kepler problem"))
    },
}


# ----------------------------------------------------------------------------- reading the bodies
# Reading a pymunk space's bodies in one Chipmunk call (``pymunk.batch``), for the poses with many
# bodies: read property by property, the reads were most of a stability search's work on the rope.
class BodyReader:
    """Every body's position and velocity, rows in ``bodies`` order (shape (n, 2) each): one
    Chipmunk call where the space lists these bodies first and in this order (the static body
    follows them), checked by their ids once; property by property otherwise. The same doubles
    either way: the batch copies Chipmunk's own. ``pymunk.batch`` is new in 6.6: on an older
    release every read is property by property."""

    def __init__(self, space, bodies):
        self.space, self.bodies = space, bodies
        try:
            from pymunk import batch
        except ImportError:
            self.batched = False
            return
        self.batch = batch
        ids = batch.Buffer()
        batch.get_space_bodies(space, batch.BodyFields.BODY_ID, ids)
        n = len(bodies)
        self.batched = np.frombuffer(ids.int_buf(), dtype=np.uintp)[:n].tolist() == [b.id for b in bodies]
        self.buffer = batch.Buffer()
        self.fields = batch.BodyFields.POSITION | batch.BodyFields.VELOCITY

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.batched:
            return (
                np.array([tuple(b.position) for b in self.bodies]).reshape(-1, 2),
                np.array([tuple(b.velocity) for b in self.bodies]).reshape(-1, 2),
            )
        self.buffer.clear()
        self.batch.get_space_bodies(self.space, self.fields, self.buffer)
        rows = np.frombuffer(self.buffer.float_buf(), dtype=float).reshape(-1, 4)[: len(self.bodies)]
        return rows[:, :2].copy(), rows[:, 2:].copy()


#: Spacing of the damped_spring chain's bodies (and every spring's rest length), in units of
#: max(|x0|, 1): a Chipmunk spring acts along the line between its bodies, so neighbours must
#: never pass each other; in the chain's exact motion no spring stretches by more than
#: sqrt(2) |x0| (its energy, k x0^2, bounds each spring's k d^2/2).
SPRING_SPACING = 10.0


class _Space(SteppedModel):
    """What every pose shares: the space, the counter, the step and the settings read back.
    A pose adds its bodies and the mode's force or constraints (``_build``), and reads and sets
    its state in the scene's coordinates."""

    settable = True
    #: The engine loop where the mode leaves Chipmunk to step alone (``space.step`` only).
    QUIET_LOOP = "space.step only"

    def __init__(self, pymunk, mode: str, scene: Scene, dt: float, count: bool = False):
        self.dt = dt
        self.mode = mode
        self.force_calls = 0 if count and mode in ("spring_force", "applied_force") else None
        values = scene.values
        self.space = space = pymunk.Space()
        space.gravity = (0.0, -values.get("g", 0.0))
        space.damping = 1.0
        space.sleep_time_threshold = math.inf
        self.constraints, self.bodies = [], []
        self.apply_before_step = None
        self._batch = None
        self._build(pymunk, mode, scene, values.get("k", 0.0), values.get("c", 0.0))
        self._install_counter()

    def _build(self, pymunk, mode: str, scene: Scene, k: float, c: float) -> None:
        raise NotImplementedError  # pragma: no cover - every pose defines it

    def _install_counter(self) -> None:
        """In a counting run, wrap the mode's Python force functions to count their calls."""
        self.settings["engine_loop"] = (
            "from Python every step: the force set on body.force, then space.step (the mode)"
            if self.mode == "applied_force"
            else "space.step only (the force is Chipmunk's velocity_func call)"
            if self.mode == "spring_force"
            else self.QUIET_LOOP
        )
        if self.force_calls is None:
            return

        def counting(function):
            def counted(*args):
                self.force_calls += 1
                return function(*args)

            return counted

        if self.mode == "spring_force":
            for b in self.bodies:
                b.velocity_func = counting(b.velocity_func)
        else:
            self.apply_before_step = counting(self.apply_before_step)

    def _record_settings(self, mode: str) -> None:
        space, body = self.space, self.bodies[0]
        self.settings = {
            "gravity": list(space.gravity),
            "damping": space.damping,
            "sleep_time_threshold": "inf" if math.isinf(space.sleep_time_threshold) else space.sleep_time_threshold,
            "iterations": space.iterations,
            "mass": sorted({b.mass for b in self.bodies}),
            "moment": "inf" if all(math.isinf(b.moment) for b in self.bodies) else [b.moment for b in self.bodies],
            "bodies": len(self.bodies),
            "shapes": 0,
            "force": {
                "spring_force": "set in body.velocity_func (sees the new positions)",
                "applied_force": "set on body.force before each space.step (sees the old positions)",
                "damped_spring": "none: DampedSpring constraints",
                "space_damping": "spring in body.velocity_func; damping as space.damping",
                "pin_joint": "none: gravity and the pin joints",
            }[mode],
        }
        if len(self.bodies) == 1:
            self.settings["mass"] = body.mass

    def _bodies_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Every body's (position, velocity) rows, in one Chipmunk call where it can (``BodyReader``)."""
        if self._batch is None:
            self._batch = BodyReader(self.space, self.bodies)
        return self._batch.read()

    def _zero_forces(self) -> None:
        for b in self.bodies:
            b.force = (0.0, 0.0)

    def advance(self) -> None:
        if self.apply_before_step is not None:
            self.apply_before_step()
        self.space.step(self.dt)

    def steps(self, n: int) -> None:
        """n steps, nothing read between them but what the mode needs (module docstring)."""
        step, dt = self.space.step, self.dt
        if self.apply_before_step is not None:
            apply = self.apply_before_step
            for _ in range(n):
                apply()
                step(dt)
        else:
            for _ in range(n):
                step(dt)

    def evaluations(self):
        if self.force_calls is not None:
            per = len(self.bodies) if self.mode == "spring_force" else 1
            what = (
                "velocity_func calls / bodies"
                if self.mode == "spring_force"
                else "calls of the force set before each step"
            )
            return self.force_calls // per, f"force evaluations counted from Python ({what})"
        if self.mode in ("spring_force", "applied_force"):
            return None, "counted only in a counting run (the counter wraps the Python force function)"
        return None, "Chipmunk's constraints compute their impulses inside space.step, with no counter or callback"

    def close(self) -> None:
        # A sleeping body attached to a constraint can segfault at interpreter exit: take
        # everything out of the space first.
        if self.constraints:
            self.space.remove(*self.constraints)
        self.space.remove(*self.bodies)


class _Body(_Space):
    """The spring and the damped spring: one body on the x axis. The DampedSpring acts along the
    line from its wall: under ``damped_spring`` the body sits SPRING_SPACING from the wall, its
    displacement measured from there (as on the chain)."""

    def _build(self, pymunk, mode, scene, k, c):
        values, space = scene.values, self.space
        self.body = body = pymunk.Body(values["m"], math.inf)
        self.bodies = [body]
        q0, v0 = scene.initial_state()
        self.offset = (
            np.array([SPRING_SPACING * max(abs(values["x0"]), 1.0)]) if mode == "damped_spring" else np.zeros(1)
        )
        self.set_state(q0, v0)
        space.add(body)
        update_velocity = pymunk.Body.update_velocity
        if mode == "damped_spring":
            rest = float(self.offset[0])
            self.constraints = [pymunk.DampedSpring(space.static_body, body, (0.0, 0.0), (0.0, 0.0), rest, k, c)]
            space.add(*self.constraints)
        elif mode == "space_damping":
            # Chipmunk keeps space.damping^h of the velocity each step: e^{-(c/m) h}.
            space.damping = math.exp(-c / values["m"])

            def velocity_func(b, gravity, damping, h):
                b.force = (-k * b.position.x, -k * b.position.y)
                update_velocity(b, gravity, damping, h)

            body.velocity_func = velocity_func
        elif mode == "spring_force":

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
        self._record_settings(mode)
        if mode == "damped_spring":
            spring = self.constraints[0]
            self.settings.update(
                {
                    "spring": "DampedSpring from a static wall to the body",
                    "rest_length": spring.rest_length,
                    "stiffness": spring.stiffness,
                    "spring_damping": spring.damping,
                }
            )

    def set_state(self, q, v) -> None:
        """As if built at (q, v) (scene coordinates)."""
        two = len(q) == 2
        self.body.position = (float(self.offset[0] + q[0]), float(q[1]) if two else 0.0)
        self.body.velocity = (float(v[0]), float(v[1]) if two else 0.0)
        self._zero_forces()

    def state(self):
        (x, _), (vx, _) = self.body.position, self.body.velocity
        return np.array([x - self.offset[0]]), np.array([vx])


class _Projectile(_Body):
    """The projectile: one body at the scene's (x, y), y up, gravity along -y."""

    def state(self):
        (x, y), (vx, vy) = self.body.position, self.body.velocity
        return np.array([x, y]), np.array([vx, vy])


class _Pendulum(_Space):
    """A body pinned to a static pivot at the origin, the scene's angle read from its position."""

    QUIET_LOOP = "space.step only, the bob's angle read between chunks of steps it cannot turn half a turn in"

    def _build(self, pymunk, mode, scene, k, c):
        values, space = scene.values, self.space
        self.body = body = pymunk.Body(values["m"], math.inf)
        self.bodies = [body]
        q0, v0 = scene.initial_state()
        L, theta = values["L"], float(q0[0])
        body.position = (L * math.sin(theta), -L * math.cos(theta))
        body.velocity = (0.0, 0.0)
        space.add(body)
        self.joint = pymunk.PinJoint(space.static_body, body, (0.0, 0.0), (0.0, 0.0))
        space.add(self.joint)
        self.constraints = [self.joint]
        self.theta = theta
        self._record_settings(mode)
        self.settings["joint"] = "PinJoint, static pivot at the origin to the bob's centre"
        self.settings.update(_joint_settings([self.joint]))

    def set_state(self, q, v) -> None:
        L, theta, omega = self.joint.distance, float(q[0]), float(v[0])
        self.body.position = (L * math.sin(theta), -L * math.cos(theta))
        self.body.velocity = (L * omega * math.cos(theta), L * omega * math.sin(theta))
        self.theta = theta
        self._zero_forces()

    def state(self):
        (x, y), (vx, vy) = self.body.position, self.body.velocity
        # The bob's angle from the downward vertical and its angular rate about the pivot.
        theta = math.atan2(x, -y)
        self.theta = unwrap(self.theta, theta) if math.isfinite(theta) else theta
        return np.array([self.theta]), np.array([(x * vy - y * vx) / (x * x + y * y)])

    def steps(self, n: int) -> None:
        """n steps of the pin-jointed pendulum, the angle followed between them in chunks.

        Chipmunk reports the bob's position, so the angle is known modulo 2 pi and its whole
        turns must be followed: ``unwrap`` is exact as long as the angle moves less than pi
        between two looks. A chunk is as many steps as the bob cannot turn a quarter turn in at
        twice the fastest angular rate its energy allows (speed at the bottom from the current
        speed and height, v_max^2 = v^2 + 2 g (y + L)); the states it reaches are those of a
        look after every step, bit for bit (``unwrap`` adds whole turns to Chipmunk's angle).
        """
        step, dt, body = self.space.step, self.dt, self.body
        g, length = -self.space.gravity[1], self.joint.distance
        theta = self.theta
        left = n
        while left > 0:
            (x, y), (vx, vy) = body.position, body.velocity
            fastest = 2.0 * math.sqrt(max(vx * vx + vy * vy + 2.0 * g * (y + length), 0.0)) / length
            chunk = int(0.5 * math.pi / (dt * fastest)) if math.isfinite(fastest) and fastest > 0.0 else 1
            chunk = max(1, min(chunk, left))
            for _ in range(chunk):
                step(dt)
            left -= chunk
            x, y = body.position
            angle = math.atan2(x, -y)
            theta = unwrap(theta, angle) if math.isfinite(angle) else angle
        self.theta = theta


class _Chain(_Space):
    """The chain: bodies on the x axis, displacements q_i (spaced SPRING_SPACING apart under
    ``damped_spring``), the forces between neighbours as the mode writes them."""

    def _build(self, pymunk, mode, scene, k, c):
        values, space = scene.values, self.space
        q0, v0 = scene.initial_state()
        n = values["N"]
        self.bodies = bodies = [pymunk.Body(values["m"], math.inf) for _ in range(n)]
        self.offset = np.zeros(n)
        if mode == "damped_spring":
            self.offset = SPRING_SPACING * max(abs(values["x0"]), 1.0) * np.arange(1, n + 1)
        for i, b in enumerate(bodies):
            b.position = (float(self.offset[i] + q0[i]), 0.0)
            b.velocity = (float(v0[i]), 0.0)
        space.add(*bodies)
        if mode == "damped_spring":
            rest = SPRING_SPACING * max(abs(values["x0"]), 1.0)
            wall = space.static_body
            self.constraints = [pymunk.DampedSpring(wall, bodies[0], (0.0, 0.0), (0.0, 0.0), rest, k, c)]
            self.constraints += [
                pymunk.DampedSpring(a, b, (0.0, 0.0), (0.0, 0.0), rest, k, c) for a, b in zip(bodies[:-1], bodies[1:])
            ]
            self.constraints.append(
                pymunk.DampedSpring(bodies[-1], wall, (0.0, 0.0), ((n + 1) * rest, 0.0), rest, k, c)
            )
        elif mode == "spring_force":
            self._spring_force(pymunk, bodies, n, k, c)
        elif mode == "applied_force":

            def apply_before_step():
                x = np.array([b.position.x for b in bodies])
                f = chain_force(k, c, x, lambda: np.array([b.velocity.x for b in bodies]))
                for b, fi in zip(bodies, f):
                    b.force = (float(fi), 0.0)

            self.apply_before_step = apply_before_step
        if self.constraints:
            space.add(*self.constraints)
        self._record_settings(mode)
        if mode == "damped_spring":
            c = self.constraints
            self.settings.update(
                {
                    "spring": "DampedSpring between neighbours and from the end bodies to static walls",
                    "rest_length": sorted({s.rest_length for s in c}),
                    "stiffness": sorted({s.stiffness for s in c}),
                    "spring_damping": sorted({s.damping for s in c}),
                    "springs": len(c),
                    "spacing": float(c[0].rest_length),
                }
            )

    def _spring_force(self, pymunk, bodies, n: int, k: float, c: float) -> None:
        update_velocity = pymunk.Body.update_velocity
        # The dashpots read the velocities from before the step: the bodies' velocity_funcs run
        # one after another, and a neighbour's would otherwise already be updated.
        old_v = np.zeros(n)

        def snapshot_velocities():
            old_v[:] = [b.velocity.x for b in bodies]

        if c != 0.0:
            self.apply_before_step = snapshot_velocities

        def velocity_func_for(i):
            left = bodies[i - 1] if i > 0 else None
            right = bodies[i + 1] if i < n - 1 else None

            def velocity_func(b, gravity, damping, h):
                # Called after every body has moved: the neighbours' new positions.
                f = (-2.0 * k) * b.position.x
                if left is not None:
                    f += k * left.position.x
                if right is not None:
                    f += k * right.position.x
                if c != 0.0:
                    d = (-2.0 * c) * old_v[i]
                    if i > 0:
                        d += c * old_v[i - 1]
                    if i < n - 1:
                        d += c * old_v[i + 1]
                    f += d
                b.force = (f, 0.0)
                update_velocity(b, gravity, damping, h)

            return velocity_func

        for i, b in enumerate(bodies):
            b.velocity_func = velocity_func_for(i)

    def set_state(self, q, v) -> None:
        for b, x, u, off in zip(self.bodies, q, v, self.offset):
            b.position, b.velocity = (float(off + x), 0.0), (float(u), 0.0)
        self._zero_forces()

    def state(self):
        x, u = self._bodies_state()
        return x[:, 0] - self.offset, u[:, 0].copy()


class _Rope(_Space):
    """The rope: bodies at the scene's (x_i, y_i), pinned to the origin and to each other."""

    def _build(self, pymunk, mode, scene, k, c):
        values, space = scene.values, self.space
        q0, v0 = scene.initial_state()
        self.bodies = bodies = [pymunk.Body(values["m"], math.inf) for _ in range(values["N"])]
        self.set_state(q0, v0)
        space.add(*bodies)
        anchors = [space.static_body] + bodies
        self.constraints = [pymunk.PinJoint(a, b, (0.0, 0.0), (0.0, 0.0)) for a, b in zip(anchors, bodies)]
        space.add(*self.constraints)
        self._record_settings(mode)
        self.settings["joint"] = "PinJoint: static pivot at the origin to body 1, then body i to body i+1, centres"
        self.settings.update(_joint_settings(self.constraints))

    def set_state(self, q, v) -> None:
        for i, b in enumerate(self.bodies):
            b.position = (float(q[2 * i]), float(q[2 * i + 1]))
            b.velocity = (float(v[2 * i]), float(v[2 * i + 1]))
        self._zero_forces()

    def state(self):
        x, u = self._bodies_state()
        return x.reshape(-1), u.reshape(-1)


class _Net(_Rope):
    """The net: a body per free mass, a DampedSpring (damping 0) per spring, pins on the static body."""

    def _build(self, pymunk, mode, scene, k, c):
        m, start = scene.grid[1], scene.rest_positions()
        self.bodies = [pymunk.Body(scene.node_mass, math.inf) for _ in scene.free_nodes()]
        self.set_state(*scene.initial_state())
        body = dict(zip((i * m + j for i, j in scene.free_nodes()), self.bodies))
        ends = {
            node: (body[node], (0.0, 0.0)) if node in body else (self.space.static_body, tuple(start[node]))
            for node in range(len(start))
        }
        self.constraints = [
            pymunk.DampedSpring(ends[a][0], ends[b][0], ends[a][1], ends[b][1], rest, stiff, 0.0)
            for a, b, stiff, rest in zip(*scene.springs())
        ]
        self.space.add(*self.bodies, *self.constraints)
        self._record_settings(mode)
        self.settings.update(
            spring="DampedSpring per spring, damping 0; pins on the static body",
            springs=len(self.constraints),
            spring_damping=sorted({s.damping for s in self.constraints}),
        )


#: How Chipmunk poses each scene it poses (the model class; each mode poses those its ``EngineMode``
#: lists); a new scene is one entry here.
POSES: dict[str, type[_Space]] = {
    "spring": _Body,
    "damped_spring": _Body,
    "projectile": _Projectile,
    "pendulum": _Pendulum,
    "chain": _Chain,
    "rope": _Rope,
    "net": _Net,
}


def _joint_settings(joints) -> dict:
    """A pin joint's settings, the same for every joint of a model (one value each, else a list)."""

    def one(values):
        values = sorted(set(values))
        values = ["inf" if math.isinf(v) else v for v in values]
        return values[0] if len(values) == 1 else values

    return {
        "joints": len(joints),
        "distance": one(j.distance for j in joints),
        "error_bias": one(j.error_bias for j in joints),
        "max_bias": one(j.max_bias for j in joints),
        "max_force": one(j.max_force for j in joints),
    }


def build(pymunk, mode: str, scene: Scene, dt: float, count: bool = False) -> _Space:
    return POSES[scene.kind](pymunk, mode, scene, dt, count)


#: The releases this adapter supports: from 6.5, the oldest with a wheel for Python 3.11 (the
#: project's interpreter), whose Body, Space, DampedSpring, PinJoint and velocity_func take what
#: the poses pass; ``pymunk.batch`` (6.6) is asked for, not required (``BodyReader``).
VERSIONS = EngineVersions(low="6.5.0", below="8", tested=("6.5.0", "6.6.0", "7.0.0", "7.3.1"))


def _mode(
    mode: str, scenes, unsupported, doc: str, settings: dict, no_match=None, behaviour: Behaviour = NO_BEHAVIOUR
) -> EngineMode:
    return EngineMode(
        engine="pymunk",
        mode=mode,
        module="pymunk",
        dist="pymunk",
        build=build,
        scenes=scenes,
        unsupported=unsupported,
        doc=doc,
        no_match=no_match or {},
        versions=VERSIONS,
        behaviour=behaviour,
        counting_run=mode in ("spring_force", "applied_force"),
        settings={"damping": 1, "sleeping": "disabled", "moment": "inf", "shapes": 0, **settings},
    )


METHODS = {
    m.id: m
    for m in (
        _mode(
            "spring_force",
            _FORCE_SCENES,
            _FORCE_UNSUPPORTED,
            """position-first semi-implicit Euler (force in velocity_func, as Chipmunk intends)
          Measured: equals ref:semi_implicit_euler_position_first bitwise on the spring and the chain.""",
            {"force": "body.velocity_func"},
        ),
        _mode(
            "applied_force",
            _FORCE_SCENES,
            _FORCE_UNSUPPORTED,
            """explicit Euler (force set on body.force before each step, as many users write it)
          Measured: equals ref:explicit_euler bitwise on the spring and the chain: energy x(1 + h^2) per
          step on the spring, unstable at every dt on the chain.""",
            {"force": "body.force before each step"},
        ),
        _mode(
            "damped_spring",
            ("damped_spring", "chain", "net"),
            _SPRING_UNSUPPORTED,
            """position-first semi-implicit Euler, damping as an exact decay after the kick (Chipmunk's DampedSpring)
          Measured: equals ref:semi_implicit_euler_position_first on the chain to roundoff of the
          bodies' spaced positions (9e-11 absolute on velocities of ~120 over 1000 steps), and
          ref:position_first_euler_decay_after_kick on the damped spring (1e-14).""",
            {
                "spring": "DampedSpring, damping 0, between neighbours and to static walls",
                "spacing": f"{SPRING_SPACING:g} max(|x0|, 1)",
            },
            {
                "chain": "with damping, Chipmunk's impulse solver decays each spring's relative velocity in turn, "
                "one spring after another: no one-step formula of the whole chain's damping"
            },
            Behaviour(integrates_as={"net": "ref:semi_implicit_euler_position_first"}),
        ),
        _mode(
            "space_damping",
            _SPACE_DAMPING_SCENES,
            _SPACE_DAMPING_UNSUPPORTED,
            """position-first semi-implicit Euler, damping as an exact decay before the kick (Chipmunk's space.damping)
          Measured: equals ref:position_first_euler_decay_before_kick on the damped spring and the
          projectile to roundoff (space.damping^h is e^{-c h/m} to a few ulps).""",
            {"damping": "e^(-c/m) (space.damping)", "force": "body.velocity_func (spring); gravity"},
        ),
        _mode(
            "pin_joint",
            ("pendulum", "rope"),
            _JOINT_UNSUPPORTED,
            """pendulum and rope on PinJoints with Chipmunk's default error correction (loses energy)
          Measured: no reference scheme; the joints' bias correction bleeds energy.""",
            {"joint": "PinJoint, default error_bias and max_bias"},
            {"pendulum": "the pin joint's error correction (error_bias, max_bias) moves the bob between steps"},
        ),
    )
}

from . import contact  # noqa: E402  (its contact poses, joined to its entry below)

#: The engine, declared once: ``adapters.ENGINES`` and every list of engines the harness keeps read it.
ENGINE = Engine(
    id="pymunk",
    module="pymunk",
    dists=("pymunk",),
    versions=VERSIONS,
    methods=METHODS,
    poses=POSES,
    build=build,
    bare_loops=bench.bare_loops,
    contact_modes=contact.MODES,
)
