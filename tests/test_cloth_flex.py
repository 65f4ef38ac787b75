"""MuJoCo's flexcomp membrane on the cloth's grid (``cloth_flex``): labelled as not the cloth's
model, its perturbing defaults off and recorded, its energy and frequency checked against
numbers computed here, its error and order against its own refined RK4 run, bad input refused."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import adapters
from harness.cli import main
from harness.measures.common import started_at
from harness.measures.order import observed_order
from harness.methods import get_method
from records import InvalidInput
from scenarios import make_scene

mujoco = pytest.importorskip("mujoco")

#: The small sheet every test steps: 3 x 3 masses, two pinned corners, 7 free (21 coordinates).
SMALL = {"n": 3, "m": 3, "k": 1000.0}


@pytest.fixture(scope="module")
def flex():
    return make_scene("cloth_flex", **SMALL)


def _step(mode, scene, hw, steps, every=1):
    return adapters.ENGINE_METHODS[f"mujoco:{mode}"].simulate(scene, hw / scene.omega, steps, every)


# ------------------------------------------------------------------ what it is, and says it is
def test_every_output_says_it_is_not_the_cloths_model(flex, capsys):
    assert "not the same model" in flex.model_note and "not the same model" in flex.describe()["model_note"]
    assert make_scene("cloth").model_note is None
    args = [
        "energy",
        "cloth_flex",
        "--method",
        "mujoco:rk4",
        "--dt",
        "1e-4",
        "--steps",
        "20",
        *(f"--set={k}={v}" for k, v in SMALL.items()),
    ]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0] == f"cloth_flex: {flex.model_note}"
    assert main([*args, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["model_note"] == flex.model_note


def test_reference_schemes_and_the_implicit_modes_do_not_step_it(flex):
    ok, why = get_method("ref:rk4").supports(flex)
    assert not ok and why
    for mode in ("implicit", "implicitfast"):
        ok, why = adapters.ENGINE_METHODS[f"mujoco:{mode}"].supports(flex)
        assert not ok and "no longer integrated implicitly" in why
        # The reason is MuJoCo's own: it refuses to compile or step a flex with elasticity there.
        with pytest.raises(ValueError, match="no longer integrated implicitly"):
            mujoco.MjModel.from_xml_string(flex.flex_xml(integrator=mode))
    for mode in ("euler", "rk4", "discrete"):
        assert adapters.ENGINE_METHODS[f"mujoco:{mode}"].supports(flex) == (True, "")


@pytest.mark.parametrize("pins", [0, 1])
def test_grid_masses_and_pins_are_the_clothes(pins):
    """Against numbers computed here from the parameters: vertices, triangles, the pinned count,
    the total moving mass and each mass (the mass matrix's diagonal), every vertex at its node."""
    scene = make_scene("cloth_flex", **SMALL, pins=pins, mass=2.0)
    n, m = 3, 3
    pinned = m if pins else 2
    run = _step("euler", scene, 0.1, 1)
    s = run.meta.settings
    assert s["flex_vertices"] == n * m and s["flex_triangles"] == 2 * (n - 1) * (m - 1)
    assert s["pinned_vertices"] == pinned
    assert s["total_mass"] == pytest.approx(2.0 * (n * m - pinned) / (n * m), rel=1e-15)
    np.testing.assert_allclose(s["mass_matrix_diagonal"], 2.0 / (n * m), rtol=1e-15)
    q0, _ = scene.initial_state()
    np.testing.assert_allclose(run.q[0, 0], q0, atol=1e-15)
    np.testing.assert_array_equal(q0, make_scene("cloth", **SMALL, pins=pins).initial_state()[0])
    assert scene.ndof == 3 * (n * m - pinned)


def test_perturbing_defaults_are_off_and_recorded(flex):
    s = _step("rk4", flex, 0.1, 1).meta.settings
    assert {"mjDSBL_CONTACT", "mjDSBL_CONSTRAINT", "mjDSBL_AUTORESET"} <= set(s["disabled"])
    assert s["contype"] == s["conaffinity"] == s["selfcollide"] == 0
    assert s["edge_stiffness"] == s["edge_damping"] == s["elasticity_damping"] == 0.0 and s["edge_equality"] == 0
    assert s["stretch"] and not s["bending"]
    assert not any(s["armature"]) and not any(s["joint_damping"]) and not any(s["joint_stiffness"])
    assert s["gravity"] == [0.0, 0.0, -9.81]


# ------------------------------------------------------------------ energy
def _engine_force(scene, q):
    """MuJoCo's passive force at the scene state q, in the scene's coordinates."""
    m = scene.engine_model()
    d = mujoco.MjData(m)
    d.qpos[:], _ = scene.engine_state(q, np.zeros_like(q))
    mujoco.mj_forward(m, d)
    return scene.scene_state(d.qfrc_passive, d.qfrc_passive)[1], m, d


def test_membrane_energy_is_the_potential_of_mujocos_force(flex):
    """-grad E (central differences of the energy computed here) is MuJoCo's qfrc_passive at a
    strained state, to 1e-8 (the differences' truncation and roundoff); mj_energyPos leaves the
    membrane's energy out, which is why the scene computes it."""
    rng = np.random.default_rng(3)
    q = flex.initial_state()[0] + rng.normal(0.0, 0.01, flex.ndof)
    force, m, d = _engine_force(flex, q)
    h = 1e-7
    grad = np.array(
        [(flex.membrane_energy(q + h * e) - flex.membrane_energy(q - h * e)) / (2 * h) for e in np.eye(flex.ndof)]
    )
    assert np.max(np.abs(force + grad)) <= 1e-8 * np.max(np.abs(force))
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_GRAVITY)
    mujoco.mj_energyPos(m, d)
    assert d.energy[0] == 0.0 and flex.membrane_energy(q) > 1e-3


def test_rk4_at_a_small_step_keeps_the_energy_computed_from_the_state(flex):
    """The energy (kinetic + membrane + gravity) is complete: MuJoCo's RK4 at h omega = 0.05
    keeps it to 1e-10 over 400 steps (RK4's error there: (h omega)^4 / 120 per period, ~1e-7 of
    the stiff modes' share, itself small) while gravity and the membrane trade 5% of it."""
    run = _step("rk4", flex, 0.05, 400, every=10)
    assert run.ok
    e = run.energy[:, 0]
    assert np.max(np.abs(e - e[0])) / e[0] < 1e-10
    membrane = flex.membrane_energy(run.q[:, 0])
    assert membrane.max() > 1e-4 * e[0]


# ------------------------------------------------------------------ omega
def test_omega_is_the_clothes_and_the_small_oscillation_frequency(flex):
    """Young's modulus is chosen so that the flex's omega_max at rest is the spring cloth's; and
    that omega is the frequency MuJoCo's sheet oscillates at: without gravity, started in the top
    eigenvector of the stiffness matrix at 1e-7 of the spacing, RK4 at h omega = 0.02 swings
    through zero at multiples of pi / omega (to 1e-4: the step and the crossing's interpolation)."""
    assert flex.omega == pytest.approx(make_scene("cloth", **SMALL).omega, rel=1e-8)
    still = make_scene("cloth_flex", **SMALL, g=0.0)
    assert still.young == flex.young
    lam, vec = np.linalg.eigh(still.hessian(still.initial_state()[0]).toarray())
    omega = math.sqrt(lam[-1] / still.node_mass)
    assert omega == pytest.approx(still.omega, rel=1e-12)
    q0 = still.initial_state()[0] + 1e-7 * still.values["s"] * vec[:, -1]
    moved = started_at(still, q0, np.zeros_like(q0))
    hw, periods = 0.02, 3
    steps = int(periods * 2 * math.pi / hw)
    run = adapters.ENGINE_METHODS["mujoco:rk4"].simulate(moved, hw / omega, steps)
    a = (run.q[:, 0] - still.initial_state()[0]) @ vec[:, -1]
    cross = np.nonzero(np.sign(a[:-1]) != np.sign(a[1:]))[0]
    t = run.t[cross] - a[cross] * (run.t[cross + 1] - run.t[cross]) / (a[cross + 1] - a[cross])
    half = np.diff(t)
    assert len(half) >= 4
    assert np.mean(half) == pytest.approx(math.pi / omega, rel=1e-4)


# ------------------------------------------------------------------ against its own refined run
@pytest.mark.parametrize("mode, lo, hi", [("rk4", 3.7, 4.3), ("euler", 0.9, 1.1)])
def test_order_against_its_own_refined_run(flex, mode, lo, hi):
    """Errors against MuJoCo's own RK4 halved until two halvings agree (never the cloth's DOP853
    reference): RK4 of order 4 and Euler of order 1 over two periods, h omega 0.3 to 1.2."""
    grid_error = flex.reference_error(None)
    assert grid_error <= 1e-11
    res = observed_order(
        f"mujoco:{mode}", flex, periods=2.0, dts=[hw / flex.omega for hw in (0.3, 0.45, 0.6, 0.9, 1.2)]
    )
    assert lo <= res["order"] <= hi, res
    assert all(p["error"] > grid_error for p in res["points"])


def test_a_blow_up_is_a_recorded_unstable_run(flex):
    run = _step("euler", flex, 4.0, 200)
    assert run.status == "unstable" and run.failed_step is not None and run.detail
    assert _step("discrete", flex, 4.0, 200).ok  # its implicit step holds where Euler's does not


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize("values, field", [({"n": 1}, "n"), ({"pins": 2}, "pins"), ({"young": 5.0}, "young")])
def test_bad_parameters_are_refused_in_one_line(values, field, capsys):
    with pytest.raises(InvalidInput, match=field):
        make_scene("cloth_flex", **values)
    assert (
        main(
            [
                "energy",
                "cloth_flex",
                "--method",
                "mujoco:euler",
                "--dt",
                "1e-3",
                "--steps",
                "2",
                *(f"--set={k}={v}" for k, v in values.items()),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert field in err and "\n" not in err


def test_implicit_mode_is_refused_in_one_line_before_stepping(capsys):
    assert main(["energy", "cloth_flex", "--method", "mujoco:implicitfast", "--dt", "1e-3", "--steps", "2"]) == 2
    err = capsys.readouterr().err.strip()
    assert "does not support scene cloth_flex" in err and "\n" not in err


# ------------------------------------------------------------------ the nightly
def test_nightly_cells_and_report_say_it_is_not_the_same_model(flex):
    """A nightly task on the flex: every cell carries the note, through the stored row and back,
    and the report's scene section prints it under the heading."""
    from harness.nightly.cells import run_task
    from harness.nightly.run import Task
    from harness.nightly.suites import SceneSpec, Suite
    from records.cell import Cell, pivot
    from reports.markdown import scene_section

    spec = SceneSpec(params=SMALL, periods=2, stability=False, order_points=6, order_periods=2.0)
    suite = Suite(
        "flex",
        scenes={"cloth_flex": spec},
        methods=("mujoco:euler",),
        cost_repeats=1,
        cost_steps=200,
        identify=False,
        bounds=False,
    )
    cells = run_task(Task("cell", "cloth_flex", "mujoco:euler", "mujoco", params=SMALL, suite=suite))
    assert {c.measure for c in cells} >= {"energy", "error", "order", "cost"}
    assert all(c.model_note == flex.model_note for c in cells)
    assert [Cell.from_db_row(c.to_db_row()).model_note for c in cells] == [flex.model_note] * len(cells)
    order = next(c for c in cells if c.measure == "order")
    assert order.ok and 0.9 <= order.value <= 1.1
    lines = scene_section("cloth_flex", pivot(cells), {})
    assert lines[0] == "### `cloth_flex`" and lines[2] == f"**{flex.model_note}.**"
