"""Records: the shapes that travel between the harness's rooms, at the bottom of the house.

Nothing here simulates or judges, and nothing here imports another package of the project:
``Trajectory`` (a run's recorded states and status), ``InvalidInput`` (the one error a user's
input raises), ``MethodId`` (``family:name``, parsed once), ``Method`` (the protocol every method
implements, its optional capabilities declared with their defaults).
"""

from __future__ import annotations

from .errors import InvalidInput
from .method import Method
from .method_id import REFERENCE, MethodId, is_reference, scheme_name
from .trajectory import CRASHED, DIVERGED, OK, TIMED_OUT, UNSTABLE, Trajectory, divergence_detail, diverged

__all__ = [
    "InvalidInput",
    "Method",
    "MethodId",
    "REFERENCE",
    "is_reference",
    "scheme_name",
    "Trajectory",
    "OK",
    "UNSTABLE",
    "CRASHED",
    "TIMED_OUT",
    "DIVERGED",
    "divergence_detail",
    "diverged",
]
