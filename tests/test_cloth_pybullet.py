"""pybullet's mass-spring soft body on the cloth (issue 24): which scheme its deformable solver
integrates, the springs and masses it builds, the defaults that perturb it, its blow-up, and
the refusals. Small sheets, a few hundred steps each; every tolerance says where it comes from.
Measured with pybullet 3.2.7.
"""

from __future__ import annotations

import io
import os
import tempfile
from contextlib import redirect_stderr, redirect_stdout

import numpy as np
import pytest

from adapters import ENGINE_METHODS
from adapters import import_engine
from adapters.pybullet.cloth import LOAD, MAX_DISPLACEMENT, grid_mesh, mesh_edges
from harness.cli import main
from harness.measures.common import started_at
from harness.measures.identify import identify
from harness.methods import check_supported, get_method
from records import InvalidInput
from scenarios import make_scene

MODE = "pybullet:semi_implicit"
#: The cloth Bullet poses: the sheet triangulated along (i, j)-(i+1, j+1), one stiffness, no bending.
TRIANGULATED = {"shear": 1, "k_shear": 200.0, "k": 200.0, "k_bend": 0.0}


def sheet(**values):
    return make_scene("cloth", **{"n": 4, "m": 3, **TRIANGULATED, **values})


def engine(scene, dt, steps, every=1, loop="engine"):
    """Stepped in this process: the adapter's numbers (test_adapters checks the worker only wraps them)."""
    return ENGINE_METHODS[MODE].simulate(scene, dt, steps, every, loop=loop)


def test_soft_body_is_semi_implicit_euler_to_roundoff():
    """The identity: ref:semi_implicit_euler over 200 steps at h omega = 0.06 (identify's default
    dt, 5.5e-4). Positions are Bullet's own; the velocity is (x_n - x_{n-1}) / h, whose roundoff is
    |x| eps / h = 0.3 x 2.2e-16 / 5.5e-4 = 1.2e-13: measured 5.4e-14. The runner-up (ref:verlet,
    another update) is 3.0e-4 away, nine orders above."""
    res = identify(MODE, sheet(), steps=200)
    assert res.status == "ok" and res.match == "ref:semi_implicit_euler", res.candidates[:3]
    assert res.max_deviation <= 1e-12
    assert res.runner_up.max_deviation >= 1e-6


def test_one_step_from_rest_is_gravity_alone():
    """Independent numbers: from the flat sheet at rest every spring sits at its rest length, so
    one step of semi-implicit Euler moves each free node by -g h^2 along z and nothing else (the
    rest lengths are Bullet's own, |x_b - x_a| of the placed nodes, so the springs' force there is
    roundoff: 1e-16 k at most, moving a node h^2 / m times that, 1e-20 here)."""
    scene, h = sheet(g=9.81), 1e-3
    run = engine(scene, h, 1)
    q0, q1 = run.q[0, 0].reshape(-1, 3), run.q[1, 0].reshape(-1, 3)
    np.testing.assert_array_equal(q0, scene.rest_positions()[[i * 3 + j for i, j in scene.free_nodes()]])
    np.testing.assert_allclose(q1[:, :2], q0[:, :2], rtol=0, atol=1e-18)
    np.testing.assert_allclose(q1[:, 2], -9.81 * h * h, rtol=1e-14)
    np.testing.assert_allclose(run.v[1, 0].reshape(-1, 3)[:, 2], -9.81 * h, rtol=1e-12)


def _bullet_sheet(n, m, k, mass, dt, **load):
    """A raw soft body on ``grid_mesh`` (g = 0, corners (0, 0) and (0, m-1) anchored), with LOAD's
    arguments overridden by ``load``: (pybullet, client, body)."""
    p = import_engine("pybullet")
    cid = p.connect(p.DIRECT)
    p.resetSimulation(p.RESET_USE_DEFORMABLE_WORLD, physicsClientId=cid)
    p.setPhysicsEngineParameter(fixedTimeStep=dt, numSubSteps=0, physicsClientId=cid)
    p.setGravity(0, 0, 0, physicsClientId=cid)
    fd, path = tempfile.mkstemp(suffix=".obj")
    with os.fdopen(fd, "w") as f:
        f.write(grid_mesh(n, m))
    try:
        body = p.loadSoftBody(
            path, scale=0.1, mass=mass, springElasticStiffness=k, physicsClientId=cid, **{**LOAD, **load}
        )
    finally:
        os.remove(path)
    p.changeDynamics(body, -1, activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=cid)
    for node in (0, m - 1):
        p.createSoftBodyAnchor(body, node, -1, -1, physicsClientId=cid)
    return p, cid, body


def _probe(n, m, k, mass, dt, node, push, **load):
    """One step at rest (the rest lengths fixed from the flat sheet), then ``node`` moved by
    ``push`` and one more step: every node's displacement in that step."""
    p, cid, body = _bullet_sheet(n, m, k, mass, dt, **load)
    try:
        flags = p.MESH_DATA_SIMULATION_MESH
        p.stepSimulation(physicsClientId=cid)
        x = np.array(p.getMeshData(body, flags=flags, physicsClientId=cid)[1])
        x[node] += push
        p.resetMeshData(body, x.tolist(), physicsClientId=cid)
        p.stepSimulation(physicsClientId=cid)
        return np.array(p.getMeshData(body, flags=flags, physicsClientId=cid)[1]) - x, x
    finally:
        p.disconnect(physicsClientId=cid)


def _moved(displacement):
    """The nodes that moved in the probe's step: a spring's pull there is h^2 k |push| / m ~ 1e-6;
    one at its rest length pulls with roundoff, 1e-15 k at most, moving a node 1e-20."""
    return np.flatnonzero(np.linalg.norm(displacement, axis=1) > 1e-12).tolist()


def test_springs_are_the_mesh_edges_at_the_scenes_stiffness_and_node_mass():
    """Bullet's spring set, read from its dynamics: node (2, 1) of a 4 x 4 sheet is pushed, and
    exactly the nodes the mesh joins it to move in the next step, each by h^2 / m_node times the
    spring force k (|d| - L) d/|d| computed here (L = s or s sqrt 2; m_node = mass / (n m)); to
    1e-9 relative, the roundoff of |d| - L (1e-16 on 1e-3 of stretch, times the transfer). The
    scene with shear = 1 lists the same springs, one per mesh edge (those between two pinned nodes
    aside: they never act)."""
    n, m, k, mass, h, s = 4, 4, 200.0, 1.6, 1e-3, 0.1
    node, push = 2 * m + 1, np.array([1e-3, 2e-3, -3e-3])
    moved, x = _probe(n, m, k, mass, h, node, push)
    edges = mesh_edges(n, m)
    neighbours = sorted({a if b == node else b for a, b in edges if node in (a, b)})
    assert sorted(set(_moved(moved)) - {node}) == neighbours
    assert len(neighbours) == 6  # four structural, two on the one diagonal
    for other in neighbours:
        d = x[node] - x[other]
        rest = s * (np.sqrt(2.0) if abs(other - node) in (m + 1,) else 1.0)
        force = k * (np.linalg.norm(d) - rest) * d / np.linalg.norm(d)
        np.testing.assert_allclose(moved[other], h * h * force / (mass / (n * m)), rtol=1e-9)
    scene = make_scene("cloth", n=n, m=m, **{**TRIANGULATED, "k": k, "k_shear": k})
    a, b, _, _ = scene.springs()
    assert {tuple(sorted(e)) for e in zip(a.tolist(), b.tolist())} == {e for e in edges if not {*e} <= {0, m - 1}}


def test_default_bending_stiffness_adds_springs_though_bending_is_off():
    """The trap LOAD avoids: pybullet passes springBendingStiffness (default 0.1) whatever
    useBendingSprings says, and a non-zero one builds links between nodes two links apart: the
    pushed node then moves 12 nodes, not the mesh's 6."""
    moved, _ = _probe(4, 4, 200.0, 1.6, 1e-3, 9, np.array([1e-3, 2e-3, -3e-3]), springBendingStiffness=0.1)
    assert len(set(_moved(moved)) - {9}) > 6


def test_sleeping_is_off():
    """Bullet freezes a soft body whose nodes all stay slower than 0.04 for 2 s (velocities
    zeroed). At g = 0.01 the sheet never reaches that speed: over 3 s at h = 0.01 it still follows
    semi-implicit Euler to roundoff (measured 8.9e-16 in positions; 0.10 off with sleeping on)."""
    scene = make_scene("cloth", n=3, m=3, **{**TRIANGULATED, "k": 100.0, "k_shear": 100.0}, g=0.01)
    run = engine(scene, 0.01, 300)
    ref = get_method("ref:semi_implicit_euler").simulate(scene, 0.01, 300, 1)
    assert float(np.max(np.abs(run.v))) < 0.04
    assert float(np.max(np.abs(run.q - ref.q))) <= 1e-13


def test_perturbing_defaults_are_off_and_recorded():
    run = engine(sheet(g=9.81), 1e-3, 2)
    s = run.meta.settings
    for name in ("springDampingStiffness", "springBendingStiffness", "frictionCoeff"):
        assert s[name] == 0.0, name
    for name in (
        "useBendingSprings",
        "useSelfCollision",
        "useFaceContact",
        "useNeoHookean",
        "springDampingAllDirections",
        "numSubSteps",
    ):
        assert s[name] == 0, name
    assert s["gravity"] == [0.0, 0.0, -9.81] and s["fixedTimeStep"] == 1e-3
    assert s["nodes"] == 12 and s["nodes_at_scene_start"] is True
    assert s["springs"].startswith(f"{len(mesh_edges(4, 3))}:")
    assert s["sleeping"].startswith("disabled")
    for kept in ("collisionMargin", "repulsionStiffness", "velocity_clamps", "implicit"):
        assert s[kept], kept
    assert run.force_evals is None and "stepSimulation" in run.meta.force_evals_reason


def test_engine_loop_and_harness_loop_agree_bitwise():
    """The engine's loop reads the positions only around the last step of an output interval;
    the harness's reads them every step: the same states, bit for bit."""
    scene = sheet()
    a = engine(scene, 1e-3, 60, every=20)
    b = engine(scene, 1e-3, 60, every=20, loop="harness")
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.v, b.v)


def test_blow_up_is_unstable_though_bullet_keeps_it_finite():
    """Far past the limit (h omega = 10) the sheet blows up, and Bullet's clamp (each velocity
    component <= m_maxDisplacement / h) holds it finite: the run ends unstable at the step a node
    first moves MAX_DISPLACEMENT, on the engine's loop as on the harness's (measured step 16 on
    the 4 x 4 sheet at k = 1000; here it must come within the horizon)."""
    scene = sheet()
    dt = 10.0 / scene.omega
    for loop in ("engine", "harness"):
        run = engine(scene, dt, 300, every=100, loop=loop)
        assert run.status == "unstable" and run.failed_step is not None, (loop, run.detail)
        assert "m_maxDisplacement" in run.detail and np.all(np.isfinite(run.q))
    assert MAX_DISPLACEMENT == 1000.0


def test_refused_cloths_name_the_fields_and_the_pose_it_takes():
    method = get_method(MODE)
    with pytest.raises(InvalidInput, match=r"shear=1, k_shear=k, k_bend=0 \(got shear=2, k_shear=50, k_bend=5\)"):
        check_supported(method, make_scene("cloth"))
    with pytest.raises(InvalidInput, match=r"\(got k_shear=100\)"):
        check_supported(method, make_scene("cloth", shear=1, k=200.0, k_shear=100.0, k_bend=0.0))
    with pytest.raises(InvalidInput, match="2-D engines"):
        check_supported(method, make_scene("net"))
    check_supported(method, sheet())
    with pytest.raises(InvalidInput, match=r"shear=3 is out of range \(allowed: integer in \[1, 2\]\)"):
        make_scene("cloth", shear=3)


def test_cli_refuses_in_one_line_with_exit_2():
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        code = main(["identify", "cloth", "--method", MODE, "--set", "shear=1"])
    assert code == 2 and out.getvalue() == ""
    assert len(err.getvalue().strip().splitlines()) == 1 and "k_shear" in err.getvalue()


def test_another_start_is_refused_before_bullet_is_stepped():
    scene = sheet()
    q0, v0 = scene.initial_state()
    with pytest.raises(ValueError, match="starts at its mesh, at rest"):
        engine(started_at(scene, q0, v0 + 0.1), 1e-3, 1)
