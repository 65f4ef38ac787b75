"""``harness list``: scenes, methods and their metadata (and why a method is unavailable)."""

from __future__ import annotations

import json

from records import is_reference

from scenarios import ENGINE_SCENES, SCENES, contact_scenes

from records.measures import measures

from harness.methods import all_methods


def add_parser(sub):
    p = sub.add_parser("list", help="list scenes and methods with their metadata")
    p.add_argument("--json", action="store_true")
    return p


def catalogue() -> dict:
    """Every scene and method; an engine's own model on a built-in grid (``ENGINE_SCENES``) is listed
    with its note, and the modes that pose it name it in their ``supported_scenes``. The contact
    scenes, engine scenes too, are listed with the contact modes that pose them (``contact_catalogue``)."""
    contact = contact_scenes()
    scenes = {sid: cls().describe() for sid, cls in {**SCENES, **ENGINE_SCENES}.items() if sid not in contact}
    methods = {}
    for mid, m in all_methods().items():
        ok, why = m.available()
        entry = m.describe()
        entry["available"] = ok
        if not ok:
            entry["unavailable_reason"] = why
        support = {}
        for sid, cls in SCENES.items():
            sup, reason = m.supports(cls()) if ok else (False, why)
            support[sid] = True if sup else reason
        entry["scenes"] = support
        methods[mid] = entry
    listed = {
        m.name: {
            "doc": m.doc,
            "figures": m.figures.__name__,
            "made_by": m.made_by,
            "trend": m.trend,
            "columns": [c.header for c in m.columns],
        }
        for m in measures()
    }
    return {"scenes": scenes, "methods": methods, "measures": listed, **contact_catalogue()}


def contact_catalogue() -> dict:
    """The contact scenes (their parameters and truth) and the engines' contact modes (what each is,
    the scenes it poses and why not the others), which ``harness contact`` runs."""
    from harness.contact.run import contact_modes

    scenes = {
        sid: {
            "title": cls.title,
            "params": {k: {"value": p.default, "allowed": p.allowed()} for k, p in cls.params.items()},
            "figures": [f.name for f in cls.FIGURES],
        }
        for sid, cls in contact_scenes().items()
    }
    modes = {}
    for mid, mode in contact_modes().items():
        ok, why = mode.available()
        modes[mid] = {
            "doc": mode.doc,
            "available": ok,
            "scenes": list(mode.scenes),
            "unsupported": dict(mode.unsupported),
            **({} if ok else {"unavailable_reason": why}),
        }
    return {"contact_scenes": scenes, "contact_modes": modes}


def run(args) -> int:
    cat = catalogue()
    if args.json:
        print(json.dumps(cat, indent=1))
        return 0
    print("Scenes")
    for sid, s in cat["scenes"].items():
        params = ", ".join(f"{k}={v['value']:g} {v['allowed']}" for k, v in s["params"].items()) or "none"
        print(f"  {sid:16s} {s['title']}")
        if s["model_note"]:
            print(f"  {'':16s} {s['model_note']}")
        print(f"  {'':16s} omega={s['omega']:.4g} (h*omega at 60 Hz: {s['omega'] / 60.0:.3g})  params: {params}")
    print("\nContact scenes (harness contact)")
    for sid, s in cat["contact_scenes"].items():
        params = ", ".join(f"{k}={v['value']:g} {v['allowed']}" for k, v in s["params"].items())
        print(f"  {sid:16s} {s['title']}\n  {'':16s} params: {params}")
    print("\nContact modes")
    for mid, m in cat["contact_modes"].items():
        state = "" if m["available"] else f"  [unavailable: {m['unavailable_reason']}]"
        print(f"  {mid:42s} {m['doc'].splitlines()[0] if m['doc'] else ''}{state}")
        for s, r in m["unsupported"].items():
            print(f"  {'':42s}   unsupported on {s}: {r}")
    print("\nMeasures")
    for name, m in cat["measures"].items():
        print(f"  {name:22s} {m['doc']}" + (f" (made by the {m['made_by']} run)" if m["made_by"] else ""))
    print("\nMethods")
    for mid, m in cat["methods"].items():
        if is_reference(mid):
            line = (
                f"order {m['order']}, {m['force_evals']} eval/step, "
                f"{'symplectic' if m['symplectic'] else 'not symplectic'}, "
                f"{'implicit' if m['implicit'] else 'explicit'}, energy {m['energy']}, h*w max {m['homega_max']}"
            )
        else:
            line = m.get("summary", "")
        state = "" if m["available"] else f"  [unavailable: {m['unavailable_reason']}]"
        print(f"  {mid:42s} {line}{state}")
        unsupported = {s: r for s, r in m["scenes"].items() if r is not True}
        if m["available"] and unsupported:
            for s, r in unsupported.items():
                print(f"  {'':42s}   unsupported on {s}: {r}")
    return 0
