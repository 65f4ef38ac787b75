"""pytest plugin (registered through the ``pytest11`` entry point): energy bounds as one-line tests.

In a user's test suite::

    def test_games_default_keeps_energy(energy_bound):
        energy_bound("ref:semi_implicit_euler", "spring", dt=0.1, steps=10_000, bound=0.06)

or, without the fixture, ``from harness.pytest_plugin import assert_energy_bound``.
The check is the nightly's: max |dE/E| against the scene's exact energy over the run; a run
that blows up, crashes or times out fails the test with its status.
"""

from __future__ import annotations

import pytest


class EnergyBoundExceeded(AssertionError):
    pass


def measure_max_rel_energy_error(
    method_id: str, scene_id: str, dt: float, steps: int, **params
) -> tuple[float, str, str]:
    import numpy as np

    from harness import validate
    from harness.methods import check_supported, get_method
    from harness.execution.simulate import simulate
    from scenarios import make_scene

    dt = validate.positive_finite("dt", dt)
    steps = validate.count("steps", steps, 1)
    scene = make_scene(scene_id, **params)
    method = get_method(method_id)
    check_supported(method, scene)
    every = max(1, steps // 2000)
    traj = simulate(method, scene, dt, steps, every)
    if not traj.ok:
        return float("inf"), traj.status, traj.detail
    exact = scene.exact_energy(traj.t)[:, None]
    rel = np.abs(traj.energy - exact) / np.maximum(np.abs(exact), np.finfo(float).tiny)
    return float(rel.max()), traj.status, ""


def assert_energy_bound(method: str, scene: str, dt: float, steps: int, bound: float, **params) -> float:
    """Assert that ``method`` on ``scene`` at ``dt`` keeps max |dE/E| <= ``bound`` over ``steps`` steps.
    Returns the measured value."""
    value, status, detail = measure_max_rel_energy_error(method, scene, dt, steps, **params)
    if status != "ok":
        raise EnergyBoundExceeded(f"{method} on {scene} at dt={dt:g}: run {status}: {detail}")
    if not value <= bound:
        raise EnergyBoundExceeded(
            f"{method} on {scene} at dt={dt:g} over {steps} steps: max |dE/E| = {value:.3e} > bound {bound:.3e}"
        )
    return value


@pytest.fixture
def energy_bound():
    """The one-line energy-bound assertion: ``energy_bound(method, scene, dt=, steps=, bound=)``."""
    return assert_energy_bound
