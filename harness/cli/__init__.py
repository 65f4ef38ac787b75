"""The ``harness`` command line. Each subcommand lives in ``harness/cli/<name>.py`` with
``add_parser(subparsers)`` and ``run(args) -> exit code``.

Bad input exits 2 with one line on stderr naming the field and the valid choices.
"""

from __future__ import annotations

import argparse
import importlib
import sqlite3
import sys

from records import InvalidInput

from harness.nightly import cells as _cells  # noqa: F401 (registers the built-in measures every command reads)

COMMANDS = [
    "run",
    "list",
    "bench",
    "identify",
    "energy",
    "order",
    "stability",
    "cost",
    "workprecision",
    "advise",
    "model",
    "contact",
    "nightly",
    "compare",
    "history",
    "bounds",
    "bisect",
]


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2, like every other input error
        self.exit(2, f"harness: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="harness", description="Validation harness for physics-engine integrators.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in COMMANDS:
        module = importlib.import_module(f"harness.cli.{name}")
        module.add_parser(sub).set_defaults(_run=module.run)
    return parser


def _preload_the_engine_named(args) -> None:
    """A command about one method (``--method ENGINE:MODE``, ``ref:NAME``) has its workers' server
    import that method's engine alone (``harness.execution.isolation.preload_engines``): every
    installed engine's import is seconds a command of one engine need not wait for."""
    method = getattr(args, "method", None)
    if isinstance(method, str):
        from harness.execution.isolation import engine_modules, preload_engines

        preload_engines(engine_modules([method]))


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    _preload_the_engine_named(args)
    try:
        return int(args._run(args) or 0)
    except InvalidInput as exc:
        print(f"harness: error: {exc}", file=sys.stderr)
        return 2
    except sqlite3.DatabaseError as exc:  # a history truncated or overwritten past its first pages
        print(
            f"harness: error: --db: the history cannot be read (SQLite: {exc}); nothing was written to it",
            file=sys.stderr,
        )
        return 2
    except BrokenPipeError:
        return 0
