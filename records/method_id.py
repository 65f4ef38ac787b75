"""A method's id, parsed once: ``family:name`` (``ref:rk4``, ``mujoco:implicit``), with the
run-time options a method declares written into it where they are set:

* ``family:name?key=value&key=value``: ``ref:xpbd?iterations=1&substeps=10``;
* ``family:name@tolerance``: an error-controlled run at that tolerance (``drake:runge_kutta3@1e-6``),
  shorthand for ``?tolerance=...``.

The canonical text (``str``) writes the tolerance after ``@`` and the other options sorted by name,
so two ways of writing one method give one id (one history series, one cell).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from decimal import Decimal

from .errors import InvalidInput

#: The family of the harness's own reference schemes.
REFERENCE = "ref"

#: The option ``@`` writes.
TOLERANCE = "tolerance"


def _option_text(value) -> str:
    """A value as the id writes it: integers plainly; a float in its shortest digits, in powers of
    ten below 0.01 (``1e-4``, ``2.5e-7``: a tolerance reads as one), else plainly (``0.5``)."""
    if isinstance(value, float):
        if value.is_integer() and abs(value) < 1e16:
            return f"{value:g}"
        if value != 0.0 and abs(value) < 0.01 and math.isfinite(value):
            sign, digits, exponent = Decimal(repr(value)).as_tuple()
            mantissa = str(digits[0]) + ("." + "".join(map(str, digits[1:])) if len(digits) > 1 else "")
            return f"{'-' if sign else ''}{mantissa}e{exponent + len(digits) - 1}"
        text = repr(value)
        mantissa, e, exponent = text.partition("e")
        return f"{mantissa}e{int(exponent)}" if e else text
    return str(value)


@dataclass(frozen=True, order=True)
class MethodId:
    """``family:name`` and its options (``((key, value-text), ...)``, sorted by key);
    ``reference`` says whether it is one of the harness's own schemes."""

    family: str
    name: str
    options: tuple[tuple[str, str], ...] = ()

    @classmethod
    def parse(cls, text: str) -> MethodId:
        head, qmark, query = str(text).partition("?")
        head, at, tolerance = head.partition("@")
        family, sep, name = head.partition(":")
        if not sep or not family or not name:
            raise InvalidInput(f"method {text!r} is not of the form family:name (ref:rk4, mujoco:euler, ...)")
        options: dict[str, str] = {}
        if at:
            if not tolerance:
                raise InvalidInput(f"method {text!r}: '@' needs a tolerance after it (drake:runge_kutta3@1e-6)")
            options[TOLERANCE] = tolerance
        if qmark:
            for item in query.split("&"):
                key, eq, value = item.partition("=")
                if not eq or not key or not value:
                    raise InvalidInput(
                        f"method {text!r}: option {item!r} is not of the form key=value "
                        "(ref:xpbd?substeps=10&iterations=1)"
                    )
                if key in options:
                    raise InvalidInput(f"method {text!r}: option {key!r} is given twice")
                options[key] = value
        return cls(family, name, tuple(sorted(options.items())))

    @classmethod
    def of(cls, family: str, name: str, options: dict | None = None) -> MethodId:
        """The id of ``family:name`` with ``options`` (values of any type, written as the id writes them)."""
        return cls(family, name, tuple(sorted((k, _option_text(v)) for k, v in (options or {}).items())))

    @property
    def reference(self) -> bool:
        return self.family == REFERENCE

    @property
    def base(self) -> str:
        """``family:name`` without its options: the registry's key."""
        return f"{self.family}:{self.name}"

    def __str__(self) -> str:
        opts = dict(self.options)
        text = self.base
        if TOLERANCE in opts:
            text += "@" + opts.pop(TOLERANCE)
        if opts:
            text += "?" + "&".join(f"{k}={v}" for k, v in opts.items())
        return text


def is_reference(method_id: str) -> bool:
    """Whether ``method_id`` names one of the harness's own schemes (``ref:...``)."""
    return str(method_id).startswith(REFERENCE + ":")


def scheme_name(method_id: str | None) -> str | None:
    """The scheme id of a reference method id (``ref:rk4`` -> ``rk4``, ``ref:xpbd?substeps=4`` ->
    ``xpbd``), None for anything else."""
    if not method_id or not is_reference(method_id):
        return None
    return MethodId.parse(method_id).name


@dataclass(frozen=True)
class Option:
    """A run-time option a method declares: its type (int or float) and its range, inclusive;
    ``default`` the value the method runs at where it is not set (None: not declared); ``tighten``,
    where the option is the method's convergence knob (an iterative solve's passes or tolerance),
    the factor that makes the solve converge further (10: ten times the passes; 0.01: a hundred
    times tighter a tolerance; ``harness.methods.tightened``); or a name (type str) among
    ``choices`` (``ref:implicit_euler?solver=direct``)."""

    name: str
    type: type
    low: float = -math.inf
    high: float = math.inf
    doc: str = ""
    default: float | None = None
    tighten: float | None = None
    choices: tuple[str, ...] = ()

    def check(self, method: str, value):
        """``value`` as this option's type, or InvalidInput naming the option and its range."""
        if self.type is str:
            if str(value) not in self.choices:
                raise InvalidInput(
                    f"method {method}: option {self.name}={value!r} is not one of its choices "
                    f"(allowed: {', '.join(self.choices)})"
                )
            return str(value)
        kind = "integer" if self.type is int else "number"
        allowed = f"allowed: {kind} from {_option_text(self.low)} to {_option_text(self.high)}"
        try:
            x = float(value)
            if self.type is int:
                if x != int(x):
                    raise ValueError
                x = int(x)
        except (TypeError, ValueError, OverflowError):
            raise InvalidInput(
                f"method {method}: option {self.name}={value!r} is not "
                f"{'an integer' if self.type is int else 'a number'} ({allowed})"
            ) from None
        if not (self.low <= x <= self.high):
            raise InvalidInput(f"method {method}: option {self.name}={value} is out of range ({allowed})")
        return x
