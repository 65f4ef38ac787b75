"""The exact compiled run (``reference.integrate_exact``): the interpreted run's bits and counts.

The nightly measures reference schemes' accuracy on it; every number it stores must be the one
the interpreted driver gives. Each pair compiles its counted kernel once per machine (a few
seconds, then cached), so the default run checks a pair of each kind (explicit, multi-step start,
implicit with Newton, constrained, decay, a libm call, a scene with coupled DOF); the ``slow``
test checks every pair of every scene.
"""
from __future__ import annotations

import dataclasses

import ast
import math

import numpy as np
import pytest

import reference
from reference import METHODS, Exact, RefMethod, exact_why, integrate, integrate_exact
from reference import _codegen, _exactness, _libm
from scenarios import SCENES, make_scene
from scenarios.spring import Spring

SIZES = {"chain": {"N": 8}, "rope": {"N": 5}, "cloth": {"n": 3, "m": 3}, "net": {"n": 3, "m": 3}}


def assert_same_run(a, b):
    assert a.status == b.status and a.failed_step == b.failed_step and a.detail == b.detail
    assert np.array_equal(a.step, b.step) and np.array_equal(a.t, b.t)
    assert a.q.shape == b.q.shape and a.q.tobytes() == b.q.tobytes()
    assert a.v.tobytes() == b.v.tobytes()
    assert a.energy.tobytes() == b.energy.tobytes()
    assert (a.force_evals, a.solves) == (b.force_evals, b.solves)
    assert dataclasses.replace(a.meta, backend=None) == dataclasses.replace(b.meta, backend=None)
    assert (a.meta.backend, b.meta.backend) == ("interpreted", "compiled, counted")


def check_pair(scheme_id: str, scene_id: str):
    scheme, scene = METHODS[scheme_id], make_scene(scene_id, **SIZES.get(scene_id, {}))
    assert exact_why(scheme, scene) == ""
    # A stable run recorded every 7 steps (and the last), and one past the stability limit
    # (explicit schemes blow up: the same failing step), recorded every step.
    for homega, steps, every in ((0.1, 300, 7), (3.5, 150, 1)):
        dt = homega / scene.omega
        assert_same_run(integrate(scheme, scene, dt, steps, every), integrate_exact(scheme, scene, dt, steps, every))


@pytest.mark.parametrize("scheme_id, scene_id", [
    ("explicit_euler", "spring"),           # blows up at h*omega = 3.5: the failing step and counts agree
    ("verlet", "kepler"),                   # a start-up evaluation, counted apart
    ("implicit_euler", "kepler"),           # Newton to tolerance: a varying count of evaluations and solves
    ("rk4", "pendulum"),                    # np.sin, a libm call
    ("position_first_euler_decay_after_kick", "damped_spring"),  # math.exp of the damping rate
    ("implicit_midpoint", "chain"),         # coupled DOF, the scene's own tridiagonal solve
    ("verlet_constrained", "rope"),         # projections, counted
])
def test_exact_run_is_the_interpreted_run(scheme_id, scene_id):
    check_pair(scheme_id, scene_id)


def test_exact_run_from_a_given_state_time_and_batch():
    scheme, scene = METHODS["leapfrog"], make_scene("kepler")
    q0 = np.array([[0.5, 0.1], [0.7, -0.2]])
    v0 = np.array([[0.0, 1.2], [0.1, 1.0]])
    a = integrate(scheme, scene, 0.01, 50, 4, q0=q0, v0=v0, t0=3.0)
    b = integrate_exact(scheme, scene, 0.01, 50, 4, q0=q0, v0=v0, t0=3.0)
    assert_same_run(a, b)
    assert b.q.shape == (14, 2, 2) and b.t[0] == 3.0


@pytest.mark.slow
@pytest.mark.parametrize("scene_id", sorted(SCENES))
def test_every_exact_pair_is_the_interpreted_run(scene_id):
    scene = make_scene(scene_id, **SIZES.get(scene_id, {}))
    for scheme_id, scheme in METHODS.items():
        if RefMethod(scheme).supports(scene)[0] and not exact_why(scheme, scene):
            check_pair(scheme_id, scene_id)


def cubic_accel(q, v, t, p):
    return -(q ** 3)


class CubicSpring(Spring):
    """A spring whose force is written with ``**``: numpy's pow, numba's repeated products."""

    id = "cubic_spring"
    accel = staticmethod(cubic_accel)


def test_a_pair_that_might_compute_other_bits_is_interpreted():
    scene = CubicSpring()
    assert exact_why(METHODS["leapfrog"], scene).endswith("cubic_accel: uses **")
    assert integrate_exact(METHODS["leapfrog"], scene, 0.1, 3) is None
    exact = RefMethod(METHODS["leapfrog"], exact=Exact())
    assert exact.simulate(scene, 0.1, 3).meta.backend == "interpreted"
    assert exact.simulate(make_scene("spring"), 0.1, 3).meta.backend == "compiled, counted"
    # The backend is the method's, stated where it is made: a RefMethod without one interprets.
    assert RefMethod(METHODS["leapfrog"]).simulate(make_scene("spring"), 0.1, 3).meta.backend == "interpreted"


def test_a_library_solve_is_exact_where_the_builds_agree():
    # The solar system's implicit solve calls LAPACK (np.linalg.solve): exact where numba's
    # build and numpy's agree on this machine (checked), interpreted where they do not.
    why = exact_why(METHODS["implicit_midpoint"], make_scene("solar_system"))
    assert why == ("" if _libm.agrees("np.linalg.solve") else
                   "numba's np.linalg.solve gives other bits than numpy's on this machine")
    if not why:
        check_pair("implicit_midpoint", "solar_system")


def test_a_scene_overriding_its_force_on_the_instance_is_interpreted():
    scene = make_scene("spring")
    scene.accel = lambda q, v, t, p: -2.0 * q
    assert "overrides its accel" in exact_why(METHODS["leapfrog"], scene)
    assert integrate_exact(METHODS["leapfrog"], scene, 0.1, 5) is None


def _why(src: str) -> tuple[str, set]:
    libm = set()
    return _exactness.exact_operations(ast.parse(src).body[0], {"np": "np", "math": "math"}, {"helper"}, libm), libm


@pytest.mark.parametrize("body, why", [
    ("return np.sqrt(q * q + 1.0) / abs(p[0])", ""),
    ("a = np.empty_like(q)\n    a[0] = helper(q)[0]\n    return a.copy()", ""),
    ("return np.sum(q)", "calls np.sum"),
    ("return q @ q", "uses @"),
    ("return q ** 3", "uses **"),
    ("x = q\n    x **= 2\n    return x", "uses **"),
    ("return np.linalg.inv(q)", "calls np.linalg.inv"),
    ("return q.dot(v)", "calls q.dot"),
    ("return sum(q)", "calls sum"),
])
def test_exact_operations(body, why):
    assert _why(f"def f(q, v, t, p):\n    {body}\n")[0] == why


def test_exact_operations_records_the_libm_calls():
    why, libm = _why("def f(q, v, t, p):\n    return np.sin(q) * math.exp(-p[0]) + np.linalg.solve(q, v)\n")
    assert why == "" and libm == {"np.sin", "math.exp", "np.linalg.solve"}


def test_libm_check_sees_a_one_ulp_difference(monkeypatch):
    _libm.agrees.cache_clear()
    try:
        assert _libm.agrees("np.sin")
        real = _libm._compiled

        def off_by_one_ulp(name):
            f = real(name)
            return lambda x: np.nextafter(f(x), np.inf) if name == "np.sin" else f(x)

        monkeypatch.setattr(_libm, "_compiled", off_by_one_ulp)
        _libm.agrees.cache_clear()
        assert not _libm.agrees("np.sin")
        assert _libm.agrees("math.exp")
    finally:
        _libm.agrees.cache_clear()


def test_counted_copy_renames_each_kernel_call():
    src = _codegen._Source()
    src.add(METHODS["rk4"].step, "scheme_step", ("scene_accel",))
    src.add(make_scene("spring").accel, "scene_accel")
    src.add_counted("scheme_step", "scheme_step_counted", {"scene_accel": 0})
    text = src.functions["scheme_step_counted"]
    assert text.startswith("def scheme_step_counted(_cnt, state, t, h, p):")
    assert text.count("scene_accel_counted(_cnt, ") == 4 and "scene_accel(" not in text
    assert "_cnt[0] += 1" in src.functions["scene_accel_counted"]


def test_a_kernel_passed_on_as_a_value_cannot_be_counted():
    src = _codegen._Source()
    src.functions["scheme_step"] = ast.unparse(ast.parse("def scheme_step(state, t, h, p):\n"
                                                         "    return helper_taking(scene_accel, state)\n"))
    src.origins["scheme_step"] = "test"
    with pytest.raises(_codegen.SourceUnavailable, match="passes the kernel scene_accel on as a value"):
        src.add_counted("scheme_step", "scheme_step_counted", {"scene_accel": 0})


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


def test_nightly_cells_are_the_same_with_and_without_the_exact_run():
    from dataclasses import replace

    from harness.nightly.cells import run_task
    from harness.nightly.run import Task
    from harness.nightly.suites import SUITES

    def measured(exact: bool):
        suite = replace(SUITES["smoke"], exact_compiled=exact)
        task = Task("cell", "spring", "ref:rk4", "ref", {}, suite)
        cells = {}
        backends = {c.figures.backend for c in run_task(task) if c.measure == "energy"}
        assert backends == {"compiled, counted" if exact else "interpreted"}
        for c in run_task(task):
            if c.measure == "cost":  # a timing: never equal run to run
                continue
            # The advice's cost per frame is this run's timing; the kernels and backend say how it ran.
            data = untimed({k: v for k, v in c.to_row()["data"].items() if k not in ("kernels", "backend")})
            cells[(c.measure, c.dt)] = (c.status, c.steps, c.value if c.measure != "advise" else None,
                                        repr(data), c.detail)
        return cells

    assert measured(True) == measured(False)


def test_only_the_schemes_let_compile_compile_their_counted_kernels(monkeypatch, tmp_path):
    from reference import _compiled

    monkeypatch.setenv("HARNESS_CACHE", str(tmp_path))  # nothing compiled here yet
    monkeypatch.setattr(_compiled, "_COUNTED", {})
    # Nor loaded in this process: another test in the same worker may have compiled the pair's
    # counted loop into a kernel module this process still holds.
    monkeypatch.setattr(_compiled, "_LOADED", {})
    scene, scheme = make_scene("spring"), METHODS["semi_implicit_euler_position_first"]

    def method(compile_for):
        return RefMethod(scheme, exact=Exact(frozenset(compile_for)))

    assert exact_why(scheme, scene, may_compile=False) == _compiled.NOT_YET
    assert method({"leapfrog"}).simulate(scene, 0.1, 10).meta.backend == "interpreted"
    assert method({"semi_implicit_euler_position_first"}).simulate(scene, 0.1, 10).meta.backend == \
        "compiled, counted"
    monkeypatch.setattr(_compiled, "_COUNTED", {})  # another process: compiled before, so taken
    assert method(set()).simulate(scene, 0.1, 10).meta.backend == "compiled, counted"


def test_a_pair_new_to_the_cache_compiles_before_the_run_that_would_bring_it_to_compilings_cost(monkeypatch,
                                                                                                  tmp_path):
    """The ski-rental rule with a look-ahead (``Exact.after_interpreting``): a pair whose compile is
    deferred is measured first (a short interpreted run gives its rate), then compiles before the
    run whose predicted interpreted cost, added to what it has cost so far, reaches what compiling
    costs; a scheme not deferred compiles at once, one not allowed to never. The rates are set
    here, not measured, so the decisions do not depend on the machine's speed."""
    from reference import _compiled

    monkeypatch.setenv("HARNESS_CACHE", str(tmp_path))  # a cache that has never seen the pair ...
    for table in ("_COUNTED", "_LOADED", "_INTERPRETED"):  # ... nor has this process
        monkeypatch.setattr(_compiled, table, {})
    scene, scheme = make_scene("spring"), METHODS["leapfrog"]
    deferred = Exact(frozenset({"leapfrog"}), frozenset({"leapfrog"}))
    compile_s = _compiled.counted_compile_s(scheme, scene)
    assert compile_s == _compiled.COUNTED_COMPILE_S["pointwise"]

    assert deferred.wants_rate(scheme, scene) and not deferred.may_compile(scheme, scene, 10**9)  # no rate yet
    Exact.interpreted(scheme, scene, 0.1 * compile_s, 100)  # 0.1 of compiling's cost for 100 steps
    assert not deferred.wants_rate(scheme, scene)
    assert not deferred.may_compile(scheme, scene, 800)  # 0.1 + 0.8 of it: interpret
    assert deferred.may_compile(scheme, scene, 900)  # 0.1 + 0.9: compile first
    assert Exact(frozenset({"leapfrog"})).may_compile(scheme, scene, 1)  # not deferred
    assert not Exact(frozenset({"rk4"}), frozenset({"leapfrog"})).may_compile(scheme, scene, 10**9)

    # Through the method: the first run is preceded by a rate measurement of PROBE_STEPS steps, and
    # a run predicted to cost far more than compiling compiles; one predicted cheap is interpreted.
    monkeypatch.setattr(_compiled, "_INTERPRETED", {})
    method = RefMethod(scheme, exact=deferred)
    short = method.simulate(scene, 0.1, 5)
    assert short.meta.backend == "interpreted"
    assert _compiled._INTERPRETED[(scheme, Spring)][1] == 5 + 5  # the probe (min(5, PROBE_STEPS)) and the run
    _compiled._INTERPRETED[(scheme, Spring)][:] = [0.01 * compile_s, 10]  # a rate of 1e-3 of compiling per step
    assert method.simulate(scene, 0.1, 20).meta.backend == "interpreted"
    assert method.simulate(scene, 0.1, 5000).meta.backend == "compiled, counted"
    assert_same_run(integrate(scheme, scene, 0.1, 5000), method.simulate(scene, 0.1, 5000))
