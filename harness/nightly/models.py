"""Model files in the nightly and in ``harness model``: each file's variants are scenes of the
suite (``SceneSpec.source``), measured by the same cells as every built-in scene and stored under
their own ids, which carry the file's content hash: an edited model is a new series.

A model's study is fixed in its own units: the nominal timestep is the model's own
(``opt.timestep`` in the file), the energy run MODEL_ENERGY_STEPS of it, the stability search
up to MODEL_STABILITY_FACTOR times it, its finite horizon MODEL_STABILITY_STEPS steps. The
conservative variant (what dissipates or injects energy off, every conservative term kept:
``scenarios.model``) is where energy means something; the advice, where asked for, is given on it.

The models a project checks every night are listed in its ``pyproject.toml``::

    [tool.harness]
    models = ["robots/arm.urdf", "characters/ragdoll.xml"]

(paths relative to the ``pyproject.toml``), and ``harness nightly --model PATH`` adds more.
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import replace
from pathlib import Path

from adapters import ENGINES
from records import InvalidInput
from scenarios import VARIANTS, ModelScene, open_model, variant

from harness.nightly.suites import SceneExtras, SceneSpec, Suite

MODEL_ENERGY_STEPS = 2000
MODEL_STABILITY_FACTOR = 1024.0
MODEL_STABILITY_STEPS = 1000
#: The stability search starts this many times below the model's own timestep, and bisects to
#: this relative width (1e-4: a limit to 0.01%, where the built-in scenes' 1e-6 takes 7 more runs).
MODEL_STABILITY_BELOW = 64.0
MODEL_STABILITY_RTOL = 1e-4
#: The engines that load a model file (those whose ``Engine`` names a ``model_loader``).
MODEL_ENGINES = tuple(e.id for e in ENGINES.values() if e.model_loader)
#: The engines whose loaders step a model file without its contacts (``Engine.loader_without_contact``:
#: Drake's parser builds no SceneGraph collision geometry here, Newton's runs with contacts off): a
#: variant that keeps contacts is not theirs to run, so no row of theirs sits beside a contact run of
#: MuJoCo's.
WITHOUT_CONTACT = {e.id: e.loader_without_contact for e in ENGINES.values() if e.loader_without_contact}
#: The modes the cross-engine cells step from the same state: MuJoCo's first, each other one
#: compared with it where its engine loads the file (a cell each).
CROSS_ENGINE = ("mujoco:euler", "pybullet:semi_implicit", "drake:semi_explicit_euler", "newton:featherstone")
#: The modes a model file runs in unless ``harness model --methods`` names others: every mode of an
#: engine not listed here, and of Drake those that answer a model's questions (semi-explicit Euler,
#: its cross-engine mode; RK3, Drake's own default; Radau IIA; the discrete plant under SAP). The
#: other ten add a plant stepped in microseconds each to every cell of every variant.
MODEL_MODES = {"drake": ("drake:semi_explicit_euler", "drake:runge_kutta3", "drake:radau3", "drake:discrete_sap")}
#: The advice's horizon on a model, in the model's own timesteps.
MODEL_ADVICE_STEPS = 600


def model_scenes(path, variants=tuple(VARIANTS), keep=(), off=(), **params) -> list[ModelScene]:
    """The file's variants as scenes (each checked: InvalidInput before anything runs); ``keep``:
    features the conservative variant leaves on, ``off``: features every variant switches off."""
    base = open_model(path, **params)
    return [variant(base, name, keep, off) for name in variants]


def _loads_in_worker(method_id: str, scenes: list) -> list[str]:
    """Why ``method_id`` cannot build each of ``scenes`` ("" where it can), in one process."""
    from harness.methods import get_method

    out = []
    for scene in scenes:
        try:
            get_method(method_id).anatomy(scene, scene.own_timestep)
        except Exception as exc:  # the engine's own error, whatever its type: one line says why
            out.append(" ".join((str(exc) or type(exc).__name__).split()))
        else:
            out.append("")
    return out


def _keeps_contact(scene) -> bool:
    found = getattr(scene, "found", {})
    return "contact" in found and scene.values.get("contact", 0) == 1


def cannot_load_all(scenes: list, engines=MODEL_ENGINES) -> list[dict[str, str]]:
    """For each scene, {engine: why} for each of ``engines`` (MODEL_ENGINES') that cannot build it (its
    loader's own message). Each engine tries every scene in one worker process (an engine's import
    is most of its cost: Newton's and Drake's take seconds); where that worker fails (a loader
    crashed or hung), each scene is tried in a worker of its own, so a crash costs nothing but
    the line of the scene that caused it."""
    from harness.execution import isolation
    from harness.methods import all_methods

    out = [{} for _ in scenes]
    for engine in engines:
        skip = set()
        if engine in WITHOUT_CONTACT:
            for i, scene in enumerate(scenes):
                if _keeps_contact(scene):
                    out[i][engine] = (
                        f"it would step the file without its contacts ({scene.found['contact']}: "
                        f"{WITHOUT_CONTACT[engine]}); never compared with a contact run, it runs on "
                        f"the conservative variant, contacts off in every engine"
                    )
                    skip.add(i)
        # The engine's first mode that poses a model file (Newton's particle solvers do not).
        posed = [
            (
                i,
                scene,
                next(
                    (m for mid, m in all_methods().items() if mid.startswith(f"{engine}:") and m.supports(scene)[0]),
                    None,
                ),
            )
            for i, scene in enumerate(scenes)
            if i not in skip
        ]
        posed = [(i, scene, mode) for i, scene, mode in posed if mode is not None and mode.available()[0]]
        by_mode: dict[str, list] = {}
        for i, scene, mode in posed:
            by_mode.setdefault(mode.id, []).append((i, scene))
        for mode_id, group in by_mode.items():
            whys = isolation.run_in_worker(
                _loads_in_worker, (mode_id, [scene for _, scene in group]), timeout=120.0 * len(group)
            )
            if isinstance(whys, isolation.WorkerFailure):
                whys = []
                for _, scene in group:
                    why = isolation.run_in_worker(_loads_in_worker, (mode_id, [scene]), timeout=120.0)
                    whys.append(
                        f"the loader {why.status}: {why.detail}" if isinstance(why, isolation.WorkerFailure) else why[0]
                    )
            for (i, _), why in zip(group, whys):
                if why:
                    out[i][engine] = why
    return out


def model_specs(
    path, variants=tuple(VARIANTS), advise: dict | None = None, keep=(), off=(), engines=MODEL_ENGINES, **params
) -> dict[str, SceneSpec]:
    """{scene id: its spec} for the file's variants. ``advise`` (Request fields but hz) asks for
    the advice on the conservative variant. The loader of each of ``engines`` (the engines a run
    steps the file in) is tried first (``cannot_load_all``); an engine the run does not step is
    neither tried nor compared."""
    specs = {}
    scenes = model_scenes(path, variants, keep, off, **params)
    for scene, unloaded in zip(scenes, cannot_load_all(scenes, engines)):
        dt = scene.own_timestep
        loaded = tuple(m for m in CROSS_ENGINE if m.split(":")[0] in engines and m.split(":")[0] not in unloaded)
        both = scene.conservative and len(loaded) > 1 and loaded[0] == CROSS_ENGINE[0]
        specs[scene.id] = SceneSpec(
            params=dict(scene.values),
            dt=dt,
            horizon=dt * MODEL_ENERGY_STEPS,
            stability_hi=dt * scene.omega * MODEL_STABILITY_FACTOR,
            stability_steps=MODEL_STABILITY_STEPS,
            stability_lo=dt * scene.omega / MODEL_STABILITY_BELOW,
            stability_rtol=MODEL_STABILITY_RTOL,
            advise=advise if advise is not None and scene.conservative else None,
            source=scene.file.path,
            cannot_load=unloaded,
            extras=SceneExtras(cross_engine=loaded if both else ()),
        )
    return specs


def engine_modes(patterns=None) -> tuple[str, ...]:
    """The engine modes that run a model, in MODEL_ENGINES' reverse order (a run with no history
    to schedule by starts with the engine listed last): those matching ``patterns`` (fnmatch,
    ``drake:*``), else MODEL_MODES' choice. A pattern that matches no model engine's mode is bad
    input, named with the valid ones."""
    import fnmatch

    from harness.methods import all_methods

    modes = [mid for engine in reversed(MODEL_ENGINES) for mid in all_methods() if mid.split(":", 1)[0] == engine]
    if not patterns:
        return tuple(m for m in modes if m.split(":", 1)[0] not in MODEL_MODES or m in MODEL_MODES[m.split(":", 1)[0]])
    chosen = []
    for pat in patterns:
        hit = [m for m in modes if fnmatch.fnmatchcase(m, pat)]
        if not hit:
            raise InvalidInput(
                f"--methods pattern {pat!r} matches no mode of an engine that loads model files "
                f"(valid: {', '.join(modes)}, or a pattern such as drake:*)"
            )
        chosen += hit
    return tuple(dict.fromkeys(chosen))


def engines_of(method_ids) -> tuple[str, ...]:
    """The model engines (MODEL_ENGINES' order) that these method ids step."""
    families = {m.split(":", 1)[0] for m in method_ids}
    return tuple(e for e in MODEL_ENGINES if e in families)


def with_models(suite: Suite, paths, **params) -> Suite:
    """``suite`` with the files' variants added as scenes (engine modes only run them: a
    reference scheme has no force kernel to step on a model); the loaders tried are those of the
    engines the suite runs (every model engine where it names no methods)."""
    scenes = dict(suite.scenes)
    engines = MODEL_ENGINES if suite.methods is None else engines_of(suite.methods)
    for path in paths:
        for sid, spec in model_specs(path, engines=engines, **params).items():
            scenes[sid] = replace(spec, methods=engine_modes())
    return replace(suite, scenes=scenes)


def model_suite(
    paths, variants=tuple(VARIANTS), advise: dict | None = None, frame_rates=(), keep=(), off=(), methods=None, **params
) -> Suite:
    """The suite ``harness model`` runs: the files' variants in the engine modes that load them
    (``engine_modes(methods)``)."""
    frame_rates = tuple(frame_rates) if advise is not None else ()
    modes = engine_modes(methods)  # a bad pattern is refused before any engine loads the file
    engines = engines_of(modes)
    scenes = {}
    for path in paths:
        scenes.update(model_specs(path, variants, advise if frame_rates else None, keep, off, engines, **params))
    return Suite(
        "model", scenes, methods=modes, cost_repeats=3, bounds=False, identify=False, frame_rates=tuple(frame_rates)
    )


def configured_models(pyproject: Path | str = "pyproject.toml") -> list[str]:
    """The model files ``[tool.harness] models`` lists (relative to the file), or none."""
    pyproject = Path(pyproject)
    if not pyproject.is_file():
        return []
    try:
        data = tomllib.loads(pyproject.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise InvalidInput(f"{pyproject}: [tool.harness] cannot be read ({exc})") from None
    tool = data["tool"] if "tool" in data else {}
    section = tool["harness"] if "harness" in tool else {}
    models = section["models"] if "models" in section else []
    if not isinstance(models, list) or not all(isinstance(m, str) for m in models):
        raise InvalidInput(f"{pyproject}: [tool.harness] models must be a list of file paths (got {models!r})")
    return [os.path.join(pyproject.parent, m) for m in models]
