"""Engine behaviour a user would not expect, on any scene (``harness.judge`` lists these before
each scene's own checks): a mode that integrates as another scheme than its name suggests, or as
explicit Euler, or as none; an energy gain or a blow-up at the nominal timestep, and a blow-up
within the stability measure's horizon set beside the same engine's other modes."""

from __future__ import annotations

import math

import numpy as np

from records.findings import Finding


def _g(x, spec=".3g") -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def engine_findings(piv: dict) -> list[Finding]:
    """Engine behaviour a user would not expect, on any scene: a mode that integrates as another
    scheme than its name suggests, or as explicit Euler, or as none; a blow-up or an energy gain
    at the nominal timestep."""
    out = []
    for (scene, method), ms in sorted(piv.items()):
        if method.startswith("ref:"):
            continue
        ident, energy = ms.identity, ms.energy
        if ident is not None and ident.status == "ok":
            f = ident.figures
            matches, dev = f.all_matches, ident.value
            expected = f.name_suggests
            if expected and matches and f"ref:{expected}" not in matches:
                said = " = ".join(f"`{m}`" for m in matches)
                out.append(
                    Finding(
                        f"`{method}` on `{scene}` integrates as **{said}** (max deviation {dev:.1e}), "
                        f"not the {expected.replace('_', ' ')} its name suggests.",
                        None,
                        scene,
                        method,
                    )
                )
            elif matches == ["ref:explicit_euler"]:
                out.append(
                    Finding(
                        f"`{method}` on `{scene}` is **explicit Euler** (max deviation {dev:.1e}).", None, scene, method
                    )
                )
            elif not matches and f.note:
                out.append(Finding(f"`{method}` on `{scene}`: {f.note}", None, scene, method))
        if energy is not None and energy.status == "unstable" and energy.figures.failed_step:
            out.append(
                Finding(
                    f"`{method}` blows up on `{scene}` at the nominal timestep (step {energy.figures.failed_step}).",
                    None,
                    scene,
                    method,
                )
            )
        elif energy is not None and energy.status == "ok" and energy.figures.energy_class == "grows":
            numbers = energy.figures.numbers or {}
            above = numbers.get("max_over_start") if numbers.get("dissipative") else None
            figure = (
                f"its energy rises to {above:.3g} x its start where the exact motion's only falls; "
                if above is not None
                else ""
            )
            out.append(
                Finding(
                    f"`{method}` gains energy on `{scene}` at the nominal timestep ({figure}max |ΔE/E| "
                    f"{energy.value:.2e}).",
                    None,
                    scene,
                    method,
                )
            )
        elif energy is not None and energy.status == "ok" and energy.figures.energy_class == "damps less":
            ratio = (energy.figures.numbers or {}).get("end_ratio")
            numbers = energy.figures.numbers or {}
            how = (
                "ends below its start, having risen above it at some steps"
                if numbers.get("energy_rose")
                else "never rises above its start"
                if numbers.get("energy_step_rises")
                else "falls, never rises"
            )
            out.append(
                Finding(
                    f"`{method}` damps `{scene}` less than the exact motion at the nominal timestep (its energy "
                    + how
                    + (
                        f"; {ratio:.{6 if abs(ratio - 1.0) < 0.01 else 3}g} x the exact energy at the end"
                        if ratio is not None
                        else ""
                    )
                    + ").",
                    None,
                    scene,
                    method,
                )
            )
    return out


def blowups_at_nominal(piv: dict) -> list[Finding]:
    """A method that blows up within the stability measure's finite horizon at the suite's
    nominal timestep, with its evidence: the step, its largest stable h·ω, and the same engine's
    other modes on the same scene at that step (their nominal runs). Where a companion runs on
    there, the engine and the scene's model are the same and only the integrator differs: the
    cause is the mode; where none does, the model at this timestep (its stiffness or its
    constraints) is what every mode fails on."""
    out = []
    for (scene, method), ms in sorted(piv.items()):
        stab = ms.stability
        nominal = stab.figures.nominal if stab is not None and stab.status == "ok" else None
        if nominal is None or not nominal.failed_step:
            continue
        step, family = nominal.failed_step, method.split(":")[0]
        t_fail = step * nominal.dt
        companions = []
        for (s2, m2), ms2 in sorted(piv.items()):
            other = ms2.stability
            if s2 != scene or m2 == method or m2.split(":")[0] != family or other is None or not other.figures.nominal:
                continue
            n2 = other.figures.nominal
            runs_on = not n2.failed_step or n2.failed_step > step
            kept = ""
            if runs_on and n2.has_series:
                t, e = np.asarray(n2.series["t"]), np.asarray(n2.series["energy"], dtype=float)
                e_at = float(np.interp(t_fail, t, e))
                kept = f", energy {e_at:.3g} (started at {e[0]:.3g})"
            companions.append(
                (m2, runs_on, (f"runs on{kept}" if runs_on else f"blew up too, at step {n2.failed_step}"))
            )
        limit = stab.value
        own = nominal.series["energy"] if nominal.has_series else []
        gained = f", its energy {own[0]:.3g} -> {own[-1]:.3g} before it" if len(own) > 1 else ""
        text = (
            f"`{method}` on `{scene}` blows up at the nominal h·ω = {nominal.homega:.3g} (dt = "
            f"{nominal.dt:.3g}) at step {step} of {nominal.steps}{gained} "
            f"({nominal.detail or 'diverged'}); its largest stable h·ω there is {_g(limit, '.3g')}."
        )
        if companions:
            text += (
                " At that step the same engine's other modes, on the same model: "
                + "; ".join(f"`{m}` {what}" for m, _, what in companions)
                + "."
            )
            steady = [m for m, ok, _ in companions if ok]
            if steady:
                text += (
                    f" Cause: the mode's integrator, not the scene's model ({', '.join(f'`{m}`' for m in steady)} "
                    f"integrate the same model at the same dt). Use {'one of them' if len(steady) > 1 else 'it'}, "
                    f"or h·ω <= {_g(limit, '.3g')} with `{method}`."
                )
            else:
                text += (
                    f" Cause: the scene's model at this timestep (every mode of the engine fails on it): "
                    f"h·ω <= {_g(limit, '.3g')}."
                )
        out.append(Finding(text, None, scene, method))
    return out
