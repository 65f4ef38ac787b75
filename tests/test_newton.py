"""Newton's solvers (adapters/newton.py) are the schemes the harness names them, measured against
the reference schemes run from Newton's float32 inputs (dt and parameters rounded to float32, the
states rounded: ``harness.measures.identify``), with float32 tolerances; every perturbing default
is off; every scene a mode does not pose has its one-line reason. Skipped where newton cannot be
imported. Each solver's kernels compile on first use and are cached by Warp under the harness cache."""
from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("newton")

import adapters  # noqa: E402
from adapters import newton as adapter  # noqa: E402
from harness.measures.identify import FLOAT32_MATCH_RTOL, float32_inputs, identify, rounded_to_float32  # noqa: E402
from reference import METHODS, integrate  # noqa: E402
from scenarios import SCENES, make_scene  # noqa: E402

#: float32's unit roundoff, 2^-24: the scale of every tolerance below.
U32 = 2.0 ** -24


def _deviation(mode: str, scheme_id: str, scene, h: float, steps: int) -> float:
    """Largest |difference| in (q, v) between the mode and the scheme's run at the mode's float32
    inputs, relative to the state's size (the largest |q| or |v| of the run, at least 1), as
    ``identify`` measures it."""
    run = adapters.ENGINE_METHODS[f"newton:{mode}"].simulate(scene, h, steps)
    c_scene, c_h = float32_inputs(scene, h)
    ref = rounded_to_float32(integrate(METHODS[scheme_id], c_scene, c_h, steps))
    assert run.ok and ref.ok and np.array_equal(run.step, ref.step)
    scale = max(1.0, float(np.max(np.abs(run.q))), float(np.max(np.abs(run.v))))
    return float(max(np.max(np.abs(run.q - ref.q)), np.max(np.abs(run.v - ref.v)))) / scale


#: (mode, scene, scheme, tolerance) over 1000 steps at 100 a period (h omega = 0.063) from x0 = 1.
#: Measured (newton 1.8.0, warp 1.19.0, CPU): semi_implicit 4.2e-7 and 1.6e-7, featherstone 8.6e-7 and
#: 2.4e-7 (the semi-implicit step's own float32 roundoff, about 7 and 15 u32 walking over 1000
#: steps); xpbd 3.8e-6 and 2.0e-6, vbd 6.3e-6 and 4.4e-6 (their velocity is (x_new - x) / h: u32 / (h
#: omega) = 9.5e-7 a step). Held to 2e-5 (336 u32, three times the largest), where the nearest other
#: scheme is 2.3e-2 away (asserted below it).
SPRING_IDENTITIES = [
    ("semi_implicit", "spring", "semi_implicit_euler"),
    ("semi_implicit", "damped_spring", "semi_implicit_euler"),
    ("featherstone", "spring", "semi_implicit_euler"),
    ("featherstone", "damped_spring", "semi_implicit_euler"),
    ("xpbd", "spring", "implicit_euler"),
    ("xpbd", "damped_spring", "implicit_euler"),
    ("vbd", "spring", "implicit_euler"),
    ("vbd", "damped_spring", "implicit_euler"),
]
SPRING_TOL = 2e-5
#: What each identity is told apart from: the other scheme is at least this far (measured 2.3e-2 and up).
APART = 1e-2
OTHER = {"semi_implicit_euler": "implicit_euler", "implicit_euler": "semi_implicit_euler"}


@pytest.mark.parametrize("mode, scene_id, scheme_id", SPRING_IDENTITIES,
                         ids=[f"{m}-{s}" for m, s, _ in SPRING_IDENTITIES])
def test_each_newton_solver_is_its_scheme_on_the_spring_to_float32_rounding(mode, scene_id, scheme_id):
    scene = make_scene(scene_id)
    h = scene.period / 100
    assert _deviation(mode, scheme_id, scene, h, 1000) <= SPRING_TOL
    assert _deviation(mode, OTHER[scheme_id], scene, h, 1000) >= APART


def test_identify_names_xpbd_implicit_euler_at_float32():
    """The harness's own identification of a float32 mode: the candidates at float32 inputs, the
    float32 tolerance (FLOAT32_MATCH_RTOL of the state's size) and the verdict."""
    res = identify("newton:xpbd", make_scene("spring"))
    assert res.precision == "float32" and res.tolerance == pytest.approx(FLOAT32_MATCH_RTOL * 1.0, rel=1e-3)
    assert res.match == "ref:implicit_euler" and res.max_deviation <= SPRING_TOL
    assert "ref:semi_implicit_euler" not in res.matches


def test_featherstone_pendulum_is_semi_implicit_euler_in_the_angle():
    """A point mass on a revolute joint, theta0 = 2, 1000 steps of period/100, relative to the
    largest |omega| (5.3): measured 5.5e-6 (the float32 sin and the angle's roundoff over a
    nonlinear swing), held to 5e-5; verlet is 1.3e-2 away."""
    pendulum = make_scene("pendulum")
    h = pendulum.period / 100
    assert _deviation("featherstone", "semi_implicit_euler", pendulum, h, 1000) <= 5e-5
    assert _deviation("featherstone", "verlet", pendulum, h, 1000) >= 5e-3


@pytest.mark.parametrize("mode, scheme_id", [("semi_implicit", "semi_implicit_euler"),
                                             ("featherstone", "semi_implicit_euler")])
def test_the_particle_chain_and_cloth_are_semi_implicit_euler(mode, scheme_id):
    """The chain (N = 8, k = 1e4) and a 4 x 4 cloth, 200 steps of period/100 (h omega = 0.063),
    relative to the state's size. Measured: chain 2.5e-6 (its particles sit up to 4.5 s = 9 from
    the origin, so each position carries 2^-24 of 9), cloth 1.4e-5 (each step adds h v, 1e-4 of a
    position near 0.3, so most of the step's digits are rounded off); held to 2e-5 and 5e-5."""
    chain = make_scene("chain", N=8)
    assert _deviation(mode, scheme_id, chain, chain.period / 100, 200) <= 2e-5
    cloth = make_scene("cloth", n=4, m=4)
    assert _deviation(mode, scheme_id, cloth, cloth.period / 100, 200) <= 5e-5


def test_every_perturbing_default_is_off_and_recorded():
    """Read back from the model that ran: no contact pass (radius 0, no particle grid, triangle
    contact off), no triangles (so no tri_ke / tri_kd), spring damping the scene's (0), the rest
    length the scene's (not add_spring's initial distance), gravity the scene's, no velocity clamp,
    no angular damping."""
    spring = make_scene("spring")
    model = adapter._Model(__import__("newton"), "semi_implicit", spring, 0.1)
    try:
        s = model.settings
        assert s["particle_radius"] == 0.0 and s["particle_grid"] is None and s["triangles"] == 0
        assert s["enable_tri_contact"] is False and model.solver.enable_tri_contact is False
        assert model.model.particle_grid is None and model.model.tri_count == 0
        assert s["spring_damping"] == 0.0 and s["gravity"] == [0.0, 0.0, 0.0] and s["angular_damping"] == 0.0
        assert s["particle_max_velocity"] == adapter.MAX_VELOCITY
        assert model.model.spring_rest_length.numpy()[0] == np.float32(adapter.spring_rest(spring))
    finally:
        model.close()
    cloth = make_scene("cloth", n=4, m=4)
    model = adapter._Model(__import__("newton"), "xpbd", cloth, 0.01)
    try:
        _, _, _, rest = cloth.springs()
        assert np.array_equal(model.model.spring_rest_length.numpy(), rest.astype(np.float32))
        assert model.settings["gravity"] == [0.0, 0.0, float(np.float32(-cloth.values["g"]))]
        assert model.settings["iterations"] == adapter.XPBD_ITERATIONS and model.model.tri_count == 0
    finally:
        model.close()
    fs = adapter._Model(__import__("newton"), "featherstone", make_scene("damped_spring"), 0.1)
    assert fs.settings["angular_damping"] == 0.0 and fs.settings["joint_armature"] == [0.0]
    assert fs.settings["joint_damping"] == [float(np.float32(0.1))]


def test_every_scene_a_mode_does_not_pose_has_a_one_line_reason():
    for mid, mode in adapters.ENGINE_METHODS.items():
        if mode.engine != "newton":
            continue
        assert mode.precision == "float32" and mode.describe()["precision"] == "float32", mid
        for scene_id in SCENES:
            if scene_id in mode.scenes:
                continue
            why = mode.unsupported.get(scene_id)
            assert why and "\n" not in why, (mid, scene_id)
    assert adapters.ENGINE_METHODS["newton:xpbd"].supports(make_scene("pendulum"))[1].startswith("SolverXPBD holds")
    assert "no particle springs" in adapter.NOT_MODES["style3d"]
    assert math.isfinite(adapter.spring_rest(make_scene("spring")))
