"""Scenes: exact solutions solve their ODE, energies, parameter validation."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from records import InvalidInput

from scenarios import SCENES, make_scene, parse_overrides


def ode(scene):
    p = scene.pvec
    n = scene.ndof

    def f(t, y):
        q, v = y[:n, None], y[n:, None]
        return np.concatenate([v[:, 0], scene.accel(q, v, t, p)[:, 0]])

    return f


EXACT_SCENES = [s for s in SCENES if make_scene(s).closed_form(np.zeros(1)) is not None]


@pytest.mark.parametrize("scene_id", EXACT_SCENES)
def test_exact_solution_solves_the_scene_ode(scene_id):
    scene = make_scene(scene_id)
    q0, v0 = scene.initial_state()
    t = np.linspace(0, 2 * scene.period, 41)
    sol = solve_ivp(ode(scene), (0, t[-1]), np.concatenate([q0, v0]), method="DOP853", rtol=1e-13, atol=1e-13, t_eval=t)
    q, v = scene.closed_form(t)
    n = scene.ndof
    scale = 1 + np.abs(sol.y).max()
    # DOP853 at rtol 1e-13 over two periods agrees to ~1e-10 of the state's scale.
    np.testing.assert_allclose(q, sol.y[:n].T, atol=1e-9 * scale)
    np.testing.assert_allclose(v, sol.y[n:].T, atol=1e-9 * scale)


@pytest.mark.parametrize("scene_id", EXACT_SCENES)
def test_exact_energy_matches_energy_of_exact_state(scene_id):
    scene = make_scene(scene_id)
    t = np.linspace(0, scene.period, 17)
    q, v = scene.closed_form(t)
    np.testing.assert_allclose(scene.exact_energy(t), scene.energy(q, v), rtol=1e-12, atol=1e-12)


def test_damped_energy_decays():
    scene = make_scene("damped_spring")
    e = scene.exact_energy(np.linspace(0, 50, 200))
    assert np.all(np.diff(e) <= 1e-15) and e[-1] < 0.01 * e[0]


@pytest.mark.parametrize(
    "scene_id,params,field",
    [
        ("spring", {"m": -1}, "m"),
        ("spring", {"k": 0}, "k"),
        ("kepler", {"e": 1.0}, "e"),
        ("kepler", {"e": -0.1}, "e"),
        ("pendulum", {"L": 0}, "L"),
        ("pendulum", {"theta0": 4}, "theta0"),
        ("damped_spring", {"c": -1}, "c"),
        ("chain", {"c": -0.5}, "c"),
        ("projectile", {"m": 0}, "m"),
        ("spring", {"k": "nan"}, "k"),
    ],
)
def test_out_of_range_parameters_name_the_field_and_range(scene_id, params, field):
    with pytest.raises(InvalidInput) as err:
        make_scene(scene_id, **params)
    msg = str(err.value)
    assert field in msg and "allowed" in msg and "\n" not in msg


def test_unknown_scene_and_parameter_list_valid_choices():
    with pytest.raises(InvalidInput, match="valid: spring"):
        make_scene("sprung")
    with pytest.raises(InvalidInput, match="valid: GM, e"):
        make_scene("kepler", ecc=0.2)


def test_overrides_parse():
    assert parse_overrides(["e=0.9", "k = 2"]) == {"e": "0.9", "k": "2"}
    with pytest.raises(InvalidInput, match="key=value"):
        parse_overrides(["e0.9"])


def test_kepler_starts_at_perihelion():
    scene = make_scene("kepler", e=0.5)
    q0, v0 = scene.initial_state()
    assert q0.tolist() == [0.5, 0.0]
    assert v0[1] == pytest.approx(np.sqrt(3.0))
    assert scene.energy(q0, v0) == pytest.approx(-0.5)  # -GM/(2a), a = 1


# ------------------------------------------------------------- damping, every ratio (issue 12)
#: Against a DOP853 solve at rtol 1e-12 / atol 1e-14 over 30 time units: measured 1.1e-12
#: (zeta 0.05) to 2.9e-12 (zeta 2) on (x, v); 1e-10 leaves room for the solver's error.
DAMPED_TOL = 1e-10


@pytest.mark.parametrize("c", [0.0, 0.1, 1.0, 2.0, 2.0 + 1e-9, 2.5, 4.0])
def test_damped_spring_is_exact_for_every_damping_ratio(c):
    from scipy.integrate import solve_ivp

    scene = make_scene("damped_spring", c=c, v0=0.3)
    assert scene.zeta == pytest.approx(c / 2.0)
    t = np.linspace(0.0, 30.0, 301)
    q, v = scene.closed_form(t)
    sol = solve_ivp(
        lambda _, y: [y[1], -y[0] - c * y[1]],
        (0.0, 30.0),
        [1.0, 0.3],
        t_eval=t,
        method="DOP853",
        rtol=1e-12,
        atol=1e-14,
    )
    assert np.max(np.abs(q[:, 0] - sol.y[0])) <= DAMPED_TOL and np.max(np.abs(v[:, 0] - sol.y[1])) <= DAMPED_TOL
    e = scene.exact_energy(t)
    assert np.all(np.diff(e) <= 1e-15)  # energy never rises


def test_critical_damping_is_the_limit_of_the_overdamped_solution():
    # zeta = 1 exactly (c = 2) uses s = 0; a hair above it must agree to O(zeta - 1).
    t = np.linspace(0.0, 20.0, 201)
    crit = make_scene("damped_spring", c=2.0).closed_form(t)
    near = make_scene("damped_spring", c=2.0 * (1 + 1e-10)).closed_form(t)
    assert np.max(np.abs(crit[0] - near[0])) < 1e-9 and np.max(np.abs(crit[1] - near[1])) < 1e-9


@pytest.mark.parametrize("c", [20.0, 300.0])
def test_damped_chain_modes_are_exact(c):
    # Mode zetas from 0.04 to 2.9 (c = 300): under-, near-critically and overdamped modes at once.
    from scipy.integrate import solve_ivp

    scene = make_scene("chain", N=6, c=c)
    q0, v0 = scene.initial_state()
    t = np.linspace(0.0, 0.2, 41)
    q, v = scene.closed_form(t)

    def rhs(_, y):
        return np.concatenate([y[6:], scene.accel(y[:6, None], y[6:, None], 0.0, scene.pvec)[:, 0]])

    sol = solve_ivp(rhs, (0.0, 0.2), np.concatenate([q0, v0]), t_eval=t, method="Radau", rtol=1e-12, atol=1e-13)
    assert np.max(np.abs(q - sol.y[:6].T)) <= 1e-10
    assert np.max(np.abs(v - sol.y[6:].T)) / scene.omega <= 1e-10
    assert not scene.conservative and np.all(np.diff(scene.exact_energy(t)) <= 0)


def test_undamped_chain_is_bitwise_what_it_was():
    # c = 0 (the default) takes the undamped paths: the same floats as before damping existed.
    scene = make_scene("chain", N=5)
    rng = np.random.default_rng(1)
    q, v = rng.standard_normal((5, 3)), rng.standard_normal((5, 3))
    c = scene.values["k"] / scene.values["m"]
    expected = np.empty_like(q)
    a = scene.accel(q, v, 0.0, scene.pvec)
    for i in range(5):
        x = (-2.0 * c) * q[i]
        if i > 0:
            x = x + c * q[i - 1]
        if i < 4:
            x = x + c * q[i + 1]
        expected[i] = x
    np.testing.assert_array_equal(a, expected)


@pytest.mark.parametrize("scene_id", sorted(SCENES))
def test_every_parameter_refuses_a_non_finite_value_in_one_line(scene_id):
    """``--set k=inf`` ran and printed an infinite energy: a parameter is finite unless it says
    otherwise (``Param.infinite``), and the refusal names the parameter and its range."""
    from records import InvalidInput

    for name, spec in SCENES[scene_id].params.items():
        for bad in ("nan", "inf", "-inf"):
            if bad == "inf" and spec.infinite:
                continue
            with pytest.raises(InvalidInput, match=f"parameter {name}=") as err:
                SCENES[scene_id](**{name: bad})
            assert "allowed:" in str(err.value) and "\n" not in str(err.value)
