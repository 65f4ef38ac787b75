"""records/: the divergence test every run asks at every step; method ids parsed once; and the
one Method protocol every registered method answers in full (reference schemes, engine modes, a
plugin's modes, and a plugin's method that declares only the least a method must have)."""

from __future__ import annotations

import re
import sys
import types
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pytest

import adapters
import reference
from harness import methods as registry
from harness.measures import energy
from records import REFERENCE, InvalidInput, Method, MethodId, is_reference, scheme_name
from records.method import OPTIONAL
from records.trajectory import DIVERGED, diverged
from reference import RefMethod
from scenarios import make_scene

ROOT = Path(__file__).resolve().parents[1]
PLUGINS = "tests.faulty_plugin,tests.slow_plugin"


# --------------------------------------------------------------------------- divergence
def componentwise(q, v) -> bool:
    """The rule, spelled out: some component not finite, or beyond DIVERGED."""
    x = np.concatenate([np.ravel(q), np.ravel(v)])
    return bool(np.any(~np.isfinite(x)) or np.any(np.abs(x) > DIVERGED))


@pytest.mark.parametrize(
    "value",
    [
        0.0,
        1.0,
        -3e99,
        DIVERGED,
        -DIVERGED,
        np.nextafter(DIVERGED, np.inf),
        1e101,
        1e160,
        -1e200,
        np.inf,
        -np.inf,
        np.nan,
    ],
)
@pytest.mark.parametrize("where", ["q", "v"])
def test_diverged_is_the_componentwise_rule(value, where):
    """Edge values in either half of the state (NaN in v alone included), among ordinary ones."""
    q, v = np.array([0.5, -2.0, 1e3]), np.array([0.1, 7.0, -1e-300])
    (q if where == "q" else v)[1] = value
    assert diverged(q, v) == componentwise(q, v)


def test_diverged_agrees_with_the_rule_on_random_states_across_every_scale():
    """Many components each just under DIVERGED (their squares' sum passes the fast bound, so the
    componentwise test decides), and random magnitudes from 1e-300 to 1e300."""
    rng = np.random.default_rng(7)
    q = np.full(100, 0.99 * DIVERGED)
    assert not diverged(q, np.zeros(3)) and not componentwise(q, np.zeros(3))
    for _ in range(2000):
        n = rng.integers(1, 12)
        q = rng.choice([-1, 1], n) * 10.0 ** rng.uniform(-300, 300, n)
        v = rng.choice([-1, 1], (n, 2)) * 10.0 ** rng.uniform(-300, 300, (n, 2))
        assert diverged(q, v) == componentwise(q, v)


# --------------------------------------------------------------------------- MethodId
@pytest.mark.parametrize(
    "text, family, name",
    [
        ("ref:rk4", "ref", "rk4"),
        ("mujoco:implicitfast", "mujoco", "implicitfast"),
        ("plugin:mode:with:colons", "plugin", "mode:with:colons"),  # only the first colon splits
    ],
)
def test_method_id_parses_family_and_name(text, family, name):
    mid = MethodId.parse(text)
    assert (mid.family, mid.name, str(mid)) == (family, name, text)
    assert mid.reference == (family == REFERENCE) == is_reference(text)
    assert scheme_name(text) == (name if family == REFERENCE else None)


@pytest.mark.parametrize("text", ["rk4", ":rk4", "ref:", "", "ref"])
def test_a_method_id_without_family_and_name_is_a_one_line_error(text):
    with pytest.raises(InvalidInput) as exc:
        MethodId.parse(text)
    message = str(exc.value)
    assert "\n" not in message and repr(text) in message and "family:name" in message


def test_scheme_name_of_anything_but_a_reference_id_is_none():
    assert scheme_name(None) is None and scheme_name("refx:rk4") is None and not is_reference("refx:rk4")
    assert scheme_name("ref:semi_implicit_euler") == "semi_implicit_euler"


@pytest.mark.parametrize(
    "text, canonical, options",
    [
        (
            "ref:xpbd?substeps=10&iterations=1",
            "ref:xpbd?iterations=1&substeps=10",
            {"iterations": "1", "substeps": "10"},
        ),
        ("drake:runge_kutta3@1e-6", "drake:runge_kutta3@1e-6", {"tolerance": "1e-6"}),
        ("drake:radau3?tolerance=1e-8", "drake:radau3@1e-8", {"tolerance": "1e-8"}),
    ],
)
def test_a_method_id_carries_its_options_in_one_canonical_text(text, canonical, options):
    mid = MethodId.parse(text)
    assert str(mid) == canonical and dict(mid.options) == options and str(MethodId.parse(canonical)) == canonical
    assert mid.base == text.split("?")[0].split("@")[0]
    assert scheme_name(text) == (mid.name if mid.reference else None)


@pytest.mark.parametrize(
    "text, words",
    [
        ("ref:xpbd?substeps", "not of the form key=value"),
        ("ref:xpbd?substeps=1&substeps=2", "given twice"),
        ("drake:runge_kutta3@", "needs a tolerance"),
        ("ref:xpbd?=3", "not of the form key=value"),
    ],
)
def test_a_malformed_option_in_a_method_id_is_a_one_line_error(text, words):
    with pytest.raises(InvalidInput, match=words) as exc:
        MethodId.parse(text)
    assert "\n" not in str(exc.value)


def test_options_in_an_id_are_checked_against_what_the_method_declares():
    """The id written with its options resolves to the method with them set, and its ``id`` is
    the canonical text; an option the method does not declare, or out of its range, is one line
    naming the option and the valid ones, before anything is stepped."""
    from harness.methods import get_method

    m = get_method("ref:verlet_constrained?iterations=4")
    assert m.id == "ref:verlet_constrained?iterations=4" and m.options == {"iterations": 4}
    assert get_method("ref:verlet_constrained", {"iterations": "4"}).id == m.id
    assert get_method(m.id) == m and get_method("ref:verlet_constrained").id == "ref:verlet_constrained"
    for text, words in [
        ("ref:rk4?substeps=2", "unknown option 'substeps' for method ref:rk4 (valid: none)"),
        ("ref:verlet_constrained?iterations=0", "iterations=0 is out of range"),
        ("ref:verlet_constrained?iterations=2.5", "is not an integer"),
        ("ref:rk4@1e-6", "unknown option 'tolerance'"),
    ]:
        with pytest.raises(InvalidInput) as exc:
            get_method(text)
        assert words in str(exc.value) and "\n" not in str(exc.value), text


# --------------------------------------------------------------------------- the protocol
class Partial:
    """A plugin's method with only what every method must have (README: ``id``, ``available()``,
    ``supports(scene)``, ``simulate(...)``, ``describe()``): semi-implicit Euler underneath."""

    id = "partial:semi_implicit"

    def available(self):
        return True, ""

    def supports(self, scene):
        return (True, "") if scene.id == "spring" else (False, "spring only")

    def simulate(self, scene, dt, steps, every=1):
        traj = reference.integrate(reference.METHODS["semi_implicit_euler"], scene, dt, steps, every)
        traj.method = self.id
        return traj

    def describe(self):
        return {"id": self.id, "family": "partial"}


@pytest.fixture
def with_plugins(monkeypatch):
    """The two test plugins and a partial one, loaded as ``$HARNESS_PLUGINS`` loads them."""
    module = types.ModuleType("partial_plugin_for_tests")
    module.METHODS = {Partial.id: Partial()}
    monkeypatch.setitem(sys.modules, module.__name__, module)
    monkeypatch.setattr(registry, "_PLUGIN_METHODS", {})
    monkeypatch.setenv(registry.PLUGINS_ENV, f"{PLUGINS},{module.__name__}")
    return registry.all_methods()


def test_every_registered_method_answers_every_capability(with_plugins):
    methods = with_plugins
    assert {"ref:rk4", "mujoco:euler", "faulty:abort", "slowtest:semi_implicit", Partial.id} <= set(methods)
    for mid, m in methods.items():
        assert isinstance(m, Method), mid
        assert m.id == mid and m.family == MethodId.parse(mid).family, mid
        assert (m.scheme is not None) == is_reference(mid), mid
        assert m.scheme is None or m.scheme is reference.METHODS[scheme_name(mid)], mid
        assert all(isinstance(getattr(m, flag), bool) for flag in ("isolated", "adaptive", "counting_run")), mid
        assert isinstance(m.no_match, Mapping) and isinstance(m.LOOPS, tuple), mid
        assert m.one_steps is None or callable(m.one_steps), mid
        assert m.timed_run is None or callable(m.timed_run), mid
        twin = m.compiled_twin()
        assert isinstance(twin, Method) and twin.id == mid, mid
        info = m.describe()
        assert info["id"] == mid and info["family"] == m.family, mid


def test_reference_methods_declare_in_process_fixed_step_and_a_compiled_twin():
    for sid, scheme in reference.METHODS.items():
        m = registry.get_method(f"ref:{sid}")
        assert isinstance(m, RefMethod) and m.scheme is scheme and m.family == REFERENCE
        # A counting run: where its compiled loop cannot count (Newton's passes vary), the interpreted run.
        assert (m.isolated, m.adaptive, m.counting_run, m.LOOPS, m.one_steps, m.timed_run) == (
            False,
            False,
            True,
            (),
            None,
            None,
        )
        assert dict(m.no_match) == {}
        twin = m.compiled_twin()
        assert twin.compiled and not m.compiled and twin.scheme is scheme


def test_the_compiled_twin_steps_the_same_states():
    # Bitwise on the spring: the compiled kernel is generated from the same step function.
    spring = make_scene("spring")
    m = registry.get_method("ref:rk4")
    interpreted, compiled = m.simulate(spring, 0.1, 200, 7), m.compiled_twin().simulate(spring, 0.1, 200, 7)
    np.testing.assert_array_equal(interpreted.q, compiled.q)
    np.testing.assert_array_equal(interpreted.v, compiled.v)
    assert interpreted.force_evals == 4 * 200 and compiled.force_evals is None


def test_engine_modes_declare_no_scheme_their_loops_and_themselves_as_twin():
    for mid, m in adapters.ENGINE_METHODS.items():
        assert m.scheme is None and m.isolated and m.compiled_twin() is m, mid
        assert m.LOOPS == ("engine", "harness") and callable(m.one_steps) and callable(m.timed_run), mid
        # Only IAS15 picks its own steps; the counting run is where the counter is a callback.
        assert m.adaptive == (mid == "rebound:ias15"), mid
        assert m.counting_run == (m.engine == "rebound" or mid in ("pymunk:spring_force", "pymunk:applied_force"))


def test_a_plugin_that_builds_on_engine_mode_is_used_as_it_is(with_plugins):
    for mid in ("faulty:abort", "faulty:hang", "slowtest:semi_implicit"):
        assert isinstance(with_plugins[mid], adapters.EngineMode)


def test_a_partial_plugin_method_gets_the_defaults_once_where_it_is_loaded(with_plugins):
    m = with_plugins[Partial.id]
    assert isinstance(m, registry.CompletedMethod) and isinstance(m.inner, Partial)
    assert m.family == "partial" and m.compiled_twin() is m
    assert {name: getattr(m, name) for name in OPTIONAL} == dict(OPTIONAL)
    assert registry.get_method(Partial.id) is m  # loaded once, completed once
    # The measures take it as they take an engine mode: stepped in this process, nothing declared.
    res = energy.energy_behaviour(Partial.id, make_scene("spring"), 0.1, 1000)
    ref = energy.energy_behaviour("ref:semi_implicit_euler", make_scene("spring"), 0.1, 1000)
    assert res["status"] == "ok" and res["classification"] == ref["classification"] == "bounded"
    assert res["max_rel_error"] == ref["max_rel_error"] and res["state_error_max"] == ref["state_error_max"]


def test_a_plugin_may_not_register_a_reference_id_or_a_bare_name(monkeypatch):
    for bad in ("ref:rk4", "rk4"):
        module = types.ModuleType("bad_plugin_for_tests")
        inner = Partial()
        inner.id = bad
        module.METHODS = {bad: inner}
        monkeypatch.setitem(sys.modules, module.__name__, module)
        monkeypatch.setattr(registry, "_PLUGIN_METHODS", {})
        with pytest.raises(InvalidInput, match="ids are family:mode, the family not 'ref'") as exc:
            registry.load_plugins([module.__name__])
        assert "\n" not in str(exc.value)


def test_a_plugin_method_without_what_every_method_must_have_is_a_one_line_error(monkeypatch):
    module = types.ModuleType("incomplete_plugin_for_tests")
    inner = types.SimpleNamespace(id="incomplete:mode", available=lambda: (True, ""))
    module.METHODS = {inner.id: inner}
    monkeypatch.setitem(sys.modules, module.__name__, module)
    monkeypatch.setattr(registry, "_PLUGIN_METHODS", {})
    with pytest.raises(InvalidInput) as exc:
        registry.load_plugins([module.__name__])
    assert str(exc.value) == (
        "method 'incomplete:mode' has no supports, simulate, describe "
        "(a method has id, available, supports, simulate, describe)"
    )


def test_an_unknown_method_is_a_one_line_error_naming_the_valid_ones():
    with pytest.raises(InvalidInput) as exc:
        registry.get_method("ref:no_such_scheme")
    message = str(exc.value)
    assert "\n" not in message and "'ref:no_such_scheme'" in message and "ref:rk4" in message
    assert "mujoco:euler" in message


def test_a_nightly_task_resolves_its_method_once(monkeypatch):
    """``run_task`` looks the task's method up once and hands the object on (its measures, the
    list of measures); the cost cell's explicit-Euler baseline is looked up once too."""
    from harness.execution import isolation
    from harness.nightly.cells import run_task
    from harness.nightly.run import build_tasks
    from harness.nightly.suites import SUITES

    looked_up = []
    real = registry.get_method

    def counting(method_id, *args, **kwargs):
        looked_up.append(method_id)
        return real(method_id, *args, **kwargs)

    monkeypatch.setattr(registry, "get_method", counting)
    monkeypatch.setattr(isolation, "IN_WORKER", True)  # as in a nightly worker
    tasks, _ = build_tasks(SUITES["smoke"])
    task = next(t for t in tasks if t.kind == "cell" and t.method == "ref:semi_implicit_euler")
    cells = run_task(task)
    assert {c.measure for c in cells} >= {"energy", "error", "order", "cost"}
    assert all(c.status == "ok" for c in cells), [(c.measure, c.detail) for c in cells]
    assert looked_up.count(task.method) == 1 and looked_up.count("ref:explicit_euler") == 1, looked_up


# --------------------------------------------------------------------------- the bottom floor
def test_records_import_nothing_of_the_project_not_even_by_name():
    """records/ is the bottom floor (docs/layout.md): it imports only itself, and loads no module
    by name (the built-in measures are registered from the harness, not fetched from here)."""
    import ast

    for path in sorted((ROOT / "records").glob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module or ""]
                if isinstance(node, ast.ImportFrom) and not node.level
                else []
            )
            for name in names:
                assert name.split(".")[0] not in {"harness", "adapters", "reference", "scenarios", "reports"}, (
                    path.name,
                    name,
                )
            assert not (isinstance(node, ast.Name) and node.id in ("import_module", "__import__")), path.name
            assert not (isinstance(node, ast.Attribute) and node.attr == "import_module"), path.name


# --------------------------------------------------------------------------- private modules
PRIVATE_IMPORT = re.compile(
    r"^\s*(?:from|import)\s+((?:reference|adapters|scenarios|harness|reports|records)"
    r"(?:\.[a-z_]+)*\._[a-z_]+)",
    re.M,
)


def test_no_package_imports_another_packages_private_module():
    offenders = []
    for path in ROOT.rglob("*.py"):
        rel = path.relative_to(ROOT)
        if rel.parts[0] in ("tests", ".venv", "build") or rel.parts[0].startswith("."):
            continue
        for module in PRIVATE_IMPORT.findall(path.read_text()):
            if module.split(".")[0] != rel.parts[0]:
                offenders.append(f"{rel}: {module}")
    assert offenders == []


def test_a_run_row_and_its_timing_become_typed_records_and_an_older_row_keeps_the_defaults():
    from records.run import RunRecord, RunSettings, RunTiming

    row = {
        "run_id": 3,
        "suite": "smoke",
        "started": "2026-11-23T10:00:00+00:00",
        "measurement_version": 3,
        "git_commit": "abc",
        "complete": 1,
        "versions": {"numpy": "2.1"},
        "machine": {"cpus": 2},
        "settings": {
            "suite": {"name": "smoke", "scenes": {}},
            "executor": "local",
            "cell_timeout": 60.0,
            "plugins": ["tests.faulty_plugin"],
            "skipped": [],
            "jobs": 2,
            "unknown_later_key": 1,
        },
        "wall_s": 12.5,
        "timing": {"total_s": 10.0},
    }
    run = RunRecord.of(row)
    assert (run.run_id, run.suite, run.git_commit, run.versions, run.settings.executor) == (
        3,
        "smoke",
        "abc",
        {"numpy": "2.1"},
        "local",
    )
    assert run.settings.plugins == ["tests.faulty_plugin"] and run.settings.cell_timeout == 60.0
    assert RunRecord.of(run) is run
    old = RunRecord.of(
        {"run_id": 1, "suite": "smoke", "started": "x", "measurement_version": 2, "settings": None, "versions": None}
    )
    assert old.settings == RunSettings() and old.versions == {} and old.git_commit is None
    timing = RunTiming.of(
        {
            "total_s": 5.0,
            "cells_s": 4.0,
            "kernels_compiled": 0,
            "kernel_load_s": None,
            "slowest_tasks": [["cell spring ref:rk4", 1.0]],
            "not_a_field": 9,
        }
    )
    assert (timing.total_s, timing.cells_s, timing.kernels_compiled, timing.kernel_load_s) == (5.0, 4.0, 0, 0.0)
    assert RunTiming.of(None) == RunTiming() and RunTiming().total_s is None


def test_the_identity_table_says_where_a_float32_mode_was_matched_at_float32_rounding():
    """A float32 engine (Newton on Warp) is matched within float32 rounding, a float64 one within
    1e-9: the table says which, so a deviation of 4e-7 is not read as a float64 mismatch."""
    from records.cell import Cell
    from records.figures import IdentityFigures
    from reports.markdown import identity_table

    def cell(method, precision, value):
        return Cell(
            scene="spring",
            method=method,
            family=method.split(":")[0],
            measure="identity",
            status="ok",
            value=value,
            figures=IdentityFigures(match="ref:semi_implicit_euler", precision=precision),
        )

    piv = {
        ("spring", "newton:semi_implicit"): {"identity": cell("newton:semi_implicit", "float32", 4.2e-7)},
        ("spring", "mujoco:euler"): {"identity": cell("mujoco:euler", "float64", 0.0)},
    }
    rows = {line.split("|")[1].strip(): line for line in identity_table(piv) if line.startswith("| `")}
    assert "4.20e-07 (float32: matched at float32 rounding)" in rows["`newton:semi_implicit`"]
    assert "float32" not in rows["`mujoco:euler`"]
    from harness.methods import get_method

    assert get_method("ref:rk4").precision == "float64"


def test_the_stored_request_has_the_fields_of_the_request_the_advice_validates():
    """``records.advice.Request`` is how the report reads an advice's or a sweep's request; the
    harness's ``Request`` (validated, then stored with ``asdict``) writes it: one set of fields."""
    from dataclasses import asdict, fields

    from records.advice import Request as Stored
    from records.advice import SweepFigures

    from harness.measures.advise import Request

    assert [f.name for f in fields(Stored)] == [f.name for f in fields(Request)]
    asked = Request(hz=60.0, horizon=2.0, energy_tol=1e-3, max_substeps=16).checked()
    read = SweepFigures(request=asdict(asked)).sweep_request()
    assert (read.hz, read.horizon, read.energy_tol, read.error_tol, read.max_substeps) == (60.0, 2.0, 1e-3, None, 16)
