"""Drake's bare loop for ``harness bench --engines``: one ``Simulator.AdvanceTo(t + N dt)``."""

from __future__ import annotations


def bare_loops(mode, pydrake, model, scene, dt: float):
    """([(name, once(n))], what it is)."""
    sim = model.sim

    def advanced(n):  # one AdvanceTo over the n steps, as a user writes it
        sim.AdvanceTo(sim.get_context().get_time() + n * dt)

    return [("AdvanceTo(t + N dt)", advanced)], "one Simulator.AdvanceTo(t + N dt) call"
