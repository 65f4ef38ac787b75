"""Benchmarks (``harness bench``): the reference kernels beside their hand-written floors
(``kernels``) and every engine mode beside a bare loop of its step call (``engines``). Targets
are reported met or MISSED, never asserted."""
