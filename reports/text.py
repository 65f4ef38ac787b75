"""Text helpers shared by the report's sections: numbers as the report prints them, the cells of
one measure, and footnotes that say why a figure is missing."""

from __future__ import annotations

import math

from records.cell import Cell
from records.figures import limit_text  # noqa: F401 - the one rule, printed by every section

_SUPERSCRIPTS = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")


class Footnotes:
    """Why a figure is missing, said once below its table: ``mark(reason)`` is the dash with the
    reason's number (one number a reason), ``lines()`` the notes."""

    def __init__(self):
        self.reasons: dict[str, int] = {}

    def mark(self, reason: str | None, what: str = "–") -> str:
        if not reason:
            return what
        n = self.reasons.setdefault(reason, len(self.reasons) + 1)
        return what + str(n).translate(_SUPERSCRIPTS)

    def lines(self) -> list[str]:
        return [
            f"{str(n).translate(_SUPERSCRIPTS)} {reason}" + ("" if reason.endswith(".") else ".")
            for reason, n in self.reasons.items()
        ] + ([""] if self.reasons else [])


def fmt(x, spec=".3g", none="–"):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return none
    if isinstance(x, float) and math.isinf(x):
        return "unbounded"
    return format(x, spec)


def of_measure(cells: list[Cell], measure: str, *statuses: str) -> list[Cell]:
    """The cells of one measure (of these statuses, if any given)."""
    return [c for c in cells if c.measure == measure and (not statuses or c.status in statuses)]
