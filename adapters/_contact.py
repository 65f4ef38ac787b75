"""A contact mode (one engine integrator with its contact model), how an engine poses a contact
scene (``ContactPose``, one entry per scene in each engine's ``POSES``) and the two loops every
pose runs: ``record_loop`` (every step's state, with a blow-up caught where it happens) and
``timed_loop`` (the same steps again, nothing recorded, the process CPU clock around the engine's
calls)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from collections.abc import Callable, Mapping

import numpy as np

from records.contact import ContactTrajectory
from records.trajectory import OK, UNSTABLE

from ._engine import engine_version, import_engine

#: The least CPU time the timed passes of a run's loop add up to (s), and the most passes: below it
#: a coarse process clock (one that ticks in milliseconds) reads a short run as nothing. Policy.
MIN_TIMED_S = 0.05
MAX_TIMED_PASSES = 50

#: A state further than this from the origin (m) is a blow-up: every scene's bodies stay within a
#: few metres of it (a ball thrown a few times its drop height is an energy gain, measured as one).
RUNAWAY_M = 100.0


@dataclass(frozen=True)
class ContactPose:
    """How an engine poses one contact scene: the entry of the engine's ``POSES`` for the scene's
    kind. ``shape``: ``sphere`` (the ball: a sphere of the scene's ``radius`` requested its
    restitution ``e``, frictionless, held to z where the engine can hold it) or ``box`` (a cube of
    side 2 ``half`` a body, at rest on contact, with the scene's friction ``mu``, or 1 where it has
    none); the bodies start at the scene's ``initial_centres`` with its ``initial_velocities``,
    in its ``gravity`` where the engine takes a field."""

    shape: str


SPHERE = ContactPose("sphere")
BOX = ContactPose("box")
#: A box that turns (the edge, corner and tipping scenes): a cube of side 2 ``half`` on a free
#: joint, started at the scene's ``initial_orientations`` and ``initial_angular_velocities``, with
#: its friction ``mu`` and its restitution ``e`` where the scene asks one (else a resting contact);
#: its run records each body's orientation and angular velocity too.
TURNING_BOX = ContactPose("turning_box")
#: A solid sphere of the scene's ``radius`` that rolls (moment 2/5 m r^2, friction ``mu``, no
#: rolling or spinning resistance, a resting contact), on a free joint, its turning recorded.
ROLLING_SPHERE = ContactPose("rolling_sphere")


@dataclass(frozen=True)
class ContactMode:
    """One engine integrator with its contact model. ``run(mode, scene, dt) -> ContactTrajectory``
    poses and steps it; ``poses`` ({scene kind: ``ContactPose``}, the engine's ``POSES``) are the
    contact scenes it poses (``scenes``; a pose added to the engine's ``POSES`` is posed by each of
    its modes) and ``unsupported`` says why not the others; ``settings`` are the contact settings
    every run of the mode uses (a run adds those it derives from the scene, e.g. MuJoCo's solref
    from e); ``own_process``: every run needs a fresh process (an engine whose settings are
    process-wide, pybullet's contact breaking threshold); ``dims``: 2 for a planar engine (pymunk)."""

    engine: str
    mode: str
    dist: str
    run: Callable
    poses: Mapping[str, ContactPose]
    unsupported: Mapping[str, str] = field(default_factory=dict)
    settings: Mapping[str, object] = field(default_factory=dict)
    doc: str = ""
    own_process: bool = False
    dims: int = 3
    module: str = ""
    #: The engine holds the ball to z (a slide or prismatic joint): it poses no motion along x or y.
    holds_ball_to_z: bool = False
    #: The engine's gravity is along -z only (REBOUND's planet): it poses no tilted field.
    gravity_along_z: bool = False

    @property
    def id(self) -> str:
        return f"{self.engine}:{self.mode}"

    @property
    def scenes(self) -> tuple[str, ...]:
        return tuple(self.poses)

    def pose(self, scene) -> ContactPose:
        """The engine's pose of ``scene`` (its kind's entry of ``poses``)."""
        return self.poses[scene.kind]

    def available(self) -> tuple[bool, str]:
        if engine_version(self.dist) is None:
            return False, f"{self.dist} is not installed"
        try:
            import_engine(self.module or self.engine)
        except Exception as exc:  # an engine that cannot import is unavailable, never a crash
            return False, f"{self.dist} does not import: {type(exc).__name__}: {exc}"
        return True, ""

    def supports(self, scene) -> tuple[bool, str]:
        """Whether the mode poses ``scene``: a scene id (its kind has a pose here) or a contact
        scene, whose starting state and gravity are then checked against what the pose can hold
        (the reason says what it cannot: a pose that ran anyway would judge the engine for a
        motion it was never given)."""
        kind = scene if isinstance(scene, str) else scene.kind
        if kind not in self.poses:
            return False, self.unsupported.get(kind, f"{self.id} does not pose {kind}")
        if isinstance(scene, str):
            return True, ""
        why = self.state_why(scene)
        return (not why), why

    def state_why(self, scene) -> str:
        """Why the pose cannot start ``scene`` as the scene says ("" where it can)."""
        gravity = [float(x) for x in scene.gravity]
        centres = [[float(x) for x in c] for c in scene.initial_centres()]
        velocities = [[float(x) for x in u] for u in scene.initial_velocities()]
        off_z = any(g != 0.0 for g in gravity[:2])
        if self.gravity_along_z and off_z:
            return f"{self.id} poses gravity along -z only (the scene's is {gravity})"
        if self.dims == 2 and (gravity[1] != 0.0 or any(c[1] != 0.0 for c in (*centres, *velocities))):
            return f"{self.id} is planar (x and z): the scene has a y component in its state or gravity"
        if self.dims == 2:
            turns = [[float(x) for x in q] for q in scene.initial_orientations()]
            spins = [[float(x) for x in w] for w in scene.initial_angular_velocities()]
            if any(q[1] != 0.0 or q[3] != 0.0 for q in turns) or any(w[0] != 0.0 or w[2] != 0.0 for w in spins):
                return f"{self.id} is planar (x and z): the scene turns a body about an axis other than y"
        moves_sideways = any(u[0] != 0.0 or u[1] != 0.0 for u in velocities) or off_z
        off_axis = any(c[0] != 0.0 or c[1] != 0.0 for c in centres)
        if self.holds_ball_to_z and self.pose(scene).shape == "sphere" and (moves_sideways or off_axis):
            return (
                f"{self.id} holds the ball to z on a joint: the scene moves it along x or y, or starts it off the axis"
            )
        return ""


def record_loop(
    mode: ContactMode,
    scene,
    dt: float,
    step: Callable[[], None],
    read: Callable[[], tuple[np.ndarray, np.ndarray]],
    settings: dict,
    loop: str,
    time_again: Callable[[int], float] | None = None,
) -> ContactTrajectory:
    """Step ``steps = ceil(duration / dt)`` times, reading (centres, velocities) (each (bodies, 3))
    before the first and after every step; a pose whose bodies turn reads (centres, velocities,
    orientations, angular velocities), the last two (bodies, 4) as (w, x, y, z) and (bodies, 3) in
    world axes. A non-finite state, or one past ``RUNAWAY_M``, stops the
    run as ``unstable`` at that step. ``time_again(steps)``, where given, steps a fresh copy of the
    pose that many times with nothing recorded and returns its CPU seconds (``timed_loop``)."""
    steps = int(math.ceil(scene.duration / dt - 1e-9))
    first = read()
    c0, v0 = first[0], first[1]
    bodies = len(c0)
    centres = np.empty((steps + 1, bodies, 3))
    velocities = np.empty((steps + 1, bodies, 3))
    centres[0], velocities[0] = c0, v0
    turns = len(first) == 4
    quats = np.empty((steps + 1, bodies, 4)) if turns else None
    spins = np.empty((steps + 1, bodies, 3)) if turns else None
    if turns:
        quats[0], spins[0] = first[2], first[3]
    status, detail, failed = OK, "", None
    n = steps
    for i in range(1, steps + 1):
        step()
        state = read()
        c, v = state[0], state[1]
        centres[i], velocities[i] = c, v
        if turns:
            quats[i], spins[i] = state[2], state[3]
        if not (np.all(np.isfinite(c)) and np.all(np.isfinite(v))) or np.max(np.abs(c)) > RUNAWAY_M:
            status, failed, n = UNSTABLE, i, i
            detail = (
                f"state {'not finite' if not np.all(np.isfinite(c)) else f'past {RUNAWAY_M:g} m'} at step {i} "
                f"(t = {i * dt:.4g} s)"
            )
            break
    run = ContactTrajectory.of(
        scene,
        mode.id,
        dt,
        np.arange(n + 1) * dt,
        centres[: n + 1],
        velocities[: n + 1],
        loop=loop,
        settings=dict(settings),
        status=status,
        detail=detail,
        failed_step=failed,
        engine_version=engine_version(mode.dist),
        steps=steps,
        orientations=None if quats is None else quats[: n + 1],
        angular=None if spins is None else spins[: n + 1],
    )
    if status == OK and time_again is not None:
        # Timed again until the clock has counted enough to say something (a process clock may tick
        # coarsely: a few hundred steps of a fast engine read as 0), each pass a fresh copy.
        total, passes = 0.0, 0
        while passes < 1 or (total < MIN_TIMED_S and passes < MAX_TIMED_PASSES):
            total += time_again(steps)
            passes += 1
        run.loop_cpu_s = total / passes if total > 0 else None
        run.settings["loop timed"] = f"{passes} pass{'es' if passes > 1 else ''} of {steps} steps, process CPU clock"
    return run


def timed_loop(step: Callable[[], None], steps: int) -> float:
    """CPU seconds of ``steps`` calls of ``step`` (the process clock: a neighbour's load does not
    count, a wait does not either)."""
    t0 = time.process_time()
    for _ in range(steps):
        step()
    return time.process_time() - t0
