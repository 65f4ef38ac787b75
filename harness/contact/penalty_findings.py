"""What the judge says of the ``penalty`` cells: the seed's "lively bounces go dead" on the penalty
ground, judged on one impact's restitution per scheme (``harness.contact.penalty``)."""

from __future__ import annotations

from records.findings import MARK, Finding

from .findings import SEED_CLAIM, _rows


def penalty_findings(scene: str, piv: dict) -> list[Finding]:
    """The seed's claim that implicit Euler makes "lively bounces go dead", judged where
    semi-implicit Euler (the games' default, symplectic) still keeps a perfectly elastic impact
    within the tolerance at every phase: it holds where implicit Euler's impact (its step solved
    exactly) keeps under half the speed. Where the harness's Newton solve of implicit Euler failed
    at some step, that is said too (its figures there are not shown)."""
    from .penalty import seed_claim

    cells = _rows(piv, scene, "penalty")
    if "ref:implicit_euler" not in cells or "ref:semi_implicit_euler" not in cells:
        return []
    rows = [r for c in cells.values() for r in c.figures.rows]
    claim = seed_claim(rows)
    imp, sym = claim["implicit"], claim["symplectic"]
    omega = cells["ref:implicit_euler"].figures.omega_c
    per = "one impact's" if all("impact_mean" in r for r in rows) else "the mean of five bounces'"
    if claim["holds"]:
        hw = claim["where"]
        shown = ", ".join(f"h·ω_c = {x:g}: {sym[x]:.3f} against {imp[x]:.3f}" for x in hw)
        text = (
            f'{MARK} The seed: implicit Euler makes "{SEED_CLAIM}". On a penalty ground (ω_c = {omega:g} rad/s, '
            f"e = 1) semi-implicit Euler keeps the impact within tolerance where implicit Euler keeps under half "
            f"its speed ({shown}: {per} restitution, semi-implicit against implicit)."
        )
    else:
        text = (
            f'{MARK} The seed: implicit Euler makes "{SEED_CLAIM}". Not seen on a penalty ground '
            f"(ω_c = {omega:g} rad/s, e = 1): at no h·ω_c of the grid does semi-implicit Euler keep the impact "
            f"within tolerance while implicit Euler keeps under half its speed ({per} restitution, implicit: "
            + ", ".join(f"{x:g}: {v:.3f}" for x, v in imp.items() if v is not None)
            + ")."
        )
    unsolved = {
        (r["e"], r["homega"]): r["newton_unsolved"]
        for r in cells["ref:implicit_euler"].figures.rows
        if r.get("newton_unsolved")
    }
    if unsolved:
        by_e = {}
        for (e, hw), n in sorted(unsolved.items(), key=lambda kv: (-kv[0][0], kv[0][1])):
            by_e.setdefault(e, []).append(f"{hw:g} ({n})")
        text += (
            " The harness's Newton solve of implicit Euler failed (unsolved steps at h·ω_c: "
            + "; ".join(f"e = {e:g}: {', '.join(items)}" for e, items in by_e.items())
            + ") where the dashpot's jump at the ground leaves the step no consistent branch; the figures are "
            "its step solved exactly."
        )
    return [Finding(text, claim["holds"], scene, "ref:implicit_euler")]
