"""What the judge says of the ``penalty`` cells: the seed's "lively bounces go dead" on the penalty
ground, judged on the reference schemes' table (``harness.contact.penalty``)."""

from __future__ import annotations

from records.findings import MARK, Finding

from .findings import SEED_CLAIM, _rows


def penalty_findings(scene: str, piv: dict) -> list[Finding]:
    """The seed's claim that implicit Euler makes "lively bounces go dead", judged where
    semi-implicit Euler (the games' default, symplectic) still keeps a perfectly elastic bounce
    within the tolerance: it holds where implicit Euler's bounce keeps under half its speed."""
    import pandas as pd

    from .penalty import seed_claim

    cells = _rows(piv, scene, "penalty")
    if "ref:implicit_euler" not in cells or "ref:semi_implicit_euler" not in cells:
        return []
    df = pd.DataFrame([r for c in cells.values() for r in c.figures.rows])
    claim = seed_claim(df)
    imp, sym = claim["implicit"], claim["symplectic"]
    omega = cells["ref:implicit_euler"].figures.omega_c
    if claim["holds"]:
        hw = claim["where"]
        shown = ", ".join(f"h·ω_c = {x:g}: {sym[x]:.3f} against {imp[x]:.3f}" for x in hw)
        rests = ""
        if claim["unconverged"]:
            rests = (
                "; implicit Euler's Newton iteration did not converge at "
                + ", ".join(f"{n} step(s) at h·ω_c = {x:g}" for x, n in claim["unconverged"].items())
                + " (the kink of the ground's force), so those figures rest on an unconverged solve"
            )
        text = (
            f'{MARK} The seed: implicit Euler makes "{SEED_CLAIM}". On a penalty ground (ω_c = {omega:g} rad/s, '
            f"e = 1) semi-implicit Euler keeps the bounce within tolerance where implicit Euler keeps under half "
            f"its speed ({shown}: mean restitution, semi-implicit against implicit){rests}."
        )
    else:
        text = (
            f'{MARK} The seed: implicit Euler makes "{SEED_CLAIM}". Not seen on a penalty ground '
            f"(ω_c = {omega:g} rad/s, e = 1): at no h·ω_c of the grid does semi-implicit Euler keep the bounce "
            f"within tolerance while implicit Euler keeps under half its speed (implicit: "
            + ", ".join(f"{x:g}: {v:.3f}" for x, v in imp.items() if v is not None)
            + ")."
        )
    return [Finding(text, claim["holds"], scene, "ref:implicit_euler")]
