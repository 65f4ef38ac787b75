"""The engine mode: one integrator mode of one engine as a ``records.Method``, usable wherever a
``ref:`` method is, every capability declared, and stepped through its adapter's ``build``.

An engine module (``adapters/mujoco/``, ...) provides ``build(engine_module, mode, scene, dt,
count=False)`` returning a model (``adapters._model``) and one :class:`EngineMode` per mode in
its ``METHODS``; ``simulate`` steps the model through one of the loops of ``adapters._loops`` and
records with the trajectory what ran: the engine, its release and the settings read back.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from collections.abc import Callable, Mapping

import numpy as np

from records import MethodId, Trajectory
from records.method import NO_BEHAVIOUR, Behaviour
from records.method_id import Option
from records.trajectory import diverged, divergence_detail
from scenarios import Scene

from ._engine import EngineVersions, engine_version, import_engine
from ._loops import drive, run_engine_loop
from ._model import declared


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
    #: What the mode was measured to do that its name does not say (``records.method.Behaviour``:
    #: the scheme it integrates on a scene, symplectic, ...), which the judge checks on every run.
    behaviour: Behaviour = field(default=NO_BEHAVIOUR, compare=False)

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

    def with_options(self, options: dict) -> EngineMode:
        """The same mode with ``options`` set (checked by the caller, ``harness.methods``); setting
        ``adaptive_with`` makes it adaptive."""
        merged = {**self.options, **options}
        return replace(
            self,
            options_set=tuple(sorted(merged.items())),
            adaptive=self.adaptive or (self.adaptive_with is not None and self.adaptive_with in merged),
        )

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
            return False, (
                f"{self.module} cannot be imported ({type(exc).__name__}: {exc}); "
                f"install it with: pip install 'integrator-harness[{self.engine}]'"
            )
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
        kind = "" if scene.kind == scene.id else f" as {scene.kind} (its parameters make it a kind of its own)"
        return False, self.unsupported.get(scene.kind, f"{self.id} has no model of scene {scene.id}{kind}")

    def compiled_twin(self) -> EngineMode:
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

    def simulate(
        self, scene: Scene, dt: float, steps: int, every: int = 1, *, loop: str = "engine", count: bool = False
    ) -> Trajectory:
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

    def timed_run(
        self, scene: Scene, dt: float, steps: int, now: Callable[[], float], loop: str = "engine"
    ) -> tuple[float, int | None]:
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
                    out.append(
                        (None, f"one step from {y.tolist()} ended unstable: {trouble or divergence_detail(1, dt)}")
                    )
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
        return {
            "id": self.id,
            "family": self.engine,
            "engine": self.engine,
            "mode": self.mode,
            "summary": self.summary,
            "engine_version": engine_version(self.dist),
            "engine_versions": str(self.versions) if self.versions else None,
            "settings": dict(self.settings),
            "supported_scenes": list(self.scenes),
            "adaptive": self.adaptive,
            "precision": self.precision,
            "doc": " ".join(self.doc.split()),
        }
