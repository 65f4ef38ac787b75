"""Newton's solvers (adapters/newton/) are the schemes the harness names them, measured against
the reference schemes run from Newton's float32 inputs (dt and parameters rounded to float32, the
states rounded: ``harness.measures.identify``), with float32 tolerances; every perturbing default
is off; every scene a mode does not pose has its one-line reason. Skipped where newton cannot be
imported. Each solver's kernels compile on first use, forward passes only, and are cached by Warp
under the harness cache."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

# Skipped without Newton, which is imported where a test uses it: its import is seconds of every
# worker's collection.
pytestmark = pytest.mark.skipif(importlib.util.find_spec("newton") is None, reason="newton is not installed")

import adapters  # noqa: E402
from adapters import newton as adapter  # noqa: E402
from harness.measures.identify import FLOAT32_MATCH_RTOL, float32_inputs, identify, rounded_to_float32  # noqa: E402
from reference import METHODS, integrate  # noqa: E402
from scenarios import SCENES, make_scene  # noqa: E402

#: float32's unit roundoff, 2^-24: the scale of every tolerance below.
U32 = 2.0**-24


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
#: Measured (newton 1.8.0, warp 1.19.0, CPU, the spring's anchor at ``adapter.REACH`` = 20
#: amplitudes): semi_implicit 7.7e-7 and 9.8e-7, featherstone 8.6e-7 and 2.4e-7 (the semi-implicit
#: step's own float32 roundoff, walking over 1000 steps; the particle spring's length s + x is
#: rounded to 2^-24 of s); xpbd 4.1e-6 and 1.9e-6, vbd 8.1e-6 and 3.5e-6 (their velocity is
#: (x_new - x) / h: u32 / (h omega) = 9.5e-7 a step). Held to 2e-5 (336 u32, 2.5 times the
#: largest), where the nearest other scheme is 2.3e-2 away (asserted below it).
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


@pytest.mark.parametrize(
    "mode, scene_id, scheme_id", SPRING_IDENTITIES, ids=[f"{m}-{s}" for m, s, _ in SPRING_IDENTITIES]
)
@pytest.mark.slow
def test_each_newton_solver_is_its_scheme_on_the_spring_to_float32_rounding(mode, scene_id, scheme_id):
    scene = make_scene(scene_id)
    h = scene.period / 100
    assert _deviation(mode, scheme_id, scene, h, 1000) <= SPRING_TOL
    assert _deviation(mode, OTHER[scheme_id], scene, h, 1000) >= APART


def test_the_spring_is_linear_as_far_out_as_the_stability_criterion_looks():
    """The finite horizon calls a run stable while its size stays within GROWTH (10) times the true
    solution's: the particle spring must be the linear spring that far out, its anchor beyond it.
    Semi-implicit Euler's orbit from (1, 0) at h omega = y has size up to 1/sqrt(1 - y/2) in
    (q, v/omega) (its invariant q^2 - y q v + v^2 = 1, omega = 1), which passes 2 amplitudes at
    y = sqrt(3): with the anchor at twice the amplitude the mass crossed it there, and Newton's
    semi-implicit Euler read a limit of 1.73 where the criterion gives 2 (1 - 1/GROWTH^2) = 1.98.
    At y = 1.9 the run is stable and grows as theory says, to float32 rounding; at 1.99 it is not."""
    from harness.measures.stability import GROWTH, finite_horizon_test

    spring = make_scene("spring")
    assert adapter.spring_rest(spring) >= 2 * GROWTH * 1.0
    mode = adapters.ENGINE_METHODS["newton:semi_implicit"]
    for y, stable in ((1.9, True), (1.99, False)):
        ok, info = finite_horizon_test(mode, spring, y / spring.omega, steps=1000)
        assert ok is stable
        assert info["growth"] == pytest.approx(1.0 / math.sqrt(1.0 - y / 2.0), rel=1e-4)


def test_identify_names_xpbd_implicit_euler_at_float32():
    """The harness's own identification of a float32 mode: the candidates at float32 inputs, the
    float32 tolerance (FLOAT32_MATCH_RTOL of the state's size) and the verdict."""
    res = identify("newton:xpbd", make_scene("spring"))
    assert res.precision == "float32" and res.tolerance == pytest.approx(FLOAT32_MATCH_RTOL * 1.0, rel=1e-3)
    assert res.match == "ref:implicit_euler" and res.max_deviation <= SPRING_TOL
    assert "ref:semi_implicit_euler" not in res.matches


@pytest.mark.slow
def test_identify_names_xpbd_the_jacobi_xpbd_scheme_on_the_cloth():
    """Newton's SolverXPBD projects the cloth's springs in parallel (each pass sums every spring's
    correction, then applies them): on the 4 x 4 cloth (k = 1000) over the scene's identification
    run (h omega = 1, 0.5 s: ``Cloth.identification_run``) it is ``ref:xpbd_jacobi`` at its default
    two passes, to float32 rounding (measured 3.7e-5 of a tolerance of 1.5e-4), and nothing else
    comes near: the runner-up, run in full, is 100 times further; sequential XPBD, the scheme the
    engine's name suggests, parts beyond the tolerance within the screen's first steps (2.3e-4
    at the seventh) and never runs in full."""
    res = identify("newton:xpbd", make_scene("cloth", n=4, m=4, k=1000.0), timeout=600)
    assert res.precision == "float32" and res.matches == ["ref:xpbd_jacobi"]
    assert res.runner_up.max_deviation > 100 * res.max_deviation
    sequential = next(c for c in res.candidates if c.method == "ref:xpbd")
    assert not sequential.matches and sequential.max_deviation > res.tolerance
    assert sequential.steps <= res.screen_steps < res.steps


def test_featherstone_pendulum_is_semi_implicit_euler_in_the_angle():
    """A point mass on a revolute joint, theta0 = 2, 1000 steps of period/100, relative to the
    largest |omega| (5.3): measured 5.5e-6 (the float32 sin and the angle's roundoff over a
    nonlinear swing), held to 5e-5; verlet is 1.3e-2 away."""
    pendulum = make_scene("pendulum")
    h = pendulum.period / 100
    assert _deviation("featherstone", "semi_implicit_euler", pendulum, h, 1000) <= 5e-5
    assert _deviation("featherstone", "verlet", pendulum, h, 1000) >= 5e-3


@pytest.mark.parametrize(
    "mode, scheme_id", [("semi_implicit", "semi_implicit_euler"), ("featherstone", "semi_implicit_euler")]
)
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


# ------------------------------------------------------------------ Warp's compile
def _newton_warp_modules(wp) -> list:
    """The Warp module of every kernel Newton's imported modules define."""
    import sys

    return list(
        {
            id(k.module): k.module
            for name, module in list(sys.modules.items())
            if module is not None and name.startswith("newton.")
            for k in list(vars(module).values())
            if isinstance(k, wp.Kernel)
        }.values()
    )


def test_newtons_kernels_compile_forward_only_into_the_harness_cache_to_the_same_bits():
    """Once a model is built, every Warp module of Newton's compiles its kernels without their
    backward passes (``forward_only``), into Warp's cache under the harness cache (so emptying the
    harness cache empties it); a run is the same bit for bit as with the backward passes compiled
    (SolverSemiImplicit's particle kernels, the cheapest to compile both ways)."""
    import warp as wp

    from reference import kernel_cache_dir

    newton, scene = __import__("newton"), make_scene("damped_spring")
    forward = adapter._Model(newton, "semi_implicit", scene, 0.1)
    modules = _newton_warp_modules(wp)
    assert modules and all(wp.get_module_options(m)["enable_backward"] is False for m in modules)
    assert Path(wp.config.kernel_cache_dir).parent == (kernel_cache_dir().parent / adapter.WARP_CACHE).resolve()
    both = adapter._Model(newton, "semi_implicit", scene, 0.1)
    try:
        forward.steps(200)
        for m in modules:
            wp.set_module_options({"enable_backward": True}, module=m)
        both.steps(200)
        for a, b in zip(forward.state(), both.state()):
            assert np.array_equal(a, b)
    finally:
        adapter.forward_only(wp, newton)
        forward.close()
        both.close()
    assert all(wp.get_module_options(m)["enable_backward"] is False for m in modules)


# ------------------------------------------------------------------ model files (harness model)
def _pybullet_data(name: str) -> str:
    pybullet_data = pytest.importorskip("pybullet_data")
    import os

    return os.path.join(pybullet_data.getDataPath(), name)


def _newton_and_mujoco(path: str, variant_name: str):
    from harness.measures.cross_engine import anatomy_differences
    from scenarios import open_model, variant

    scene = variant(open_model(path), variant_name)
    newton_mode, mujoco = (adapters.ENGINE_METHODS[m] for m in ("newton:featherstone", "mujoco:euler"))
    a, b = mujoco.anatomy(scene, scene.own_timestep), newton_mode.anatomy(scene, scene.own_timestep)
    differences = anatomy_differences(a, b, (mujoco.id, newton_mode.id), scene.dof_names)
    return scene, differences, b, newton_mode, mujoco


def test_a_urdf_through_newtons_loader_is_mujocos_model_to_float32_rounding():
    """The cartpole URDF (pybullet_data), conservative: Newton's add_urdf (root fixed, fixed links
    collapsed, as MuJoCo compiles a URDF) builds what MuJoCo builds, no quantity differing by more
    than ANATOMY_RTOL_FLOAT32 (measured: the pole's mass 1.5e-8 and the mass matrix 2.2e-8 off,
    float32's storing and summing), and newton:featherstone follows mujoco:euler over 100 of the
    file's own steps to 3.9e-8 in q (|q| <= 0.13) and 7.1e-8 in v (|v| <= 0.32), measured: the
    float32 roundoff of 100 steps, held to 1e-6. As written, the slider's limits are kept by
    MuJoCo: a note, never silent (a limit as a penalty spring); no pair of its links can collide."""
    path = _pybullet_data("cartpole.urdf")
    scene, differences, built, newton_mode, mujoco = _newton_and_mujoco(path, "conservative")
    assert differences == [] and built["precision"] == "float32"
    assert built["joints"]["slider_to_cart"]["type"] == "slide" and built["joints"]["cart_to_pole"]["type"] == "hinge"
    a = mujoco.simulate(scene, scene.own_timestep, 100)
    b = newton_mode.simulate(scene, scene.own_timestep, 100)
    assert a.ok and b.ok and float(np.max(np.abs(a.q - b.q))) <= 1e-6 and float(np.max(np.abs(a.v - b.v))) <= 1e-6
    s = b.meta.settings
    assert s["precision"] == "float32" and s["angular_damping"] == 0.0 and s["gravity"][2] == pytest.approx(-9.81)
    assert s["contacts"].startswith("none") and s["joint_target_gains"].startswith("0")
    _, written, built, _, _ = _newton_and_mujoco(path, "as_written")
    assert written == []  # the limits [-15, 15] are Newton's too
    said = " ".join(built["notes"])
    # No pair of its links can collide (MuJoCo's parent filter): no contact to note.
    assert "keeps contact" not in said and "penalty spring" in said


def test_what_newton_does_not_apply_in_an_mjcf_is_listed_never_silent(tmp_path):
    """A hinge with friction loss 0.3 (and a spring, its springref 0.1 in the file's degrees, damping
    and armature, which Newton reads; held to float32's 1e-6 relative): Newton's MJCF
    loader reads frictionloss into joint_friction, but SolverFeatherstone applies none, so the model
    it steps lacks it: a difference of the built models and a note, as written; conservative (friction
    loss off in both) nothing differs."""
    path = tmp_path / "hinge_friction.xml"
    path.write_text("""<mujoco model="hinge_friction"><option timestep="0.01"/><worldbody>
  <body name="b" pos="0 0 0"><inertial pos="0 0 -0.5" mass="1" diaginertia="0.01 0.01 0.01"/>
   <joint name="h" type="hinge" axis="0 1 0" stiffness="2" springref="0.1" damping="0.2" armature="0.05"
          frictionloss="0.3"/></body>
 </worldbody></mujoco>""")
    _, differences, built, _, _ = _newton_and_mujoco(str(path), "as_written")
    assert differences == ["newton: joint h has no friction loss (mujoco 0.3)"]
    assert any("SolverFeatherstone applies no joint friction (the loader read up to 0.3)" in n for n in built["notes"])
    joint = built["joints"]["h"]
    assert joint["stiffness"] == pytest.approx(2.0) and joint["spring_ref"] == pytest.approx(
        math.radians(0.1), rel=1e-6
    )
    assert joint["damping"] == pytest.approx(0.2, rel=1e-6) and joint["armature"] == pytest.approx(0.05, rel=1e-6)
    _, conservative, _, _, _ = _newton_and_mujoco(str(path), "conservative")
    assert conservative == []


def test_a_file_newton_refuses_says_newtons_reason_in_one_line():
    """humanoid.xml's <option solver="PGS"> stops Newton's MJCF option parser; r2d2.urdf's meshes
    need trimesh, which Newton's loaders import only for meshes (newton[importers]); a free body
    (capsule.xml) has a quaternion the scene's coordinates do not hold. The particle and
    maximal-coordinate solvers pose no model file, each with its one-line reason."""
    from scenarios import open_model

    featherstone = adapters.ENGINE_METHODS["newton:featherstone"]
    humanoid = open_model(_pybullet_data("mjcf/humanoid.xml"))
    with pytest.raises(ValueError, match=r"^Newton cannot load it: ValueError: invalid literal for int\(\) .*'pgs'$"):
        featherstone.anatomy(humanoid, humanoid.own_timestep)
    capsule = open_model(_pybullet_data("mjcf/capsule.xml"))
    with pytest.raises(ValueError, match="quaternion is not mapped"):
        featherstone.anatomy(capsule, capsule.own_timestep)
    for mode in ("semi_implicit", "xpbd", "vbd"):
        ok, why = adapters.ENGINE_METHODS[f"newton:{mode}"].supports(humanoid)
        assert not ok and "not the file's joint coordinates" in why and "\n" not in why
