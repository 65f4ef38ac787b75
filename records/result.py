"""A measure's result: a frozen dataclass with a field for every figure the measure computes.

The CLI prints it (``--json``: ``as_dict``), the nightly picks its cell's figures from it
(``records.cell.Figures.pick``), the tests read its fields: one result, read by name, where a
dict's keys were looked up by string (and a missing key read as None) before.
"""

from __future__ import annotations

from dataclasses import fields


class Result:
    """Base of the measures' results (each a frozen dataclass)."""

    def as_dict(self) -> dict:
        """Every field, a nested result as its dict: the JSON form and what figures are picked from."""
        return {f.name: _plain(getattr(self, f.name)) for f in fields(self)}


def _plain(value):
    if isinstance(value, Result):
        return value.as_dict()
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value
