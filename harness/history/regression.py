"""A regression: what changed for the worse in one cell between runs, and a line saying so.
Found by ``compare`` (the last two runs, the bounds) and ``series`` (the history's steps)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Regression:
    kind: str
    scene: str
    method: str
    measure: str
    dt: float | None
    before: object
    after: object
    detail: str

    def line(self) -> str:
        where = f"{self.method} on {self.scene}" + (f" at dt={self.dt:g}" if self.dt is not None else "")
        return f"{self.kind}: {where}: {self.detail}"

    def as_dict(self) -> dict:
        return {
            "kind": self.kind,
            "scene": self.scene,
            "method": self.method,
            "measure": self.measure,
            "dt": self.dt,
            "before": self.before,
            "after": self.after,
            "detail": self.detail,
        }
