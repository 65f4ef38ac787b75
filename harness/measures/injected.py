"""Timings injected instead of the clock's (``HARNESS_INJECT_TIMINGS``): a test of a verdict
drawn from timings reads them, so that its outcome depends on no machine's load.

The file is JSON: ``s_per_step`` by method id (``"*"`` for any other), each repeat multiplied by
``jitter`` (cycled), and the ``calibration`` pair (``harness.measures.calibration``). The cost
measure (``harness.measures.cost``) still runs every timed run; only the figures are replaced,
and the clock is recorded as ``injected``.
"""

from __future__ import annotations

import json
import os


#: A JSON file of timings to record instead of the clock's (module docstring).
INJECT_VAR = "HARNESS_INJECT_TIMINGS"


def load_injected(path=None) -> dict | None:
    """The injected timings named by ``path`` (default: ``$HARNESS_INJECT_TIMINGS``), or None."""
    path = path or os.environ.get(INJECT_VAR)
    if not path:
        return None
    from records import InvalidInput

    try:
        data = json.loads(open(path).read())
        per_step = data["s_per_step"]
        if not isinstance(per_step, dict) or not all(float(v) > 0 for v in per_step.values()):
            raise ValueError("s_per_step must map method ids to seconds > 0")
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InvalidInput(
            f"{INJECT_VAR}={path}: not an injected-timings file ({exc}); valid: JSON with "
            f"s_per_step {{method id or '*': seconds}}, optional jitter [factors], calibration "
            f"{{python, compiled}}"
        ) from None
    # What the file leaves out, in one place: no jitter (every repeat the same), no calibration pair.
    return {"jitter": [1.0], "calibration": None, **data}


def jitter(injected: dict, i: int) -> float:
    factors = injected["jitter"] or [1.0]
    return float(factors[i % len(factors)])


def calibration_injected(injected: dict | None) -> dict | None:
    """The calibration pair to record instead of the clock's, with the file's jitter (None: timed)."""
    if injected is None or not injected["calibration"]:
        return None
    return {**injected["calibration"], "jitter": injected["jitter"]}


def injected_value(injected: dict | None, method_id: str) -> float | None:
    if injected is None:
        return None
    per_step = injected["s_per_step"]
    value = per_step.get(method_id, per_step.get("*"))
    return None if value is None else float(value)
