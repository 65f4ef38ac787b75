"""Newton's contact poses (``adapters/newton/contact.py``): each solver poses every scene (the
ball at the three report steps, over one bounce to keep Warp on the CPU quick), the figures
measured to hold hold, and XPBD's trap (no bounce unless ``enable_restitution``) is caught."""

import importlib.util

import pytest

# Skipped without Newton, which is imported where a test uses it: its import is seconds of every
# worker's collection.
pytestmark = pytest.mark.skipif(importlib.util.find_spec("newton") is None, reason="newton is not installed")

from adapters import CONTACT_MODES  # noqa: E402
from adapters.newton import contact as newton_contact  # noqa: E402
from harness.contact.figures import contact_figures  # noqa: E402
from harness.contact.run import REPORT_DTS, run_contact  # noqa: E402
from scenarios.contact import make_contact_scene  # noqa: E402

MODES = ("newton:semi_implicit", "newton:xpbd")
ONE_BOUNCE = {"bounces": 1}


def figures(mode, scene, params, dt):
    run = run_contact(mode, scene, params, dt, isolated=False)
    return run, contact_figures(make_contact_scene(scene, **params), run)


@pytest.mark.slow
@pytest.mark.parametrize("dt", REPORT_DTS)
@pytest.mark.parametrize("mode", MODES)
def test_the_ball_runs_at_every_report_step(mode, dt):
    run, f = figures(mode, "ball", ONE_BOUNCE, dt)
    assert run.status == "ok", run.detail
    assert run.settings["precision"] == "float32"
    assert f.cpu_per_s > 0
    if dt == 1 / 1000:
        # Measured (newton 1.8.0): semi-implicit 0.806, XPBD 0.7996 at the first bounce.
        assert abs(f.restitution[0] - 0.8) < 0.05, f.restitution


@pytest.mark.slow
@pytest.mark.parametrize("scene", ["slide", "rest", "stack"])
@pytest.mark.parametrize("mode", MODES)
def test_the_boxes_run(mode, scene):
    run, _ = figures(mode, scene, {}, 1 / 60)
    assert run.status in ("ok", "unstable"), run.detail
    if run.status == "ok":
        assert run.centres.shape[1] == make_contact_scene(scene).bodies


def test_the_penalty_damping_follows_e():
    # Damped on approach only: e = exp(-zeta atan(sqrt(1 - zeta^2) / zeta) / sqrt(1 - zeta^2)).
    assert newton_contact.zeta_for(1.0) == 0.0
    for e in (0.3, 0.8, 0.95):
        assert newton_contact.restitution_of(newton_contact.zeta_for(e)) == pytest.approx(e, abs=1e-12)


@pytest.mark.slow
def test_xpbd_ignores_restitution_unless_enabled():
    """Newton's default ``enable_restitution=False``: XPBD's ball stops at the first impact
    (measured: apex below 1 mm), where with it enabled it bounces at e."""
    scene = make_contact_scene("ball", **ONE_BOUNCE)
    mode = CONTACT_MODES["newton:xpbd"]
    off = contact_figures(scene, newton_contact.run(mode, scene, 1 / 240, enable_restitution=False))
    on = contact_figures(scene, newton_contact.run(mode, scene, 1 / 240))
    assert off.restitution[0] < 0.1, off.restitution
    assert abs(on.restitution[0] - 0.8) < 0.05, on.restitution
