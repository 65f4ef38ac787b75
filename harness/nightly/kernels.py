"""What a nightly run will compile, known before it starts.

A reference scheme's pair (scheme, scene) has one compiled loop (``reference._kernels``), which its
cost cell times and its accuracy runs step wherever it computes the interpreted run's bits
(``reference.bitwise_why``). It compiles once per machine and source, then loads from the disk
cache under ``$HARNESS_CACHE``: a run after one on the same cache compiles nothing new.

``plan`` says, before the run, how many loops it will compile ("cold cache: about N kernels to
compile"): the loops of the reference tasks' pairs and of explicit Euler on every scene (each cost
cell's baseline, and the calibration's on the unit spring), timed whatever their bits, each counted
once where the cache lacks it. An engine task's identity cell compiles nothing: its candidates step
their loops where the cache holds them and are interpreted elsewhere (``harness.measures.identify``),
the same bits either way, and their runs are kept on disk, so a second run steps none of them.
"""

from __future__ import annotations

from dataclasses import dataclass

from records.method_id import scheme_name
from scenarios import make_scene

BASELINE = "explicit_euler"


@dataclass(frozen=True)
class KernelPlan:
    """The loops a run will compile (``compile``) of those it steps (``loops``), and the cache's folder."""

    compile: int = 0
    cache: str = ""
    loops: int = 0

    def line(self) -> str:
        """The line the nightly prints before it starts."""
        if self.compile:
            what = (
                f"{'cold cache' if self.compile == self.loops else 'kernel cache'}: about {self.compile} "
                f"kernels to compile (of the {self.loops} the run steps)"
            )
        else:
            what = "kernel cache warm: nothing to compile"
        return f"{what}; kernel cache {self.cache}"


def plan(tasks: list, suite) -> KernelPlan:
    """What a run of ``tasks`` in ``suite`` will compile."""
    import reference

    to_compile: dict[str, bool] = {}  # kernel file -> its loop is to compile
    baseline = reference.RefMethod(reference.METHODS[BASELINE])
    scenes: dict[tuple, object] = {}

    def scene_of(task):
        sid = getattr(task, "scene_id", None) or task.scene
        key = (sid, task.source, tuple(sorted((task.params or {}).items())))
        if key not in scenes:
            scenes[key] = make_scene(sid, source=task.source, **(task.params or {}))
        return scenes[key]

    def need(scheme, scene):
        loop = reference.cache_state(scheme, scene)
        to_compile.setdefault(loop.name, not loop.compiled)

    for task in tasks:
        if task.kind != "cell":
            continue
        scene = scene_of(task)
        if not scene.has_kernels:  # a model file: only its engines step it, nothing compiles
            continue
        # The baseline is the cost cell's: a task of one other measure (the penalty table) times none.
        timed = not getattr(task, "only", ()) or "cost" in task.only
        if timed and baseline.supports(scene)[0]:  # explicit Euler cannot pose a constrained scene: no ratio there
            need(baseline.scheme, scene)
        if task.family == "ref":
            need(reference.METHODS[scheme_name(task.method)], scene)
    if to_compile:
        need(baseline.scheme, make_scene("spring"))  # the calibration's loop
    return KernelPlan(sum(to_compile.values()), str(reference.kernel_cache_dir()), len(to_compile))
