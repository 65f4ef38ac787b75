"""Backward Euler's Newton iteration with an Armijo line search (``ref:implicit_euler?line_search=armijo``,
``reference.schemes.implicit_euler``): every step it takes solves backward Euler's equation, it
keeps the stiff sheet's energy bounded where the full-step Newton blows up, it computes the
full-step Newton's bits wherever every full update is accepted, and it counts what it did."""

from __future__ import annotations

import math

import numpy as np
import pytest

from harness.methods import get_method
from records import InvalidInput
from reference import integrate, solvers
from reference.schemes import implicit_euler as ie
from scenarios import make_scene

H = 1.0 / 60.0
ARMIJO = "ref:implicit_euler?line_search=armijo"
DIRECT = "ref:implicit_euler?solver=direct"


def run(method_id, scene, steps, q0=None, v0=None):
    m = get_method(method_id)
    if q0 is None:
        return m.simulate(scene, H, steps, 1)
    return integrate(m.scheme, scene, H, steps, 1, q0=q0[None], v0=v0[None], solver=m.solver)


def same_bits(a, b) -> bool:
    return np.array_equal(a.q, b.q) and np.array_equal(a.v, b.v)


def relative_energy(traj) -> np.ndarray:
    e = traj.energy[:, 0]
    return (e - e[0]) / abs(e[0])


@pytest.fixture(scope="module")
def crumpled():
    """A 6 x 6 sheet at k = 1e6 (node mass 1/64, as the sweeps' larger sheets), its free nodes
    moved at random by 3 mm (3% of the spacing): compressed springs from the first step, where the
    full-step Newton fails every step at h = 1/60 (measured: 50 iterations each, the energy
    1.7e4 times E0). Ten steps."""
    scene = make_scene("cloth", n=6, m=6, mass=36 / 64, k=1e6)
    q0, v0 = scene.initial_state()
    q0 = q0 + 0.003 * np.random.default_rng(1).standard_normal(q0.shape)
    return scene, q0, v0


# ----------------------------------------------------------------------------- the option
def test_the_line_search_is_an_option_of_backward_euler_alone():
    m = get_method("ref:implicit_euler?solver=direct&line_search=armijo&hessian=projected")
    assert m.id == "ref:implicit_euler?hessian=projected&line_search=armijo&solver=direct"
    assert m.solver.line_search == "armijo" and m.solver.hessian == "projected" and m.solver.solver.name == "direct"
    # On the scene's own kernel it is a run of its own; without it, the compiled full-step Newton.
    assert get_method(ARMIJO).solver.solver is solvers.SCENE_SOLVE
    assert get_method("ref:implicit_euler?line_search=none").solver is None
    assert "Armijo" in get_method(ARMIJO).describe()["solver"]
    small = make_scene("cloth", n=3, m=3)
    said = run(ARMIJO, small, 2).meta.linear_solver
    assert said.startswith("the scene's banded LDL^T") and said.endswith("(the scene's energy)"), said
    assert (
        "solve kernels compiled where they compute the interpreted bits"
        in get_method(ARMIJO).step_timer(small, H, 2)[2]
    )
    assert "line_search" not in solvers.options_for(get_method("ref:linearly_implicit_euler").scheme)


@pytest.mark.parametrize(
    "method_id, says",
    [
        ("ref:implicit_euler?hessian=projected", "option hessian=projected applies with line_search=armijo"),
        ("ref:implicit_euler?hessian=projected&line_search=armijo", "applies with a library solve"),
        ("ref:implicit_euler?line_search=armijo&solver=local_global", "solver=local_global is its own iteration"),
        ("ref:implicit_euler?line_search=wolfe", "allowed: none, armijo"),
        ("ref:implicit_midpoint?line_search=armijo", "unknown option 'line_search'"),
    ],
)
def test_a_bad_newton_option_is_refused_in_one_line(method_id, says):
    with pytest.raises(InvalidInput) as err:
        get_method(method_id)
    assert says in str(err.value) and "\n" not in str(err.value)


def test_where_the_projection_does_not_run():
    projected = get_method("ref:implicit_euler?hessian=projected&line_search=armijo&solver=direct")
    ok, why = projected.supports(make_scene("spring"))
    assert not ok and "sparse form" in why
    assert projected.supports(make_scene("cloth", n=3, m=3))[0]


# ----------------------------------------------------------------------------- full steps: the bits
def test_full_steps_compute_the_full_step_newton_s_bits():
    """The 4 x 4 sheet at k = 1000 and 60 Hz: every full Newton update is accepted (no backtrack),
    and the run is the full-step Newton's to the bit, on the scene's own solve (compiled kernels
    against the interpreted step) and on SuperLU."""
    sheet = make_scene("cloth", n=4, m=4, k=1000.0)
    searched = run(ARMIJO, sheet, 30)
    assert searched.meta.settings["newton_backtracks"] == 0 and searched.meta.settings["newton_failures"] == 0
    assert same_bits(searched, run("ref:implicit_euler", sheet, 30))
    direct = run(DIRECT, sheet, 30)
    assert same_bits(run(f"{ARMIJO}&solver=direct", sheet, 30), direct)
    # The full-step Newton counted (a library solve, one batch member) is the scheme's own step,
    # which a batch runs: two copies of the start, each the single run's bits.
    m = get_method(DIRECT)
    q0, v0 = sheet.batch_state(2)
    batch = integrate(m.scheme, sheet, H, 30, 1, q0=q0, v0=v0, solver=m.solver)
    assert batch.meta.settings is None and np.array_equal(batch.q[:, 1], direct.q[:, 0])
    assert np.array_equal(batch.v[:, 0], direct.v[:, 0])
    assert searched.solves == searched.force_evals == searched.meta.settings["newton_iterations"]


def test_a_force_without_potential_takes_the_residual_as_its_merit():
    """The damped spring (a(x, v) = -(k x + c v)/m): no incremental potential, the residual's norm
    instead, said in the run; linear, so one Newton update is exact and accepted: the same bits."""
    spring = make_scene("damped_spring")
    searched = run(ARMIJO, spring, 50)
    settings = searched.meta.settings
    assert "residual's norm" in settings["objective"] and "depends on the velocity" in settings["objective_why"]
    assert settings["newton_failures"] == 0 and settings["newton_iterations"] == 50
    assert same_bits(searched, run("ref:implicit_euler", spring, 50))


def test_a_force_that_moves_with_the_velocity_is_found_whatever_the_scene_declares():
    """The objective is read from the scene's kernels, not taken on its word: a spring whose force
    leaks with the velocity but that declares itself conservative gets the residual's norm."""
    from scenarios.spring import Spring

    class Leaky(Spring):
        accel = staticmethod(lambda q, v, t, p: -q - 0.1 * v)

    objective, why = solvers.objective_for(Leaky())
    assert isinstance(objective, ie.ResidualNorm) and "depends on the velocity" in why
    assert isinstance(solvers.objective_for(make_scene("spring"))[0], ie.IncrementalPotential)


# ----------------------------------------------------------------------------- where full steps fail
def test_every_step_solves_backward_euler_s_equation(crumpled):
    """The crumpled sheet: each recorded step checked against backward Euler's equations by hand,
    with the scene's own force kernel (the run's force on SuperLU is the sparse form's):
    x1 = x0 + h v1 to roundoff, and M (v1 - v0) - h f(x1) = 0 to 1e-8 of its terms' size (measured
    4.7e-10: the springs' stretches near rest keep ~1e-10 of their bits); the full-step Newton's
    steps miss it by their own size."""
    scene, q0, v0 = crumpled

    def residuals(traj):
        q, v = traj.q[:, 0], traj.v[:, 0]
        a = scene.accel(np.ascontiguousarray(q[1:].T), np.ascontiguousarray(v[1:].T), 0.0, scene.pvec).T
        size = np.max(np.abs(v[1:] - v[:-1]), axis=1) + H * np.max(np.abs(a), axis=1)
        drift = np.max(np.abs(q[1:] - q[:-1] - H * v[1:]))
        return np.max(np.abs(v[1:] - v[:-1] - H * a), axis=1) / size, drift

    for method_id in (ARMIJO, f"{ARMIJO}&solver=direct", f"{ARMIJO}&solver=direct&hessian=projected"):
        traj = run(method_id, scene, 10, q0, v0)
        assert traj.ok and traj.meta.settings["newton_failures"] == 0, method_id
        rel, drift = residuals(traj)
        assert np.all(rel < 1e-8) and drift < 1e-15, (method_id, rel.max(), drift)
    plain = run(DIRECT, scene, 10, q0, v0)
    rel, _ = residuals(plain)
    assert plain.meta.settings["newton_failures"] == 10 and np.max(rel) > 0.1


def test_the_crumpled_sheet_keeps_its_energy_bounded(crumpled):
    """Where the full-step Newton fails every step and the energy reaches 1.7e4 E0, the line
    search converges every step (a handful of backtracks) and the energy never rises above E0
    (backward Euler damps the crumpling); the run says both."""
    scene, q0, v0 = crumpled
    plain = run(DIRECT, scene, 10, q0, v0)
    searched = run(f"{ARMIJO}&solver=direct", scene, 10, q0, v0)
    assert np.max(relative_energy(plain)) > 1e3
    assert "10 of 10 steps ended their Newton iteration unconverged (the cap of 50 iterations reached)" in plain.detail
    assert np.max(relative_energy(searched)) < 1e-9 and searched.detail == ""
    s = searched.meta.settings
    assert s["newton_failures"] == 0 and s["newton_backtracks"] > 0 and s["newton_steps"] == 10
    assert s["newton_objective_evals"] == s["newton_iterations"] + s["newton_backtracks"]
    # The projected Hessian and the exact one reach the same steps (the equation's one root here).
    projected = run(f"{ARMIJO}&solver=direct&hessian=projected", scene, 10, q0, v0)
    assert projected.meta.settings["projected_systems"] > 0
    assert np.max(np.abs(projected.q - searched.q)) < 1e-12 and np.max(np.abs(projected.v - searched.v)) < 1e-10


@pytest.mark.slow
def test_the_16_by_16_sheet_at_k_1e6_in_one_substep():
    """The sweep's 16 x 16 sheet (node mass 1/64) at k = 1e6, h = 1/60 over 2 s: the full-step
    Newton fails from step 102 on (18 of 120 steps at the cap) and its energy error reaches 1.7e8;
    with the line search every step converges and the energy error ends at 0.295 (local/global
    passes' 0.29 to 0.33, docs/findings.md)."""
    sheet = make_scene("cloth", n=16, m=16, mass=4.0, k=1e6)
    plain = run(DIRECT, sheet, 120)
    searched = run(f"{ARMIJO}&solver=direct", sheet, 120)
    assert plain.meta.settings["newton_failures"] > 0 and np.max(np.abs(relative_energy(plain))) > 1e6
    assert searched.meta.settings["newton_failures"] == 0
    assert 0.28 < np.max(np.abs(relative_energy(searched))) < 0.31


# ----------------------------------------------------------------------------- the pieces
def test_an_update_that_does_not_descend_is_replaced_by_the_residual():
    """A solve that returns -r (an ascent direction of Phi) on the unit spring: each iteration
    takes the residual instead (steepest descent in the metric M) and still reaches backward
    Euler's step, the spring's closed form (``floor``)."""
    spring = make_scene("spring")
    objective, why = solvers.objective_for(spring)
    assert isinstance(objective, ie.IncrementalPotential) and why == ""
    counts = ie.NewtonCounts()
    q, v = np.array([[1.0]]), np.array([[0.5]])
    h = 0.1
    k, m = spring.values["k"], spring.values["m"]
    qn, vn = ie.newton_line_search(spring.accel, lambda *a: -a[-1], 50, (q, v), 0.0, h, spring.pvec, objective, counts)
    exact = ie.floor((1.0, 0.5), h, k, m)
    assert counts.failures == 0 and counts.not_descent == counts.iterations - 1 > 0
    assert math.isclose(qn[0, 0], exact[0], rel_tol=1e-12) and math.isclose(vn[0, 0], exact[1], rel_tol=1e-12)


def test_the_merit_function_backtracks_where_newton_overshoots():
    """a = -k atan(x) - c v, stiff (h^2 k = 100): Newton's full updates on the atan overshoot and
    never settle (the cap reached); on the residual's norm the line search converges."""
    k, c, h = 100.0, 0.1, 1.0

    def accel(q, v, t, p):
        return -k * np.arctan(q) - c * v

    def solve(q, v, t, p, alpha, beta, r):
        return r / (1.0 + alpha * c + beta * k / (1.0 + q * q))

    state = (np.array([[2.0]]), np.array([[0.0]]))
    plain, searched = ie.NewtonCounts(), ie.NewtonCounts()
    ie.newton_line_search(accel, solve, 50, state, 0.0, h, None, None, plain)
    q1, v1 = ie.newton_line_search(accel, solve, 50, state, 0.0, h, None, ie.ResidualNorm(), searched)
    assert plain.failures == 1 and plain.iterations == 50
    assert searched.failures == 0 and searched.backtracks > 0
    assert abs(v1[0, 0] - h * accel(q1, v1, 0.0, None)[0, 0]) < 1e-12  # v0 = 0


def test_the_projection_clamps_compressed_springs_only():
    """A 4 x 4 sheet's free nodes moved 10% towards the origin (the springs among them compressed)
    at k = 1e6: the Newton matrix I + h^2 M^-1 K is indefinite, projected it is I plus a positive
    semi-definite part (eigenvalues at least 1); at the flat start no spring is compressed and
    nothing changes."""
    sheet = make_scene("cloth", n=4, m=4, k=1e6)
    form, projection = sheet.sparse_form(), solvers.SpringProjection(sheet)
    q0, _ = sheet.initial_state()
    assert projection.correction(q0, H * H) is None
    shrunk = 0.9 * q0
    matrix = form.matrix(shrunk, np.zeros_like(q0), 0.0, H, H * H)
    clamp = projection.correction(shrunk, H * H)
    assert np.linalg.eigvalsh(matrix.toarray()).min() < -1.0
    assert np.linalg.eigvalsh((matrix + clamp).toarray()).min() > 1.0 - 1e-6


def test_on_a_stiff_damped_sheet_unsolved_steps_are_failures_and_stalls_at_the_root_are_not():
    """The damped sheet's Newton matrix leaves the dashpots' dependence on the positions out, so its
    update need not descend: on an 8 x 8 sheet at k = 1e6, d = 10, one substep, some steps' searches
    end with the residual far from roundoff (failures, said with the run) and others at the root to
    roundoff, where the update's test cannot pass (stalls, converged). Each step's backward Euler
    residual, computed here from the reference's right-hand side, says which."""
    sheet = make_scene("cloth", n=8, m=8, mass=1.0, k=1e6, d=10.0)
    steps = 60
    traj = run(f"{ARMIJO}&solver=direct", sheet, steps)
    s = traj.meta.settings
    assert s["newton_steps"] == steps and s["newton_failures"] > 0 and s["newton_stalls"] > 0
    assert f"{s['newton_failures']} of {steps} steps ended their Newton iteration unconverged" in traj.detail
    rhs, n = sheet._rhs(), sheet.ndof
    residual = []
    for i in range(steps):
        q1, v0, v1 = traj.q[i + 1, 0], traj.v[i, 0], traj.v[i + 1, 0]
        a = rhs(0.0, np.concatenate([q1, v1]))[n:]
        residual.append(np.max(np.abs(v0 + H * a - v1)) / (1.0 + np.max(np.abs(v1))))
    residual = np.array(residual)
    unsolved = int(np.count_nonzero(residual > 1e-6))
    assert unsolved > 0 and unsolved <= s["newton_failures"]  # every unsolved step is counted as failed
    assert int(np.count_nonzero(residual <= ie.STALL_RTOL)) >= steps - s["newton_failures"]


def test_the_advice_marks_a_row_whose_newton_steps_did_not_converge_as_resting_on_its_solve():
    from harness.measures.advise import Request, _row, convergence, rests_on_solve, solve_note
    from records.advice import MethodAdvice

    sheet = make_scene("cloth", n=8, m=8, mass=1.0, k=1e6, d=10.0)
    method = get_method(f"{ARMIJO}&solver=direct")
    request = Request(hz=60, horizon=0.5, energy_tol=0.9, error_rel=None).checked()
    advice = MethodAdvice(method.id)
    row = _row(method, sheet, request, 1, advice, None, reference=False, count=False)
    assert "ended their Newton iteration unconverged" in row.detail
    row.converged = convergence(method, sheet, request, row, advice, None, reference=False, count=False)
    assert row.converged["unconverged"] and not row.converged["meets"] and rests_on_solve(row)
    assert solve_note(row).startswith("its win rests on steps its solve did not converge: ")
