"""Running a contact mode on a contact scene: validated first (the mode, the scene and its
parameters, the step; one line naming the bad field), then in a worker process, so that a crash,
a hang or a blow-up is a recorded run (``crashed`` / ``timed_out`` / ``unstable``, with where and
why), never a dead harness. A mode whose settings are process-wide (``ContactMode.own_process``)
gets a fresh worker for every run; the others may share the caller's (a nightly task's worker)."""

from __future__ import annotations

import math

from records import InvalidInput
from records.contact import REPORT_DTS, ContactTrajectory  # noqa: F401 (the steps every mode is reported at)
from records.trajectory import CRASHED, TIMED_OUT

#: The ladder of steps each mode's largest step in tolerance is searched on (s).
LADDER = (1 / 3840, 1 / 1920, 1 / 1000, 1 / 960, 1 / 480, 1 / 240, 1 / 120, 1 / 60, 1 / 30)

#: Seconds one run may take.
TIMEOUT_S = 120.0


def contact_modes() -> dict:
    from adapters import CONTACT_MODES

    return CONTACT_MODES


def get_mode(mode_id: str):
    modes = contact_modes()
    try:
        return modes[mode_id]
    except KeyError:
        raise InvalidInput(f"unknown contact mode {mode_id!r} (valid: {', '.join(modes)})") from None


def check_dt(dt) -> float:
    try:
        x = float(dt)
    except (TypeError, ValueError):
        raise InvalidInput(f"dt={dt!r} is not a number (allowed: (0, 0.1] s)") from None
    if not (math.isfinite(x) and 0.0 < x <= 0.1):
        raise InvalidInput(f"dt={dt} is out of range (allowed: (0, 0.1] s)")
    return x


def _step_in_worker(mode_id: str, scene_id: str, params: dict, dt: float, plugins: tuple = ()) -> ContactTrajectory:
    """The run, where it steps (a worker has the plugin modules of its caller loaded first: a
    contact scene or pose a plugin registers is known there too)."""
    from scenarios.contact import make_contact_scene

    if plugins:
        from harness.methods import load_plugins

        load_plugins(plugins)
    return get_mode(mode_id).run(get_mode(mode_id), make_contact_scene(scene_id, **params), dt)


def run_contact(
    mode_id: str,
    scene_id: str,
    params: dict | None = None,
    dt: float = 1 / 240,
    timeout: float = TIMEOUT_S,
    isolated: bool = True,
) -> ContactTrajectory:
    """One run, validated first; ``isolated`` False steps in this process unless the mode needs one
    of its own (a nightly task's worker is already isolated)."""
    from scenarios.contact import make_contact_scene

    mode = get_mode(mode_id)
    scene = make_contact_scene(scene_id, **(params or {}))
    dt = check_dt(dt)
    ok, why = mode.available()
    if not ok:
        raise InvalidInput(f"contact mode {mode_id} is unavailable: {why}")
    ok, why = mode.supports(scene)
    if not ok:
        raise InvalidInput(f"contact mode {mode_id} does not pose {scene.id}: {why}")
    from harness.methods import active_plugins

    args = (mode_id, scene.id, dict(scene.values), dt, active_plugins())
    if not isolated and not mode.own_process:
        try:
            return _step_in_worker(*args)
        except Exception as exc:  # an engine's exception is the run's result
            return ContactTrajectory.failed(scene.id, mode_id, dt, CRASHED, f"{type(exc).__name__}: {exc}")
    import multiprocessing

    if multiprocessing.current_process().daemon:  # a nightly pool's worker may start no worker of its own
        return _in_fork(args, timeout)
    from harness.execution.isolation import WorkerFailure, run_in_worker

    out = run_in_worker(_step_in_worker, args, timeout=timeout)
    if isinstance(out, WorkerFailure):
        status = TIMED_OUT if out.status == TIMED_OUT else CRASHED
        return ContactTrajectory.failed(scene.id, mode_id, dt, status, out.detail)
    return out


def _in_fork(args: tuple, timeout: float) -> ContactTrajectory:
    """The run in a child forked from this process (``os.fork``: a daemonic process, a nightly
    pool's worker, may start no ``multiprocessing`` worker of its own). The child inherits the
    engine as imported, never as run: this process steps no mode that needs a process of its
    own itself. It writes the run pickled to a file and exits; past ``timeout`` it is killed."""
    import os
    import pickle
    import signal
    import tempfile
    import time

    mode_id, scene_id, _, dt = args[:4]
    with tempfile.TemporaryDirectory(prefix="harness-contact-") as tmp:
        out = os.path.join(tmp, "run.pickle")
        pid = os.fork()
        if pid == 0:  # the child: never returns
            code = 0
            try:
                os.chdir(tmp)
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, 1)
                os.dup2(devnull, 2)
                try:
                    run = _step_in_worker(*args)
                except Exception as exc:  # the engine's exception is the run's result
                    run = ContactTrajectory.failed(scene_id, mode_id, dt, CRASHED, f"{type(exc).__name__}: {exc}")
                with open(out + ".tmp", "wb") as fh:
                    pickle.dump(run, fh)
                os.replace(out + ".tmp", out)
            except BaseException:
                code = 1
            finally:
                os._exit(code)
        deadline = time.monotonic() + timeout
        while True:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                break
            if time.monotonic() > deadline:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
                return ContactTrajectory.failed(
                    scene_id, mode_id, dt, TIMED_OUT, f"no result within {timeout:g} s; process killed"
                )
            time.sleep(0.002)
        if not os.path.exists(out):
            how = (
                f"killed by signal {os.WTERMSIG(status)}"
                if os.WIFSIGNALED(status)
                else f"exited {os.WEXITSTATUS(status)}"
            )
            return ContactTrajectory.failed(scene_id, mode_id, dt, CRASHED, f"the process {how} without a result")
        with open(out, "rb") as fh:
            return pickle.load(fh)
