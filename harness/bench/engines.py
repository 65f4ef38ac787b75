"""``harness bench --engines``: ns per step of each engine mode, timed as ``harness cost`` times it
(``engine s/step``, the engine's own loop), beside a bare loop of that engine's step call on the
same model, timed in the same process in interleaved repeats. A benchmark, not a test: the
target is met or MISSED, never asserted.

The rule:

* **Scene**: the one-spring scene (``spring``, dt = 0.01) for every mode that poses it; a mode
  that does not (REBOUND: Kepler, its one-body problem; pymunk's constraint modes: their first
  scene) runs its first scene in ``FALLBACK_SCENES`` order.
* **Harness figures**: ``engine s/step`` and ``as stepped by the harness``, both by
  :mod:`harness.measures.cost`'s rule ((min t(N) - min t(0)) / N of ``simulate``, model building not
  counted).
* **Bare loops** on a model the adapter built (the same engine settings, the same physics),
  nothing else in the loop, each engine's own (``adapters/<engine>/bench.py``, its
  ``Engine.bare_loops``): MuJoCo ``mujoco.rollout`` (one call, as a user writes it, the
  state array allocated and recorded) and a Python loop of ``mj_step``; REBOUND one
  ``sim.steps(N)`` (IAS15, adaptive, whose dt is the output interval: a loop of
  ``sim.integrate(k dt)``); pybullet a loop of ``stepSimulation``; pymunk a loop of ``space.step``
  (a mode's ``velocity_func`` runs inside it); Drake one ``Simulator.AdvanceTo(t + N dt)``; Newton a
  loop of ``clear_forces`` and ``solver.step`` with the two states swapped, as Newton's examples
  step (the adapter's own ``steps``: on the CPU Warp captures no graph, so no loop is less). Where
  the mode applies the scene's force from Python before every step (pybullet;
  ``pymunk:applied_force``), a second bare loop does just that and steps (``bare loop + force``):
  the least Python can do for that mode.
* **Steps**: N such that the bare loop runs about ``RUN_S`` (20 ms), at least ``MIN_STEPS`` where
  those take at most ``MAX_RUN_S`` (0.1 s);
  ``repeats`` (7) interleaved repeats (harness, bare, harness, bare, ...), minimum of each.
* **Clock**: the CPU time of this process (``time.process_time``), which other processes on a
  shared core do not inflate (everything here runs in one thread).
* **Target**: the engine figure within ``TARGET`` (1.3x) of the least loop that simulates the
  scene on that engine: the bare step loop (MuJoCo: ``mujoco.rollout``), or, for a mode whose
  force is set from Python before every step (pybullet, which has no spring; ``pymunk:applied_force``,
  which is that by definition), the ``bare loop + force``: a step-only loop there would simulate a
  body with no spring. The ratio to the step-only loop is printed beside it (``ratio_to_step_loop``):
  what the per-step Python force costs over the engine's step alone.
"""

from __future__ import annotations

import time

from scenarios import Scene, make_scene

from reference import CLOCKS

from harness.measures.cost import HARNESS_TIME_STEPS, _Timing

TARGET = 1.3
DT = 0.01
RUN_S = 0.02
MIN_STEPS = 20_000
#: A run of MIN_STEPS longer than this (a step dearer than MAX_RUN_S / MIN_STEPS: Drake's
#: continuous plants, Newton's Warp kernels launched from Python) is cut to this long, still five
#: times RUN_S.
MAX_RUN_S = 0.1
MAX_STEPS = 2_000_000
REPEATS = 7
FALLBACK_SCENES = ("spring", "kepler", "pendulum", "damped_spring", "chain")


def bench_scene(mode) -> Scene:
    """The scene a mode is benched on (module docstring)."""
    return make_scene(next((s for s in FALLBACK_SCENES if s in mode.scenes), sorted(mode.scenes)[0]))


CLOCK = "cpu"


class _Bare:
    """One bare loop on a model the adapter built: ``once(n)`` runs n steps."""

    def __init__(self, name: str, once, close):
        self.name, self.once, self.close, self.times = name, once, close, []

    def repeat(self, n: int) -> None:
        now = CLOCKS[CLOCK]
        t = now()
        self.once(n)
        self.times.append((now() - t) / n)


def _bare_loops(mode, scene: Scene) -> tuple[list[_Bare], str]:
    """The bare loops of ``mode`` (the first is the target's) and a line saying what they are: its
    engine's own (``adapters.Engine.bare_loops``), on a model the adapter built."""
    import adapters

    entry = adapters.ENGINES.get(mode.engine)
    if entry is None or entry.bare_loops is None:
        raise ValueError(f"no bare loop for engine {mode.engine}")
    engine, model = mode._model(scene, DT)
    try:
        loops, doc = entry.bare_loops(mode, engine, model, scene, DT)
    except BaseException:
        model.close()
        raise
    return [_Bare(name, once, model.close if i == 0 else _nothing) for i, (name, once) in enumerate(loops)], doc


def _nothing() -> None:
    pass


def bench_mode(mode, *, repeats: int = REPEATS) -> dict:
    """One mode's row (module docstring)."""
    scene = bench_scene(mode)
    bare, bare_doc = _bare_loops(mode, scene)
    try:
        pilot = 2_000
        for b in bare:
            b.once(pilot)  # warm-up
        t = time.perf_counter()
        bare[0].once(pilot)
        per = max((time.perf_counter() - t) / pilot, 1e-12)  # only sizes N
        n = int(min(MAX_STEPS, max(min(MIN_STEPS, MAX_RUN_S / per), RUN_S / per)))
        engine = _Timing(mode, scene, DT, n, CLOCK, "engine")
        stepped = _Timing(mode, scene, DT, min(n, HARNESS_TIME_STEPS), CLOCK, "harness")
        for _ in range(repeats):
            engine.repeat()
            for b in bare:
                b.repeat(n)
            stepped.repeat()
    finally:
        for b in bare:
            b.close()
    eng, st = engine.result(CLOCK), stepped.result(CLOCK)
    bare_ns = {b.name: min(b.times) * 1e9 for b in bare}
    target_loop = "bare loop + force" if "bare loop + force" in bare_ns else bare[0].name
    ratio = eng["s_per_step"] * 1e9 / bare_ns[target_loop]
    row = {
        "method": mode.id,
        "scene": scene.id,
        "dt": DT,
        "steps": engine.n,
        "repeats": repeats,
        "clock": CLOCK,
        "engine_ns_per_step": eng["s_per_step"] * 1e9,
        "engine_spread": eng["rel_spread"],
        "as_stepped_ns_per_step": st["s_per_step"] * 1e9,
        "as_stepped_steps": stepped.n,
        "bare_ns_per_step": bare_ns,
        "bare_loops": bare_doc,
        "engine_loop": eng.get("engine_loop"),
        "target_loop": target_loop,
        "ratio_to_bare": ratio,
        "target_ratio": TARGET,
        "meets_target": ratio <= TARGET,
    }
    if "mj_step loop" in bare_ns:
        row["ratio_to_mj_step_loop"] = eng["s_per_step"] * 1e9 / bare_ns["mj_step loop"]
    if target_loop != bare[0].name:
        row["ratio_to_step_loop"] = eng["s_per_step"] * 1e9 / bare_ns[bare[0].name]
    return row


def engine_modes(ids=None) -> list:
    """The available engine modes (all, or ``ids`` in order)."""
    import adapters

    modes = [adapters.ENGINE_METHODS[i] for i in ids] if ids else list(adapters.ENGINE_METHODS.values())
    return [m for m in modes if m.available()[0]]


def measure(ids=None, *, repeats: int = REPEATS) -> list[dict]:
    return [bench_mode(m, repeats=repeats) for m in engine_modes(ids)]


def lines(rows: list[dict]):
    yield (
        f"{'engine mode':24s} {'scene':7s} {'engine ns/step':>14s} {'bare loop ns/step':>34s} "
        f"{'ratio':>6s} {'as stepped':>11s}  target (<= {TARGET:g}x the loop that simulates the scene)"
    )
    for r in rows:
        bare = ", ".join(f"{k} {v:.0f}" for k, v in r["bare_ns_per_step"].items())
        verdict = "met" if r["meets_target"] else "MISSED"
        yield (
            f"{r['method']:24s} {r['scene']:7s} {r['engine_ns_per_step']:14.0f} {bare:>34s} "
            f"{r['ratio_to_bare']:6.2f} {r['as_stepped_ns_per_step']:11.0f}  {verdict}"
        )
        if r.get("ratio_to_step_loop") is not None:
            yield (
                f"{'':32s}judged against {r['target_loop']} (the force is set from Python each step); "
                f"{r['ratio_to_step_loop']:.2f}x the step-only loop"
            )
        if r.get("engine_loop"):
            yield f"{'':32s}the engine's loop: {r['engine_loop']}"
