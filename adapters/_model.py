"""What an engine model is: the :class:`Model` protocol an adapter's ``build`` returns, and
:class:`EngineModel` / :class:`SteppedModel`, which declare its optional members with their
defaults so that the rest of the harness reads declarations and never probes.

A model is the minimal engine model of one scene, set to the scene's initial state, that
advances one step of ``dt`` at a time (or many, through the engine's own loop) and reports its
state in the scene's own coordinates (``adapters._loops`` turns it into a trajectory).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from records.trajectory import diverged, step_loop


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
