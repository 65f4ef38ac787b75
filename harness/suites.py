"""Nightly suites: which scenes, at what nominal timestep, horizons and sweeps.

A scene's nominal timestep is given as h*omega (so one number means the same thing on a
spring and on a stiff chain); horizons are in the scene's periods. ``smoke`` runs in seconds
(for the tests), ``standard`` is what ``make nightly`` runs (<= 5 minutes on 2 cores),
``full`` uses longer horizons and finer sweeps.
"""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class SceneSpec:
    params: dict = field(default_factory=dict)
    homega: float = 0.1            # nominal h*omega for the energy/error/cost cells
    periods: float = 50.0          # energy horizon, in periods of the scene
    order_points: int = 6          # timesteps in the order / work-precision sweep
    order_span: float = 8.0        # ratio of the largest to the smallest timestep in that sweep
    order_periods: float = 1.0     # horizon of each order run, in periods
    stability: bool = True         # bisect the largest stable timestep


@dataclass(frozen=True)
class Suite:
    name: str
    scenes: dict[str, SceneSpec]
    methods: tuple[str, ...] | None = None   # None: every available method
    cost_repeats: int = 5
    cost_steps: int = 20_000
    series_points: int = 400                 # energy-series samples kept per cell for the charts
    stability_steps: int = 1000              # horizon of the boundedness test
    cell_timeout: float = 120.0
    bounds: bool = True                      # measure the reviewed energy bounds
    identify: bool = True                    # identity table for engine modes


SUITES: dict[str, Suite] = {
    "smoke": Suite(
        "smoke",
        scenes={"spring": SceneSpec(periods=20, order_points=6, order_span=4.0)},
        methods=("ref:explicit_euler", "ref:semi_implicit_euler", "ref:leapfrog", "ref:rk4", "ref:implicit_euler",
                 "mujoco:euler", "pymunk:applied_force"),
        cost_repeats=3, cost_steps=2_000, series_points=200, stability_steps=500, cell_timeout=60.0,
    ),
    "standard": Suite(
        "standard",
        scenes={
            "spring": SceneSpec(periods=200),
            "damped_spring": SceneSpec(periods=50),
            "pendulum": SceneSpec(periods=50),
            "kepler": SceneSpec(homega=0.02, periods=50, order_span=8.0),
            "projectile": SceneSpec(homega=0.01, periods=0.2, stability=True),
        },
    ),
    "full": Suite(
        "full",
        scenes={
            "spring": SceneSpec(periods=2000, order_points=8, order_span=16.0),
            "damped_spring": SceneSpec(periods=200, order_points=8, order_span=16.0),
            "pendulum": SceneSpec(periods=500, order_points=8, order_span=16.0),
            "kepler": SceneSpec(homega=0.02, periods=1000, order_points=8, order_span=16.0),
            "projectile": SceneSpec(homega=0.01, periods=0.2, order_points=8, order_span=16.0),
        },
        cost_repeats=9, cost_steps=100_000, series_points=1000, stability_steps=5000, cell_timeout=900.0,
    ),
}
