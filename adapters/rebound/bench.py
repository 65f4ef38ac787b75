"""REBOUND's bare loop for ``harness bench --engines``: one ``sim.steps(N)``; for IAS15 (adaptive,
its dt the output interval) a loop of ``sim.integrate(k dt)``."""

from __future__ import annotations


def bare_loops(mode, rebound, model, scene, dt: float):
    """([(name, once(n))], what it is)."""
    sim = model.sim
    if mode.adaptive:  # dt is the output interval: its step call is integrate(k dt)

        def intervals(n):
            integrate, k0 = sim.integrate, model.n
            for k in range(k0 + 1, k0 + n + 1):
                integrate(k * dt)
            model.n = k0 + n

        return [("integrate(k dt) loop", intervals)], "a Python loop of sim.integrate(k dt)"

    def steps(n):
        sim.steps(n)

    return [("sim.steps(N)", steps)], "one sim.steps(N) call"
