"""``harness bounds``: show the reviewed energy bounds, or ``--update`` to propose new ones from a
stored run. Tightening and new bounds are written with ``--write``; loosening a bound needs
``--allow-loosen`` as well, and is always listed."""

from __future__ import annotations

import json
from pathlib import Path

from records import InvalidInput

from harness.history import bounds as bounds_mod
from harness import validate
from harness.nightly.run import DEFAULT_DB
from harness.history.storage import History


def add_parser(sub):
    p = sub.add_parser("bounds", help="show or update the reviewed energy bounds")
    p.add_argument("--update", action="store_true", help="propose bounds from a stored run's measurements")
    p.add_argument("--run", default=None, help="run id (default: the latest complete run)")
    p.add_argument("--db", default=str(DEFAULT_DB))
    p.add_argument("--file", default=None, help="bounds file (default: the reviewed harness/energy_bounds.csv)")
    p.add_argument("--write", action="store_true", help="write added and tightened bounds to the file")
    p.add_argument("--allow-loosen", action="store_true", help="also write loosened bounds (review the diff!)")
    p.add_argument("--json", action="store_true")
    return p


def run(args) -> int:
    path = Path(args.file) if args.file else bounds_mod.DEFAULT_PATH
    current = bounds_mod.load(path)
    if not args.update:
        rows = [b.__dict__ for b in current]
        if args.json:
            print(json.dumps(rows, indent=1))
        else:
            for b in current:
                print(f"{b.label()}: max |dE/E| <= {b.bound:.2g}")
        return 0
    if not Path(args.db).exists():
        raise InvalidInput(f"--db={args.db}: no such history (run `harness nightly` first)")
    history = History(args.db)
    runs = history.runs()
    if runs.empty:
        raise InvalidInput(f"no complete run stored in {args.db}")
    run_id = validate.count("--run", args.run, 1) if args.run is not None else int(runs.run_id.iloc[-1])
    cells = history.cells(run_id)
    measured = {
        (r["scene"], r["method"], float(r["dt"]), int(r["steps"])): float(r["value"])
        for _, r in cells[(cells.measure == "bound") & (cells.status == "ok")].iterrows()
    }
    proposals = bounds_mod.propose(current, measured)
    if args.json:
        print(
            json.dumps(
                [{"action": p.action, **p.bound.__dict__, "measured": p.measured, "old": p.old} for p in proposals],
                indent=1,
            )
        )
    else:
        for p in proposals:
            old = f"{p.old:.2g}" if p.old is not None else "none"
            print(f"{p.action:8s} {p.bound.label()}: measured {p.measured:.3e}, bound {old} -> {p.bound.bound:.2g}")
        loosen = [p for p in proposals if p.action == "loosen"]
        if loosen and not args.allow_loosen:
            print(f"{len(loosen)} bound(s) would loosen: not written without --allow-loosen")
    if args.write:
        bounds_mod.save(bounds_mod.apply(current, proposals, args.allow_loosen), path)
        print(f"wrote {path}")
    return 0
