"""The built-in measures beyond a task's own (``harness.nightly.cells``): a module each, or one
module for a few that share their study, each declaring ``MEASURES = [records.measures.Measure(...)]``
exactly as a plugin module does. ``harness.nightly.cells`` registers them after the task's own
measures, the modules in name order, so a measure here may read what those made (their cells,
the energy run, the claims) but not another module's.

A new built-in measure is a new module here and nothing else (docs/contributing.md).
"""

from __future__ import annotations

import importlib
import pkgutil

from records.measures import Measure


def declared() -> list[Measure]:
    """The measures every module of this package declares, the modules in name order."""
    out: list[Measure] = []
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{__name__}.{info.name}")
        found = getattr(module, "MEASURES", None)
        if found is None:
            raise ValueError(f"{module.__name__} declares no MEASURES (each module here declares its measures)")
        out += list(found)
    return out
