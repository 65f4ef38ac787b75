"""The nightly cells only some scenes have, measured beside the five every task measures.

* ``constraint`` (every constrained scene, every method): ``harness.measures.constraint`` over the
  energy run (the same dt, steps and recording). For a scheme with projection passes
  (``ref:verlet_constrained``) also at each pass count in ``extras["constraint"]["iterations"]``
  (``data["by_iterations"]``). Value: the largest relative stretch.
* ``damping`` (scenes whose suite entry lists it in ``extras``: the chain; every method):
  ``harness.measures.damping`` at ``extras["damping"]["factor"]`` (default 100) times the explicit
  limit. Value: the energy kept after one step. As with ``stability``, a method found to
  grow there is a measured result (``data["stable"]`` False, the run's own status in
  ``data["run_status"]``), not a failed cell; the status is ``crashed`` / ``timed_out`` only
  when the measurement itself did not finish.
* ``stability_vs_damping`` (scenes whose suite entry lists it: the damped spring; every
  method): ``harness.measures.stability_damping`` over ``extras["stability_vs_damping"]["zetas"]``, each
  limit beside the theory of the method's own scheme, or for an engine mode of the scheme it
  was identified as (the task's claims). Value: the number of damping ratios whose measured
  limit agrees with that theory; a reference scheme's cell also carries its theory curve.
* ``scaling`` (the chain, ``ref:implicit_euler``; ``extras["scaling"]``): compiled cost per
  step at each N of ``ns`` (``harness.measures.scaling``). Value: the log-log slope.
"""
from __future__ import annotations

from scenarios import make_scene

#: Methods the ``scaling`` cell is measured for unless the suite entry names others.
SCALING_METHODS = ("ref:implicit_euler",)


def measures_for(task, spec) -> list[str]:
    out = []
    if make_scene(task.scene, **task.params).constrained:
        out.append("constraint")
    if "damping" in spec.extras:
        out.append("damping")
    if "stability_vs_damping" in spec.extras:
        out.append("stability_vs_damping")
    scaling = spec.extras.get("scaling")
    if scaling is not None and task.method in scaling.get("methods", SCALING_METHODS):
        out.append("scaling")
    return out


def scene_cells(task, method, scene, dt, spec, suite, claims=None) -> list[dict]:
    from harness.nightly.cells import _guard

    builders = {"constraint": lambda: _constraint(task, method, scene, dt, spec, suite),
                "damping": lambda: _damping(task, method, scene, spec, suite),
                "stability_vs_damping": lambda: _stability_vs_damping(task, method, spec, claims or {}),
                "scaling": lambda: _scaling(task, spec)}
    return [_guard(task, m, builders[m]) for m in measures_for(task, spec)]


def _constraint(task, method, scene, dt, spec, suite) -> dict:
    from harness.nightly.cells import _cell, _finite, _plain, energy_run
    from harness.measures.constraint import constraint_drift
    from harness.methods import get_method

    steps, every = energy_run(scene, dt, spec, suite)
    res = constraint_drift(method, scene, dt, steps, every=every, timeout=suite.cell_timeout)
    data = {k: res.get(k) for k in ("final_stretch", "energy_change", "max_energy_change", "t_final",
                                    "iterations", "failed_step")}
    passes = spec.extras.get("constraint", {}).get("iterations", ())
    if passes and method.scheme is not None and method.scheme.constrained:
        rows = []
        for k in passes:
            r = constraint_drift(get_method(task.method, {"iterations": k}), scene, dt, steps, every=every,
                                 timeout=suite.cell_timeout)
            rows.append({key: r.get(key) for key in ("iterations", "status", "max_stretch", "final_stretch",
                                                     "energy_change", "max_energy_change")})
        data["by_iterations"] = rows
    return _cell(task, "constraint", res["status"], _finite(res.get("max_stretch")), dt, steps, res["detail"],
                 _plain(data))


def _damping(task, method, scene, spec, suite) -> dict:
    from harness.nightly.cells import _cell, _finite, _plain
    from harness.measures.damping import FACTOR, damping_far_beyond_the_limit

    factor = spec.extras["damping"].get("factor", FACTOR)
    res = damping_far_beyond_the_limit(method, scene, factor=factor, timeout=suite.cell_timeout)
    status = res["status"] if res["status"] in ("crashed", "timed_out") else "ok"
    detail = res["detail"]
    if res.get("stable") is False:
        detail = f"grows: spectral radius {res['rho']:.4g} at h*omega = {res['omega_dt']:.4g}"
    data = {k: res.get(k) for k in ("factor", "omega_dt", "energy_kept", "rho", "stable", "reason", "modal_leak",
                                    "linearity_residual", "highest", "lowest", "failed_step")}
    data["run_status"] = res["status"]
    return _cell(task, "damping", status, _finite(res.get("energy_kept_one_step")), res["dt"], res["steps"], detail,
                 _plain(data))


def _stability_vs_damping(task, method, spec, claims) -> dict:
    from harness.nightly.cells import _cell, _plain
    from harness.measures.stability_damping import ZETAS, CURVE_ZETAS, limit_vs_damping, theory_curve

    zetas = tuple(spec.extras["stability_vs_damping"].get("zetas", ZETAS))
    scheme = claims.get("scheme")
    res = limit_vs_damping(method, zetas, scheme=scheme)
    data = {"scheme": res["scheme"], "rows": res["rows"], "tolerance": res["tolerance"],
            "judged_by": "own scheme" if task.family == "ref" else "identified scheme"}
    if task.family == "ref" and res["scheme"]:
        data["theory_curve"] = {"zeta": list(CURVE_ZETAS), "homega_max": theory_curve(res["scheme"][4:])}
    agreeing = sum(1 for r in res["rows"] if r["agrees"])
    detail = "" if res["scheme"] else "no scheme identified: measured only"
    return _cell(task, "stability_vs_damping", "ok", float(agreeing) if res["scheme"] else None, detail=detail,
                 data=_plain(data))


def _scaling(task, spec) -> dict:
    from harness.nightly.cells import _cell, _plain
    from harness.measures.scaling import implicit_cost_vs_n

    settings = dict(spec.extras["scaling"])
    settings.pop("methods", None)
    frame = implicit_cost_vs_n(scheme=task.method.split(":", 1)[1], **settings)
    return _cell(task, "scaling", "ok", frame.attrs["slope"],
                 data=_plain({"rows": frame.to_dict("records"), "rvalue": frame.attrs["rvalue"],
                              "intercept": frame.attrs["intercept"], "settings": settings}))
