"""A model file as a scene (``scenarios/model.py``): bad input refused in one line, the scene's
identity, features, variants, state and energy, and the truth checks against independent
numbers (a linear model's stability limits from the generalised eigenvalues of (K, M); the
unit spring as MJCF against the ``spring`` scene; observed orders on the double pendulum)."""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest
from scipy.linalg import eigh

mujoco = pytest.importorskip("mujoco")

from records import InvalidInput  # noqa: E402
from scenarios import ModelScene, make_scene, variant  # noqa: E402
from scenarios._model_reference import reference_grid  # noqa: E402

from harness.measures.energy import energy_behaviour  # noqa: E402
from harness.measures.order import observed_order  # noqa: E402
from harness.measures.stability import largest_stable_dt  # noqa: E402
from harness.methods import get_method  # noqa: E402


def pybullet_data(rel: str) -> str:
    pb = pytest.importorskip("pybullet_data")
    return os.path.join(pb.getDataPath(), rel)


#: Three nested slide joints along x with springs: M is the (constant) matrix of the summed
#: masses below each joint, K = diag(stiffness); no gravity, nothing else. Linear exactly.
LINEAR = """<mujoco model="linear3">
  <option timestep="0.01" gravity="0 0 0"/>
  <worldbody>
    <body name="a"><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
      <joint name="xa" type="slide" axis="1 0 0" stiffness="40"/>
      <body name="b"><inertial pos="0 0 0" mass="0.5" diaginertia="1 1 1"/>
        <joint name="xb" type="slide" axis="1 0 0" stiffness="90"/>
        <body name="c"><inertial pos="0 0 0" mass="0.25" diaginertia="1 1 1"/>
          <joint name="xc" type="slide" axis="1 0 0" stiffness="10"/>
        </body>
      </body>
    </body>
  </worldbody>
  <keyframe><key qpos="0.01 -0.005 0.002" qvel="0 0 0"/></keyframe>
</mujoco>
"""


@pytest.fixture
def linear_file(tmp_path):
    path = tmp_path / "linear3.xml"
    path.write_text(LINEAR)
    return path


def omega_max_from_eigenvalues(scene) -> float:
    """sqrt of the largest generalised eigenvalue of (K, M), M read from MuJoCo (mj_fullM) at
    the initial state, K the joints' stiffness: independent of the scene's own Jacobian."""
    m = mujoco.MjModel.from_xml_path(scene.file.path)
    d = mujoco.MjData(m)
    d.qpos[:] = scene.initial_state()[0]
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    K = np.diag(m.jnt_stiffness)
    return float(math.sqrt(eigh(K, M, eigvals_only=True)[-1]))


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(
    "content, suffix, says",
    [
        (None, ".xml", "no such file"),
        ("<mujoco><worldbody>", ".xml", "malformed XML"),
        ("<robot name='r'/>", ".xml", "root element <robot>"),
        ("<mujoco/>", ".obj", "unknown format"),
        ("<mujoco><worldbody><body><geom size='.1'/></body></worldbody></mujoco>", ".xml", "no degrees of freedom"),
        (
            """<robot name="r"><link name="base"/><link name="arm"><visual><geometry><mesh filename="nowhere.stl"/>
        </geometry></visual><collision><geometry><mesh filename="nowhere.stl"/></geometry></collision>
        <inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
        <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
        <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>""",
            ".urdf",
            "nowhere.stl",
        ),
    ],
)
def test_bad_model_files_are_refused_in_one_line(tmp_path, content, suffix, says):
    path = tmp_path / f"m{suffix}"
    if content is not None:
        path.write_text(content)
    with pytest.raises(InvalidInput) as info:
        ModelScene(path)
    message = str(info.value)
    assert says in message and "\n" not in message and str(path) in message


def test_unknown_variant_and_bad_switch_are_refused(linear_file):
    scene = ModelScene(linear_file)
    with pytest.raises(InvalidInput, match="unknown variant 'loose'"):
        variant(scene, "loose")
    with pytest.raises(InvalidInput, match="contact=2 is out of range"):
        ModelScene(linear_file, contact=2)


# ------------------------------------------------------------------ identity, features, state
def test_the_id_is_the_file_name_and_content_hash(tmp_path, linear_file):
    a = ModelScene(linear_file)
    assert a.id.startswith("model:linear3.xml@") and len(a.id.split("@")[1]) == 8
    assert a.kind == "model"
    linear_file.write_text(LINEAR.replace('stiffness="40"', 'stiffness="41"'))
    b = ModelScene(linear_file)
    assert b.id != a.id  # an edited model is a new series


def test_features_found_and_switched_off_on_the_double_pendulum():
    path = pybullet_data("mjcf/inverted_double_pendulum.xml")
    written = ModelScene(path)
    # Its geoms have contype bits, yet no pair of them can collide (parent filter): no contact.
    assert set(written.found) == {"damping", "actuators", "limits", "gravity"}
    assert written.switched_off == []
    cons = variant(written, "conservative")
    # What dissipates or injects energy goes; gravity, a conservative force, stays unless asked.
    assert cons.switched_off == ["damping", "actuators", "limits"] and cons.kept == ["gravity"]
    assert not cons.engine_model().opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY)
    cons = variant(written, "conservative", off=("gravity",))
    assert cons.switched_off == ["damping", "actuators", "limits", "gravity"]
    assert cons.id.endswith("~conservative-gravity")
    m = cons.engine_model()
    bits = mujoco.mjtDisableBit
    for bit in (bits.mjDSBL_CONTACT, bits.mjDSBL_ACTUATION, bits.mjDSBL_LIMIT, bits.mjDSBL_GRAVITY):
        assert m.opt.disableflags & int(bit)
    assert not np.any(m.dof_damping)
    # The compiled file itself is untouched: the as-written variant still has its damping.
    assert np.all(written.engine_model().dof_damping == 0.05)


def test_the_initial_state_is_the_keyframe_or_a_seeded_perturbation(linear_file):
    keyed = ModelScene(linear_file)
    np.testing.assert_array_equal(keyed.initial_state()[0], [0.01, -0.005, 0.002])
    path = pybullet_data("mjcf/inverted_double_pendulum.xml")
    a, b, c = ModelScene(path, seed=3), ModelScene(path, seed=3), ModelScene(path, seed=4)
    np.testing.assert_array_equal(np.concatenate(a.initial_state()), np.concatenate(b.initial_state()))
    assert not np.array_equal(np.concatenate(a.initial_state()), np.concatenate(c.initial_state()))
    assert "seed=3" in a.describe_state()


def test_energy_is_computed_from_the_state_itself():
    """Against MuJoCo's own d.energy after mj_forward on the same state (energy flag on): the
    same numbers, where d.energy after a step would describe the state before it."""
    scene = ModelScene(pybullet_data("mjcf/inverted_double_pendulum.xml"))
    m = scene.engine_model()
    m.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(1)
    qs, vs = rng.normal(size=(5, m.nq)), rng.normal(size=(5, m.nv))
    expected = []
    for q, v in zip(qs, vs):
        d.qpos[:], d.qvel[:] = q, v
        mujoco.mj_forward(m, d)
        expected.append(d.energy[0] + d.energy[1])
    np.testing.assert_allclose(scene.energy(qs, vs), expected, rtol=1e-12)


# ------------------------------------------------------------------ reference
def test_the_reference_states_its_own_error():
    scene = variant(ModelScene(pybullet_data("mjcf/inverted_double_pendulum.xml")), "conservative")
    grid = reference_grid(scene)
    assert grid.converged and 0 < grid.error <= 1e-11
    # Its estimate is an upper bound: the finest level against one more halving.
    assert len(grid.history) >= 1 and grid.history[-1][1] == grid.error


def test_an_error_below_the_reference_is_not_reported_as_a_number():
    from harness.measures.error import global_error

    scene = variant(
        ModelScene(pybullet_data("mjcf/inverted_double_pendulum.xml"), perturb=0.01), "conservative", off=("gravity",)
    )
    res = global_error("mujoco:rk4", scene, 0.01, 100)
    assert res["reference_error"] > 0 and res["below_reference"]
    order = observed_order("mujoco:rk4", scene)
    assert order["order"] is None and order["excluded"]
    assert all("below the reference's accuracy" in p["reason"] or "roundoff" in p["reason"] for p in order["excluded"])


# ------------------------------------------------------------------ truth checks
def test_omega_is_the_largest_natural_frequency_of_a_linear_model(linear_file):
    scene = ModelScene(linear_file)
    assert scene.omega == pytest.approx(omega_max_from_eigenvalues(scene), rel=1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("mode, limit", [("euler", 2.0), ("implicitfast", 2.0), ("rk4", 2.0 * math.sqrt(2.0))])
def test_linear_model_stability_limit_is_theory_over_omega_max(linear_file, mode, limit):
    scene = ModelScene(linear_file)
    w = omega_max_from_eigenvalues(scene)
    res = largest_stable_dt(get_method(f"mujoco:{mode}"), scene, lo=0.25, hi=16.0, rtol=1e-4)
    assert res.verdict == "limited"
    assert res.dt_max == pytest.approx(limit / w, rel=0.01)


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["euler", "rk4"])
def test_the_unit_spring_as_a_file_gives_the_spring_scenes_figures(mode):
    """scenarios/data/unit_spring.xml is the spring scene written as MJCF (k = m = x0 = 1, v0 = 0)."""
    model, spring = make_scene("model"), make_scene("spring")
    assert model.omega == pytest.approx(1.0, rel=1e-9)
    method = get_method(f"mujoco:{mode}")
    a = largest_stable_dt(method, model, lo=0.25, hi=16.0, rtol=1e-4)
    b = largest_stable_dt(method, spring, lo=0.25, hi=16.0, rtol=1e-4)
    assert a.omega_dt_max == pytest.approx(b.omega_dt_max, rel=1e-3)
    oa, ob = observed_order(method, model), observed_order(method, spring)
    assert oa["order"] == pytest.approx(ob["order"], abs=0.01)
    ea = energy_behaviour(method, model, 0.1, 2000)
    eb = energy_behaviour(method, spring, 0.1, 2000)
    assert ea["classification"] == eb["classification"]
    assert ea["max_rel_error"] == pytest.approx(eb["max_rel_error"], rel=1e-9)


@pytest.mark.parametrize("mode, order", [("euler", 1.0), ("implicitfast", 1.0), ("rk4", 4.0)])
def test_observed_orders_on_the_conservative_double_pendulum(mode, order):
    scene = variant(ModelScene(pybullet_data("mjcf/inverted_double_pendulum.xml")), "conservative")
    res = observed_order(f"mujoco:{mode}", scene)
    assert res["order"] == pytest.approx(order, abs=0.1)


# ------------------------------------------------------------------ harness model
def cli(*argv):
    import io
    from contextlib import redirect_stderr, redirect_stdout

    from harness.cli import main

    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as exc:
            code = exc.code
    return code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize(
    "content, says",
    [
        (None, "no such file"),
        ("<mujoco><worldbody>", "malformed XML"),
        ("<mujoco><worldbody><body><geom size='.1'/></body></worldbody></mujoco>", "no degrees of freedom"),
    ],
)
def test_harness_model_refuses_bad_files_in_one_line_exit_2(tmp_path, content, says):
    path = tmp_path / "bad.xml"
    if content is not None:
        path.write_text(content)
    code, out, err = cli("model", str(path), "--out", str(tmp_path / "out"))
    assert code == 2 and out == ""
    assert says in err and err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "out").exists()  # refused before anything ran or was written


@pytest.mark.parametrize(
    "flag, value, says",
    [
        ("--variant", "loose", "unknown --variant 'loose'"),
        ("--keep", "wind", "unknown --keep 'wind'"),
        ("--hz", "-1", "--hz=-1 is out of range"),
        ("--methods", "drake:nope*", "--methods pattern 'drake:nope*' matches no mode"),
    ],
)
def test_harness_model_refuses_bad_flags(tmp_path, linear_file, flag, value, says):
    code, _, err = cli("model", str(linear_file), flag, value, "--out", str(tmp_path / "out"))
    assert code == 2 and says in err and err.count("\n") == 1


def test_harness_model_on_the_unit_spring_file(tmp_path):
    """Every MuJoCo mode (--methods: the other engines' model runs have tests of their own) on the
    file as written, the report written, then the conservative variant; the figures are the cells'."""
    from scenarios.model import DEFAULT_FILE

    out = tmp_path / "out"
    code, text, _ = cli(
        "model",
        DEFAULT_FILE,
        "--out",
        str(out),
        "--hz",
        "0",
        "--jobs",
        "1",
        "--methods",
        "mujoco:*",
        "--variant",
        "as_written",
    )
    assert code == 0
    assert "perturbs an integrator: nothing found" in text
    assert "initial state: the model's first keyframe" in text
    for mode in ("euler", "rk4", "implicit", "implicitfast", "discrete"):
        assert f"| `mujoco:{mode}` | ok |" in text
    assert (out / "report.md").is_file() and any((out / "charts").glob("*stability.png"))
    code, js, _ = cli(
        "model",
        DEFAULT_FILE,
        "--out",
        str(out),
        "--hz",
        "0",
        "--json",
        "--variant",
        "conservative",
        "--methods",
        "mujoco:euler,mujoco:rk4",
    )
    data = json.loads(js)
    stab = {c["method"]: c["value"] for c in data["cells"] if c["measure"] == "stability"}
    assert stab["mujoco:euler"] == pytest.approx(2.0, rel=2e-3)  # the spring scene's 2 (h*omega)
    assert stab["mujoco:rk4"] == pytest.approx(2 * math.sqrt(2), rel=2e-3)


# ------------------------------------------------------------------ the nightly
def _models_suite(paths):
    from harness.nightly.models import with_models
    from harness.nightly.suites import Suite

    base = Suite(
        "models-test",
        {},
        methods=("mujoco:euler", "mujoco:rk4", "pybullet:semi_implicit"),
        bounds=False,
        identify=False,
        cost_repeats=2,
        cost_steps=2000,
        stability_steps=200,
    )
    suite = with_models(base, paths)
    # The engine modes of this test only (with_models gives a model every engine mode).
    import dataclasses

    return dataclasses.replace(
        suite, scenes={k: dataclasses.replace(v, methods=base.methods) for k, v in suite.scenes.items()}
    )


@pytest.mark.slow
def test_the_nightly_stores_reports_and_trends_two_model_files(tmp_path):
    """Two files (an MJCF written here, pybullet_data's cartpole URDF), three runs: the model cells
    are stored under the files' hashed ids, reported, compared run to run with no regression; an
    edited file is a new series, never a regression of the old one."""
    from harness.history.storage import History
    from harness.nightly.run import run_nightly

    spring = tmp_path / "spring.xml"
    spring.write_text(
        open(os.path.join(os.path.dirname(__file__), "..", "scenarios", "data", "unit_spring.xml")).read()
    )
    cart = pybullet_data("cartpole.urdf")
    db, out = tmp_path / "h.sqlite", tmp_path / "out"
    first = run_nightly(_models_suite([spring, cart]), out, db, jobs=2)
    second = run_nightly(_models_suite([spring, cart]), out, db, jobs=2)
    assert second["previous"] == first["run_id"] and second["regressions"] == []
    cells = History(db).cells(second["run_id"])
    scenes = set(cells.scene)
    ids = {ModelScene(spring).id, ModelScene(cart).id}
    assert ids <= scenes and {f"{i}~conservative" for i in ids} <= scenes
    assert set(cells[cells.scene == ModelScene(cart).id].method) == {
        "mujoco:euler",
        "mujoco:rk4",
        "pybullet:semi_implicit",
    }
    report = (out / "report.md").read_text()
    assert f"### `{ModelScene(cart).id}`" in report
    # The engines compared from the same state: a stored cell on each conservative variant (both
    # files are one model in both engines: the spring's semi-implicit Euler, the cartpole's).
    cross = cells[cells.measure == "cross_engine"]
    # The spring file has nothing to switch off: as written, it is conservative too; the cartpole's is not.
    assert set(cross.scene) == {f"{i}~conservative" for i in ids} | {ModelScene(spring).id}
    assert set(cross.method) == {"pybullet:semi_implicit"}
    assert (cross.status == "ok").all()
    assert cross.detail.str.startswith("mujoco:euler and pybullet:semi_implicit agree within").all()
    assert report.count("Two engines from the same state: mujoco:euler and pybullet:semi_implicit") == 3
    spring.write_text(spring.read_text().replace('stiffness="1"', 'stiffness="4"'))
    third = run_nightly(_models_suite([spring, cart]), out, db, jobs=2)
    assert third["regressions"] == []  # the edited spring is a new series (its stability limit moved by 2x)
    new_id = ModelScene(spring).id
    assert new_id not in ids and new_id in set(History(db).cells(third["run_id"]).scene)


def test_a_failed_model_run_touches_nothing_stored(tmp_path):
    db = tmp_path / "h.sqlite"
    db.write_bytes(b"")  # an existing history file, whatever it holds, must not change
    before = db.stat().st_mtime_ns
    code, _, err = cli(
        "nightly",
        "--suite",
        "smoke",
        "--db",
        str(db),
        "--out",
        str(tmp_path / "out"),
        "--model",
        str(tmp_path / "missing.xml"),
    )
    assert code == 2 and "no such file" in err and err.count("\n") == 1
    assert db.stat().st_mtime_ns == before and db.read_bytes() == b"" and not (tmp_path / "out").exists()


def test_pyproject_lists_the_nightly_models(tmp_path):
    from harness.nightly.models import configured_models

    (tmp_path / "pyproject.toml").write_text('[tool.harness]\nmodels = ["robots/arm.urdf"]\n')
    assert configured_models(tmp_path / "pyproject.toml") == [str(tmp_path / "robots" / "arm.urdf")]
    (tmp_path / "pyproject.toml").write_text('[tool.harness]\nmodels = "arm.urdf"\n')
    with pytest.raises(InvalidInput, match="models must be a list"):
        configured_models(tmp_path / "pyproject.toml")


# ------------------------------------------------------------------ pybullet and the cross-engine comparison
def test_pybullet_runs_a_model_with_its_defaults_off_and_recorded():
    scene = variant(ModelScene(pybullet_data("kuka_iiwa/model.urdf")), "conservative", off=("gravity",))
    traj = get_method("pybullet:semi_implicit").simulate(scene, scene.own_timestep, 500, 100)
    s = traj.meta.settings
    assert traj.ok and s["jointDamping"] == [0.0] * 7 and s["jointDamping_read_from_file"] == [0.5] * 7
    assert s["maxJointVelocity"] == "inf" and s["linearDamping"] == 0 and s["gravity"] == [0.0, 0.0, 0.0]
    assert "URDF_USE_INERTIA_FROM_FILE" in s["loaded"]
    # Damping really off (a call of its own): semi-implicit Euler keeps the energy within 1e-3 here.
    e = traj.energy[:, 0]
    assert np.max(np.abs(e - e[0])) / e[0] < 1e-3


def test_an_engine_that_cannot_load_the_file_says_why_in_one_line(tmp_path):
    from harness.nightly.models import cannot_load_all

    path = tmp_path / "tendon.xml"  # two slides coupled by a tendon spring: Bullet has no tendons
    path.write_text(
        LINEAR.replace(
            "</worldbody>",
            '</worldbody><tendon><fixed stiffness="5"><joint joint="xa" '
            'coef="1"/><joint joint="xc" coef="-1"/></fixed></tendon>',
        )
    )
    # MuJoCo's loader beside Bullet's (Newton's and Drake's refusals have tests of their own; Newton
    # builds Warp kernels for seconds on an empty cache).
    engines = ("mujoco", "pybullet")
    why = cannot_load_all([ModelScene(path)], engines)[0]
    assert set(why) == {"pybullet"} and "tendons" in why["pybullet"] and "\n" not in why["pybullet"]
    # a joint spring Bullet applies as a torque from Python
    assert cannot_load_all([make_scene("model")], engines)[0] == {}


def test_pybullet_applies_the_files_joint_springs_as_mujoco_integrates_them():
    """The unit spring file: Bullet (the spring a TORQUE_CONTROL torque from Python) and MuJoCo's
    Euler are both semi-implicit Euler on m x'' = -k x: the same trajectory to roundoff."""
    scene = make_scene("model")
    a = get_method("pybullet:semi_implicit").simulate(scene, 0.1, 1000, 100)
    b = get_method("mujoco:euler").simulate(scene, 0.1, 1000, 100)
    assert a.ok and b.ok
    np.testing.assert_allclose(a.q, b.q, atol=1e-12)


def test_cross_engine_agreement_and_what_differs():
    from harness.measures.cross_engine import cross_engine

    cart = cross_engine(variant(ModelScene(pybullet_data("cartpole.urdf")), "conservative"))
    assert cart.verdict == "agree" and cart.differences == [] and cart.difference <= min(cart.errors)
    pend = cross_engine(variant(ModelScene(pybullet_data("mjcf/inverted_double_pendulum.xml")), "conservative"))
    assert pend.verdict == "differ" and pend.disagree is True
    assert max(pend.errors) <= 0.1 * pend.difference
    # The two built models, read independently: MuJoCo's mj_fullM against Bullet's calculateMassMatrix.
    mj, pb = (np.array(a["mass_matrix"]) for a in pend.anatomies)
    assert not np.allclose(mj, pb, rtol=1e-6)
    assert any(d.startswith("pybullet: mass matrix at the initial state") for d in pend.differences)


def test_a_model_unstable_at_its_own_timestep_is_a_recorded_result(tmp_path):
    """k = 1e6 at the file's dt = 0.01: h*omega = 10, past every explicit limit. The energy run
    ends ``unstable`` where it blew up, and the stability cell's limit lies below the nominal step."""
    from harness.history.storage import History
    from harness.nightly.run import run_nightly

    stiff = tmp_path / "stiff.xml"
    stiff.write_text(
        open(os.path.join(os.path.dirname(__file__), "..", "scenarios", "data", "unit_spring.xml"))
        .read()
        .replace('stiffness="1"', 'stiffness="1e6"')
    )
    res = run_nightly(_models_suite([stiff]), tmp_path / "out", tmp_path / "h.sqlite", jobs=2)
    cells = History(tmp_path / "h.sqlite").cell_records(res["run_id"])
    sid = ModelScene(stiff).id
    energy = {c.method: c for c in cells if c.scene == sid and c.measure == "energy"}
    stab = {c.method: c for c in cells if c.scene == sid and c.measure == "stability"}
    for mode in ("mujoco:euler", "pybullet:semi_implicit"):
        assert energy[mode].status == "unstable" and energy[mode].figures.failed_step is not None
        # h*omega 2 (semi-implicit Euler), below the nominal 10; to 0.5%: the energy criterion (1e3 x)
        # is met a little below 2, where the bounded swing 1/(1 - (h omega / 2)^2) passes 1e3
        assert stab[mode].value == pytest.approx(2.0, rel=5e-3)
    assert energy["mujoco:rk4"].status == "unstable"


def test_every_measure_command_takes_a_model_file():
    from scenarios.model import DEFAULT_FILE

    code, out, _ = cli("energy", DEFAULT_FILE, "--method", "mujoco:rk4", "--dt", "0.1", "--steps", "100", "--json")
    assert code == 0
    res = json.loads(out)
    assert res["scene"] == make_scene("model").id and res["status"] == "ok"
    code, _, err = cli("energy", DEFAULT_FILE, "--method", "ref:rk4", "--dt", "0.1", "--steps", "10")
    assert code == 2 and "no force kernel" in err


def test_pybullet_is_measured_against_its_own_refined_run():
    """On a model file the reference is MuJoCo's RK4 on MuJoCo's model; Bullet builds its own, so
    its error is Richardson's estimate from its own run at dt/2. On the unit spring file, where
    Bullet integrates m x'' = -k x by semi-implicit Euler, the estimate is checked against the
    exact error of the same scheme on the `spring` scene (an independent closed form); on the
    conservative double pendulum its observed order is 1."""
    from harness.measures.error import global_error
    from harness.measures.order import observed_order

    scene = make_scene("model")
    dt, steps = 0.01, 628
    own = global_error("pybullet:semi_implicit", scene, dt, steps)
    assert own["source"].startswith("own run at dt/2") and own["below_reference"] is False
    exact = global_error("ref:semi_implicit_euler", make_scene("spring"), dt, steps)
    assert exact["source"] == "exact"
    # Richardson is exact up to the next order: relative difference O(h omega).
    assert own["error_max"] == pytest.approx(exact["error_max"], rel=0.05)
    assert own["reference_error"] == pytest.approx(own["error_max"] / 2)
    # MuJoCo's own modes keep MuJoCo's reference.
    assert global_error("mujoco:euler", scene, dt, 100)["source"].endswith("reference_solution")

    pend = variant(ModelScene(pybullet_data("mjcf/inverted_double_pendulum.xml")), "conservative")
    res = observed_order("pybullet:semi_implicit", pend)
    assert res["order"] == pytest.approx(1.0, abs=0.1)


def test_a_model_run_tries_the_loaders_of_the_engines_it_steps_alone(monkeypatch):
    """``harness model --methods mujoco:*`` neither tries another engine's loader (an import of
    seconds) nor compares another engine's mode; the nightly's models try every engine's."""
    from harness.nightly import models
    from scenarios.model import DEFAULT_FILE

    tried = []  # which engines' loaders each call would try (none is run: every engine loads this file)
    monkeypatch.setattr(
        models,
        "cannot_load_all",
        lambda scenes, engines=models.MODEL_ENGINES: tried.append(engines) or [{} for _ in scenes],
    )
    suite = models.model_suite([DEFAULT_FILE], ("conservative",), methods=["mujoco:*"])
    assert tried == [("mujoco",)]
    assert all(not spec.extras.cross_engine for spec in suite.scenes.values())
    assert {m.split(":")[0] for m in suite.methods} == {"mujoco"}
    # A nightly suite that names its methods tries their engines' loaders; one that names none, every one.
    from harness.nightly.suites import Suite

    tried.clear()
    models.with_models(Suite("models", {}, methods=("mujoco:euler", "pybullet:semi_implicit")), [DEFAULT_FILE])
    models.with_models(Suite("models", {}, methods=None), [DEFAULT_FILE])
    assert tried == [("mujoco", "pybullet"), models.MODEL_ENGINES]
