"""What a nightly run will compile, known before it starts.

A reference scheme's pair (scheme, scene) has one compiled loop (``reference._kernels``), which its
cost cell times and its accuracy runs step wherever it computes the interpreted run's bits
(``reference.bitwise_why``). It compiles once per machine and source, then loads from the disk
cache under ``$HARNESS_CACHE``: a run after one on the same cache compiles nothing new.

``plan`` says, before the run, how many loops it will compile ("cold cache: about N kernels to
compile"): the loops of the reference tasks' pairs and of explicit Euler on every scene (each cost
cell's baseline, and the calibration's on the unit spring), timed whatever their bits, each counted
once where the cache lacks it. An engine task's identity cell steps a reference scheme's loop only
where the scheme survives its short interpreted screen (``harness.measures.identify``): the match
and the runner-up, found by running. The plan cannot know them beforehand, so it names them apart
("besides the loops of the identity candidates a screen keeps") and counts only the loops among
them already compiled as stepped. A screen is deterministic, so a second run on the same cache
keeps the same candidates and compiles nothing.
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
    screened: int = 0   # identity candidates whose loop is not compiled: compiled only where a screen keeps them

    def line(self) -> str:
        """The line the nightly prints before it starts."""
        if self.compile:
            what = (f"{'cold cache' if self.compile == self.loops else 'kernel cache'}: about {self.compile} "
                    f"kernels to compile (of the {self.loops} the run steps)")
        else:
            what = "kernel cache warm: nothing to compile"
        if self.screened:
            what += f", besides the loops of the identity candidates a screen keeps (of {self.screened})"
        return f"{what}; kernel cache {self.cache}"


def plan(tasks: list, suite) -> KernelPlan:
    """What a run of ``tasks`` in ``suite`` will compile."""
    import reference

    from harness.measures.identify import candidate_methods
    from harness.nightly.cells import identifies

    to_compile: dict[str, bool] = {}  # kernel file -> its loop is to compile
    screened: set[str] = set()        # identity candidates' kernel files not compiled yet
    baseline = reference.RefMethod(reference.METHODS[BASELINE])
    scenes: dict[tuple, object] = {}

    def scene_of(task):
        key = (task.scene, task.source, tuple(sorted((task.params or {}).items())))
        if key not in scenes:
            scenes[key] = make_scene(task.scene, source=task.source, **(task.params or {}))
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
        if baseline.supports(scene)[0]:  # explicit Euler cannot pose a constrained scene: no ratio there
            need(baseline.scheme, scene)
        if task.family == "ref":
            need(reference.METHODS[scheme_name(task.method)], scene)
        elif identifies(suite, scene, task.family):
            for ref in candidate_methods(scene).values():
                if not reference.bitwise_why(ref.scheme, scene):
                    loop = reference.cache_state(ref.scheme, scene)
                    if loop.compiled:
                        to_compile.setdefault(loop.name, False)
                    else:
                        screened.add(loop.name)
    if to_compile:
        need(baseline.scheme, make_scene("spring"))  # the calibration's loop
    return KernelPlan(sum(to_compile.values()), str(reference.kernel_cache_dir()), len(to_compile),
                      len(screened - to_compile.keys()))
