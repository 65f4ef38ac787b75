"""REBOUND's contact pose (``adapters/rebound/contact.py``): the ball at the three report steps,
its hard-sphere impulse exact, its restitution the requested one."""

import numpy as np
import pytest

pytest.importorskip("rebound")

from adapters import CONTACT_MODES  # noqa: E402
from harness.contact.figures import contact_figures  # noqa: E402
from harness.contact.run import REPORT_DTS, run_contact  # noqa: E402
from records import InvalidInput  # noqa: E402
from scenarios.contact import make_contact_scene  # noqa: E402

MODE = "rebound:hardsphere"


@pytest.mark.parametrize("dt", REPORT_DTS)
@pytest.mark.parametrize("e", [0.8, 1.0])
def test_the_ball_bounces_at_e_at_every_report_step(e, dt):
    run = run_contact(MODE, "ball", {"e": e}, dt, isolated=False)
    assert run.status == "ok", run.detail
    f = contact_figures(make_contact_scene("ball", e=e), run)
    assert not f.gained
    # Measured (rebound 5.2.2): 0.7995..0.7998 at 1 ms, 0.759..0.793 at 1/60 s (the collision is
    # found up to a step's fall inside the ground, where e < 1 rebounds from that much deeper);
    # 1 to 1e-9 at e = 1. The judged tolerance, 0.05, holds at every step.
    assert all(abs(x - e) <= 0.05 for x in f.restitution), f.restitution
    if e == 1.0:
        assert abs(f.apex_ratio - 1.0) < 1e-6
    assert f.cpu_per_s is not None and f.cpu_per_s > 0


@pytest.mark.parametrize("dt", [1 / 1000, 1 / 60])
def test_the_impulse_is_exact(dt):
    """Each impact reverses the fall's velocity times e, to roundoff: the velocity after the step
    that found the collision is -e times the one before less the step's g dt (leapfrog's kick)."""
    e = 0.8
    run = run_contact(MODE, "ball", {"e": e}, dt, isolated=False)
    v = run.velocities[:, 0, 2]
    impacts = np.nonzero((v[1:] > 0) & (v[:-1] < 0))[0] + 1
    assert len(impacts) >= 5
    for i in impacts[:5]:
        before = v[i - 1] - 9.81 * dt
        # The planet's gravity differs from g by 2 h0 / R = 2e-7 of it over the drop.
        assert v[i] / -before == pytest.approx(e, rel=1e-8)


def test_the_boxes_are_unsupported_with_a_reason():
    mode = CONTACT_MODES[MODE]
    for scene in ("slide", "rest", "stack"):
        ok, why = mode.supports(scene)
        assert not ok and "sphere" in why
        with pytest.raises(InvalidInput):
            run_contact(MODE, scene, {}, 1 / 240, isolated=False)


def test_the_turning_scenes_are_unsupported_with_a_reason():
    """REBOUND's particles do not turn: the edge, corner, tip and roll scenes are refused with the reason."""
    mode = CONTACT_MODES[MODE]
    for scene in ("edge", "corner", "tip", "roll"):
        ok, why = mode.supports(scene)
        assert not ok and "spheres without orientation" in why, why
        with pytest.raises(InvalidInput):
            run_contact(MODE, scene, {}, 1 / 240, isolated=False)


def test_the_mode_is_the_documented_hard_sphere_bounce():
    """The one mode is REBOUND's documented practice (collisions page, bouncing-balls example):
    its run states collision "direct", collision_resolve "hardsphere", leapfrog and the source;
    and a bare REBOUND loop set up as the documentation's example sets it (the ball a particle on
    the planet, the same e) gives the harness's heights step for step."""
    import rebound

    from adapters.rebound import contact as rebound_contact

    e, dt = 0.8, 1 / 240
    run = run_contact(MODE, "ball", {"e": e}, dt, isolated=False)
    s = run.settings
    assert (s["collision"], s["collision_resolve"], s["gravity"]) == ("direct", "hardsphere", "basic")
    assert s["integrator"].startswith("leapfrog")
    assert "rebound.readthedocs.io/en/latest/collisions" in s["practice"]
    assert "no other contact mode" in CONTACT_MODES[MODE].doc

    scene = make_contact_scene("ball", e=e)
    sim = rebound.Simulation()
    sim.G = 1.0
    sim.integrator = "leapfrog"
    sim.collision = "direct"
    sim.collision_resolve = "hardsphere"
    sim.coefficient_of_restitution = lambda _sim, _v: e
    sim.dt = dt
    R = rebound_contact.PLANET_RADIUS
    sim.add(m=scene.g * R * R, r=R)
    sim.add(m=scene.mass, r=scene.radius, z=R + scene.initial_centres()[0][2])
    sim.N_active = 1
    sim.testparticle_type = 0
    heights = [sim.particles[1].z - sim.particles[0].z - R]
    for _ in range(run.steps):
        sim.steps(1)
        heights.append(sim.particles[1].z - sim.particles[0].z - R)
    assert np.array_equal(np.array(heights), run.centres[:, 0, 2])
