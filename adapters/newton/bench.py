"""Newton's bare loop for ``harness bench --engines``: ``clear_forces`` and ``solver.step`` with the
two states swapped, as Newton's examples step; the adapter's own ``steps`` are that loop already,
with nothing else in it (on the CPU Warp captures no graph, so no loop is less)."""

from __future__ import annotations


def bare_loops(mode, newton, model, scene, dt: float):
    """([(name, once(n))], what it is)."""
    return [
        ("solver.step loop", model.steps)
    ], "a Python loop of state.clear_forces(); solver.step(s0, s1, control, None, dt); swap"
