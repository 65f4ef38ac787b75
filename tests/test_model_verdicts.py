"""A model file's verdicts that cannot mislead: the cross-engine comparison at a resolved step,
every difference in the two built models named, the conservative variant that keeps armature,
stability limits against the generalized eigenvalues of (K, M), and a file only Bullet loads."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
pybullet_data = pytest.importorskip("pybullet_data")

from scenarios import BulletModelScene, ModelScene, open_model, variant  # noqa: E402

from harness.measures import cross_engine as ce  # noqa: E402

#: Three hinges with joint stiffness and armature, no gravity, no contacts: capsules whose
#: masses the file states (0.7, 0.5, 0.3 kg), so Bullet's loader, which takes a geom's mass
#: from its volume and density, builds other bodies. Shipped for README's ``harness model``.
CHAIN_FILE = Path(__file__).resolve().parents[1] / "scenarios" / "data" / "chain.xml"
CHAIN = CHAIN_FILE.read_text()
#: (length, radius) of each capsule above.
CAPSULES = {"b1": (0.3, 0.03), "b2": (0.25, 0.025), "b3": (0.2, 0.02)}

#: The same three links hanging under gravity, as a URDF with explicit inertials, no springs,
#: no armature: both engines build the same model.
HANGING = """<?xml version="1.0"?>
<robot name="hanging3">
  <link name="base"/>
  <link name="b1"><inertial><origin xyz="0 0 -0.15"/><mass value="0.7"/>
    <inertia ixx="0.006" ixy="0" ixz="0" iyy="0.006" iyz="0" izz="0.0003"/></inertial></link>
  <link name="b2"><inertial><origin xyz="0 0 -0.125"/><mass value="0.5"/>
    <inertia ixx="0.003" ixy="0" ixz="0" iyy="0.003" iyz="0" izz="0.00015"/></inertial></link>
  <link name="b3"><inertial><origin xyz="0 0 -0.1"/><mass value="0.3"/>
    <inertia ixx="0.0013" ixy="0" ixz="0" iyy="0.0013" iyz="0" izz="0.00006"/></inertial></link>
  <joint name="j1" type="continuous"><parent link="base"/><child link="b1"/><axis xyz="0 1 0"/></joint>
  <joint name="j2" type="continuous"><parent link="b1"/><child link="b2"/><origin xyz="0 0 -0.3"/>
    <axis xyz="0 1 0"/></joint>
  <joint name="j3" type="continuous"><parent link="b2"/><child link="b3"/><origin xyz="0 0 -0.25"/>
    <axis xyz="0 1 0"/></joint>
</robot>
"""

HOPPER = Path(pybullet_data.getDataPath()) / "mjcf" / "hopper.xml"


@pytest.fixture
def chain(tmp_path) -> Path:
    path = tmp_path / "chain.xml"
    path.write_text(CHAIN)
    return path


@pytest.fixture
def hanging(tmp_path) -> Path:
    path = tmp_path / "hanging.urdf"
    path.write_text(HANGING)
    return path


def test_the_chains_differences_name_every_body_mass_inertia_missing_armature_and_applied_stiffness(chain):
    scene = variant(ModelScene(chain), "conservative")
    res = ce.cross_engine(scene)
    assert res.resolved and res.verdict == "differ"
    assert max(res.errors) <= ce.RESOLVE_FRACTION * res.difference
    text = "\n".join(res.differences)
    for body, (length, radius) in CAPSULES.items():
        # Bullet's mass is the capsule's volume at density 1000 (independent of both engines).
        volume = math.pi * radius**2 * length + 4.0 / 3.0 * math.pi * radius**3
        line = next(d for d in res.differences if d.startswith(f"pybullet: body {body} mass "))
        built = float(line.split(" mass ")[1].split(" kg")[0])
        assert built == pytest.approx(1000.0 * volume, rel=1e-6)
        assert f"pybullet: body {body} principal inertia" in text
    for joint, armature in (("j1", 0.05), ("j2", 0.03), ("j3", 0.02)):
        assert f"pybullet: joint {joint} has no armature (mujoco {armature:g})" in text
    assert "mass matrix at the initial state differs" in text
    # The stiffness Bullet's loader leaves out is named joint by joint, with how it is applied.
    springs = next(n for n in res.notes if "has no joint stiffness" in n)
    assert all(f"{j} (k {k:g})" in springs for j, k in (("j1", 40), ("j2", 25), ("j3", 10)))
    assert "agree" not in ce.verdict_text(
        res.verdict, res.methods, res.difference, res.errors, res.dt, res.steps, res.horizon, res.differences
    )


def test_a_joint_without_stiffness_is_left_out_of_the_applied_springs(tmp_path):
    path = tmp_path / "chain.xml"
    path.write_text(CHAIN.replace('stiffness="10"', 'stiffness="0"'))
    from harness.methods import get_method

    built = get_method("pybullet:semi_implicit").anatomy(variant(ModelScene(path), "conservative"), 0.002)
    springs = next(n for n in built["notes"] if "has no joint stiffness" in n)
    assert "j1 (k 40), j2 (k 25) as a torque" in springs
    assert [built["joints"][j]["stiffness"] for j in ("j1", "j2", "j3")] == [40.0, 25.0, 0.0]


def test_a_urdf_both_engines_build_alike_agrees_with_a_difference_below_both_errors(hanging):
    scene = variant(ModelScene(hanging, perturb=0.01), "conservative")
    res = ce.cross_engine(scene)
    assert res.differences == []
    assert res.verdict == "agree" and res.resolved
    assert res.difference < min(res.errors)
    assert max(res.errors) <= ce.RESOLVE_FRACTION * ce.AGREE_RTOL
    # The horizon is one period of the slowest mode, from the linearisation's eigenvalues.
    assert res.horizon == pytest.approx(2 * math.pi / scene.slowest_omega)


def test_a_comparison_without_a_resolving_step_says_not_resolved_never_agree(hanging):
    scene = variant(ModelScene(hanging, perturb=0.01), "conservative")
    res = ce.cross_engine(scene, max_steps=256)
    assert res.verdict == "not resolved" and not res.resolved
    assert res.difference < min(res.errors)  # they are close, but the steps cannot show it
    text = ce.verdict_text(
        res.verdict, res.methods, res.difference, res.errors, res.dt, res.steps, res.horizon, res.differences
    )
    assert "not resolved" in text and " agree " not in text


def test_trajectories_within_the_tolerance_of_two_different_built_models_are_not_called_agreement(hanging, monkeypatch):
    scene = variant(ModelScene(hanging, perturb=0.01), "conservative")
    monkeypatch.setattr(ce, "anatomy_differences", lambda *a: ["pybullet: body b2 mass 0.51 kg, mujoco 0.5 kg"])
    res = ce.cross_engine(scene)
    assert res.resolved and res.verdict == "models differ" and res.disagree
    text = ce.verdict_text(
        res.verdict, res.methods, res.difference, res.errors, res.dt, res.steps, res.horizon, res.differences
    )
    assert "are not the same model" in text


def test_the_conservative_variant_keeps_armature_and_gravity_and_switches_off_what_dissipates(chain):
    base = ModelScene(chain, perturb=1e-3)  # small amplitude: the linearisation is (K, M)
    kept = variant(base, "conservative")
    assert kept.id.endswith("~conservative") and kept.switched_off == ["damping"] and kept.kept == ["armature"]
    without = variant(base, "conservative", off=("armature",))
    assert without.id.endswith("~conservative-armature")
    # Armature is inertia: it changes the frequencies (the generalized eigenvalues of (K, M)).
    assert kept.omega < 0.5 * without.omega
    for scene in (kept, without):
        m = scene.engine_model()
        d = mujoco.MjData(m)
        full = np.zeros((m.nv, m.nv))
        q, _ = scene.initial_state()
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        mujoco.mj_fullM(m, d, full)
        eig = np.linalg.eigvals(np.linalg.solve(full, np.diag(m.jnt_stiffness)))
        assert scene.omega == pytest.approx(float(np.sqrt(np.max(eig.real))), rel=1e-4)


@pytest.mark.parametrize(
    "mode, limit", [("mujoco:euler", 2.0), ("mujoco:implicitfast", 2.0), ("mujoco:rk4", 2.0 * math.sqrt(2.0))]
)
@pytest.mark.slow
def test_the_chains_largest_stable_step_at_small_amplitude_is_the_schemes_limit_over_omega_max(chain, mode, limit):
    from scipy.linalg import eigh

    from harness.measures.stability import largest_stable_dt

    scene = variant(ModelScene(chain, perturb=1e-3), "conservative")
    m = scene.engine_model()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    mass = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, mass)
    omega_max = math.sqrt(float(np.max(eigh(np.diag(m.jnt_stiffness), mass, eigvals_only=True))))
    res = largest_stable_dt(mode, scene, criterion="finite_horizon", lo=0.5, hi=4.0)
    assert res.dt_max * omega_max == pytest.approx(limit, rel=0.01)


def test_a_file_mujoco_refuses_but_bullet_loads_is_measured_in_bullet_with_mujocos_reason():
    scene = open_model(HOPPER)
    assert isinstance(scene, BulletModelScene)
    assert "global coordinates" in scene.mujoco_refusal
    assert scene.dof_names[-3:] == ("thigh_joint", "leg_joint", "foot_joint")
    from harness.measures.error import global_error

    res = global_error("pybullet:semi_implicit", variant(scene, "conservative"), 0.002, 200)
    assert res["status"] == "ok" and res["source"].startswith("own run at dt/2")
    assert res["error_max"] is not None and res["error_max"] > 0


@pytest.mark.slow
def test_harness_model_on_a_file_mujoco_refuses_reports_mujocos_reason_and_stores_nothing_on_failure(tmp_path):
    db = tmp_path / "h.sqlite"
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "harness",
            "model",
            str(HOPPER),
            "--variant",
            "conservative",
            "--hz",
            "0",
            "--out",
            str(tmp_path / "r"),
            "--db",
            str(db),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert "mujoco cannot load it: MuJoCo cannot compile it: XML Error: global coordinates" in out.stdout
    assert "`pybullet:semi_implicit`" in out.stdout
    report = (tmp_path / "r" / "report.md").read_text()
    assert "global coordinates no longer supported" in report
    before = db.read_bytes()
    bad = subprocess.run(
        [sys.executable, "-m", "harness", "model", str(HOPPER), "--variant", "nope", "--db", str(db)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert bad.returncode == 2 and "--variant" in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
    assert db.read_bytes() == before


def test_no_energy_figure_of_an_engine_is_computed_on_a_model_it_did_not_build(chain):
    """Issue 54: on chain.xml Drake's parser reads no joint stiffness (the file gives j1, j2 and j3
    one each, read here from the XML), so the file's energy, MuJoCo's function of MuJoCo's model,
    is not Drake's: its energy cell says "model differs" and names what, with no figure; MuJoCo's
    own energy cell on the same file has one."""
    import xml.etree.ElementTree as ET
    from types import SimpleNamespace

    from harness.methods import get_method
    from harness.nightly.cells import _energy_and_error

    stiff = sorted(j.get("name") for j in ET.parse(chain).getroot().iter("joint") if float(j.get("stiffness", 0)) > 0)
    assert stiff == ["j1", "j2", "j3"]
    scene = open_model(chain)
    cells = {}
    for method_id in ("drake:radau3", "mujoco:rk4"):
        task = SimpleNamespace(scene=scene.id, method=method_id, family=method_id.split(":")[0], params={})
        spec = SimpleNamespace(horizon=scene.own_timestep * 200, periods=None)
        suite = SimpleNamespace(series_points=100, cell_timeout=120.0)
        cells[method_id] = _energy_and_error(task, get_method(method_id), scene, scene.own_timestep, spec, suite)[0]
    drake, mine = cells["drake:radau3"], cells["mujoco:rk4"]
    assert drake.value is None and drake.figures.energy_class is None and drake.detail.startswith("model differs")
    named = " ".join(drake.figures.numbers["model_differs"])
    assert all(f"joint {j} has no stiffness" in named for j in stiff) and "j1 has no stiffness" in drake.detail
    assert mine.value is not None and not (mine.detail or "").startswith("model differs")


def test_the_advice_does_not_rank_an_engine_on_the_energy_of_a_model_it_did_not_build(chain):
    from harness.measures.advise import Request, advise_method

    scene = open_model(chain)
    request = Request(hz=60, horizon=0.2, energy_tol=0.5, max_substeps=1).checked()
    res = advise_method("drake:radau3", scene, request, timeout=120)
    assert res.best_row is None
    assert all(r.energy_error is None and "model differs" in r.why for r in res.rows if r.stable)


def test_an_engine_whose_built_model_cannot_be_read_has_no_energy_figure_either(chain, monkeypatch):
    """Where an engine cannot say what it built (its anatomy fails: a release that renamed an API, a
    worker that died), nothing says its model is MuJoCo's: the energy cell says "model unchecked",
    with no figure, never MuJoCo's energy function on an unchecked model."""
    from types import SimpleNamespace

    from harness.measures import cross_engine
    from harness.methods import get_method
    from harness.nightly.cells import _energy_and_error

    real = cross_engine.anatomy

    def failing(method_id, scene, dt, timeout=60.0):
        if method_id.startswith("pybullet:"):
            raise RuntimeError("the engine's API changed")
        return real(method_id, scene, dt, timeout)

    monkeypatch.setattr(cross_engine, "anatomy", failing)
    scene = open_model(chain)
    method = get_method("pybullet:semi_implicit")
    said = cross_engine.built_differently(method, scene, scene.own_timestep)
    assert said == [f"pybullet: {cross_engine.UNCHECKED}: RuntimeError: the engine's API changed"]
    assert cross_engine.differs_word(said) == "model unchecked"
    assert cross_engine.differs_word(["drake: joint j1 has no stiffness (mujoco 40)"]) == "model differs"
    task = SimpleNamespace(scene=scene.id, method=method.id, family="pybullet", params={})
    spec = SimpleNamespace(horizon=scene.own_timestep * 50, periods=None)
    suite = SimpleNamespace(series_points=50, cell_timeout=120.0)
    energy = _energy_and_error(task, method, scene, scene.own_timestep, spec, suite)[0]
    assert energy.value is None and energy.detail.startswith("model unchecked: pybullet built a model not compared")
    assert cross_engine.built_differently(get_method("mujoco:rk4"), scene, scene.own_timestep) == []
