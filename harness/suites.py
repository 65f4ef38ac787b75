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
    order_periods: float = 0.5     # horizon of each order run, in periods (the order measure's default:
                                   # half an orbit from perihelion; one period took Kepler's first-order
                                   # sweeps 30x the steps, 1.47M for explicit Euler, for the same slope)
    stability: bool = True         # bisect the largest stable timestep


@dataclass(frozen=True)
class Suite:
    name: str
    scenes: dict[str, SceneSpec]
    methods: tuple[str, ...] | None = None   # None: every available method
    cost_repeats: int = 5
    cost_steps: int | None = None            # timed steps per repeat (None: the cost measure's, 100,000
                                             # compiled, 2,000 for an engine mode)
    series_points: int = 400                 # energy-series samples kept per cell for the charts
    stability_steps: int = 1000              # horizon of the boundedness test
    stability_homega_max: float = 100.0      # top of the stability search, in h*omega: beyond it a method is
                                             # "unbounded (searched to ...)". An adaptive engine mode (REBOUND's
                                             # ias15: dt is its output interval) is stable at every dt and its
                                             # finite-horizon test costs in proportion to dt: 4.6 s at 100 on
                                             # Kepler, so a search to 1e4 would take about 15 minutes.
    cell_timeout: float = 120.0              # seconds a task (one scene x method, all its measures) may take
    bounds: bool = True                      # measure the reviewed energy bounds
    identify: bool = True                    # identity table for engine modes


SUITES: dict[str, Suite] = {
    "smoke": Suite(
        "smoke",
        scenes={"spring": SceneSpec(periods=20, order_points=6, order_span=4.0)},
        methods=("ref:explicit_euler", "ref:semi_implicit_euler", "ref:leapfrog", "ref:rk4", "ref:implicit_euler",
                 "mujoco:euler", "pymunk:applied_force"),
        cost_repeats=3, series_points=200, stability_steps=500, cell_timeout=60.0,
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
        stability_homega_max=1000.0,
    ),
}
