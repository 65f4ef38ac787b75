"""Measures: one module per question asked of a method on a scene.

``energy`` (drift and class), ``error`` (against the exact or reference solution), ``order``
(observed convergence), ``stability`` (the largest stable h*omega), ``stability_damping`` (that
limit against the damping ratio), ``cost`` (time per step on the engine's own loop or the compiled
kernel, counted force evaluations), ``identify`` (which textbook scheme an engine mode is),
``workprecision`` (error against cost), ``advise`` (the cheapest method and substeps at a frame
rate), and the scene studies ``damping``, ``constraint``, ``scaling``, ``rope_study``.
``common`` resolves a method for a scene; ``frames`` turns results into tidy DataFrames.
"""
