"""The recipes of docs/contributing.md, held by tests: a scene is one class (one module), an engine
is one module of modes (``tests/slow_plugin.py`` is one, run by test_history's slowdown test), a
measure is one declaration (tests/test_measure_registry.py), and the registries that name them are
the only other place a new one appears."""

from __future__ import annotations

import ast
import math
import re
from pathlib import Path

import numpy as np
import pytest

from scenarios import SCENES
from scenarios.scene import Param, Scene, no_velocity_dependence

ROOT = Path(__file__).resolve().parent.parent


def _accel(q, v, t, p):
    k, eps = p[0], p[1]
    return -k * q - eps * q**3


class Duffing(Scene):
    """A scene written as the recipe says, in this test module alone: x'' = -k x - eps x^3."""

    id = "duffing_test"
    title = "undamped Duffing oscillator (a test's scene)"
    params = {
        "k": Param(1.0, "linear stiffness", lo=0.0, lo_open=True),
        "eps": Param(0.5, "cubic stiffness", lo=0.0),
        "x0": Param(1.0, "initial position"),
    }
    dof_names = ("x",)
    pointwise = True
    accel = staticmethod(_accel)
    damping_rate = staticmethod(no_velocity_dependence)

    def initial_state(self):
        return np.array([self.values["x0"]]), np.array([0.0])

    @property
    def omega(self):
        k, eps, x0 = self.values["k"], self.values["eps"], self.values["x0"]
        return math.sqrt(k + 3 * eps * x0**2)  # the linearisation's largest frequency

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


def _lines_naming(path: Path, word: str) -> list[int]:
    """The lines of ``path``'s strings (literals and docstrings) where ``word`` stands as a word of
    its own: ``net`` in "the net" but not in "network", ``cloth`` not in ``cloth_flex``."""
    pattern = re.compile(rf"\b{re.escape(word)}\b")
    return sorted(
        {
            n.lineno
            for n in ast.walk(ast.parse(path.read_text()))
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and pattern.search(n.value)
        }
    )


def test_the_scene_id_check_matches_whole_words_of_any_length(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text('"""The net, and cloth_flex."""\nA = "network"\nB = f"on the {A} rope"\nC = "kinetic"\n')
    assert _lines_naming(probe, "net") == [1]  # a word of its own, not "network" or "kinetic"
    assert _lines_naming(probe, "rope") == [3]  # in an f-string's text too
    assert _lines_naming(probe, "cloth") == []  # cloth_flex is another id


def test_a_built_in_scene_is_its_module_plus_its_registry_entry():
    """Each scene class lives in a module of its own under scenarios/, and outside scenarios/ its id
    is named only where an engine poses it (an adapter's POSES), a suite or the judge asks for
    it, or a study of that scene runs: the machinery every scene goes through names none, in its
    code or its docstrings."""
    # The machinery every scene goes through (a study of one scene, in harness/measures, names its scene).
    machinery = [p for d in ("harness/execution", "harness/history", "records") for p in (ROOT / d).glob("*.py")]
    machinery += [ROOT / "harness" / "nightly" / f for f in ("cells.py", "cell_kit.py", "run.py")]
    for sid, cls in SCENES.items():
        module = Path(__import__(cls.__module__, fromlist=["x"]).__file__)
        assert module.parent.name == "scenarios", sid
        named = {str(p.relative_to(ROOT)): lines for p in machinery if (lines := _lines_naming(p, sid))}
        assert not named, f"scene {sid!r} is named in the harness's machinery (file: lines): {named}"


def test_an_engine_is_one_package_and_one_entry():
    """Every built-in engine is one package, ``adapters/<engine>/``, declaring its one ``Engine``
    entry (``ENGINE``), joined into ``adapters.ENGINES`` in one line; its modes are that entry's."""
    import adapters

    init = (ROOT / "adapters" / "__init__.py").read_text()
    for mid, mode in adapters.ENGINE_METHODS.items():
        engine = mid.split(":")[0]
        assert f"{engine}.ENGINE" in init
        assert (ROOT / "adapters" / engine / "__init__.py").is_file()
        assert adapters.ENGINES[engine].methods[mid] is mode
    assert not [p.name for p in (ROOT / "adapters").glob("*.py") if p.stem.lstrip("_") in adapters.ENGINES]


# ------------------------------------------------------------------ a scheme (docs/contributing.md)
def _kdk_floor(s, h, k, m):
    x, v = s
    v = v + 0.5 * h * (-k * x / m)
    x = x + h * v
    return (x, v + 0.5 * h * (-k * x / m))


def _kdk_amplification(y, z):
    from reference.oscillator import drift, kick

    return kick(0.5 * y, z) @ drift(y) @ kick(0.5 * y, z)


def _declare_kick_drift_kick(**where):
    """Kick-drift-kick leapfrog, written as the recipe says in this test module alone: a splitting,
    not a tableau, its floor and its recurrence on the damped oscillator declared with its step;
    ``where``: the suites it joins (none unless given)."""
    from reference import Floor
    from reference._scheme import scheme

    @scheme(
        order=2,
        force_evals=2,
        symplectic=True,
        energy_claim="bounded",
        homega_max=2.0,
        order_velocity_dependent=1,
        floor=Floor(_kdk_floor),
        amplification=_kdk_amplification,
        **where,
    )
    def kick_drift_kick_test(accel, state, t, h, p):
        """Kick-drift-kick leapfrog, evaluating the force for both kicks (a test's scheme):

            v_{n+1/2} = v_n + (h/2) a(x_n, v_n, t_n)
            x_{n+1}   = x_n + h v_{n+1/2}
            v_{n+1}   = v_{n+1/2} + (h/2) a(x_{n+1}, v_{n+1/2}, t_{n+1})

        Second order, symplectic, two evaluations; stable for h w <= 2.
        """
        q, v = state
        half = 0.5 * h
        v = v + half * accel(q, v, t, p)
        q = q + h * v
        return (q, v + half * accel(q, v, t + h, p))

    return kick_drift_kick_test


@pytest.fixture
def kick_drift_kick(monkeypatch):
    """The scheme registered in ``reference.METHODS`` for the test, joining no suite: the one entry it is."""
    from reference import METHODS

    kdk = _declare_kick_drift_kick()
    monkeypatch.setitem(METHODS, kdk.id, kdk)
    return kdk


def test_a_scheme_written_in_one_module_runs_interpreted_and_compiled_to_the_same_bits(kick_drift_kick):
    """On the spring and on the damped spring (whose force depends on the velocity): the compiled
    kernel, generated from the test module's source, gives the interpreted run's bits; the counted
    force evaluations are the declared two a step (counted, not declared)."""
    from reference import integrate, integrate_compiled
    from scenarios import make_scene

    for scene in (make_scene("spring"), make_scene("damped_spring", c=0.6)):
        dt, steps = 0.05 / scene.omega, 300
        interpreted = integrate(kick_drift_kick, scene, dt, steps, every=7)
        compiled = integrate_compiled(kick_drift_kick, scene, dt, steps, every=7)
        np.testing.assert_array_equal(compiled.step, interpreted.step)
        np.testing.assert_array_equal(compiled.q, interpreted.q)
        np.testing.assert_array_equal(compiled.v, interpreted.v)
        assert interpreted.force_evals == kick_drift_kick.force_evals * steps == 2 * steps


def test_a_scheme_written_in_one_module_has_its_floor_its_damping_and_its_limit(kick_drift_kick):
    """Its floor (``harness bench``) computes the compiled kernel's bits on the unit spring (the same
    operations in the same order); its declared recurrence is the measured one-step map on the damped
    spring (1e-14: a few roundoffs of unit-size entries); the limit computed from it undamped is the
    declared h omega = 2 (1e-3: the search's rho > 1 + RHO_TOL crosses just past the double
    eigenvalue at 2); and the measured limit agrees with that theory at every damping ratio."""
    from harness.bench.kernels import on_the_spring
    from harness.measures.stability_damping import limit_vs_damping, theory_limit
    from harness.methods import get_method
    from reference import carried_map, integrate_compiled
    from reference._floors import run_floor
    from scenarios import make_scene

    assert kick_drift_kick.id in on_the_spring()
    traj = integrate_compiled(kick_drift_kick, make_scene("spring"), 0.01, 1000, every=1000)
    assert (traj.q[-1, 0, 0], traj.v[-1, 0, 0]) == run_floor(kick_drift_kick.floor, 1.0, 0.0, 0.01, 1.0, 1.0, 1000)
    for zeta, y in ((0.0, 0.5), (0.3, 1.2)):
        M, c, _ = carried_map(kick_drift_kick, make_scene("damped_spring", c=2.0 * zeta), y)
        np.testing.assert_allclose(M, kick_drift_kick.amplification(y, zeta), rtol=0, atol=1e-14)
        assert not c.any()
    undamped = theory_limit(kick_drift_kick.id, 0.0)
    assert undamped["source"] == "computed"
    assert undamped["homega_max"] == pytest.approx(kick_drift_kick.homega_max, rel=1e-3)
    res = limit_vs_damping(get_method(f"ref:{kick_drift_kick.id}"))
    assert res["rows"] and all(row["agrees"] for row in res["rows"]), res["rows"]


def test_a_new_scheme_runs_nowhere_in_the_standard_suite_until_it_says_where(kick_drift_kick, monkeypatch):
    """Registered, it is in no task of the standard suite, each scene it could run on saying why;
    declaring two scenes puts it in exactly those two tasks. The full suite runs every scheme on every
    scene it can run on, this one too."""
    import dataclasses

    from harness.nightly.run import build_tasks
    from harness.nightly.suites import SUITES
    from reference import METHODS

    standard = dataclasses.replace(SUITES["standard"], bounds=False)
    mid = f"ref:{kick_drift_kick.id}"
    tasks, skipped = build_tasks(standard)
    assert tasks and not [t for t in tasks if t.method == mid]
    why = {s["scene"]: s["reason"] for s in skipped if s["method"] == mid}
    assert "does not declare spring among the scenes it joins in the standard suite" in why["spring"]

    monkeypatch.setitem(
        METHODS, kick_drift_kick.id, _declare_kick_drift_kick(suites={"standard": ("spring", "pendulum")})
    )
    tasks, _ = build_tasks(standard)
    assert sorted(t.scene for t in tasks if t.method == mid) == ["pendulum", "spring"]
    full, _ = build_tasks(dataclasses.replace(SUITES["full"], bounds=False))
    assert {"spring", "pendulum", "kepler", "chain", "cloth"} <= {t.scene for t in full if t.method == mid}


#: The standard suite's reference tasks, scheme -> scenes, as it ran them when its schemes came to
#: declare their scenes (``suites`` in each scheme's file) in place of its skip lists: the same tasks,
#: in the same order. A built-in scheme that joins or leaves a scene of the standard suite changes its
#: budget, and this table with it, on purpose; a new scheme is held to its own declaration.
STANDARD_REFERENCE_TASKS = {
    "explicit_euler": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "chain", "solar_system", "cloth"),
    "semi_implicit_euler": (
        "spring",
        "damped_spring",
        "pendulum",
        "kepler",
        "projectile",
        "chain",
        "solar_system",
        "cloth",
    ),
    "semi_implicit_euler_position_first": ("spring", "damped_spring", "pendulum", "kepler", "projectile"),
    "verlet": ("spring", "damped_spring", "pendulum", "kepler", "projectile"),
    "velocity_verlet": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "solar_system"),
    "leapfrog": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "chain", "solar_system", "cloth"),
    "rk4": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "chain", "solar_system", "cloth"),
    "implicit_euler": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "chain", "cloth"),
    "implicit_midpoint": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "chain", "cloth"),
    "forest_ruth": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "solar_system"),
    "linearly_implicit_euler": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "chain", "cloth"),
    "implicit_euler_doubled": ("spring", "damped_spring", "pendulum"),
    "radau_iia2": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "chain"),
    "pbd": ("spring", "chain", "rope", "cloth"),
    "xpbd": ("spring", "chain", "rope", "cloth"),
    "heun": ("spring", "damped_spring", "pendulum"),
    "kutta_rk3": ("spring", "damped_spring", "pendulum"),
    "bogacki_shampine3": ("spring", "damped_spring", "pendulum"),
    "dormand_prince5": ("spring", "damped_spring", "pendulum"),
    "semi_implicit_euler_velocity_implicit": ("damped_spring", "projectile", "chain"),
    "position_first_euler_decay_after_kick": ("damped_spring", "projectile"),
    "position_first_euler_decay_before_kick": ("damped_spring", "projectile"),
    "verlet_constrained": ("rope",),
}


def test_the_built_in_schemes_declare_the_standard_suites_reference_tasks_and_the_full_suite_runs_all():
    """The standard suite's reference tasks, scene by scene in the suite's order, are the table's (with
    ``ref:xpbd?iterations=1``, which the rope's and the cloth's specs add); the full suite runs every
    scheme on every scene it can run on (``RefMethod.supports``)."""
    import dataclasses

    from harness.methods import get_method
    from harness.nightly.run import build_tasks
    from harness.nightly.suites import SUITES
    from reference import METHODS
    from scenarios import make_scene

    standard = dataclasses.replace(SUITES["standard"], bounds=False)
    tasks, _ = build_tasks(standard)
    # not the penalty ground's tasks (cell tasks of one measure, ``only``)
    got = [(t.scene, t.method) for t in tasks if t.family == "ref" and t.kind == "cell" and not t.only]

    # A built-in scheme's tasks are the table's; a scheme added since (a contributor's) is held to
    # its own declaration, so that adding one changes no line here.
    def joins(sid, scene):
        if sid in STANDARD_REFERENCE_TASKS:
            return scene in STANDARD_REFERENCE_TASKS[sid]
        spec = standard.scenes[scene]
        return (
            METHODS[sid].joins("standard", scene)
            and get_method(f"ref:{sid}").supports(make_scene(scene, source=spec.source, **spec.params))[0]
        )

    want = [(scene, f"ref:{sid}") for scene in standard.scenes for sid in METHODS if joins(sid, scene)]
    want += [(scene, mid) for scene, spec in standard.scenes.items() for mid in spec.with_options]
    assert sorted(got) == sorted(want) and len(got) == len(set(got))
    for scene in standard.scenes:  # in the suite's method order on each scene
        assert [m for s, m in got if s == scene] == [m for s, m in want if s == scene]

    full = dataclasses.replace(SUITES["full"], bounds=False)
    tasks, _ = build_tasks(full)
    got = {
        (t.scene, t.method)
        for t in tasks
        if t.family == "ref" and t.kind == "cell" and not t.only and "?" not in t.method
    }
    runs = {
        (scene, f"ref:{sid}")
        for scene, spec in full.scenes.items()
        for sid in METHODS
        if get_method(f"ref:{sid}").supports(make_scene(scene, source=spec.source, **spec.params))[0]
    }
    assert got == runs


# ------------------------------------------------------------------ a splitting, a substepped scheme
#: One file, as the recipe writes it: Ruth's third-order splitting declared as its kicks and drifts
#: (the adjoint of Ruth's 1983 form), and the same scheme substepped twice.
RUTH3_FILE = '''\
"""Ruth's third-order splitting, and it taken twice at h/2 (a test's schemes, in one file)."""
from reference import DRIFT, KICK, Splitting, splitting_scheme, substepped

ruth3_test = splitting_scheme(
    "ruth3_test",
    Splitting((KICK, "7/24"), (DRIFT, "2/3"), (KICK, "3/4"), (DRIFT, "-2/3"), (KICK, "-1/24"), (DRIFT, 1)),
    order=3, module=__name__, doc="""\\
Ruth's third-order splitting (a test's scheme):

        v += 7/24 h a;  x += 2/3 h v;  v += 3/4 h a;  x -= 2/3 h v;  v -= 1/24 h a;  x += h v

    Third order, symplectic, three evaluations; stable for h w <= 2.507.
    """)

ruth3_doubled_test = substepped(ruth3_test, 2, id="ruth3_doubled_test", module=__name__, doc="""\\
Ruth's third-order splitting taken twice at h/2 (a test's scheme): x, v = ruth3(ruth3((x, v), h/2), h/2).

    Third order, six evaluations; stable for h w <= 5.015.
    """)
'''

#: What the theory table (tests/theory.py) says of the two, the lines a new scheme adds there: the
#: table is the oracle the measures are held to, written apart from the schemes' declarations.
RUTH3_THEORY = {
    "ruth3_test": {"REF_ORDER": 3, "REF_STABILITY": 2.5074811709523552, "REF_ENERGY": "bounded", "REF_EVALS": (3, 0)},
    "ruth3_doubled_test": {
        "REF_ORDER": 3,
        "REF_STABILITY": 2 * 2.5074811709523552,
        "REF_ENERGY": "bounded",
        "REF_EVALS": (6, 0),
    },
}


@pytest.fixture(scope="module")
def ruth3_module(tmp_path_factory):
    import importlib.util
    import sys

    path = tmp_path_factory.mktemp("schemes") / "ruth3_test.py"
    path.write_text(RUTH3_FILE)
    spec = importlib.util.spec_from_file_location("ruth3_test_schemes", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop(spec.name, None)


@pytest.fixture
def ruth3(ruth3_module, monkeypatch):
    """The two schemes registered in ``reference.METHODS`` for the test: the one entry each is."""
    from reference import METHODS

    for s in (ruth3_module.ruth3_test, ruth3_module.ruth3_doubled_test):
        monkeypatch.setitem(METHODS, s.id, s)
    return ruth3_module.ruth3_test, ruth3_module.ruth3_doubled_test


def test_a_splitting_and_a_substepped_scheme_in_one_file_run_interpreted_and_compiled_to_the_same_bits(ruth3):
    """The splitting on the damped spring (its force depends on the velocity), the substepped one on
    the spring: the compiled kernels, generated from the file's declarations, give the interpreted
    bits; the counted evaluations are the derived three a step and twice that; the floor (``harness
    bench``) computes the kernel's bits on the spring."""
    from reference import integrate, integrate_compiled
    from reference._floors import run_floor
    from scenarios import make_scene

    split, doubled = ruth3
    assert (split.force_evals, doubled.force_evals, doubled.substepped_from) == (3, 6, (split, 2))
    for scheme, scene in ((split, make_scene("damped_spring", c=0.6)), (doubled, make_scene("spring"))):
        dt, steps = 0.05 / scene.omega, 300
        interpreted = integrate(scheme, scene, dt, steps, every=7)
        compiled = integrate_compiled(scheme, scene, dt, steps, every=7)
        np.testing.assert_array_equal(compiled.q, interpreted.q)
        np.testing.assert_array_equal(compiled.v, interpreted.v)
        assert interpreted.force_evals == scheme.force_evals * steps
    traj = integrate_compiled(doubled, make_scene("spring"), 0.01, 1000, every=1000)
    assert (traj.q[-1, 0, 0], traj.v[-1, 0, 0]) == run_floor(doubled.floor, 1.0, 0.0, 0.01, 1.0, 1.0, 1000)


def test_a_splitting_and_a_substepped_scheme_have_their_order_their_damping_and_their_limit(ruth3):
    """Their derived recurrence is the measured one-step map on the damped spring (1e-13: a few
    roundoffs over six products); the derived limit is the one computed from it undamped (h omega =
    2.507, twice that substepped); the observed order on the spring is the declared 3."""
    from harness.measures.order import observed_order
    from harness.measures.stability_damping import theory_limit
    from reference import carried_map
    from scenarios import make_scene

    for scheme in ruth3:
        for zeta, y in ((0.0, 0.5), (0.3, 1.2)):
            M, c, _ = carried_map(scheme, make_scene("damped_spring", c=2.0 * zeta), y)
            np.testing.assert_allclose(M, scheme.amplification(y, zeta), rtol=0, atol=1e-13)
            assert not c.any()
        undamped = theory_limit(scheme.id, 0.0)
        assert undamped["source"] == "computed"
        assert undamped["homega_max"] == pytest.approx(scheme.homega_max, rel=1e-3)
        assert observed_order(f"ref:{scheme.id}", make_scene("spring"))["order"] == pytest.approx(3.0, abs=0.15)
    assert ruth3[1].homega_max == 2 * ruth3[0].homega_max == pytest.approx(5.01496, abs=1e-5)


def test_the_inventories_take_a_new_scheme_from_the_registry_and_its_theory_lines(ruth3, monkeypatch):
    """With the two registered, every inventory of the schemes holds as it is: the floors, the damped
    recurrences, the closed forms and the standard suite's tasks (where the new ones, joining no
    suite, run nowhere) follow from the registry. The theory table is the independent oracle: it
    fails until each new scheme has its line there, and holds with it."""
    import test_kernels
    import test_measure
    import test_stability_damping
    import theory

    test_kernels.test_every_unconstrained_scheme_has_a_floor()
    test_stability_damping.test_every_scheme_that_runs_on_the_damped_spring_has_its_damped_recurrence()
    test_stability_damping.test_the_closed_forms_are_the_ones_jury_and_a_stability_give()
    with pytest.raises(AssertionError):
        test_measure.test_the_theory_tables_cover_every_unconstrained_scheme()
    for sid, lines in RUTH3_THEORY.items():
        for table, value in lines.items():
            monkeypatch.setitem(getattr(theory, table), sid, value)
    test_measure.test_the_theory_tables_cover_every_unconstrained_scheme()
    for scheme in ruth3:
        assert scheme.homega_max == pytest.approx(theory.REF_STABILITY[scheme.id], rel=theory.STABILITY_RTOL)
    test_the_built_in_schemes_declare_the_standard_suites_reference_tasks_and_the_full_suite_runs_all()
