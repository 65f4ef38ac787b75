"""What the measurement commands share: the scene/method arguments, validation before
anything is stepped, and printing a result as JSON or as a short table."""

from __future__ import annotations

import json
import sys
from contextlib import contextmanager

from records.result import Result
from scenarios import make_scene, parse_overrides

from harness import validate
from harness.measures.frames import jsonable
from harness.methods import check_supported, get_method


def add_common(p, method_required: bool = True):
    p.add_argument("scene")
    if method_required:
        p.add_argument("--method", required=True, help="ref:NAME or ENGINE:MODE (see `harness list`)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter")
    p.add_argument("--timeout", default="60", help="seconds an engine run may take")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    return p


def scene_of(args):
    return make_scene(args.scene, **parse_overrides(args.set))


def method_for(method_id: str, scene, options: dict | None = None):
    """The method, checked against ``scene``; a reference scheme steps as in the nightly, on its
    compiled loop wherever that computes the interpreted bits (``reference.RefMethod``)."""
    method = get_method(method_id, options, compiled_where_bitwise=True)
    check_supported(method, scene)
    return method


@contextmanager
def progress():
    """The command's progress on stderr (``harness.nightly.progress.Lines``: nothing within its
    first seconds), every kernel compile named before it starts: a callable taking a line."""
    from reference import compile_notices

    from harness.nightly.progress import Lines

    with Lines() as say, compile_notices(say):
        yield say


def timeout_of(args) -> float:
    return validate.positive_finite("--timeout", args.timeout)


def emit(result, as_json: bool, lines, scene=None) -> int:
    """Print a measure's result: its JSON form (a ``records.result.Result``'s ``as_dict``), or its lines.
    Where ``scene`` is another force model on a built-in scene's grid (``Scene.model_note``), the
    note comes first (the JSON's ``model_note``)."""
    note = scene.model_note if scene is not None else None
    if as_json:
        out = result.as_dict() if isinstance(result, Result) else result
        if note:
            out = {"model_note": note, **out}
        json.dump(jsonable(out), sys.stdout, indent=1)
        sys.stdout.write("\n")
    else:
        if note:
            print(f"{scene.id}: {note}")
        for line in lines(result):
            print(line)
    return 0


def fmt(x, spec: str = ".6g") -> str:
    return "-" if x is None else format(x, spec)
