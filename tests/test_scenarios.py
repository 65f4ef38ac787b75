"""Scenes: exact solutions solve their ODE, energies, parameter validation."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from scenarios import SCENES, InvalidInput, make_scene, parse_overrides


def ode(scene):
    p = scene.pvec
    n = scene.ndof

    def f(t, y):
        q, v = y[:n, None], y[n:, None]
        return np.concatenate([v[:, 0], scene.accel(q, v, t, p)[:, 0]])

    return f


EXACT_SCENES = [s for s in SCENES if make_scene(s).exact(np.zeros(1)) is not None]


@pytest.mark.parametrize("scene_id", EXACT_SCENES)
def test_exact_solution_solves_the_scene_ode(scene_id):
    scene = make_scene(scene_id)
    q0, v0 = scene.initial_state()
    t = np.linspace(0, 2 * scene.period, 41)
    sol = solve_ivp(ode(scene), (0, t[-1]), np.concatenate([q0, v0]), method="DOP853",
                    rtol=1e-13, atol=1e-13, t_eval=t)
    q, v = scene.exact(t)
    n = scene.ndof
    scale = 1 + np.abs(sol.y).max()
    # DOP853 at rtol 1e-13 over two periods agrees to ~1e-10 of the state's scale.
    np.testing.assert_allclose(q, sol.y[:n].T, atol=1e-9 * scale)
    np.testing.assert_allclose(v, sol.y[n:].T, atol=1e-9 * scale)


@pytest.mark.parametrize("scene_id", EXACT_SCENES)
def test_exact_energy_matches_energy_of_exact_state(scene_id):
    scene = make_scene(scene_id)
    t = np.linspace(0, scene.period, 17)
    q, v = scene.exact(t)
    np.testing.assert_allclose(scene.exact_energy(t), scene.energy(q, v), rtol=1e-12, atol=1e-12)


def test_damped_energy_decays():
    scene = make_scene("damped_spring")
    e = scene.exact_energy(np.linspace(0, 50, 200))
    assert np.all(np.diff(e) <= 1e-15) and e[-1] < 0.01 * e[0]


@pytest.mark.parametrize("scene_id,params,field", [
    ("spring", {"m": -1}, "m"), ("spring", {"k": 0}, "k"), ("kepler", {"e": 1.0}, "e"),
    ("kepler", {"e": -0.1}, "e"), ("pendulum", {"L": 0}, "L"), ("pendulum", {"theta0": 4}, "theta0"),
    ("damped_spring", {"c": 5}, "c"), ("projectile", {"m": 0}, "m"), ("spring", {"k": "nan"}, "k"),
])
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
