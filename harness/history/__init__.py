"""The stored history: ``storage`` (SQLite, one row per measured cell, one schema version), ``regression`` (what got
worse), ``series`` (a cell's values across runs), ``step_detect`` (steps in a noisy series), ``compare``
(regressions of the latest run), ``bounds`` (the reviewed energy-bounds file beside it)."""
