"""``harness contact``: the engines on the contact scenes, and the reference schemes on a penalty
ground.

    harness contact ball --set e=1 [--modes mujoco:euler,...] [--dt 1/1000,1/240,1/60]
    harness contact --penalty [--methods ref:implicit_euler,...] [--grid 0.01,0.1,1,10] [--set omega_c=1000]
    harness contact --advise [--hz 60]

Every input is checked before any engine is touched (one line naming the bad field and the valid
choices, exit 2); an engine's crash, hang or blow-up is a row of its own.
"""

from __future__ import annotations

import json
import math
import sys

from records import InvalidInput
from scenarios import parse_overrides

from harness import validate
from harness.measures.frames import jsonable


def add_parser(sub):
    p = sub.add_parser("contact", help="contact: bounce, slide, rest and stack in every engine; the penalty table")
    p.add_argument(
        "scene",
        nargs="?",
        help="a contact scene: ball, slide, rest, stack, ... (harness list; every one where none is given)",
    )
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="a scene parameter (e, mu, h0, ...)")
    p.add_argument("--modes", help="engine contact modes, comma-separated (default: every available one)")
    p.add_argument("--dt", default="1/1000,1/240,1/60", help="steps in seconds, comma-separated (fractions allowed)")
    p.add_argument("--penalty", action="store_true", help="the reference schemes on a penalty ground instead")
    p.add_argument("--methods", help="--penalty: the reference schemes, comma-separated")
    p.add_argument("--grid", help="--penalty: h*omega_c values, comma-separated (default: 0.01 to 100)")
    p.add_argument(
        "--advise",
        action="store_true",
        help="which mode bounces, slides and rests within tolerance at a --hz frame (1 to 16 substeps), cheapest first",
    )
    p.add_argument("--hz", default="60", help="--advise: the frame rate")
    p.add_argument(
        "--profile",
        help="the tolerances judged by: game (Box2D's 5 mm slop) or robotics (1 mm); "
        "default: game below 200 Hz, robotics from it",
    )
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    return p


def run(args) -> int:
    if args.penalty:
        from .penalty import run_penalty

        return run_penalty(args)
    from scenarios import contact_scenes
    from scenarios.contact import make_contact_scene, profile

    from harness.contact.run import check_dt, contact_modes
    from harness.methods import active_plugins, load_plugins

    load_plugins(active_plugins())  # a plugin module may register contact scenes and their poses
    known = contact_scenes()
    scenes = [args.scene] if args.scene else list(known)
    if args.advise:
        scenes = ["ball", "slide", "stack"]
        hz = validate.positive_finite("--hz", args.hz)
        dts = [1.0 / hz]
    else:
        dts = [check_dt(x) for x in validate.positive_list("--dt", args.dt)]
    tol = profile(args.profile) if args.profile is not None else None  # None: each step by its own
    overrides = parse_overrides(args.set)
    params = {}
    for s in scenes:
        if s not in known:
            raise InvalidInput(f"unknown contact scene {s!r} (valid: {', '.join(known)})")
        mine = {k: v for k, v in overrides.items() if k in known[s].params}
        if args.scene:
            mine = overrides
        params[s] = dict(make_contact_scene(s, **mine).values)
    modes = contact_modes()
    chosen = None
    if args.modes:
        chosen = [m.strip() for m in args.modes.split(",") if m.strip()]
        for m in chosen:
            if m not in modes:
                raise InvalidInput(f"--modes: unknown contact mode {m!r} (valid: {', '.join(modes)})")
    if args.advise:
        return advise_contact(dts[0], chosen, {s: params[s] for s in scenes}, args.json, tol)
    from harness.contact.study import study

    from harness.cli.measure_args import progress

    with progress() as say:
        df = study({s: params[s] for s in scenes}, chosen, dts, tol=tol, progress=say)
    if args.json:
        json.dump(jsonable(df.to_dict(orient="records")), sys.stdout, indent=1)
        print()
        return 0
    for line in _lines(df):
        print(line)
    return 0


def _fmt(x) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, list):
        if all(isinstance(v, int) for v in x):
            return ",".join(str(v) for v in x) if x else "none"
        return " ".join(f"{v:.3f}" for v in x) if x else "none"
    return f"{x:.4g}"


def _shown(scene_id: str, params: dict) -> tuple[tuple[str, int], ...]:
    """The scene's figures shown in the table, as it declares them (``scenarios.contact.Figure``):
    (name, column width) each, a figure per bounce in a wide column."""
    from scenarios.contact import make_contact_scene

    return tuple(
        (f.name, 30 if f.fmt == "list" else 11) for f in make_contact_scene(scene_id, **params).FIGURES if f.shown
    )


def _lines(df):
    by_dt = {}
    if "profile" in df:
        for r in df[df.profile.notna()].itertuples():
            by_dt.setdefault(r.profile, set()).add(r.dt)
    if by_dt:
        yield (
            "judged by "
            + "; ".join(
                f"the {name} profile at {', '.join(f'1/{1 / dt:.0f} s' for dt in sorted(dts))}"
                for name, dts in by_dt.items()
            )
            + " (harness contact --profile; each figure's ✓ under every profile in --json)"
        )
    for scene, rows in df.groupby("scene", sort=False):
        truth = rows.iloc[0].truth
        shown = _shown(scene, rows.iloc[0].params)
        yield f"{scene} ({', '.join(f'{k}={v:g}' for k, v in rows.iloc[0].params.items())}): truth " + ", ".join(
            f"{k} {_fmt(truth[k])}" for k, _ in shown if k in truth
        )
        yield f"  {'mode':32} {'dt':>8}  " + "  ".join(f"{k:>{w}}" for k, w in shown) + "  verdict      CPU s/s"
        for _, r in rows.iterrows():
            if r.status == "unsupported":
                yield f"  {r.method:32} {'-':>8}  unsupported: {r.detail}"
                continue
            if r.status != "ok":
                yield f"  {r.method:32} {r['dt']:8.5f}  {r.status}: {r.detail}"
                continue
            failed = sorted(k for k, v in r.passes.items() if not v)
            verdict = "within" if not failed else "x " + ",".join(failed)
            cells = "  ".join(f"{_fmt(r[k]):>{w}}" for k, w in shown)
            yield f"  {r.method:32} {r['dt']:8.5f}  {cells}  {verdict:12} {_fmt(r.cpu_per_s)}"
        yield ""


def profile_for(name: str | None, dt: float):
    """The tolerance profile named (one line naming the valid ones where it is not one), or the
    one a step is judged by where none is named (``scenarios.contact.profile_at``)."""
    from scenarios.contact import profile, profile_at

    return profile(name) if name is not None else profile_at(dt)


def advise_contact(dt: float, modes=None, scenes=None, as_json: bool = False, tol=None) -> int:
    """The contact advice at one step (``harness contact --advise``, ``harness advise contact``):
    the modes within every tolerance of the profile ``tol`` (``profile_for``'s where None) on the
    ball, the slide and the stack, cheapest first."""
    from scenarios.contact import make_contact_scene

    from harness.contact.study import ADVICE_SCENES, advise_frame

    from harness.cli.measure_args import progress

    tol = tol or profile_for(None, dt)
    scenes = scenes or {s: dict(make_contact_scene(s).values) for s in ADVICE_SCENES}
    with progress() as say:
        out = advise_frame(scenes, 1.0 / dt, modes, tol, progress=say)
    if as_json:
        json.dump(jsonable(out), sys.stdout, indent=1)
        print()
        return 0
    for line in _advice_lines(out):
        print(line)
    return 0


def contact_modes_matching(patterns) -> list[str] | None:
    """The contact modes ``patterns`` name (ids or shell patterns, ``mujoco:*``); None: every one."""
    import fnmatch

    from harness.contact.run import contact_modes

    if not patterns:
        return None
    modes = list(contact_modes())
    chosen = [m for m in modes if any(fnmatch.fnmatchcase(m, p) for p in patterns)]
    missing = [p for p in patterns if not any(fnmatch.fnmatchcase(m, p) for m in modes)]
    if missing:
        raise InvalidInput(f"--methods: {missing[0]!r} names no contact mode (valid: {', '.join(modes)})")
    return chosen


def _advice_lines(out):
    yield (
        f"a {1 / out['dt']:.4g} Hz frame, judged by the {out['profile']} profile ({out['tolerances']['source']}): "
        "within every tolerance on ball, slide and stack at its fewest substeps a frame (1, 2, 4, 8, 16 tried), "
        "cheapest first (engine loop CPU s per simulated s summed over the three):"
    )
    for m in out["within"]:
        n = out.get("substeps", {}).get(m, 1)
        yield f"  {m}: {out['cost'][m]:.3g} at {n} substep{'s' if n > 1 else ''} a frame"
    if not out["within"]:
        yield "  none"
    for m, bad in sorted(out["failing"].items()):
        yield f"  not {m}: " + "; ".join(f"{scene} ({', '.join(figs)})" for scene, figs in bad.items())
    for m, why in sorted(out.get("unposed", {}).items()):
        yield f"  not posed by {m}: " + "; ".join(f"{scene} ({reason})" for scene, reason in why.items())
