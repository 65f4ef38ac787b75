"""A method's id, parsed once: ``family:name`` (``ref:rk4``, ``mujoco:implicit``)."""
from __future__ import annotations

from dataclasses import dataclass

from .errors import InvalidInput

#: The family of the harness's own reference schemes.
REFERENCE = "ref"


@dataclass(frozen=True, order=True)
class MethodId:
    """``family:name``; ``reference`` says whether it is one of the harness's own schemes."""

    family: str
    name: str

    @classmethod
    def parse(cls, text: str) -> "MethodId":
        family, sep, name = str(text).partition(":")
        if not sep or not family or not name:
            raise InvalidInput(f"method {text!r} is not of the form family:name (ref:rk4, mujoco:euler, ...)")
        return cls(family, name)

    @property
    def reference(self) -> bool:
        return self.family == REFERENCE

    def __str__(self) -> str:
        return f"{self.family}:{self.name}"


def is_reference(method_id: str) -> bool:
    """Whether ``method_id`` names one of the harness's own schemes (``ref:...``)."""
    return str(method_id).startswith(REFERENCE + ":")


def scheme_name(method_id: str | None) -> str | None:
    """The scheme id of a reference method id (``ref:rk4`` -> ``rk4``), None for anything else."""
    return method_id[len(REFERENCE) + 1:] if method_id and is_reference(method_id) else None
