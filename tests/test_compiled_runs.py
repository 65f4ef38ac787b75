"""The accuracy runs on a pair's compiled loop (``reference.integrate_compiled``, the loop its
timings time too): the interpreted run's bits wherever ``reference.bitwise_why`` finds nothing,
and its counts, declared by the scheme where they are fixed.

The nightly measures reference schemes' accuracy on it; every number it stores must be the one
the interpreted driver (the specification, and the counting truth) gives. The default run checks
a pair of each kind (explicit, multi-step start, implicit with Newton, constrained, decay, a libm
call, a scene with coupled DOF, a scheme compiled as its velocity-free twin); the ``slow`` test
checks every pair of every scene.
"""

from __future__ import annotations

import dataclasses

import ast
import json

import numpy as np
import pytest

from reference import METHODS, RefMethod, bitwise_why, integrate, integrate_compiled
from reference import _bitwise, _counts, _libm
from scenarios import SCENES, make_scene
from scenarios.spring import Spring

SIZES = {"chain": {"N": 8}, "rope": {"N": 5}, "cloth": {"n": 3, "m": 3}, "net": {"n": 3, "m": 3}}


def assert_same_run(a, b):
    """``b`` (compiled) is the interpreted run ``a``: the same states, stop and recording, bit
    for bit, and the same counts where ``b`` has them (declared); where they vary, none, and why."""
    assert a.status == b.status and a.failed_step == b.failed_step and a.detail == b.detail
    assert np.array_equal(a.step, b.step) and a.t.tobytes() == b.t.tobytes()
    assert a.q.shape == b.q.shape and a.q.tobytes() == b.q.tobytes()
    assert a.v.tobytes() == b.v.tobytes()
    assert a.energy.tobytes() == b.energy.tobytes()
    assert (a.meta.backend, b.meta.backend) == ("interpreted", "compiled")
    if b.force_evals is None:
        assert b.solves is None and b.meta.force_evals_reason == _counts.VARYING
        b = dataclasses.replace(
            b,
            force_evals=a.force_evals,
            solves=a.solves,
            meta=dataclasses.replace(b.meta, projections=a.meta.projections, force_evals_reason=None),
        )
    assert (a.force_evals, a.solves) == (b.force_evals, b.solves)
    assert dataclasses.replace(a.meta, backend=None) == dataclasses.replace(b.meta, backend=None)


def check_pair(scheme_id: str, scene_id: str):
    scheme, scene = METHODS[scheme_id], make_scene(scene_id, **SIZES.get(scene_id, {}))
    assert bitwise_why(scheme, scene) == ""
    # A stable run recorded every 7 steps (and the last), and one past the stability limit
    # (explicit schemes blow up: the same failing step), recorded every step.
    for homega, steps, every in ((0.1, 300, 7), (3.5, 150, 1)):
        dt = homega / scene.omega
        assert_same_run(
            integrate(scheme, scene, dt, steps, every),
            integrate_compiled(scheme, scene, dt, steps, every, counted=True),
        )


@pytest.mark.parametrize(
    "scheme_id, scene_id",
    [
        ("explicit_euler", "spring"),  # blows up at h*omega = 3.5: the failing step and counts agree
        ("verlet", "kepler"),  # a start-up evaluation, counted apart
        ("implicit_euler", "kepler"),  # Newton to tolerance: counts that vary, not taken from the loop
        ("rk4", "pendulum"),  # np.sin, a libm call
        ("position_first_euler_decay_after_kick", "damped_spring"),  # math.exp of the damping rate
        ("implicit_midpoint", "chain"),  # coupled DOF, the scene's own tridiagonal solve
        ("verlet_constrained", "rope"),  # projections, declared
        ("semi_implicit_euler_velocity_implicit", "pendulum"),  # compiled as semi-implicit Euler: two passes a step
    ],
)
def test_the_compiled_run_is_the_interpreted_run(scheme_id, scene_id):
    check_pair(scheme_id, scene_id)


def test_the_compiled_run_from_a_given_state_time_and_batch():
    scheme, scene = METHODS["leapfrog"], make_scene("kepler")
    q0 = np.array([[0.5, 0.1], [0.7, -0.2]])
    v0 = np.array([[0.0, 1.2], [0.1, 1.0]])
    a = integrate(scheme, scene, 0.01, 50, 4, q0=q0, v0=v0, t0=3.0)
    b = integrate_compiled(scheme, scene, 0.01, 50, 4, q0=q0, v0=v0, t0=3.0, counted=True)
    assert_same_run(a, b)
    assert b.q.shape == (14, 2, 2) and b.t[0] == 3.0


@pytest.mark.slow
@pytest.mark.parametrize("scene_id", sorted(SCENES))
def test_every_bitwise_pair_is_the_interpreted_run(scene_id):
    scene = make_scene(scene_id, **SIZES.get(scene_id, {}))
    for scheme_id, scheme in METHODS.items():
        if RefMethod(scheme).supports(scene)[0] and not bitwise_why(scheme, scene):
            check_pair(scheme_id, scene_id)


@pytest.mark.parametrize("scene_id", sorted(SCENES))
def test_declared_counts_are_the_interpreted_counts(scene_id):
    """Every pair of the scene: where the kind declares a step's force evaluations, solves and
    projections (``Kind.step_counts``), they are what the interpreted driver counts over a few
    steps (and the start's, counted apart, too); where it declares none, the step is an implicit
    one that may take more than one Newton pass. Nothing is compiled: the counts are the
    declaration's and the interpreted start's."""
    scene = make_scene(scene_id, **SIZES.get(scene_id, {}))
    if not scene.has_kernels:
        pytest.skip(f"{scene_id} has no force kernel for a reference scheme")
    steps, dt = 3, 0.1 / scene.omega
    for scheme_id, scheme in METHODS.items():
        if not RefMethod(scheme).supports(scene)[0]:
            continue
        per_step = _counts.step_counts(scheme, scene)
        if per_step is None:
            assert scheme.implicit and scheme.kind.count(scheme, scene) > 1, scheme_id
            continue
        a = integrate(scheme, scene, dt, steps)
        assert a.ok, scheme_id
        declared = _counts.of_run(scheme, scene, steps)
        projections = a.meta.projections if a.meta.projections is not None else 0
        assert (declared.force_evals, declared.solves, declared.projections) == (
            a.force_evals,
            a.solves,
            projections,
        ), scheme_id
        q, v = (np.ascontiguousarray(np.atleast_2d(x).T) for x in scene.batch_state(1))
        assert _counts.start_evaluations(scheme, scene, q, v, 0.0, dt) == a.meta.start_force_evals, scheme_id


def test_varying_counts_come_from_an_interpreted_counting_run():
    """Implicit Euler on Kepler: Newton's passes vary (two to fifty a step), so the run on the
    compiled loop has none, and the cost measure's counting run, interpreted, counts them."""
    from harness.measures.cost import counted_evaluations

    scheme, scene = METHODS["implicit_euler"], make_scene("kepler")
    dt = 0.1 / scene.omega
    method = RefMethod(scheme, compiled_where_bitwise=True)
    assert method.counting_run
    run = method.simulate(scene, dt, 100)
    assert run.meta.backend == "compiled" and run.force_evals is None
    truth = integrate(scheme, scene, dt, 100)
    counted = method.simulate(scene, dt, 100, count=True)
    assert counted.meta.backend == "interpreted" and counted.force_evals == truth.force_evals
    figures = counted_evaluations(method, scene, dt, steps=100)
    assert figures["force_evals_per_step"] == truth.force_evals / 100
    assert figures["solves_per_step"] == truth.solves / 100


def cubic_accel(q, v, t, p):
    return -(q**3)


class CubicSpring(Spring):
    """A spring whose force is written with ``**``: numpy's pow, numba's repeated products."""

    id = "cubic_spring"
    accel = staticmethod(cubic_accel)


def test_a_pair_that_might_compute_other_bits_is_interpreted():
    scene = CubicSpring()
    assert bitwise_why(METHODS["leapfrog"], scene).endswith("cubic_accel: uses **")
    method = RefMethod(METHODS["leapfrog"], compiled_where_bitwise=True)
    assert method.simulate(scene, 0.1, 3).meta.backend == "interpreted"
    assert method.simulate(make_scene("spring"), 0.1, 3).meta.backend == "compiled"
    # The backend is the method's, stated where it is made: a RefMethod without it interprets.
    assert RefMethod(METHODS["leapfrog"]).simulate(make_scene("spring"), 0.1, 3).meta.backend == "interpreted"


def test_a_library_solve_is_bitwise_where_the_builds_agree():
    # The solar system's implicit solve calls LAPACK (np.linalg.solve): the same bits where numba's
    # build and numpy's agree on this machine (checked), interpreted where they do not.
    why = bitwise_why(METHODS["implicit_midpoint"], make_scene("solar_system"))
    assert why == (
        ""
        if _libm.agrees("np.linalg.solve")
        else "numba's np.linalg.solve gives other bits than numpy's on this machine"
    )
    if not why:
        check_pair("implicit_midpoint", "solar_system")


def test_a_scene_overriding_its_force_on_the_instance_is_interpreted():
    scene = make_scene("spring")
    scene.accel = lambda q, v, t, p: -2.0 * q
    assert "overrides its accel" in bitwise_why(METHODS["leapfrog"], scene)
    method = RefMethod(METHODS["leapfrog"], compiled_where_bitwise=True)
    assert method.simulate(scene, 0.1, 5).meta.backend == "interpreted"


def test_the_pointwise_loop_is_bitwise_for_newton_on_one_entry_or_one_pass():
    """The pointwise loop ends each entry's Newton iteration on that entry's update, the
    interpreted step on the largest over all: a batch of pendulums, which iterate, is
    interpreted; a batch of springs (one pass) and a single pendulum are not."""
    pendulum, spring = make_scene("pendulum"), make_scene("spring")
    two = np.array([[0.3], [1.0]])
    assert "Newton iteration" in bitwise_why(METHODS["implicit_euler"], pendulum, q0=two)
    assert bitwise_why(METHODS["implicit_euler"], pendulum) == ""
    assert bitwise_why(METHODS["implicit_euler"], spring, q0=two) == ""
    a = integrate(METHODS["implicit_euler"], spring, 0.1, 40, 3, q0=two, v0=np.zeros_like(two))
    b = integrate_compiled(METHODS["implicit_euler"], spring, 0.1, 40, 3, q0=two, v0=np.zeros_like(two), counted=True)
    assert_same_run(a, b)


def _why(src: str) -> tuple[str, set]:
    libm = set()
    return _bitwise.bitwise_why(ast.parse(src).body[0], {"np": "np", "math": "math"}, {"helper"}, libm), libm


@pytest.mark.parametrize(
    "body, why",
    [
        ("return np.sqrt(q * q + 1.0) / abs(p[0])", ""),
        ("a = np.empty_like(q)\n    a[0] = helper(q)[0]\n    return a.copy()", ""),
        ("return np.sum(q)", "calls np.sum"),
        ("return q @ q", "uses @"),
        ("return q ** 3", "uses **"),
        ("x = q\n    x **= 2\n    return x", "uses **"),
        ("return np.linalg.inv(q)", "calls np.linalg.inv"),
        ("return q.dot(v)", "calls q.dot"),
        ("return sum(q)", "calls sum"),
    ],
)
def test_bitwise_operations(body, why):
    assert _why(f"def f(q, v, t, p):\n    {body}\n")[0] == why


def test_bitwise_operations_record_the_libm_calls():
    why, libm = _why("def f(q, v, t, p):\n    return np.sin(q) * math.exp(-p[0]) + np.linalg.solve(q, v)\n")
    assert why == "" and libm == {"np.sin", "math.exp", "np.linalg.solve"}


def test_libm_check_sees_a_one_ulp_difference(monkeypatch, tmp_path):
    monkeypatch.setenv("HARNESS_CACHE", str(tmp_path))  # no answer kept from an earlier process
    _libm.agrees.cache_clear()
    try:
        assert _libm.agrees("np.sin")
        real = _libm._compiled

        def off_by_one_ulp(name):
            f = real(name)
            return lambda x: np.nextafter(f(x), np.inf) if name == "np.sin" else f(x)

        monkeypatch.setattr(_libm, "_compiled", off_by_one_ulp)
        _libm.agrees.cache_clear()
        assert _libm.agrees("np.sin")  # the answer kept on disk for this machine, read
        monkeypatch.setenv("HARNESS_CACHE", str(tmp_path / "other"))
        _libm.agrees.cache_clear()
        assert not _libm.agrees("np.sin")  # checked afresh
        assert _libm.agrees("math.exp")
        assert json.loads(next((tmp_path / "other" / "kernels").glob("libm-*.json")).read_text()) == {
            "np.sin": False,
            "math.exp": True,
        }
    finally:
        _libm.agrees.cache_clear()


def test_identity_reuses_candidate_runs(monkeypatch, tmp_path):
    from harness.measures import identify as ident

    monkeypatch.setenv("HARNESS_CACHE", str(tmp_path))  # no candidate run stored on disk before
    ident._CANDIDATES.clear()
    calls = []
    real = RefMethod.simulate

    def counting(self, *args, **kwargs):
        calls.append(self.id)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(RefMethod, "simulate", counting)

    def in_full(res):  # the candidates run in full (the screen rules the others out in a few steps)
        return {c.method for c in res.candidates if c.steps == res.steps}

    scene = make_scene("spring")
    first = ident.identify("ref:semi_implicit_euler", scene, steps=50)
    assert len(calls) == 1 + len(in_full(first))
    before = len(calls)
    second = ident.identify("ref:leapfrog", scene, steps=50)
    # Only its own method and the candidates not run in full before are run (semi-implicit Euler,
    # the method before, was not a candidate then).
    assert sorted(calls[before:]) == sorted(["ref:leapfrog", *(in_full(second) - in_full(first))])
    assert len(second.candidates) == len(first.candidates)
    fresh = ident._CANDIDATES.clear() or ident.identify("ref:leapfrog", scene, steps=50)
    assert fresh.candidates == second.candidates
    before = len(calls)
    third = ident.identify("ref:leapfrog", make_scene("spring", k=2.0), steps=50)  # another scene: run afresh
    assert len(calls) - before == 1 + len(in_full(third))


def untimed(x):
    if isinstance(x, dict):
        return {k: untimed(v) for k, v in x.items() if "cost" not in k}
    if isinstance(x, list):
        return [untimed(v) for v in x]
    return x


def test_nightly_cells_are_the_same_compiled_and_interpreted(monkeypatch):
    from reference import method as ref_method

    from harness.nightly.cells import run_task
    from harness.nightly.run import Task
    from harness.nightly.suites import SUITES

    def measured(compiled: bool):
        if not compiled:  # every pair judged to compute other bits: every run interpreted
            monkeypatch.setattr(ref_method, "bitwise_why", lambda *args, **kwargs: "interpreted for the test")
        task = Task("cell", "spring", "ref:rk4", "ref", {}, SUITES["smoke"])
        cells = {}
        measured_cells = run_task(task)
        backends = {c.figures.backend for c in measured_cells if c.measure == "energy"}
        assert backends == {"compiled" if compiled else "interpreted"}
        for c in measured_cells:
            if c.measure == "cost":  # a timing: never equal run to run
                continue
            # The advice's cost per frame is this run's timing; the kernels and backend say how it ran.
            data = untimed({k: v for k, v in c.to_row()["data"].items() if k not in ("kernels", "backend")})
            cells[(c.measure, c.dt)] = (
                c.status,
                c.steps,
                c.value if c.measure != "advise" else None,
                repr(data),
                c.detail,
            )
        return cells

    assert measured(True) == measured(False)
