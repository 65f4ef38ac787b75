"""Between versions: what changed in one engine's cells from one release to the next.

Each group is one run of the same suite on one release of the engine (a version matrix's runs, or
the run before an upgrade and the run after it). For each pair of consecutive releases, every cell
of the engine's modes is set beside its counterpart: **bit for bit unchanged** where its status,
value and every stored figure are equal (less how it ran: clocks, kernels, backend); otherwise one
row with both values. A cost cell is compared as its ratio to explicit Euler, each measured in its
own run, and beyond the process-to-process spread only (``PROCESS_SPREAD``): a ratio is not a bit.
A mode one release has and the other lacks is said so ("not in mujoco 3.3.7").
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

from records.cell import Cell

#: What a stored cell records of how it ran, not of what it measured.
HOW = ("wall_s", "kernels", "backend", "settings", "engine_version", "timing", "clock", "numbers_timing")
#: A cost ratio to explicit Euler moving by less than this (relative) is not a change between releases.
PROCESS_SPREAD = 0.5


#: Measures with several cells a task (one per frame rate, one per bound): keyed by their dt too.
MANY = ("advise", "bound")


def _timing(key: str) -> bool:
    return "cost" in key or "per_frame" in key or "timing" in key


def _data(c: Cell) -> dict:
    """A cell's stored figures less how it ran; an advice cell's less its costs (timings)."""
    data = {k: v for k, v in c.figures.to_data().items() if k not in HOW}
    if c.measure == "advise":
        data = {k: v for k, v in data.items() if not _timing(k)}
        data["rows"] = [{k: v for k, v in row.items() if not _timing(k)} for row in data.get("rows") or []]
    return data


def _figures(c: Cell) -> str:
    return json.dumps(_data(c), sort_keys=True, default=str)


def _key(c: Cell) -> tuple:
    return (c.scene, c.method, c.measure, c.dt if c.measure in MANY else None)


def what_differs(a: Cell, b: Cell) -> str:
    """The names of what differs between two counterparts: status, value, detail, figures."""
    out = [name for name, x, y in (("status", a.status, b.status), ("detail", a.detail, b.detail)) if x != y]
    if a.measure not in ("cost", "advise") and a.value != b.value:
        out.append("value")
    da, db = _data(a), _data(b)
    out += sorted(k for k in set(da) | set(db) if da.get(k) != db.get(k) and k != "claims")
    return ", ".join(out) or "–"


def _value(c: Cell | None) -> str:
    if c is None:
        return "–"
    if c.status != "ok":
        return c.status
    if c.measure == "energy" and c.figures.energy_class:
        final = c.figures.final_rel_error
        said = f"{c.value:.9g}" + (f", final {final:.9g}" if final is not None else "")
        return f"{said} ({c.figures.energy_class})" if c.value is not None else c.figures.energy_class
    if c.measure == "identity":
        return f"{c.figures.match or 'no match'} ({c.value:.2e})" if c.value is not None else str(c.figures.match)
    if c.measure == "cost":
        r = c.figures.ratio_to_explicit_euler
        return f"ratio {r:.3g}" if r else "–"
    if c.measure == "advise":
        best = c.figures.best
        rows = c.figures.rows or []
        return f"{rows[best]['substeps']} substeps" if best is not None and best < len(rows) else "meets none"
    if c.value is None:
        return "none"
    return "inf" if math.isinf(c.value) else f"{c.value:.9g}"


def _same(a: Cell, b: Cell) -> bool:
    if a.measure == "cost":
        ra, rb = a.figures.ratio_to_explicit_euler, b.figures.ratio_to_explicit_euler
        return a.status == b.status and (not ra or not rb or abs(rb / ra - 1.0) <= PROCESS_SPREAD)
    same_value = (
        a.measure == "advise"
        or a.value == b.value
        or (a.value is not None and b.value is not None and math.isnan(a.value) and math.isnan(b.value))
    )
    return a.status == b.status and same_value and a.detail == b.detail and _figures(a) == _figures(b)


@dataclass
class ReleaseComparison:
    """One engine's cells in two releases' runs: how many are bit for bit ``unchanged``, the
    ``changed`` ones (key, cell before, cell after), and the keys (scene, method, measure, dt)
    only one release has."""

    unchanged: int = 0
    changed: list[tuple[tuple, Cell, Cell]] = field(default_factory=list)
    only_before: list[tuple] = field(default_factory=list)
    only_after: list[tuple] = field(default_factory=list)


def compare_releases(engine: str, before: tuple[str, list[Cell]], after: tuple[str, list[Cell]]) -> ReleaseComparison:
    """The cells of ``engine``'s modes in two runs (each ``(version, cells)``), set side by side."""

    def mine(cells):
        return {_key(c): c for c in cells if c.family == engine and c.measure != "bound"}

    a, b = mine(before[1]), mine(after[1])
    out = ReleaseComparison(only_before=sorted(set(a) - set(b)), only_after=sorted(set(b) - set(a)))
    for key in sorted(set(a) & set(b), key=str):
        if _same(a[key], b[key]):
            out.unchanged += 1
        else:
            out.changed.append((key, a[key], b[key]))
    return out


def between_versions_section(engine: str, runs: list[tuple[str, list[Cell]]], skipped: dict | None = None) -> list[str]:
    """The report's "Between versions" lines for ``engine``: ``runs`` as (version, cells), oldest
    release first; ``skipped``: {version: {(scene, method): reason}} of what a release did not run."""
    lines = [
        f"## Between versions: {engine}",
        "",
        f"Each release's cells of the {engine} modes beside the next release's (status, value and every "
        "stored figure; cost as its ratio to explicit Euler, each from its own run).",
        "",
    ]
    for (va, ca), (vb, cb) in zip(runs, runs[1:]):
        res = compare_releases(engine, (va, ca), (vb, cb))
        head = f"**{engine} {va} → {vb}**: "
        if not res.changed and not res.only_before and not res.only_after:
            lines += [head + f"bit for bit unchanged ({res.unchanged} cells).", ""]
            continue
        lines.append(head + f"{res.unchanged} cells bit for bit unchanged, {len(res.changed)} changed.")
        lines.append("")
        if res.changed:
            lines += [
                f"| scene | method | measure | {engine} {va} | {engine} {vb} | what differs |",
                "|---|---|---|---|---|---|",
            ]
            for (scene, method, measure, _), x, y in res.changed:
                lines.append(f"| {scene} | `{method}` | {measure} | {_value(x)} | {_value(y)} | {what_differs(x, y)} |")
            lines.append("")
        for only, version, other in ((res.only_before, va, vb), (res.only_after, vb, va)):
            for scene, method in sorted({(k[0], k[1]) for k in only}):
                why = (skipped or {}).get(other, {}).get((scene, method)) or f"no such cell on {engine} {other}"
                lines.append(f"- `{method}` on {scene}: measured on {engine} {version} only; on {other}: {why}")
        if res.only_before or res.only_after:
            lines.append("")
    return lines
