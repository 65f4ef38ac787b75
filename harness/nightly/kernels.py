"""What a nightly run will compile, known before it starts, and which counted loops are worth it.

A reference scheme's pair (scheme, scene) has two compiled loops (``reference._kernels``): the
timing loop ``advance_n``, which every cost cell needs (its figure is the compiled kernel's), and
the counted run, which only speeds up the accuracy runs (``reference.Exact``: the interpreted
bits, counted alike). Compiling a counted run costs about what interpreting one task's accuracy
runs costs (``reference._compiled.COUNTED_COMPILE_S``; an array scene's loop about three times a
pointwise one's); it pays off at once only where the task's runs are long, and otherwise only where
the disk cache keeps it for later runs. So a reference task whose pair is already in the disk
cache (the pair ran on this machine before and its cache was kept: a CI runner that restores
``$HARNESS_CACHE``, a developer's machine) compiles its counted run at once, as before; one whose
pair is new to the cache (the first run on a fresh machine, or a runner that keeps nothing)
interprets its accuracy runs, and compiles before the run that would bring what interpreting has
cost, with that run, to what compiling would (``reference.Exact.after_interpreting``: the
ski-rental rule, at most about twice the cheaper of the two, with the next run's cost predicted
from the pair's rate so far, so that one long run is not interpreted past the point). The next
run finds the pair in the cache and compiles what is left. The numbers are the same either way,
bit for bit.

``plan`` says, before the run, how many loops it will compile ("cold cache: about N kernels to
compile"): the timing loops of the reference tasks' pairs and of explicit Euler on every scene
(each cost cell's baseline, and the calibration's on the unit spring), and the counted runs the
tasks will compile, each counted once where the cache lacks it.

``command_backend`` is the same rule for a single-scene command (``harness stability``,
``identify``, ...), asked pair by pair as each first runs.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

from records.method_id import scheme_name
from scenarios import make_scene

BASELINE = "explicit_euler"


@dataclass(frozen=True)
class KernelPlan:
    """The loops a run will compile (``timing``, ``counted``), the reference tasks whose pair is
    new to the cache (their accuracy runs interpreted while that costs less than compiling would:
    their counted loops are not counted in ``counted``), and the cache's folder."""

    timing: int = 0
    counted: int = 0
    interpreted: int = 0
    cache: str = ""
    timing_loops: int = 0  # the timing loops the run needs, cached or not

    @property
    def kernels(self) -> int:
        return self.timing + self.counted

    def line(self) -> str:
        """The line the nightly prints before it starts."""
        if self.timing:
            what = (f"{'cold cache' if self.timing == self.timing_loops else 'kernel cache'}: about {self.kernels} "
                    f"kernels to compile ({self.timing} timing loops, {self.counted} counted accuracy loops)")
        elif self.counted:
            what = (f"kernel cache: {self.counted} counted accuracy loops to compile (their pairs ran here "
                    f"before), every timing loop cached")
        else:
            what = "kernel cache warm: nothing to compile"
        if self.interpreted:
            what += (f"; {self.interpreted} reference tasks new to the cache interpret their accuracy runs "
                     f"while that costs less than compiling would")
        return f"{what}; kernel cache {self.cache}"


def plan(tasks: list, suite) -> tuple[list, KernelPlan]:
    """The tasks, each reference task told whether to compile its counted run
    (``Task.compile_counted``), and what the run will compile (``KernelPlan``)."""
    import reference

    timing: dict[str, bool] = {}  # kernel file -> its timing loop is to compile
    baseline = reference.RefMethod(reference.METHODS[BASELINE])
    scenes: dict[tuple, object] = {}
    counted, interpreted, out = 0, 0, []

    def scene_of(task):
        key = (task.scene, task.source, tuple(sorted((task.params or {}).items())))
        if key not in scenes:
            scenes[key] = make_scene(task.scene, source=task.source, **(task.params or {}))
        return scenes[key]

    def state(scheme_id, scene):
        loop, run = reference.cache_state(reference.METHODS[scheme_id], scene)
        timing.setdefault(loop.name, not loop.timing)
        return run

    for task in tasks:
        if task.kind != "cell":
            out.append(task)
            continue
        scene = scene_of(task)
        if not scene.has_kernels:  # a model file: only its engines step it, nothing compiles
            out.append(task)
            continue
        if baseline.supports(scene)[0]:  # explicit Euler cannot pose a constrained scene: no ratio there
            state(BASELINE, scene)
        if task.family == "ref":
            own = state(scheme_name(task.method), scene)
            task = replace(task, compile_counted=own.file)
            if suite.exact_compiled and not suite.scenes[task.scene].compiled:
                interpreted += not own.file
                counted += own.file and not own.counted
        out.append(task)
    if timing:
        state(BASELINE, make_scene("spring"))  # the calibration's loop
    return out, KernelPlan(sum(timing.values()), counted, interpreted, str(reference.kernel_cache_dir()), len(timing))


#: Steps of the interpreted run that measures the rate of a command's pair new to the cache
#: (``reference.Exact.probe_steps``), fewer than a task's: a command steps schemes whose every
#: interpreted step solves a system the size of the scene (every implicit scheme on the
#: default cloth, in ``harness identify``), where the task's probe alone would cost more than
#: compiling does; four steps still spread the first call's own cost.
COMMAND_PROBE_STEPS = 4


def command_backend():
    """The reference backend of a single-scene command (``harness stability``, ``identify``,
    ...): the exact compiled run the nightly's cells take (``reference.Exact``: the interpreted
    bits, every force evaluation counted alike), by the rule of a nightly reference task (``plan``
    and ``cells.run_task``) for every scheme it steps: a pair the disk cache holds compiles (or
    loads) its counted run at once, one new to it is interpreted while that costs less than
    compiling would. The pairs are asked as they first run (a command does not know them all
    before it starts)."""
    import reference

    return reference.Exact(new_to_cache=True, probe_steps=COMMAND_PROBE_STEPS)
