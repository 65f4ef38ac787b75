"""The cloth in the engines: what each engine mode integrates there, against the reference
schemes and independent numbers. Every tolerance says where it comes from."""

from __future__ import annotations

import numpy as np
import pytest

from harness.measures.identify import identify
from harness.methods import get_method
from reference import METHODS, integrate
from scenarios import make_scene


#: The 3-D sheet's identities run every candidate scheme on 48 degrees of freedom: marked slow
#: (``make test-slow``); the planar net asks the same questions of the same code in ``make test``.
@pytest.fixture(
    scope="module",
    params=[
        pytest.param(("cloth", {"n": 4, "m": 4}), marks=pytest.mark.slow, id="sheet"),
        pytest.param(("net", {"n": 4, "m": 3, "pins": 1}), id="planar"),
    ],
)
def cloth(request):
    return make_scene(request.param[0], **request.param[1])


@pytest.mark.parametrize(
    "method_id, scheme_id",
    [
        ("mujoco:euler", "ref:semi_implicit_euler"),
        ("mujoco:implicit", "ref:semi_implicit_euler"),
        ("mujoco:implicitfast", "ref:semi_implicit_euler"),
        ("mujoco:rk4", "ref:rk4"),
    ],
)
def test_mujoco_tendon_sheet_is_the_reference_scheme(cloth, method_id, scheme_id):
    """Slide joints and spatial tendons pose the scene's force exactly: each mode is its scheme to
    roundoff over 300 steps at h omega = 0.063 (measured 3.8e-14 at most; MATCH_RTOL 1e-9 of the
    state's size), the runner-up 5.8e-9 or more away (Forest-Ruth beside RK4, both fourth order).
    At 100 steps a period, not the cloth's own identification run (h omega = 1, for a float32 engine)."""
    res = identify(method_id, cloth, cloth.period / 100, steps=300)
    assert res.match == scheme_id, res.candidates[:3]
    assert res.max_deviation <= 1e-12 and res.runner_up.max_deviation >= 1e-9


def test_mujoco_discrete_is_one_solve_without_the_geometric_stiffness(cloth):
    """From a generic state (the reference at t = 0.3: every spring off its rest length), one step
    of mujoco:discrete against the step computed here with numpy: (M + h^2 K_GN) dv =
    h (f - h K_GN v), K_GN = sum k J^T J (the springs' u u^T blocks only). Measured 2.6e-16;
    with the full Hessian (ref:linearly_implicit_euler's K) the same step is 1e-2 away on the
    sheet, 6.6e-5 on the planar net (its springs stretched less)."""
    q, v = (x[0] for x in cloth.reference_solution([0.3]))
    h = 0.5 / cloth.omega
    ((y1, why),) = get_method("mujoco:discrete").one_steps(cloth, h, np.concatenate([q, v])[None, :])
    assert y1 is not None, why
    a, b, k, _ = cloth.springs()
    x = cloth.positions(q)
    u = x[b] - x[a]
    u /= np.linalg.norm(u, axis=1)[:, None]
    d = cloth.grid[2]
    free = np.full(cloth.grid[0] * cloth.grid[1], -1)
    free[[i * cloth.grid[1] + j for i, j in cloth.free_nodes()]] = np.arange(len(cloth.free_nodes()))
    gn = np.zeros((cloth.ndof, cloth.ndof))
    for t in range(len(a)):
        block = k[t] * np.outer(u[t], u[t])
        for r, c, sign in ((a[t], a[t], 1), (b[t], b[t], 1), (a[t], b[t], -1), (b[t], a[t], -1)):
            if free[r] >= 0 and free[c] >= 0:
                gn[free[r] * d : free[r] * d + d, free[c] * d : free[c] * d + d] += sign * block
    m = cloth.node_mass
    f = m * cloth.accel(q[:, None], v[:, None], 0.0, cloth.pvec)[:, 0]

    def step(stiffness):
        dv = np.linalg.solve(m * np.eye(cloth.ndof) + h * h * stiffness, h * (f - h * stiffness @ v))
        return np.concatenate([q + h * (v + dv), v + dv])

    assert np.max(np.abs(y1 - step(gn))) <= 1e-14
    assert np.max(np.abs(y1 - step(cloth.hessian(q).toarray()))) >= 1e-6


def test_mujoco_discrete_matches_nothing_and_says_why(cloth):
    res = identify("mujoco:discrete", cloth, steps=40)  # parts from every scheme at the first step
    assert res.match is None and "k J^T J" in res.why_no_match


def test_mujoco_cloth_model_records_the_scene(cloth):
    """The model's masses, tendons and gravity, read back from the compiled model."""
    run = get_method("mujoco:euler").simulate(cloth, 1e-3, 2)
    settings = run.meta.settings
    _, _, k, rest = cloth.springs()
    np.testing.assert_array_equal(settings["tendon_stiffness"], k)
    np.testing.assert_allclose(settings["tendon_springlength"], rest, rtol=1e-15)
    assert settings["tendon_damping"] == [0.0] * len(k)
    assert settings["mass_matrix_diagonal"] == [cloth.node_mass] * cloth.ndof
    assert settings["gravity"] == [0.0, 0.0, -cloth.values["g"]] and settings["ngeom"] == 0
    assert run.ok and run.force_evals == 2


def test_reference_schemes_run_on_the_planar_variant():
    planar = make_scene("net", n=3, m=3)
    for sid in ("semi_implicit_euler", "rk4", "implicit_euler", "linearly_implicit_euler"):
        tr = integrate(METHODS[sid], planar, 0.5 / planar.omega, 50)
        assert tr.status == "ok" and tr.q.shape == (51, 1, planar.ndof)


@pytest.mark.parametrize("params", [{"n": 4, "m": 4}, {"n": 4, "m": 3, "pins": 1}])
def test_chipmunk_springs_on_the_net_are_position_first_euler(params):
    """The planar net on Chipmunk's DampedSprings (damping 0), pins on the static body: position-first
    semi-implicit Euler to roundoff (measured 5.2e-14 over 1000 steps at h omega = 0.063), as on the chain."""
    net = make_scene("net", **params)
    res = identify("pymunk:damped_spring", net, steps=300)
    assert res.match == "ref:semi_implicit_euler_position_first", res.candidates[:3]
    assert res.max_deviation <= 1e-12 and res.runner_up.max_deviation >= 1e-8
    run = get_method("pymunk:damped_spring").simulate(net, 1e-3, 1)
    assert run.meta.settings["springs"] == len(net.springs()[0])
    assert run.meta.settings["spring_damping"] == [0.0] and run.meta.settings["bodies"] == len(net.free_nodes())


def test_the_sheet_is_refused_by_the_2d_engine_with_the_reason():
    ok, why = get_method("pymunk:damped_spring").supports(make_scene("cloth"))
    assert not ok and "net" in why
