"""What every engine adapter shares: the engine mode as a method, quiet engine imports,
and the two loops that turn an engine model into a :class:`Trajectory`.

An engine module (``adapters/mujoco.py``, ...) provides ``build(engine_module, mode, scene, dt,
count=False)`` returning a :class:`Model`: the minimal engine model of the scene, set to the
scene's initial state, that advances one step of ``dt`` at a time (or many, through the
engine's own loop) and reports its state in the scene's own coordinates. Both loops record
exactly as ``reference/_integrate.py`` records a scheme (step 0, then every ``every`` steps,
always the last), so the two are compared like with like; the energy is the scene's, from
the state.

* ``loop="engine"`` (the default, :func:`run_engine_loop`): the engine advances from one output
  point to the next through its own loop (``mujoco.rollout``, REBOUND's ``sim.steps(n)``, a
  Python loop that calls only the step function for pybullet and pymunk) and the state is read
  at output points only. This is what ``engine s/step`` times.
* ``loop="harness"`` (:func:`drive`): one ``advance()`` per step, the state read and checked
  after every step: the path the harness always took, kept as the trajectories' witness and
  timed as ``as stepped by the harness``.

Both give the same trajectory bitwise (``tests/test_engine_loops.py``). A run whose engine
loop meets a diverged output state or an engine warning is run again from its start on the
per-step path, which stops it at the exact step.
"""
from __future__ import annotations

import contextlib
import functools
import importlib
import importlib.metadata
import math
import os
import re
import sys
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Protocol

import numpy as np

from records import MethodId, Trajectory
from records.method_id import Option

from scenarios import Scene
from records.trajectory import OK, UNSTABLE, RunMeta, divergence_detail, diverged, output_marks, step_loop


class Model(Protocol):
    """A built engine model of one scene. ``settings`` are read back from the engine after
    building (what actually ran, not what was asked for) and must be plain JSON values."""

    settings: dict

    def advance(self) -> None:
        """One engine step of dt."""

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) in the scene's coordinates, each (ndof,), copies."""


class EngineModel:
    """An engine model with every optional member of :class:`Model` declared, and its default.

    An adapter's model subclasses this (or :class:`SteppedModel`) and overrides what its engine
    offers; a plugin's model that declares only ``Model`` is completed by :func:`declared`, the
    one place that looks for optional members. The rest of the harness reads the declarations:

    * ``own_loop``: ``run(marks)`` is the engine's own loop (else the harness steps the model one
      ``advance()`` at a time);
    * ``settable``: ``set_state(q, v)`` puts the model in a state (scene coordinates) as if it had
      been built there, so that one model can take one step from many states (``one_steps``);
    * ``run_checks_divergence``: ``run(marks)`` itself stops at the first diverged state (through
      ``step_loop``), so :func:`run_engine_loop` need not ask again of the states it returns.
    """

    settings: dict
    own_loop: bool = False
    settable: bool = False
    run_checks_divergence: bool = False

    def advance(self) -> None:  # pragma: no cover - every model defines it
        raise NotImplementedError

    def state(self) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - every model defines it
        raise NotImplementedError

    def trouble(self) -> str | None:
        """A divergence the engine itself reported during the last step (None if none)."""
        return None

    def close(self) -> None:
        """Release the engine's resources."""

    def run(self, marks: np.ndarray) -> tuple[list[tuple[np.ndarray, np.ndarray]], bool]:
        """Advance through the engine's own loop from step ``marks[0]`` (the current step) to
        each later mark in turn, reading the state (scene coordinates) only there: ``(states at
        marks[1:], clean)``. ``clean`` is False, and the list may stop early, where the engine
        reported trouble or a state diverged; the caller then replays the run step by step.
        Only where ``own_loop``."""
        raise NotImplementedError(f"{type(self).__name__} has no loop of its own (own_loop is False)")

    def evaluations(self) -> tuple[int | None, str]:
        """(force evaluations since the model was built, what was counted), or (None, why not)."""
        return None, "the engine mode does not count them"

    def anatomy(self) -> dict | None:
        """What the engine built, at the model's current state, where it says: ``total_mass``,
        ``mass_matrix`` (generalised, the scene's coordinates) and ``joint_axes`` (world frame,
        one per coordinate); None where it does not (what a cross-engine comparison reads)."""
        return None

    def set_state(self, q: np.ndarray, v: np.ndarray) -> None:
        """Only where ``settable``."""
        raise NotImplementedError(f"{type(self).__name__} cannot be set to a state (settable is False)")


class SteppedModel(EngineModel):
    """A model whose engine loop is ``steps(n)``: n steps through the engine's own loop, nothing
    read in between; ``run`` reads the state at each mark (:func:`run_by_steps`)."""

    own_loop = True
    run_checks_divergence = True  # run_by_steps checks every mark

    def steps(self, n: int) -> None:  # pragma: no cover - every stepped model defines it
        raise NotImplementedError

    def run(self, marks: np.ndarray):
        return run_by_steps(self, marks)


class _Declared(EngineModel):
    """A plugin's model that declares only part of :class:`EngineModel`, its optional members
    set to their defaults (``declared``)."""

    def __init__(self, inner):
        self.inner = inner
        self.settings = inner.settings
        self.advance, self.state = inner.advance, inner.state
        self.own_loop, self.settable = hasattr(inner, "run"), hasattr(inner, "set_state")
        for name in ("trouble", "close", "run", "evaluations", "set_state"):
            if hasattr(inner, name):
                setattr(self, name, getattr(inner, name))


def declared(model) -> EngineModel:
    """``model`` with every optional member declared: itself if it is an :class:`EngineModel`."""
    return model if isinstance(model, EngineModel) else _Declared(model)


@contextlib.contextmanager
def quiet_fds():
    """Send file descriptors 1 and 2 to /dev/null for the duration (C-level output included:
    pybullet prints its build banner with printf on import). C stdio buffers are flushed
    before the descriptors are put back, so buffered engine output cannot surface later.
    Where 1 or 2 is not open there is nothing to protect, and nothing is redirected."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    try:
        saved = [os.dup(1), os.dup(2)]
    except OSError:
        yield
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        _flush_c_stdio()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


def _flush_c_stdio() -> None:
    try:
        import ctypes

        ctypes.CDLL(None).fflush(None)
    except Exception:  # pragma: no cover - no C library to flush (not on Linux/macOS)
        pass


def import_engine(name: str):
    """Import an engine module with its import-time output silenced."""
    if sys.modules.get(name) is not None:  # already imported: skip the descriptor juggling
        return sys.modules[name]
    with quiet_fds():
        return importlib.import_module(name)


def engine_version(dist: str) -> str | None:
    """The installed version of ``dist``: the first one on ``sys.path``, so an engine environment
    put ahead of the venv (``harness.execution.engine_env``) names its own release. Asked once per
    distribution and search path: every method lookup checks it (``EngineMode.available``), and
    reading the metadata scans the path."""
    return _engine_version(dist, tuple(sys.path))


@functools.lru_cache(maxsize=64)
def _engine_version(dist: str, path: tuple) -> str | None:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return None


_VERSION = re.compile(r"^v?(\d+(?:\.\d+)*)(?:[.-]?(a|b|rc)(\d+))?(?:[.-]?post(\d+))?(?:[.-]?dev(\d+))?$")


def version_key(version: str) -> tuple:
    """A sort key of a release number (PEP 440's final, pre-, post- and dev-releases: what a
    registry lists): ``2.3.1.post1`` after ``2.3.1``, ``3.0.0rc1`` before ``3.0.0``, trailing
    zeros ignored (``4.0`` == ``4.0.0``). ValueError for anything else."""
    match = _VERSION.match(version.strip())
    if match is None:
        raise ValueError(f"{version!r} is not a release number")
    release, pre, pre_n, post, dev = match.groups()
    parts = [int(x) for x in release.split(".")]
    while len(parts) > 1 and parts[-1] == 0:
        parts.pop()
    pre_key = ({"a": 0, "b": 1, "rc": 2}[pre], int(pre_n)) if pre else (3, 0)
    return (tuple(parts), pre_key, int(post) if post else -1, int(dev) if dev else 1 << 30)


@dataclass(frozen=True)
class EngineVersions:
    """The engine releases an adapter supports (``low`` inclusive up to ``below`` exclusive, None:
    no upper bound) and those it was measured on (``tested``). Between releases the adapter asks
    the engine what it has (a member of an enum, a binding's signature), not its version."""

    low: str
    below: str | None = None
    tested: tuple[str, ...] = ()

    def __contains__(self, version: str) -> bool:
        key = version_key(version)
        return key >= version_key(self.low) and (self.below is None or key < version_key(self.below))

    def __str__(self) -> str:
        return f">={self.low}" + (f",<{self.below}" if self.below else "")

    def outside(self, dist: str, version: str | None) -> str | None:
        """Why ``version`` of ``dist`` cannot be used (one line naming the range), None where it can."""
        if version is None:
            return None
        try:
            if version in self:
                return None
        except ValueError:
            pass
        tested = f"; tested on {', '.join(self.tested)}" if self.tested else ""
        return f"{dist} {version} is outside the versions its adapter supports ({dist}{self}{tested})"


@dataclass(frozen=True)
class EngineMode:
    """One integrator mode of one engine, usable wherever a ``ref:`` method is: a
    ``records.Method``, every capability declared (``scheme`` None: no reference scheme behind it).

    ``scenes`` lists the scene ids the mode poses; ``unsupported`` gives the reason for every
    scene it cannot pose minimally. ``settings`` describe the mode (each result records the
    settings read back from the engine that ran).
    ``doc`` says, measured, which scheme the mode is; its first line is the summary.
    ``adaptive``: the engine chooses its own steps and ``dt`` is only the output interval, so
    nothing is measured against dt (observed order, largest stable dt).
    ``no_match``: for a scene where the mode, measured, integrates no reference scheme, why
    (one line); ``harness identify`` prints it when nothing matches.
    ``refuses``: for a scene the mode poses only in some of its parameters, a function of the
    scene that says why these cannot be posed (None where they can): ``supports`` refuses them.
    """

    engine: str
    mode: str
    module: str
    dist: str
    build: Callable
    scenes: tuple[str, ...]
    unsupported: Mapping[str, str]
    settings: Mapping[str, object]
    doc: str = field(default="", compare=False)
    adaptive: bool = False
    no_match: Mapping[str, str] = field(default_factory=dict, compare=False)
    refuses: Mapping[str, Callable[[Scene], str | None]] = field(default_factory=dict, compare=False)
    #: Its force evaluations are counted only in a counting run (``simulate(..., count=True)``:
    #: the counter is a Python callback that would slow the timed loop; REBOUND, pymunk).
    counting_run: bool = False
    #: The engine releases the adapter supports (None: any); one outside them makes every mode of
    #: the engine unavailable with one line naming the range (``check_version``).
    versions: EngineVersions | None = field(default=None, compare=False)
    #: Whether the imported engine has this mode (a capability asked of the engine, e.g. an
    #: integrator enum's member): True, False, or a one-line reason why not; None: every
    #: supported release has it. A release without it leaves the mode unavailable with that
    #: reason, else "not in <dist> <version>", never a crash.
    present: Callable[[object], bool | str] | None = field(default=None, compare=False)
    #: The floating-point width the engine computes in ("float64", or "float32" for Warp's
    #: engines): a float32 mode is identified against the reference schemes to float32 rounding
    #: (``harness.measures.identify``).
    precision: str = "float64"
    #: The run-time options the mode takes (``records.method_id.Option`` by name), written into
    #: its id where set (``drake:runge_kutta3@1e-6``); ``build`` gets each one set as a keyword.
    options_declared: Mapping[str, Option] = field(default_factory=dict, compare=False)
    #: The options set, ``((name, value), ...)`` (``with_options``).
    options_set: tuple = ()
    #: The option that, set, hands the step to the engine's error control (``tolerance``): the
    #: mode is then adaptive (``dt`` its output interval).
    adaptive_with: str | None = field(default=None, compare=False)

    isolated = True
    scheme = None

    #: The loops ``simulate`` can step a model with (module docstring).
    LOOPS = ("engine", "harness")

    @property
    def id(self) -> str:
        return str(MethodId.of(self.engine, self.mode, self.options))

    @property
    def options(self) -> dict:
        """The options set (``options_set``) by name."""
        return dict(self.options_set)

    def with_options(self, options: dict) -> "EngineMode":
        """The same mode with ``options`` set (checked by the caller, ``harness.methods``); setting
        ``adaptive_with`` makes it adaptive."""
        merged = {**self.options, **options}
        return replace(self, options_set=tuple(sorted(merged.items())),
                       adaptive=self.adaptive or (self.adaptive_with is not None and self.adaptive_with in merged))

    @property
    def family(self) -> str:
        return self.engine

    @property
    def summary(self) -> str:
        return self.doc.strip().splitlines()[0] if self.doc else self.id

    def available(self) -> tuple[bool, str]:
        # The version first: a release outside the range may not even import cleanly.
        outside = self.version_problem()
        if outside:
            return False, outside
        try:
            engine = import_engine(self.module)
        except Exception as exc:  # ImportError, or a broken install (OSError from a shared library)
            return False, (f"{self.module} cannot be imported ({type(exc).__name__}: {exc}); "
                           f"install it with: pip install 'integrator-harness[{self.engine}]'")
        has = True if self.present is None else self.present(engine)
        if has is not True:
            return False, has if isinstance(has, str) and has else f"not in {self.dist} {engine_version(self.dist)}"
        return True, ""

    def version_problem(self) -> str | None:
        """One line naming the supported range where the installed engine is outside it, else None."""
        return self.versions.outside(self.dist, engine_version(self.dist)) if self.versions else None

    def supports(self, scene: Scene) -> tuple[bool, str]:
        if scene.kind in self.scenes:
            refusal = self.refuses.get(scene.kind)
            why = refusal(scene) if refusal is not None else None
            return (False, why) if why else (True, "")
        return False, self.unsupported.get(scene.kind, f"{self.id} has no model of scene {scene.id}")

    def compiled_twin(self) -> "EngineMode":
        """Itself: an engine mode already runs the engine's own loop."""
        return self

    def _model(self, scene: Scene, dt: float, count: bool = False):
        """(engine module, model of ``scene`` at ``dt``); a scene it does not pose is a ValueError."""
        ok, why = self.supports(scene)
        if not ok:
            raise ValueError(f"{self.id} does not support scene {scene.id}: {why}")
        engine = import_engine(self.module)
        return engine, self._build(engine, scene, dt, count)

    def _build(self, engine, scene: Scene, dt: float, count: bool):
        # ``count`` is passed only when asked for, so that a plugin's build(engine, mode, scene, dt) still fits.
        return declared(self.build(engine, self.mode, scene, dt, **({"count": True} if count else {}), **self.options))

    def simulate(self, scene: Scene, dt: float, steps: int, every: int = 1, *, loop: str = "engine",
                 count: bool = False) -> Trajectory:
        """Step the engine in this process (the harness calls this inside a worker process).

        ``loop`` is ``"engine"`` (the engine's own loop between output points) or ``"harness"``
        (one step at a time, state read after each): the same trajectory, bitwise (module
        docstring). ``count=True`` builds the model with its force-evaluation counter installed
        where counting needs a callback (REBOUND, pymunk), which slows the engine's loop."""
        if loop not in self.LOOPS:
            raise ValueError(f"loop: {loop!r} is not one of {', '.join(self.LOOPS)}")
        engine, model = self._model(scene, dt, count)
        try:
            # A model with no loop of its own (a plugin's) is stepped one advance() at a time.
            if loop == "engine" and model.own_loop:
                traj = run_engine_loop(model, scene, self.id, dt, steps, every)
                if traj is None:  # diverged or the engine warned: find the step as the harness always has
                    spent, model = model, None
                    spent.close()
                    model = self._build(engine, scene, dt, count)
                    traj = drive(model, scene, self.id, dt, steps, every)
                    traj.meta.loop = "engine, replayed step by step from the start (diverged or warned)"
            else:
                traj = drive(model, scene, self.id, dt, steps, every)
            evals, what = model.evaluations()
        finally:
            if model is not None:
                model.close()
        traj.force_evals = evals
        if evals is not None:
            traj.meta.force_evals_counted = what
        else:
            traj.meta.force_evals_reason = what
        traj.meta.backend, traj.meta.engine, traj.meta.engine_version = "engine", self.engine, engine_version(self.dist)
        traj.meta.settings = dict(model.settings)
        return traj

    def timed_run(self, scene: Scene, dt: float, steps: int, now: Callable[[], float],
                  loop: str = "engine") -> tuple[float, int | None]:
        """(seconds on the clock ``now`` that one run of ``steps`` steps with a single output point
        takes through ``loop`` (as ``simulate`` runs it), the step it diverged at or None), the
        model built and closed outside the clock: what ``harness.measures.cost`` times, free of
        the jitter of building an engine model. A run that needs its step-by-step replay (it
        diverged) is timed with the replay; the cost measure then times the steps before."""
        if loop not in self.LOOPS:
            raise ValueError(f"loop: {loop!r} is not one of {', '.join(self.LOOPS)}")
        engine, model = self._model(scene, dt)
        try:
            every = max(int(steps), 1)
            t = now()
            traj = None
            if loop == "engine" and model.own_loop:
                traj = run_engine_loop(model, scene, self.id, dt, steps, every)
                if traj is None:
                    spent, model = model, None
                    spent.close()
                    model = self._build(engine, scene, dt, False)
                    traj = drive(model, scene, self.id, dt, steps, every)
            else:
                traj = drive(model, scene, self.id, dt, steps, every)
            return now() - t, traj.failed_step
        finally:
            if model is not None:
                model.close()

    def one_steps(self, scene: Scene, dt: float, states) -> list[tuple[np.ndarray | None, str]] | None:
        """One step of ``dt`` from each state y = (q, v) (rows of ``states``, scene coordinates),
        all on one model built once: ``(y_1, "")``, or ``(None, why)`` where the step diverged
        or the engine complained. None if the model cannot be set to a state (``set_state``):
        then each state needs a model built from it. Runs in this process, unvalidated."""
        engine, model = self._model(scene, dt)
        try:
            if not model.settable:
                return None
            n = scene.ndof
            out = []
            for y in np.atleast_2d(np.asarray(states, dtype=float)):
                model.set_state(y[:n].copy(), y[n:].copy())
                model.advance()
                q, v = model.state()
                trouble = model.trouble()
                if trouble is not None or diverged(q, v):
                    out.append((None, f"one step from {y.tolist()} ended unstable: "
                                      f"{trouble or divergence_detail(1, dt)}"))
                else:
                    out.append((np.concatenate([q, v]), ""))
            return out
        finally:
            model.close()

    def anatomy(self, scene: Scene, dt: float) -> dict | None:
        """``EngineModel.anatomy`` of the model built for ``scene`` at its initial state (in this
        process: the harness calls it inside a worker)."""
        _, model = self._model(scene, dt)
        try:
            return model.anatomy()
        finally:
            model.close()

    def describe(self) -> dict:
        return {"id": self.id, "family": self.engine, "engine": self.engine, "mode": self.mode,
                "summary": self.summary, "engine_version": engine_version(self.dist),
                "engine_versions": str(self.versions) if self.versions else None,
                "settings": dict(self.settings), "supported_scenes": list(self.scenes), "adaptive": self.adaptive,
                "precision": self.precision,
                "doc": " ".join(self.doc.split())}


def drive(model: Model, scene: Scene, method: str, dt: float, steps: int, every: int = 1) -> Trajectory:
    """Step ``model`` ``steps`` times, recording as the reference driver records.

    A step whose state diverged (the reference driver's criterion, ``records.trajectory.diverged``)
    or where the engine reported a divergence, stops the
    run: status ``unstable`` with that step, the arrays ending at the last good recorded state.
    """
    now = list(model.state())  # (q, v) after the latest step
    rec_step, rec_q, rec_v = [], [], []

    def check(n: int) -> str:
        now[:] = model.state()
        trouble = model.trouble()
        if trouble is not None:
            return f"{trouble} at step {n} (t = {n * dt:g})"
        return divergence_detail(n, n * dt) if diverged(*now) else ""

    def record(n: int) -> None:
        rec_step.append(n)
        rec_q.append(now[0])
        rec_v.append(now[1])

    failed, detail = step_loop(lambda a, n: model.advance(), check, record, steps, every)
    traj = _trajectory(scene, method, dt, steps, every, rec_step, rec_q, rec_v, UNSTABLE if failed else OK,
                       detail, failed)
    traj.meta.loop = "harness: one advance() per step, state read after each"
    return traj


def _trajectory(scene: Scene, method: str, dt: float, steps: int, every: int, rec_step, rec_q, rec_v,
                status: str = OK, detail: str = "", failed: int | None = None) -> Trajectory:
    q_arr = np.asarray(rec_q)[:, None, :]
    v_arr = np.asarray(rec_v)[:, None, :]
    step_arr = np.array(rec_step, dtype=np.int64)
    with np.errstate(all="ignore"):
        energy = scene.energy(q_arr, v_arr)
    return Trajectory(
        scene=scene.id, method=method, dt=dt, steps=steps, every=every,
        step=step_arr, t=step_arr * dt, q=q_arr, v=v_arr, energy=energy,
        status=status, detail=detail, failed_step=failed,
        meta=RunMeta(steps_run=(failed - 1) if failed else steps, params=dict(scene.values)),
    )


def run_engine_loop(model: Model, scene: Scene, method: str, dt: float, steps: int,
                    every: int = 1) -> Trajectory | None:
    """The run through the engine's own loop (``model.run``), recorded as :func:`drive` records;
    None where the engine reported trouble or an output state diverged (the caller replays the
    run with :func:`drive`, which finds the step). A state that diverges and comes back within
    one output interval would be missed: blow-ups do not come back, and MuJoCo warns at the step
    after any state beyond 1e10."""
    q, v = model.state()
    if diverged(q, v):
        return None
    marks = output_marks(steps, every)
    states, clean = model.run(marks)
    if not clean or len(states) != len(marks) - 1:
        return None
    rec = {0: (q, v), **{int(n): s for n, s in zip(marks[1:], states)}}
    rec_step, rec_q, rec_v = [], [], []

    def record(n):
        rec_step.append(n)
        rec_q.append(rec[n][0])
        rec_v.append(rec[n][1])

    # The engine's loop ran to the end; the rule reads its states at the marks and stops at the
    # first diverged one (then the caller replays the run step by step to find the step), unless
    # the model's run asked that of every mark already.
    def check(n):
        return divergence_detail(n, n * dt) if diverged(*rec[n]) else ""

    failed, _ = step_loop(lambda a, b: None, (lambda n: "") if model.run_checks_divergence else check,
                          record, steps, every, spans=True)
    if failed:
        return None
    traj = _trajectory(scene, method, dt, steps, every, rec_step, np.array(rec_q), np.array(rec_v))
    traj.meta.loop = "engine: the engine's own loop between output points, state read at output points only"
    return traj


def run_by_steps(model, marks: np.ndarray) -> tuple[list[tuple[np.ndarray, np.ndarray]], bool]:
    """``Model.run`` for an engine stepped by ``model.steps(n)`` (n steps through the engine's own
    loop, nothing read in between): the state at each mark, stopping at the first diverged one
    (``step_loop``'s spans, the caller replaying a failed run)."""
    out = []

    def advance(a, b):
        model.steps(b - a)
        out.append(model.state())

    def check(n):
        return model.trouble() or ("diverged" if diverged(*out[-1]) else "")

    failed, _ = step_loop(advance, check, lambda n: None, int(marks[-1]), 1, spans=True, marks=marks)
    return out, failed is None


def chain_force(k: float, c: float, x: np.ndarray, velocities: Callable[[], np.ndarray]) -> np.ndarray:
    """The chain's force from Python, k (x_{i-1} - 2 x_i + x_{i+1}) with the walls at 0, plus the
    dashpots' c (v_{i-1} - 2 v_i + v_{i+1}) where c != 0 (only then are the velocities read),
    in the one order of operations every adapter that applies it keeps."""
    f = (-2.0 * k) * x
    f[1:] += k * x[:-1]
    f[:-1] += k * x[1:]
    if c != 0.0:
        v = velocities()
        g = (-2.0 * c) * v
        g[1:] += c * v[:-1]
        g[:-1] += c * v[1:]
        f = f + g
    return f


def unwrap(previous: float, angle: float) -> float:
    """``angle`` plus the whole turns that bring it nearest ``previous``: a continuous angle from
    an engine that reports it modulo 2 pi. An angle already continuous is returned untouched."""
    turns = round((previous - angle) / (2.0 * math.pi))
    return angle + turns * (2.0 * math.pi) if turns else angle
