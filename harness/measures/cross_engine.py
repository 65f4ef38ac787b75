"""Do two engines agree on a model? Two engine modes run from the same state on the same scene
(a model file's variant), compared where the comparison means something, and what each engine
built, read back from the engine, compared quantity by quantity.

**The trajectories.** Both modes run over a horizon T of at least one period of the model's
slowest mode (``2 pi / slowest_omega``, and at least the scene's reference horizon), recorded at
OUTPUTS common times. ``difference`` is max over those times of ||y_a - y_b|| / max ||y_a||,
y = (q, v/omega) (the error measure's norm). Each mode's own discretisation error at h is its
Richardson estimate against its own run at h/2, ``||y(h) - y(h/2)|| / (1 - 2^-p)`` (p the mode's
declared order, 1 where it declares none). Starting at h omega <= H0_OMEGA, h is halved until
both own errors are at most RESOLVE_FRACTION of the difference reported: of ``difference``
where the two differ by more than AGREE_RTOL, of AGREE_RTOL where they are closer (an agreement
is reported as "within AGREE_RTOL"). A step that would need more than MAX_STEPS steps ends the
search: the comparison is **not resolved**, with the figures of the finest step tried. Each
level's (h, difference, errors) is kept (``levels``).

**The built models** (``EngineModel.anatomy``, read from each engine's own model, never from
the file): per moving body its mass and principal moments of inertia (where a joint turns it);
per hinge or slide joint
its type, world axis, stiffness, spring reference, damping, armature, limits and friction loss;
the mass matrix at the initial state. Each quantity that differs by more than ANATOMY_RTOL
(relative) is one line of ``differences`` ("pybullet: body b2 mass 0.556 kg, mujoco 0.5 kg");
how an engine came by a quantity the harness supplies (Bullet's joint springs) is a line of
``notes``.

**The verdict**: ``differ`` (resolved, the trajectories further apart than AGREE_RTOL),
``agree`` (resolved within AGREE_RTOL and no built quantity differs), ``models differ``
(resolved within AGREE_RTOL although a built quantity differs: the difference is below what
this horizon shows, never called agreement), or ``not resolved``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from records.result import Result

from scenarios import Scene

from harness.measures.common import declared_order, resolve, scaled_state, step
from harness.measures.error import richardson

#: Relative difference above which a built quantity is said to differ (a few thousand eps:
#: two engines' sums of the same inertias in another order agree far closer).
ANATOMY_RTOL = 1e-9
#: The same where either engine builds its model in float32 (its anatomy's ``precision``): 17
#: float32 roundoffs (2^-24), above a mass stored in float32 (6e-9 of it) and a mass matrix summed
#: in float32 (cartpole.urdf in Newton: 2.2e-8 of its largest entry).
ANATOMY_RTOL_FLOAT32 = 1e-6
#: Each engine's own error must be at most this fraction of the difference reported.
RESOLVE_FRACTION = 0.1
#: Two trajectories closer than this (relative) are reported as agreeing within it.
AGREE_RTOL = 1e-2
#: h omega of the first step tried.
H0_OMEGA = 0.5
#: Recorded times per run (the runs at h and h/2 share them).
OUTPUTS = 64
#: The most steps one run of the search may take: beyond it the comparison is not resolved.
MAX_STEPS = 2**17
#: Verdicts, in the order a report explains them.
VERDICTS = ("agree", "differ", "models differ", "not resolved")


@dataclass(frozen=True)
class CrossEngineResult(Result):
    scene: str
    params: dict
    methods: list
    dt: float
    steps: int
    statuses: list
    horizon: float | None = None
    difference: float | None = None
    errors: list | None = None  # each mode's own error at dt (Richardson)
    reference_error: float | None = None  # kept for stored cells; the rule above needs none
    verdict: str | None = None
    disagree: bool | None = None
    resolved: bool | None = None
    levels: list | None = None  # [h, difference, error_a, error_b] per step tried
    differences: list | None = None  # what differs in the built models, one line each
    notes: list | None = None
    anatomies: list | None = None
    detail: str = ""


def _anatomy_in_worker(method_id: str, scene: Scene, dt: float):
    from harness.methods import get_method

    return get_method(method_id).anatomy(scene, dt)


def anatomy(method_id: str, scene: Scene, dt: float, timeout: float = 60.0) -> dict | None:
    from harness.execution import isolation

    if isolation.IN_WORKER:
        return _anatomy_in_worker(method_id, scene, dt)
    out = isolation.run_in_worker(_anatomy_in_worker, (method_id, scene, dt), timeout=timeout)
    return None if isinstance(out, isolation.WorkerFailure) else out


#: The MuJoCo mode whose built model a model file's energy function is (any of MuJoCo's: one compiler).
MUJOCO_MODEL = "mujoco:euler"


#: What ``built_differently`` says where an engine's built model of a file could not be read.
UNCHECKED = "its built model could not be read (model unchecked)"


def built_differently(method, scene: Scene, dt: float) -> list[str] | None:
    """On a model file, what another engine's loader built differently from the model MuJoCo
    compiled (``anatomy_differences``: masses, inertias, joints, springs): the file's energy is
    MuJoCo's function of that model, so an energy figure of an engine whose model differs would
    be another model's. [] where the method is MuJoCo's or its model is the same; one line ending
    in ``UNCHECKED`` where either model could not be read (an energy figure is then withheld as
    well: nothing says the models agree); None where the scene is not a model file."""
    if not getattr(scene, "file", None):
        return None
    if getattr(method, "family", "mujoco") == "mujoco":
        return []
    engine = getattr(method, "family", None) or str(getattr(method, "id", method)).split(":")[0]
    if not hasattr(method, "anatomy"):
        return [f"{engine}: {UNCHECKED}"]
    built = {}
    for name, mode in (("mujoco", MUJOCO_MODEL), (engine, method.id)):
        try:
            built[name] = anatomy(mode, scene, dt)
        except Exception as exc:  # an engine that cannot say what it built: no energy is claimed
            return [f"{name}: {UNCHECKED}: {type(exc).__name__}: {exc}"[:300]]
        if built[name] is None:
            return [f"{name}: {UNCHECKED}"]
    ours, theirs = built["mujoco"], built[engine]
    return anatomy_differences(ours, theirs, (MUJOCO_MODEL, method.id), scene.dof_names)


def differs_word(differs: list[str]) -> str:
    """ "model differs", or "model unchecked" where no model could be read to compare."""
    return "model unchecked" if differs and all(UNCHECKED in line for line in differs) else "model differs"


def _differs(x: float, y: float, rtol: float = ANATOMY_RTOL) -> bool:
    return abs(x - y) > rtol * max(abs(x), abs(y))


def _g(x) -> str:
    return "none" if x is None else f"{x:.6g}" if isinstance(x, float) else str(x)


def anatomy_differences(a: dict, b: dict, names: tuple[str, str], coords) -> list[str]:
    """One line per built quantity that differs between the two engines' models, said from the
    second engine's side ("pybullet: joint j2 has no stiffness (mujoco 25)")."""
    ea, eb = names[0].split(":")[0], names[1].split(":")[0]
    rtol = ANATOMY_RTOL_FLOAT32 if "float32" in (a.get("precision"), b.get("precision")) else ANATOMY_RTOL
    out = []
    ba, bb = a.get("bodies") or {}, b.get("bodies") or {}
    for body, xa in ba.items():
        xb = bb.get(body)
        if xb is None:
            out.append(f"{eb}: body {body} is not in its model ({ea}: {xa['mass']:.9g} kg)")
            continue
        if _differs(xa["mass"], xb["mass"], rtol):
            out.append(f"{eb}: body {body} mass {xb['mass']:.9g} kg, {ea} {xa['mass']:.9g} kg")
        # A body that only translates (no joint turns it) has no inertia in its dynamics.
        if (
            xa.get("rotates", True)
            and xa["inertia"] is not None
            and xb["inertia"] is not None
            and any(_differs(u, w, rtol) for u, w in zip(xa["inertia"], xb["inertia"]))
        ):
            out.append(
                f"{eb}: body {body} principal inertia {[round(x, 9) for x in xb['inertia']]}, "
                f"{ea} {[round(x, 9) for x in xa['inertia']]} kg m^2"
            )
    for body, xb in bb.items():
        if body not in ba and xb["mass"] > 0:
            out.append(f"{eb}: body {body} ({xb['mass']:.6g} kg) is not in {ea}'s model")
    ja, jb = a.get("joints") or {}, b.get("joints") or {}
    for joint, xa in ja.items():
        xb = jb.get(joint)
        if xb is None:
            out.append(f"{eb}: joint {joint} is not in its model")
            continue
        if xa["type"] != xb["type"]:
            out.append(f"{eb}: joint {joint} is a {xb['type']} joint, {ea}'s a {xa['type']} joint")
        ua, ub = np.array(xa["axis"]), np.array(xb["axis"])
        cos = float(np.dot(ua, ub) / (np.linalg.norm(ua) * np.linalg.norm(ub)))
        if not abs(cos - 1.0) <= rtol:
            out.append(
                f"{eb}: joint {joint} axis (world) {np.round(ub, 6).tolist()}, {ea} "
                f"{np.round(ua, 6).tolist()} ({math.degrees(math.acos(max(-1.0, min(1.0, cos)))):.3g} deg apart)"
            )
        for key, what in (
            ("stiffness", "stiffness"),
            ("spring_ref", "spring reference"),
            ("damping", "damping"),
            ("armature", "armature"),
            ("frictionloss", "friction loss"),
        ):
            u, w = float(xa[key]), float(xb[key])
            if not _differs(u, w, rtol):
                continue
            if w == 0.0 and key != "spring_ref":
                out.append(f"{eb}: joint {joint} has no {what} ({ea} {u:.6g})")
            else:
                out.append(f"{eb}: joint {joint} {what} {w:.6g}, {ea} {u:.6g}")
        la, lb = xa["limits"], xb["limits"]
        if (la is None) != (lb is None) or la is not None and any(_differs(u, w, rtol) for u, w in zip(la, lb)):
            out.append(f"{eb}: joint {joint} limits {_g(lb)}, {ea} {_g(la)}")
    for joint in jb:
        if joint not in ja:
            out.append(f"{eb}: joint {joint} is not in {ea}'s model")
    if a.get("mass_matrix") is not None and b.get("mass_matrix") is not None:
        ma, mb = np.array(a["mass_matrix"]), np.array(b["mass_matrix"])
        d = np.abs(ma - mb) / max(float(np.max(np.abs(ma))), 1e-300)
        if d.size and float(np.max(d)) > rtol:
            i, j = np.unravel_index(int(np.argmax(d)), d.shape)
            out.append(
                f"{eb}: mass matrix at the initial state differs by up to {float(np.max(d)):.3g} (relative to "
                f"its largest entry), at ({coords[i]}, {coords[j]}): {mb[i, j]:.6g}, {ea} {ma[i, j]:.6g}"
            )
    elif _differs(a["total_mass"], b["total_mass"], rtol):
        out.append(f"{eb}: total mass {b['total_mass']:.9g} kg, {ea} {a['total_mass']:.9g} kg")
    return out


def horizon(scene: Scene) -> float:
    """One period of the scene's slowest mode, at least its reference horizon."""
    slowest = float(getattr(scene, "slowest_omega", scene.omega))
    return max(float(scene.reference_horizon), 2.0 * math.pi / slowest)


def _pair(ma, mb, scene, T: float, n: int, timeout):
    every = max(1, n // OUTPUTS)
    return [step(m, scene, T / n, n, every, timeout) for m in (ma, mb)]


def cross_engine(
    scene: Scene,
    a: str = "mujoco:euler",
    b: str = "pybullet:semi_implicit",
    timeout: float | None = None,
    max_steps: int = MAX_STEPS,
    budget_s: float | None = None,
) -> CrossEngineResult:
    """Compare modes ``a`` and ``b`` on ``scene`` by the rule in the module docstring.
    ``budget_s``: wall seconds the step search may spend before it stops unresolved."""
    ma, mb = resolve(a, scene), resolve(b, scene)
    T = horizon(scene)
    n = OUTPUTS
    while T / n * scene.omega > H0_OMEGA:
        n *= 2
    base = {"scene": scene.id, "params": dict(scene.values), "methods": [ma.id, mb.id], "horizon": T}
    anatomies = [anatomy(m.id, scene, T / n) for m in (ma, mb)]
    differences = notes = None
    if all(x is not None for x in anatomies):
        differences = anatomy_differences(*anatomies, (ma.id, mb.id), scene.dof_names)
        notes = [line for x in anatomies for line in x.get("notes", [])]
    started = time.monotonic()
    orders = [declared_order(m, scene) or 1 for m in (ma, mb)]
    coarse, levels, result = None, [], None
    while n <= max_steps:
        runs = _pair(ma, mb, scene, T, n, timeout)
        if not all(r.ok for r in runs):
            if any(r.status not in ("ok", "unstable") for r in runs) or 2 * n > max_steps:
                return CrossEngineResult(
                    **base,
                    dt=T / n,
                    steps=n,
                    statuses=[r.status for r in runs],
                    differences=differences,
                    notes=notes,
                    anatomies=anatomies,
                    levels=levels,
                    detail="; ".join(f"{r.method} {r.status}: {r.detail}" for r in runs if not r.ok),
                )
            coarse, n = None, 2 * n  # unstable at this step: the comparison starts finer
            continue
        if coarse is not None:
            h = T / (n // 2)
            ya = scaled_state(scene, coarse[0].q[:, 0], coarse[0].v[:, 0])
            yb = scaled_state(scene, coarse[1].q[:, 0], coarse[1].v[:, 0])
            scale = float(np.max(np.linalg.norm(ya, axis=-1))) or 1.0
            diff = float(np.max(np.linalg.norm(ya - yb, axis=-1))) / scale
            errs = [richardson(scene, c, f, p, scale)[0] for c, f, p in zip(coarse, runs, orders)]
            levels.append([h, diff, *errs])
            result = (h, n // 2, diff, errs)
            if max(errs) <= RESOLVE_FRACTION * max(diff, AGREE_RTOL):
                break
        coarse = runs
        if budget_s is not None and time.monotonic() - started > budget_s:
            break
        n *= 2
    if result is None:
        return CrossEngineResult(
            **base,
            dt=T / n,
            steps=n,
            statuses=["ok", "ok"],
            differences=differences,
            notes=notes,
            anatomies=anatomies,
            levels=levels,
            resolved=False,
            verdict="not resolved",
            detail=f"no step of at most {max_steps} steps over {T:.3g} s ran in both engines",
        )
    h, steps, diff, errs = result
    resolved = max(errs) <= RESOLVE_FRACTION * max(diff, AGREE_RTOL)
    same = differences == [] if differences is not None else False
    if not resolved:
        verdict = "not resolved"
    elif diff > AGREE_RTOL:
        verdict = "differ"
    else:
        verdict = "agree" if same else "models differ"
    return CrossEngineResult(
        **base,
        dt=h,
        steps=steps,
        statuses=["ok", "ok"],
        difference=diff,
        errors=errs,
        verdict=verdict,
        disagree=verdict in ("differ", "models differ"),
        resolved=resolved,
        levels=levels,
        differences=differences,
        notes=notes,
        anatomies=anatomies,
    )


def verdict_text(verdict: str | None, methods, difference, errors, dt, steps, horizon_s, differences) -> str:
    """The verdict in one sentence with its figures (the cell's detail, the report's head line)."""
    a, b = methods or ("?", "?")
    if difference is None or verdict is None:
        return f"{a} and {b}: not compared"
    figures = (
        f"{steps} steps of {dt:.3g} s over {horizon_s:.3g} s from the same state: difference {difference:.3g} "
        f"(relative), their own errors {errors[0]:.2g} and {errors[1]:.2g}"
    )
    built = (
        "the built models agree"
        if differences == []
        else f"the built models differ in {len(differences)} quantities"
        if differences
        else "the built models were not read"
    )
    if verdict == "differ":
        return f"{a} and {b} differ: {figures}, each at most {RESOLVE_FRACTION:g} of it; {built}"
    if verdict == "agree":
        return (
            f"{a} and {b} agree within {AGREE_RTOL:g}: {figures}, each at most {RESOLVE_FRACTION:g} of "
            f"{AGREE_RTOL:g}; {built}"
        )
    if verdict == "models differ":
        return (
            f"{a} and {b} stay within {AGREE_RTOL:g} of each other over this horizon ({figures}), but they "
            f"are not the same model: {built}"
        )
    return (
        f"{a} and {b}: not resolved: at the finest step tried, {figures}; an agreement or a difference needs "
        f"each own error at most {RESOLVE_FRACTION:g} of the difference (or of {AGREE_RTOL:g})"
    )
