"""The recipes of docs/contributing.md, held by tests: a scene is one class (one module), an engine
is one module of modes (``tests/slow_plugin.py`` is one, run by test_history's slowdown test), a
measure is one declaration (tests/test_measure_registry.py), and the registries that name them are
the only other place a new one appears."""
from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from scenarios import SCENES
from scenarios.scene import Param, Scene, no_velocity_dependence

ROOT = Path(__file__).resolve().parent.parent


def _accel(q, v, t, p):
    k, eps = p[0], p[1]
    return -k * q - eps * q ** 3


class Duffing(Scene):
    """A scene written as the recipe says, in this test module alone: x'' = -k x - eps x^3."""

    id = "duffing_test"
    title = "undamped Duffing oscillator (a test's scene)"
    params = {"k": Param(1.0, "linear stiffness", lo=0.0, lo_open=True), "eps": Param(0.5, "cubic stiffness", lo=0.0),
              "x0": Param(1.0, "initial position")}
    dof_names = ("x",)
    pointwise = True
    accel = staticmethod(_accel)
    damping_rate = staticmethod(no_velocity_dependence)

    def initial_state(self):
        return np.array([self.values["x0"]]), np.array([0.0])

    @property
    def omega(self):
        k, eps, x0 = self.values["k"], self.values["eps"], self.values["x0"]
        return math.sqrt(k + 3 * eps * x0 ** 2)  # the linearisation's largest frequency

    def energy(self, q, v):
        k, eps = self.values["k"], self.values["eps"]
        return 0.5 * v[..., 0] ** 2 + 0.5 * k * q[..., 0] ** 2 + 0.25 * eps * q[..., 0] ** 4


def test_a_scene_written_in_one_module_is_measured_by_every_measure_with_no_other_file():
    from harness.measures.error import global_error
    from harness.measures.order import observed_order

    scene = Duffing()
    res = global_error("ref:rk4", scene, 0.01, 500)
    assert res["status"] == "ok" and res["source"].startswith("reference DOP853")
    assert observed_order("ref:leapfrog", scene)["order"] == pytest.approx(2.0, abs=0.1)
    assert observed_order("ref:rk4", scene)["order"] == pytest.approx(4.0, abs=0.2)


def _names_in(path: Path) -> set[str]:
    return {n.value for n in ast.walk(ast.parse(path.read_text())) if isinstance(n, ast.Constant)
            and isinstance(n.value, str)}


def test_a_built_in_scene_is_its_module_plus_its_registry_entry():
    """Each scene class lives in a module of its own under scenarios/, and outside scenarios/ its id
    is named only where an engine poses it (an adapter's POSES), a suite or the judge asks for
    it, or a study of that scene runs: the machinery every scene goes through names none."""
    # The machinery every scene goes through (a study of one scene, in harness/measures, names its scene).
    machinery = [p for d in ("harness/execution", "harness/history", "records") for p in (ROOT / d).glob("*.py")]
    machinery += [ROOT / "harness" / "nightly" / f for f in ("cells.py", "cell_kit.py", "run.py")]
    for sid, cls in SCENES.items():
        module = Path(__import__(cls.__module__, fromlist=["x"]).__file__)
        assert module.parent.name == "scenarios", sid
        named = [p.relative_to(ROOT) for p in machinery if sid in _names_in(p) and len(sid) > 4]
        assert not named, f"scene {sid!r} is named in the harness's machinery: {named}"


def test_an_engine_is_one_module_of_modes():
    """Every built-in engine's modes come from its one adapter module, joined in one line."""
    import adapters

    init = (ROOT / "adapters" / "__init__.py").read_text()
    for mid, mode in adapters.ENGINE_METHODS.items():
        engine = mid.split(":")[0]
        assert f"{engine}.METHODS" in init
        assert (ROOT / "adapters" / f"{engine}.py").is_file()
