"""Energy bounds: the reviewed file ``harness/energy_bounds.csv`` (scene, method, dt, steps, bound).

Each row says: ``method`` on ``scene`` at ``dt`` keeps max |dE/E| <= ``bound`` over ``steps``
steps (against the scene's exact energy; for damped scenes the exact decaying energy).
The nightly measures every row exactly as written (measure ``bound``); a value above its
bound is a regression. The project's tests run the same rows through the pytest plugin.

``propose`` turns a run's measurements into new bounds: the measured value times ``MARGIN``,
rounded up to two significant digits (never below ``FLOOR``). It tightens bounds and adds new ones, and never
loosens one silently: a proposal above the current bound is listed as ``loosen`` and only
written with ``allow_loosen``.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

from records import InvalidInput

DEFAULT_PATH = Path(__file__).with_name("energy_bounds.csv")
FIELDS = ["scene", "method", "dt", "steps", "bound", "note"]

#: Headroom over the measured value: bounded schemes' max |dE/E| is deterministic for the
#: reference schemes and engines, so a factor 1.5 catches a real change and not noise.
MARGIN = 1.5
#: No bound below this: roundoff-level energy errors differ across platforms' libm and CPUs.
FLOOR = 1e-12


@dataclass(frozen=True)
class Bound:
    scene: str
    method: str
    dt: float
    steps: int
    bound: float
    note: str = ""

    @property
    def key(self) -> tuple:
        return (self.scene, self.method, self.dt, self.steps)

    def label(self) -> str:
        return f"{self.method} on {self.scene} at dt={self.dt:g} over {self.steps} steps"


def load(path: str | Path = DEFAULT_PATH) -> list[Bound]:
    path = Path(path)
    if not path.exists():
        raise InvalidInput(f"bounds file {path} does not exist")
    out = []
    try:
        with open(path, newline="") as fh:
            rows = [r for r in csv.DictReader(line for line in fh if not line.startswith("#"))]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InvalidInput(
            f"bounds file {path} cannot be read ({type(exc).__name__}: {exc}); valid: a CSV with "
            f"fields {', '.join(FIELDS)}"
        ) from None
    for i, row in enumerate(rows, start=2):
        try:
            b = Bound(
                row["scene"],
                row["method"],
                float(row["dt"]),
                int(row["steps"]),
                float(row["bound"]),
                row.get("note") or "",
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise InvalidInput(f"bounds file {path} row {i}: {exc} (fields: {', '.join(FIELDS)})") from None
        if not (b.dt > 0 and b.steps > 0 and b.bound > 0 and math.isfinite(b.bound) and math.isfinite(b.dt)):
            raise InvalidInput(f"bounds file {path} row {i}: dt, steps and bound must be finite and > 0")
        out.append(b)
    return out


def save(bounds: list[Bound], path: str | Path = DEFAULT_PATH) -> None:
    path = Path(path)
    tmp = path.with_suffix(".csv.tmp")
    with open(tmp, "w", newline="") as fh:
        fh.write(
            "# Reviewed energy bounds: max |dE/E| over `steps` steps at `dt`. Change with "
            "`harness bounds --update` and review the diff.\n"
        )
        w = csv.DictWriter(fh, FIELDS, lineterminator="\n")
        w.writeheader()
        for b in sorted(bounds, key=lambda b: b.key):
            w.writerow(
                {
                    "scene": b.scene,
                    "method": b.method,
                    "dt": repr(b.dt),
                    "steps": b.steps,
                    "bound": f"{b.bound:.2g}",
                    "note": b.note,
                }
            )
    tmp.replace(path)


#: Relative excess over a two-digit value that is floating-point noise, not measurement:
#: 1e-5 * MARGIN is 1.5000000000000002e-05 in binary, which must round up to 1.5e-5, not 1.6e-5.
ROUND_NOISE = 1e-9


def round_up_2sig(x: float) -> float:
    """``x`` rounded up to two significant digits (1.23e-5 -> 1.3e-5; 1.5e-5 stays 1.5e-5)."""
    if x <= 0 or not math.isfinite(x):
        return x
    e = math.floor(math.log10(x)) - 1
    digits = math.ceil(x / 10**e * (1 - ROUND_NOISE))
    return float(f"{digits}e{e}")  # the decimal literal: 15e-6 is 1.5e-05 exactly as written


@dataclass(frozen=True)
class Proposal:
    bound: Bound
    measured: float
    old: float | None
    action: str  # "add", "tighten", "keep", "loosen"


def propose(current: list[Bound], measured: dict[tuple, float]) -> list[Proposal]:
    """``measured`` maps a bound key (scene, method, dt, steps) to the measured max |dE/E|."""
    by_key = {b.key: b for b in current}
    out = []
    for key, value in sorted(measured.items()):
        if not math.isfinite(value):
            continue
        new = max(round_up_2sig(value * MARGIN), FLOOR)
        old = by_key.get(key)
        note = old.note if old else ""
        if old is None:
            action = "add"
        elif new < old.bound:
            action = "tighten"
        elif value > old.bound:
            action = "loosen"
        else:
            action, new = "keep", old.bound
        out.append(Proposal(Bound(*key, bound=new, note=note), value, old.bound if old else None, action))
    return out


def apply(current: list[Bound], proposals: list[Proposal], allow_loosen: bool = False) -> list[Bound]:
    by_key = {b.key: b for b in current}
    for p in proposals:
        if p.action in ("add", "tighten") or (p.action == "loosen" and allow_loosen):
            by_key[p.bound.key] = p.bound
    return list(by_key.values())
