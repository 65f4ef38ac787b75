"""``harness bisect ENGINE LOW HIGH --scene S --method M --measure X``: the first engine release
between LOW and HIGH where a cell changed.

The releases are the registry's (``engine_env.releases``) from LOW to HIGH. LOW and HIGH are
measured first; where they differ, releases are installed (``engine_env.ensure``: once, then
reused) and measured by bisection until the first release whose cell differs from LOW's is next
to one whose cell does not: about log2(number of releases) measurements. Each measurement is
the measure command's JSON (``harness run --format json``, ``harness energy --json``, ...) from a
new process that imports the engine from that release's folder; two cells are the same when
their JSON is equal bit for bit, after the fields that name the release or the clock are left
out (``VOLATILE``). A cell the release cannot measure (a mode it lacks: "not in mujoco 3.3.7")
is a value too, its one-line error. Bisection assumes one change between LOW and HIGH: a change
undone by a later release is not seen.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
from dataclasses import dataclass, field
from collections.abc import Callable

from records import InvalidInput
from scenarios import make_scene, parse_overrides

from harness import validate

#: measure -> the harness command (and its arguments besides the scene and method) that measures it.
MEASURES = {
    "trajectory": ("run", "the trajectory, every recorded q and v (harness run --format json)"),
    "energy": ("energy", "the energy figures and class (harness energy --json)"),
    "order": ("order", "the observed order (harness order --json)"),
    "stability": ("stability", "the largest stable dt (harness stability --json)"),
    "identify": ("identify", "the reference scheme the mode matches (harness identify --json)"),
}
#: ``identity`` is the trajectory compared bit for bit, as the nightly's identity cell does.
ALIASES = {"identity": "trajectory"}

#: JSON keys that say which release or process produced a cell, not what it computed.
VOLATILE = frozenset(
    {
        "engine_version",
        "engine_versions",
        "seconds",
        "elapsed",
        "elapsed_s",
        "wall_s",
        "cpu_s",
        "timings",
        "versions",
        "environment",
        "loop",
        "engine_loop",
        "worker",
    }
)

#: Seconds one measurement may take.
MEASURE_TIMEOUT_S = 1800


def add_parser(sub):
    p = sub.add_parser("bisect", help="find the first engine release between LOW and HIGH where a cell changed")
    p.add_argument("engine", help="an engine (mujoco, pybullet, pymunk, rebound, a plugin's)")
    p.add_argument("low", help="the older release (its cell is the baseline)")
    p.add_argument("high", help="the newer release")
    p.add_argument("--scene", required=True, help="a scene id or a model file (.xml, .urdf)")
    p.add_argument("--method", required=True, help="an engine mode of ENGINE (ENGINE:MODE)")
    p.add_argument(
        "--measure", default="trajectory", help=f"the cell: {', '.join([*MEASURES, *ALIASES])} (default trajectory)"
    )
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter")
    p.add_argument("--dt", default="0.01", help="the step of trajectory, energy and identify (default 0.01)")
    p.add_argument("--steps", default="1000", help="the steps of trajectory, energy and identify (default 1000)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    return p


@dataclass
class Bisection:
    """What a bisection found: ``first`` the first release whose cell differs from LOW's (None:
    LOW and HIGH alike), ``before`` the release before it, their ``values``; ``tried`` every
    release measured, in order."""

    engine: str
    low: str
    high: str
    between: list[str]
    tried: list[str] = field(default_factory=list)
    values: dict[str, object] = field(default_factory=dict)
    first: str | None = None
    before: str | None = None

    def as_dict(self) -> dict:
        return {
            "engine": self.engine,
            "low": self.low,
            "high": self.high,
            "releases": self.between,
            "tried": self.tried,
            "first_changed": self.first,
            "last_unchanged": self.before,
            "values": {v: self.values[v] for v in (self.before, self.first) if v is not None},
        }


def find_change(
    between: list[str], measure: Callable[[str], object], say: Callable[[str], None] = lambda line: None
) -> tuple[str | None, str | None, list[str], dict]:
    """Bisect ``between`` (releases, oldest first) for the first whose ``measure`` differs from the
    first release's: ``(first changed, last unchanged before it, tried, values)``; ``(None, None, ...)``
    where the last release's equals the first's. Measures the two ends, then at most
    ceil(log2(len(between) - 1)) releases."""
    values: dict[str, object] = {}
    tried: list[str] = []
    bound = 2 + (math.ceil(math.log2(len(between) - 1)) if len(between) > 2 else 0)

    def value(i: int):
        release = between[i]
        if release not in values:
            say(f"measuring {release} ({len(tried) + 1} of at most {bound})")
            values[release] = measure(release)
            tried.append(release)
        return values[release]

    lo, hi = 0, len(between) - 1
    base = value(lo)
    if value(hi) == base:
        return None, None, tried, values
    while hi - lo > 1:  # base == value(lo) != value(hi)
        mid = (lo + hi) // 2
        if value(mid) == base:
            lo = mid
        else:
            hi = mid
        say(f"the change lies after {between[lo]}, at or before {between[hi]}")
    return between[hi], between[lo], tried, values


def strip_volatile(x):
    """``x`` (parsed JSON) without the keys in ``VOLATILE``, at any depth."""
    if isinstance(x, dict):
        return {k: strip_volatile(v) for k, v in x.items() if k not in VOLATILE}
    if isinstance(x, list):
        return [strip_volatile(v) for v in x]
    return x


def cell_argv(measure: str, scene: str, method: str, dt: str, steps: str, sets: list[str]) -> list[str]:
    """The harness command line that measures ``measure`` (JSON on stdout)."""
    command = MEASURES[measure][0]
    argv = [command, scene, "--method", method, *[f"--set={s}" for s in sets]]
    if measure == "trajectory":
        argv += ["--dt", dt, "--steps", steps, "--format", "json", "--timeout", str(MEASURE_TIMEOUT_S)]
    elif measure in ("energy", "identify"):
        argv += ["--dt", dt, "--steps", steps, "--json", "--timeout", str(MEASURE_TIMEOUT_S)]
    else:
        argv += ["--json", "--timeout", str(MEASURE_TIMEOUT_S)]
    return argv


def measure_in(folder, argv: list[str]) -> object:
    """The cell measured by ``harness ARGV`` in a process on engine folder ``folder``: its JSON
    without the volatile fields (a trajectory: its status and rows), or ``{"error": its last
    line on stderr}`` where the command failed (a mode the release lacks)."""
    from harness.execution.engine_env import run_harness

    done = run_harness(folder, argv, env=None, timeout=MEASURE_TIMEOUT_S)
    if done.returncode != 0 and not done.stdout.strip():
        lines = [line for line in done.stderr.splitlines() if line.strip()]
        said = lines[-1] if lines else f"exit {done.returncode}"
        return {"error": said.removeprefix("harness: error: ")}
    try:
        out = json.loads(done.stdout)
    except json.JSONDecodeError:
        return {"error": f"no JSON from harness {' '.join(argv[:2])} (exit {done.returncode})"}
    if argv[0] == "run":
        return {
            "status": out.get("status"),
            "failed_step": out.get("failed_step"),
            "columns": out.get("columns"),
            "rows": out.get("rows"),
        }
    return strip_volatile(out)


def describe(value) -> str:
    """One line saying what a cell is."""
    if isinstance(value, dict) and "error" in value:
        return f"unavailable: {value['error']}"
    if isinstance(value, dict) and "rows" in value:
        rows = value["rows"] or []
        digest = hashlib.sha256(json.dumps(rows).encode()).hexdigest()[:12]
        last = rows[-1] if rows else {}
        state = ", ".join(f"{k} {v!r}" for k, v in last.items() if k not in ("step", "t", "energy"))
        return f"{value['status']}, {len(rows)} rows (sha256 {digest}), at step {last.get('step')}: {state}"
    if isinstance(value, dict):
        scalars = [
            f"{k} {v!r}"
            for k, v in value.items()
            if isinstance(v, (int, float, str))
            and k not in ("scene", "method", "detail", "rule", "criterion_rule", "note")
        ]
        return ", ".join(scalars[:6])
    return repr(value)


def difference(a, b) -> str:
    """Where two cells differ: for trajectories the first differing row and the largest |difference|;
    otherwise the top-level fields that differ."""
    if isinstance(a, dict) and isinstance(b, dict) and "rows" in a and "rows" in b:
        ra, rb = a["rows"] or [], b["rows"] or []
        worst, first = 0.0, None
        for x, y in zip(ra, rb):
            for k in x:
                if k in ("step", "t"):
                    continue
                if x[k] != y.get(k):
                    first = x["step"] if first is None else first
                    try:
                        worst = max(worst, abs(float(x[k]) - float(y[k])))
                    except (TypeError, ValueError):
                        worst = math.inf
        if len(ra) != len(rb):
            return f"{len(ra)} rows against {len(rb)}" + (
                f"; first difference at step {first}" if first is not None else ""
            )
        return (
            f"first difference at step {first}, largest |difference| {worst:.3g}"
            if first is not None
            else "status differs"
        )
    if isinstance(a, dict) and isinstance(b, dict):
        keys = [k for k in dict.fromkeys([*a, *b]) if a.get(k) != b.get(k)]
        return "differs in " + ", ".join(keys[:8])
    return "differs"


def bisect(
    engine: str,
    low: str,
    high: str,
    argv: list[str],
    *,
    releases=None,
    ensure=None,
    measure=None,
    say: Callable[[str], None] = lambda line: None,
) -> Bisection:
    """Validate (one line each, nothing installed before), then bisect. ``releases(dist)`` and
    ``ensure(dist, version) -> folder`` default to ``engine_env``'s (tests inject folders);
    ``measure(folder, argv)`` to :func:`measure_in`."""
    from harness.execution import engine_env

    releases = releases or engine_env.releases
    ensure = ensure or engine_env.ensure
    measure = measure or measure_in
    dist = engine_env.dist_of(engine)
    listed = releases(dist)
    between = engine_env.check_range(dist, low, high, listed)
    low, high = between[0], between[-1]
    supported = _declared_versions(argv[3])
    if supported is not None:
        for name, v in (("LOW", low), ("HIGH", high)):
            why = supported.outside(dist, v)
            if why:
                raise InvalidInput(f"{name}: {why}")
    result = Bisection(engine, low, high, between)
    say(f"bisect: {len(between)} releases of {dist} from {low} to {high}")

    def cell(release: str):
        say(f"bisect: {dist} {release}: environment")
        folder = ensure(dist, release)
        say(f"bisect: {dist} {release}: harness {' '.join(argv[:4])}")
        value = measure(folder, argv)
        if isinstance(value, dict) and isinstance(value.get("error"), str):
            # "not in mujoco 3.3.7" and "not in mujoco 3.4.0" are the same cell: the release is not the value.
            value = {**value, "error": value["error"].replace(f"{dist} {release}", f"{dist} <release>")}
        return value

    first, before, tried, values = find_change(between, cell, lambda line: say(f"bisect: {line}"))
    result.first, result.before, result.tried, result.values = first, before, tried, values
    return result


def _declared_versions(method_id: str):
    """The release range the method's adapter declares (None: none declared, or not an adapter's mode)."""
    import adapters

    mode = adapters.ENGINE_METHODS.get(method_id)
    return getattr(mode, "versions", None)


def check_method(engine: str, method_id: str) -> None:
    from harness.methods import all_methods

    methods = [m for m in all_methods() if m.split(":", 1)[0] == engine]
    if method_id not in methods:
        raise InvalidInput(f"--method: {method_id!r} is not a mode of {engine} (valid: {', '.join(methods) or 'none'})")


def run(args) -> int:
    from harness.execution import engine_env

    measure = ALIASES.get(args.measure, args.measure)
    if measure not in MEASURES:
        raise InvalidInput(f"--measure: unknown measure {args.measure!r} (valid: {', '.join([*MEASURES, *ALIASES])})")
    engine = args.engine
    engine_env.dist_of(engine)  # an unknown engine: one line
    check_method(engine, args.method)
    dt = validate.positive_finite("--dt", args.dt)
    steps = validate.count("--steps", args.steps, 1)
    scene = make_scene(args.scene, **parse_overrides(args.set))  # a bad scene or file: one line, before installing
    del scene
    argv = cell_argv(measure, args.scene, args.method, repr(dt), str(steps), list(args.set or ()))

    def say(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    result = bisect(engine, args.low, args.high, argv, say=say)
    if args.json:
        json.dump(
            {**result.as_dict(), "scene": args.scene, "method": args.method, "measure": measure}, sys.stdout, indent=1
        )
        sys.stdout.write("\n")
        return 0
    print(
        f"bisect {engine} {result.low}..{result.high}: {measure} of {args.method} on {args.scene}"
        + (f" (dt {dt:g}, {steps} steps)" if measure in ("trajectory", "energy", "identify") else "")
    )
    print(f"  releases in range: {len(result.between)}; measured {len(result.tried)}: {', '.join(result.tried)}")
    if result.first is None:
        print(f"  unchanged: {result.low} and {result.high} give the same cell, bit for bit")
        print(f"  {result.low}: {describe(result.values[result.low])}")
        return 0
    print(f"  first release where the cell changed: {result.first} (the last unchanged: {result.before})")
    print(f"  {result.before}: {describe(result.values[result.before])}")
    print(f"  {result.first}: {describe(result.values[result.first])}")
    print(f"  {difference(result.values[result.before], result.values[result.first])}")
    return 0
