"""Where forces depend on velocity (issue 12): which scheme each engine mode integrates on the
damped spring (zeta = 0.05 and 1), the projectile with drag and the damped chain, found by
``harness identify``; and what MuJoCo does with a damping matrix it does not match.

Tolerance: the issue's "bitwise or < 1e-12", relative to the largest state component of the
run (the projectile's positions reach 6e4: MuJoCo's RK4 there is 3.6e-12 absolute, 6e-17
relative). Measured with mujoco 4.0.0, pybullet 3.2.7, pymunk 7.3.1: 0 (bitwise) for every
force applied from Python and for pymunk's space.damping; 1.4e-14 for Chipmunk's DampedSpring
(its exp and the spring's spaced anchor); 7.2e-16 for MuJoCo's implicit damping.
"""

from __future__ import annotations

import numpy as np
import pytest

import adapters
from harness.measures.identify import MATCH_RTOL, identify
from scenarios import make_scene

pytestmark = pytest.mark.skipif(
    not all(
        adapters.ENGINE_METHODS[m].available()[0]
        for m in ("mujoco:euler", "pybullet:semi_implicit", "pymunk:spring_force")
    ),
    reason="needs mujoco, pybullet and pymunk",
)

RTOL = 1e-12
STEPS = 300

VELOCITY_IMPLICIT = "ref:semi_implicit_euler_velocity_implicit"
#: (scene, params) -> {mode: the scheme it is, or None: nothing matches (the mode says why)}
IDENTITY = {
    ("damped_spring", "zeta=0.05"): {
        "mujoco:euler": VELOCITY_IMPLICIT,
        "mujoco:implicit": VELOCITY_IMPLICIT,
        "mujoco:implicitfast": VELOCITY_IMPLICIT,
        "mujoco:rk4": "ref:rk4",
        "mujoco:discrete": "ref:implicit_euler",
        "pybullet:semi_implicit": "ref:semi_implicit_euler",
        "pymunk:spring_force": "ref:semi_implicit_euler_position_first",
        "pymunk:applied_force": "ref:explicit_euler",
        "pymunk:damped_spring": "ref:position_first_euler_decay_after_kick",
        "pymunk:space_damping": "ref:position_first_euler_decay_before_kick",
    },
    ("projectile", "c=0.1"): {
        "mujoco:euler": VELOCITY_IMPLICIT,
        "mujoco:implicit": VELOCITY_IMPLICIT,
        "mujoco:implicitfast": VELOCITY_IMPLICIT,
        "mujoco:rk4": "ref:rk4",
        "mujoco:discrete": VELOCITY_IMPLICIT,
        "pybullet:semi_implicit": "ref:semi_implicit_euler",
        "pymunk:spring_force": "ref:explicit_euler",
        "pymunk:applied_force": "ref:explicit_euler",
        "pymunk:space_damping": "ref:position_first_euler_decay_before_kick",
    },
    ("chain", "N=8, c=20"): {
        "mujoco:euler": None,
        "mujoco:implicit": None,
        "mujoco:implicitfast": None,
        "mujoco:rk4": "ref:rk4",
        "mujoco:discrete": None,
        "pybullet:semi_implicit": "ref:semi_implicit_euler",
        "pymunk:spring_force": "ref:semi_implicit_euler_position_first",
        "pymunk:applied_force": "ref:explicit_euler",
        "pymunk:damped_spring": None,
    },
}
IDENTITY[("damped_spring", "zeta=1")] = IDENTITY[("damped_spring", "zeta=0.05")]
PARAMS = {"zeta=0.05": {"c": 0.1}, "zeta=1": {"c": 2.0}, "c=0.1": {"c": 0.1}, "N=8, c=20": {"N": 8, "c": 20.0}}
CASES = [(scene, label, mode, scheme) for (scene, label), modes in IDENTITY.items() for mode, scheme in modes.items()]


@pytest.mark.parametrize("scene_id, label, mode, scheme", CASES, ids=[f"{s}-{l}-{m}" for s, l, m, _ in CASES])
def test_identify_names_the_scheme_each_mode_integrates_with_damping(scene_id, label, mode, scheme):
    scene = make_scene(scene_id, **PARAMS[label])
    res = identify(adapters.ENGINE_METHODS[mode], scene, steps=STEPS)
    assert res.status == "ok", res.detail
    scale = res.tolerance / MATCH_RTOL
    if scheme is None:
        assert res.matches == []
        # ... and the mode says why in one line, which identify reports.
        assert res.why_no_match and "\n" not in res.why_no_match
        # Not roundoff away from its closest scheme either: far above any tolerance.
        assert res.max_deviation > 1e-6 * scale
    else:
        assert scheme in res.matches
        dev = next(c.max_deviation for c in res.candidates if c.method == scheme)
        assert dev <= RTOL * scale
        # The runner-up does not match. (Dormand-Prince 5 is RK4's runner-up on these smooth scenes,
        # 3e-9 to 1e-6 of the scale away over 300 steps: another high-order scheme, above the match
        # tolerance, where the match itself is within 1e-12.)
        assert res.runner_up.max_deviation > MATCH_RTOL * scale


def _one_step_mujoco(integrator, scene, q, v, h):
    import mujoco

    from adapters.mujoco import POSES

    m = mujoco.MjModel.from_xml_string(POSES[scene.id].xml(integrator, scene, h))
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = q, v
    mujoco.mj_step(m, d)
    return d.qvel.copy()


@pytest.mark.parametrize(
    "integrator, implicit_part", [("Euler", "joint"), ("implicit", "diagonal"), ("implicitfast", "diagonal")]
)
def test_mujoco_makes_only_part_of_the_chains_damping_implicit(integrator, implicit_part):
    """The damped chain's reasons (adapters/mujoco/ ``_NO_MATCH``): one step from a generic
    state is v + h (M + h D')^-1 f with D' the joint damping only (Euler) or the diagonal of the
    full damping matrix (implicit, implicitfast), to roundoff (measured 3.6e-15 on velocities
    of ~1e4 h); the full matrix is off by 0.1 and more."""
    n, c, h = 4, 20.0, 1e-3
    scene = make_scene("chain", N=n, c=c)
    rng = np.random.default_rng(0)
    q, v = rng.standard_normal(n), rng.standard_normal(n)
    f = scene.accel(q[:, None], v[:, None], 0.0, scene.pvec)[:, 0]
    damping = c * (2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
    joint = np.diag([c] + [0.0] * (n - 2) + [c])
    part = joint if implicit_part == "joint" else np.diag(np.diag(damping))
    got = _one_step_mujoco(integrator, scene, q, v, h)
    assert np.max(np.abs(got - (v + h * np.linalg.solve(np.eye(n) + h * part, f)))) <= 1e-13
    assert np.max(np.abs(got - (v + h * np.linalg.solve(np.eye(n) + h * damping, f)))) > 1e-2


def test_pybullet_damping_is_measured_where_the_engine_reports_minus_one():
    """getDynamicsInfo reads -1.0 for a multibody's linear and angular damping; the adapter
    records what the engine applies, measured on a probe (free base, sliding link, 100 force-free
    steps): exactly nothing with damping set to 0, and a measurable decay when it is not."""
    import pybullet

    from adapters.pybullet import applied_damping

    run = adapters.ENGINE_METHODS["pybullet:semi_implicit"].simulate(make_scene("chain", N=3), 0.01, 3)
    settings = run.meta.settings
    assert settings["linearDamping_reported"] == settings["angularDamping_reported"] == -1.0
    measured = settings["damping_measured_per_step"]
    assert measured["linear"] == measured["angular"] == measured["joint"] == measured["kinetic_energy_change"] == 0.0
    # The probe sees damping where there is some: Bullet's default 0.04 (linear and quadratic,
    # docs/engines.md) takes -7.8e-4 of the speed per step at dt = 0.01 and |v| = 1, measured.
    damped = applied_damping(pybullet, 0.04, 0.04)
    assert damped["linear"] < -1e-4 and damped["kinetic_energy_change"] < -0.01


def test_mujoco_discrete_is_backward_euler_on_the_damped_chain_away_from_rest_lengths(monkeypatch):
    """The damped chain's reason for mujoco:discrete: from a generic state (no tendon at its rest
    length) its one-step map is backward Euler's, damping included (measured 2.8e-14 on entries
    of ~19): what fails from the chain's own initial state is the tendons left out there."""
    from harness.execution import isolation
    from harness.measures.damping import generic_state
    from harness.measures.stability import one_step_map

    monkeypatch.setattr(isolation, "IN_WORKER", True)
    scene = make_scene("chain", N=4, c=20.0)
    base = generic_state(scene)
    engine_map = one_step_map("mujoco:discrete", scene, 1e-3, base=base)["matrix"]
    scheme_map = one_step_map("ref:implicit_euler", scene, 1e-3, base=base)["matrix"]
    assert np.max(np.abs(engine_map - scheme_map)) <= 1e-12 * np.max(np.abs(scheme_map))
