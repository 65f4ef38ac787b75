"""Input checks shared by every command: each raises InvalidInput with a one-line message
naming the field and what it may be, before anything is stepped or any engine is touched."""

from __future__ import annotations

import math

from records import InvalidInput


def positive_finite(name: str, value) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InvalidInput(f"{name}={value!r} is not a number (allowed: finite, > 0)") from None
    if not math.isfinite(x) or x <= 0.0:
        raise InvalidInput(f"{name}={value} is out of range (allowed: finite, > 0)")
    return x


def positive_list(field: str, text) -> list[float]:
    """A comma-separated list of positive finite numbers, each a decimal or a fraction (1/1000)."""
    from fractions import Fraction

    out = []
    for item in str(text).split(","):
        item = item.strip()
        try:
            x = float(Fraction(item))
        except (ValueError, ZeroDivisionError):
            raise InvalidInput(f"{field} {item!r} is not a number (write e.g. 0.001 or 1/1000)") from None
        if not (math.isfinite(x) and x > 0):
            raise InvalidInput(f"{field} {item!r} is out of range (allowed: > 0, finite)")
        out.append(x)
    if not out:
        raise InvalidInput(f"{field} is empty")
    return out


#: The most timesteps a sweep (order, work-precision) takes.
MAX_POINTS = 1000
#: The largest count any field takes: 1e9 steps of the fastest kernel is minutes; beyond, a typo.
MAX_COUNT = 10**9


def count(name: str, value, minimum: int = 0, maximum: int = MAX_COUNT) -> int:
    allowed = f"allowed: integer from {minimum} to {maximum}"
    try:
        x = int(value)
    except (TypeError, ValueError, OverflowError):
        raise InvalidInput(f"{name}={value!r} is not an integer ({allowed})") from None
    if not minimum <= x <= maximum or x != float(value):
        raise InvalidInput(f"{name}={value} is out of range ({allowed})")
    return x


def choice(name: str, value: str, choices) -> str:
    if value not in choices:
        raise InvalidInput(f"unknown {name} {value!r} (valid: {', '.join(choices)})")
    return value


def scene_values(scene) -> None:
    """Check a scene's current parameter values against its declared ranges once more: a
    scene's ``values`` is a plain dict, and an engine must never see what the scene refuses."""
    scene.copy_with(**scene.values)
