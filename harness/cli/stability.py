"""``harness stability SCENE --method M``: largest stable dt (and h*omega) by bisection, with
the spectral radius of the one-step map on linear scenes. Reference schemes step on the
nightly's compiled path; ``--steps``, ``--hi`` and ``--rtol`` ask a suite's question (the
standard suite: ``--steps 1000 --hi 100 --rtol 1e-4``) and get the nightly cell's numbers."""

from __future__ import annotations

from records import InvalidInput

from harness import validate
from harness.measures.stability import (
    BISECT_RTOL,
    CRITERIA,
    HOMEGA_HI,
    HOMEGA_LO,
    HORIZON_STEPS,
    SCAN_RATIO,
    largest_stable_dt,
)
from harness.cli.measure_args import add_common, emit, fmt, method_for, progress, scene_of, timeout_of


def add_parser(sub):
    p = sub.add_parser("stability", help="largest stable timestep")
    add_common(p)
    p.add_argument("--criterion", default="auto", help="auto, spectral_radius or finite_horizon")
    p.add_argument("--steps", default=str(HORIZON_STEPS), help="horizon of the finite-horizon criterion")
    p.add_argument("--lo", default=repr(HOMEGA_LO), help="smallest h*omega searched")
    p.add_argument("--hi", default=repr(HOMEGA_HI), help="largest h*omega searched")
    p.add_argument("--rtol", default=repr(BISECT_RTOL), help="relative width the bisection stops at")
    return p


def run(args) -> int:
    criterion = validate.choice("--criterion", args.criterion, CRITERIA)
    steps = validate.count("--steps", args.steps, 1)
    lo = validate.positive_finite("--lo", args.lo)
    hi = validate.positive_finite("--hi", args.hi)
    if hi <= lo:
        raise InvalidInput(f"--hi={args.hi} is out of range (allowed: > --lo = {lo:g})")
    rtol = validate.positive_finite("--rtol", args.rtol)
    if rtol >= SCAN_RATIO - 1.0:
        raise InvalidInput(f"--rtol={args.rtol} is out of range (allowed: > 0, < {SCAN_RATIO - 1.0:g})")
    timeout = timeout_of(args)
    scene = scene_of(args)
    method = method_for(args.method, scene)
    with progress() as say:
        res = largest_stable_dt(
            method, scene, criterion=criterion, steps=steps, lo=lo, hi=hi, rtol=rtol, timeout=timeout, progress=say
        )
    return emit(res, args.json, _lines, scene)


def _lines(r):
    if r.verdict == "limited":
        head = f"dt_max {r.dt_max:.6g} (h*omega {r.omega_dt_max:.6g})"
    elif r.verdict == "unbounded":
        head = f"unbounded (stable up to h*omega {r.omega_dt_searched[1]:g})"
    elif r.verdict == "unresolved":
        head = r.detail
    else:
        head = f"unstable for every dt searched (down to h*omega {r.omega_dt_searched[0]:g})"
    yield f"{r.method} on {r.scene}: {head}"
    yield f"  criterion: {r.criterion_rule}"
    if r.note:
        yield f"  note: {r.note}"
    sp = r.spectral
    if sp and sp.get("rho") is None:  # a map that is not affine to the check's tolerance (a float32 engine's)
        yield f"  one-step map at dt {sp['dt']:.6g}: not measured ({sp['reason']})"
    elif sp:
        eig = ", ".join(f"{complex(e):.6g}" for e in sp["eigenvalues"])
        yield f"  one-step map at h*omega {sp['omega_dt']:.6g}: rho {fmt(sp['rho'], '.12g')}, eigenvalues {eig}"
