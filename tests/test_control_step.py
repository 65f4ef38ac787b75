"""``harness model``'s control-step question (``harness/control_step.py``) on the models users run:
Gymnasium's and dm_control's MuJoCo files from their registry packages, at their environments'
settings. Each headline is reproduced by an independent route: collidable pairs by MuJoCo's own
collision driver with every geom's margin made huge; the verdict's factors by a plain ``mj_step``
loop written here, which shares nothing with the study but MuJoCo."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from records import InvalidInput  # noqa: E402
from scenarios import collidable_pairs  # noqa: E402
from scenarios.control_setting import ControlSetting  # noqa: E402
from scenarios.environments import ENVIRONMENTS, environment  # noqa: E402
from scenarios.model import compile_model, read_model_file  # noqa: E402

from harness.control_step import REF_FIRST, REF_FRACTION, StudyConfig, run_study, verdict  # noqa: E402
from tests.test_cli import cli  # noqa: E402


#: The timings every study here is given: the verdicts' cost ratios never depend on the machine's
#: load (EVALUATIONS-proportional, as MuJoCo's loop is to first order).
def _timings(frame_skip):
    per = {"euler": 1.0, "implicitfast": 1.05, "implicit": 1.5, "rk4": 3.6, "discrete": 1.1}
    return {f"{i} x{s}": 1e-5 * per[i] * s * frame_skip for i in per for s in (1, 2, 4)}


def _setting(env, seeds=(0, 1)):
    e = environment(env)
    return ControlSetting.for_environment(e, seeds=seeds)


_STUDIES: dict = {}


def study_of(env, horizon=1.0, states=12):
    key = (env, horizon, states)
    if key not in _STUDIES:
        m = compile_model(read_model_file(environment(env).path()))
        e = environment(env)
        _STUDIES[key] = run_study(
            m,
            _setting(env),
            StudyConfig(horizon_s=horizon, states_per_seed=states, timings=_timings(e.frame_skip), threads=1),
            progress=None,
            path=e.path(),
        )
    return _STUDIES[key]


# ------------------------------------------------------------------ collidable pairs
def _pairs_by_collision_driver(path):
    """Every geom pair MuJoCo's own collision driver reports once each geom's margin is 1000 m
    (set before compiling, so the bodies' bounding volumes include it): the pairs it may collide."""
    import warnings

    warnings.filterwarnings("ignore", message=".*settotalmass.*")
    spec = mujoco.MjSpec.from_file(path)
    for g in spec.geoms:
        g.margin, g.gap = 1e3, 0.0
    for p in spec.pairs:  # an explicit pair carries its own margin
        p.margin, p.gap = 1e3, 0.0
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    return {tuple(sorted((int(c.geom1), int(c.geom2)))) for c in d.contact[: d.ncon]}


@pytest.mark.parametrize("env", list(ENVIRONMENTS))
def test_collidable_pairs_are_those_mujocos_collision_driver_takes(env):
    path = environment(env).path()
    assert set(collidable_pairs(compile_model(read_model_file(path)))) == _pairs_by_collision_driver(path)


def test_inverted_double_pendulum_has_no_collidable_pair_though_its_geoms_have_contype():
    m = compile_model(read_model_file(environment("InvertedDoublePendulum-v5").path()))
    assert np.count_nonzero(m.geom_contype | m.geom_conaffinity) >= 5  # what the old count reported
    assert collidable_pairs(m) == []


def test_exclude_parent_and_explicit_pairs_are_filtered_as_mujoco_filters_them(tmp_path):
    xml = """<mujoco><worldbody><geom name="floor" type="plane" size="5 5 .1"/>
      <body name="a" pos="0 0 1"><freejoint/><geom name="ga" size=".1"/>
        <body name="b" pos="0 0 .3"><joint type="hinge"/><geom name="gb" size=".1"/></body></body>
      <body name="c" pos="1 0 1"><freejoint/><geom name="gc" size=".1"/></body>
      <body name="e" pos="2 0 1"><freejoint/><geom name="ge" size=".1" contype="2" conaffinity="2"/></body>
      </worldbody><contact><exclude body1="c" body2="a"/><pair geom1="ge" geom2="floor"/></contact></mujoco>"""
    path = tmp_path / "filters.xml"
    path.write_text(xml)
    m = mujoco.MjModel.from_xml_path(str(path))
    names = {
        tuple(
            sorted(
                (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, a), mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, b))
            )
        )
        for a, b in collidable_pairs(m)
    }
    # a-b: parent; a-c: excluded; e: bits 2 collide with nothing but its explicit pair with the floor
    assert names == {("floor", "ga"), ("floor", "gb"), ("floor", "gc"), ("gb", "gc"), ("floor", "ge")}
    assert set(collidable_pairs(m)) == _pairs_by_collision_driver(str(path))


def test_model_features_count_pairs_not_geoms():
    from scenarios.model import features_found

    assert "contact" not in features_found(
        compile_model(read_model_file(environment("InvertedDoublePendulum-v5").path()))
    )
    hopper = features_found(compile_model(read_model_file(environment("Hopper-v5").path())))
    assert hopper["contact"] == "7 collidable geom pairs"


# ------------------------------------------------------------------ the settings
def test_presets_are_the_environments_own_settings():
    """Read from the packages' sources, not copied: each preset's frame skip and reset scale are
    the defaults in its environment's constructor."""
    import importlib.util
    import os
    import re

    gym = os.path.dirname(importlib.util.find_spec("gymnasium").origin)
    for e in ENVIRONMENTS.values():
        if e.package != "gymnasium":
            continue
        module = e.source.split("envs/mujoco/")[1].split(".py")[0]
        text = open(os.path.join(gym, "envs", "mujoco", f"{module}.py")).read()
        assert int(re.search(r"frame_skip: int = (\d+)", text).group(1)) == e.frame_skip
        assert float(re.search(r"reset_noise_scale: float = ([0-9.e-]+)", text).group(1)) == e.reset.qpos_scale
        assert f'"{e.file}"' in text


def test_seeded_controls_are_within_each_ctrlrange_and_held_per_control_step():
    m = compile_model(read_model_file(environment("Ant-v5").path()))
    U = _setting("Ant-v5").sequence(m, 3, 50)
    lo, hi = m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1]
    assert U.shape == (50, m.nu) and np.all(U >= lo) and np.all(U <= hi)
    assert np.array_equal(U, _setting("Ant-v5").sequence(m, 3, 50))  # seeded
    q, v = _setting("Ant-v5").start(m, 0)
    assert (
        np.max(np.abs(np.delete(q - m.qpos0, range(3, 7)))) <= 0.1
    )  # Ant-v5's U(-0.1, 0.1), the quaternion renormalised


# ------------------------------------------------------------------ the study on the robots
@pytest.mark.parametrize("env", ["Hopper-v5", "HalfCheetah-v5", "Ant-v5", "Humanoid-v5", "dm_control/walker"])
def test_every_integrator_and_substep_is_measured_at_the_environments_setting(env):
    s = study_of(env)
    m = compile_model(read_model_file(environment(env).path()))
    assert s.timestep == m.opt.timestep and s.frame_skip == environment(env).frame_skip
    # the reference: never coarser than the file's step, its error its own halving's
    assert s.reference.h <= m.opt.timestep / 2 ** (REF_FIRST + 1)
    assert s.reference.converged
    assert s.reference.error.median <= REF_FRACTION * s.baseline.obs.median
    names = {r.candidate.name for r in s.candidates}
    assert {f"{i} x{k}" for i in ("euler", "implicitfast", "implicit", "rk4", "discrete") for k in (1, 2, 4)} <= names
    for r in s.candidates:
        assert r.run_status == "ok", (r.candidate.name, r.run_status)  # no mode called unstable where it runs
        assert r.unstable_transitions == 0
        assert math.isfinite(r.obs.median) and math.isfinite(r.trajectory_error)
        assert r.contacts is not None and r.contacts.max >= 0
    assert s.pairs > 0 and s.contacts_reference.share > 0  # these robots touch the floor
    text = " ".join(verdict(s))
    assert "each control step is" in text and "Predictable horizon" in text


def _plain_states(path, frame_skip, reset, seeds=(0, 1), n_control=20, every=2, healthy=None, rng_base=1000):
    """States along runs of RK4 at h/8 with seeded uniform controls, by a plain mj_step loop from
    qpos0 + U(-reset, reset); each run stops where ``healthy(qpos)`` first fails (a termination)."""
    mr = mujoco.MjModel.from_xml_path(path)
    mr.opt.integrator, mr.opt.timestep = mujoco.mjtIntegrator.mjINT_RK4, mr.opt.timestep / 8
    d = mujoco.MjData(mr)
    out = []
    for seed in seeds:
        rng = np.random.default_rng(rng_base + seed)
        mujoco.mj_resetData(mr, d)
        d.qpos[:] += rng.uniform(-reset, reset, mr.nq)
        d.qvel[:] += rng.uniform(-reset, reset, mr.nv)
        for j in range(n_control):
            if healthy is not None and not healthy(d.qpos):
                break
            u = rng.uniform(mr.actuator_ctrlrange[:, 0], mr.actuator_ctrlrange[:, 1])
            if j % every == 0:
                out.append((d.qpos.copy(), d.qvel.copy(), u))
            d.ctrl[:] = u
            mujoco.mj_step(mr, d, nstep=8 * frame_skip)
    return out


def _plain_step(path, integrator, h, nstep, q, v, u):
    m = mujoco.MjModel.from_xml_path(path)
    m.opt.integrator, m.opt.timestep = integrator, h
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:], d.ctrl[:] = q, v, u
    mujoco.mj_step(m, d, nstep=nstep)
    return np.concatenate([d.qpos, d.qvel])


def test_half_cheetah_verdict_holds_against_a_plain_mujoco_loop():
    """HalfCheetah-v5 (Euler, 0.01 s, frame skip 5): the study says each control step is about a
    tenth of the spread off, RK4 at the same step cuts the median tens of times, implicitfast is bit
    for bit Euler. A plain loop here (its own states, seeds and spread; RK4 at h/32 as truth)
    must agree on the size of each within a factor of 2 (other states, other seeds)."""
    env = environment("HalfCheetah-v5")
    path = env.path()
    s = study_of("HalfCheetah-v5")
    m = mujoco.MjModel.from_xml_path(path)
    h, F = m.opt.timestep, env.frame_skip
    states = _plain_states(path, F, 0.1)
    E, R, IF = mujoco.mjtIntegrator.mjINT_EULER, mujoco.mjtIntegrator.mjINT_RK4, mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    truth = np.array([_plain_step(path, R, h / 32, 32 * F, q, v, u) for q, v, u in states])
    euler = np.array([_plain_step(path, E, h, F, q, v, u) for q, v, u in states])
    rk4 = np.array([_plain_step(path, R, h, F, q, v, u) for q, v, u in states])
    fast = np.array([_plain_step(path, IF, h, F, q, v, u) for q, v, u in states])
    obs = np.concatenate([np.array([q for q, _, _ in states])[:, 1:], np.array([v for _, v, _ in states])], axis=1)
    keep = np.r_[1 : m.nq, m.nq : m.nq + m.nv]
    sigma = np.maximum(obs.std(axis=0), 1e-3 * np.median(obs.std(axis=0)))

    def err(x):
        return np.median(np.sqrt(np.mean(((x[:, keep] - truth[:, keep]) / sigma) ** 2, axis=1)))

    assert np.array_equal(euler, fast)
    assert s.by_name("implicitfast x1").same_bits_as == "euler x1"
    e_plain, factor_plain = err(euler), err(euler) / err(rk4)
    assert 0.5 < s.baseline.obs.median / e_plain < 2.0
    assert 0.05 < e_plain < 0.2  # about a tenth of the spread
    factor = s.baseline.obs.median / s.by_name("rk4 x1").obs.median
    assert factor_plain > 10 and 0.5 < factor / factor_plain < 2.0
    text = " ".join(verdict(s))
    assert "implicitfast is bit for bit euler" in text and "rk4 at the same step cuts the error" in text


def test_humanoid_references_part_within_seconds_and_trajectory_errors_stop_there():
    s = study_of("Humanoid-v5", horizon=1.5, states=6)
    parted = [h for h in s.horizon if h is not None]
    assert parted and max(parted) < 1.5  # contact-rich motion: the two references part within the run
    assert "Predictable horizon: the references part" in " ".join(verdict(s))


def test_humanoid_inside_its_episodes_a_halved_rk4_step_buys_its_order_on_most_steps_and_little_on_the_rest():
    """Inside Gymnasium's episodes (the fallen states after them left out), a halved RK4 step cuts
    the Humanoid's transition error by about 2^4 = 16 on most control steps and by little where a
    contact or a limit switches: the per-state ratios are two populations. A plain loop here (its
    own states and seeds, RK4 at h/32 as the truth) must find the same two: the share of steps that
    get at least half the order's 16 x, and that gain's median."""
    env = environment("Humanoid-v5")
    path = env.path()
    s = study_of("Humanoid-v5")
    assert s.within_episode and s.past_termination == 0 and all(e is not None for e in s.episodes)
    m = mujoco.MjModel.from_xml_path(path)
    h, F, R = m.opt.timestep, env.frame_skip, mujoco.mjtIntegrator.mjINT_RK4
    states = _plain_states(
        path, F, 0.01, seeds=(0, 1, 2), n_control=400, rng_base=2000, healthy=lambda q: 1.0 < q[2] < 2.0
    )  # Humanoid-v5's healthy_z_range
    truth = np.array([_plain_step(path, R, h / 32, 32 * F, q, v, u) for q, v, u in states])
    one = np.array([_plain_step(path, R, h, F, q, v, u) for q, v, u in states])
    half = np.array([_plain_step(path, R, h / 2, 2 * F, q, v, u) for q, v, u in states])
    obs = np.concatenate([np.array([q for q, _, _ in states])[:, 2:], np.array([v for _, v, _ in states])], axis=1)
    keep = np.r_[2 : m.nq, m.nq : m.nq + m.nv]
    sigma = np.maximum(obs.std(axis=0), 1e-3 * np.median(obs.std(axis=0)))

    def err(x):
        return np.sqrt(np.mean(((x[:, keep] - truth[:, keep]) / sigma) ** 2, axis=1))

    plain = err(one) / err(half)
    study = s.baseline.obs_errors / s.by_name("rk4 x2").obs_errors
    for ratio in (plain, study):
        full = ratio >= 8
        assert 0.2 < np.mean(full) < 0.95  # two populations, neither empty
        assert 12 < np.median(ratio[full]) < 28  # fourth order where the step is smooth
    assert abs(np.mean(plain >= 8) - np.mean(study >= 8)) < 0.35  # other states, other seeds
    assert "a halved step buys at least half of what rk4's order 4 promises (16 x)" in " ".join(verdict(s))


def test_hopper_contact_figures_match_a_plain_loops_count():
    """Contacts a step of Euler's own runs: the study collides each state after a step; a plain
    loop reads d.ncon after each mj_step (the contacts of the state before it). Over the same
    runs the two means agree to a step's shift."""
    env = environment("Hopper-v5")
    s = study_of("Hopper-v5", horizon=1.0, states=12)
    r = s.by_name("euler x1")
    m = mujoco.MjModel.from_xml_path(env.path())
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    d = mujoco.MjData(m)
    setting = _setting("Hopper-v5")
    counts = []
    for i, seed in enumerate(setting.seeds):
        q, v = setting.start(m, seed)
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:] = q, v
        U = setting.sequence(m, seed, int(round(1.0 / (env.frame_skip * m.opt.timestep))))
        end = int(round(s.episodes[i] / (env.frame_skip * m.opt.timestep))) if s.episodes[i] is not None else len(U)
        for u in U[: max(1, end)]:
            d.ctrl[:] = u
            for _ in range(env.frame_skip):
                mujoco.mj_step(m, d)
                counts.append(d.ncon)
    assert r.contacts.mean == pytest.approx(np.mean(counts), abs=0.1)


def test_a_reference_that_does_not_converge_judges_nothing(monkeypatch):
    """With a demand no refinement meets (its error at most 1e-12 of the baseline's), the reference
    is not converged: the verdict says so and no candidate's error is printed as a figure."""
    import harness.control_step as cs
    from reports.control_step_section import table_rows

    monkeypatch.setattr(cs, "REF_FRACTION", 1e-12)
    m = compile_model(read_model_file(environment("Hopper-v5").path()))
    s = cs.run_study(
        m,
        _setting("Hopper-v5"),
        StudyConfig(
            horizon_s=0.3,
            states_per_seed=4,
            timings=_timings(4),
            threads=1,
            substeps=(1,),
            integrators=("rk4", "euler"),
        ),
        progress=None,
    )
    assert not s.reference.converged and s.reference.level == cs.REF_LAST
    words = cs.verdict(s)
    assert len(words) == 1 and "no candidate is judged: the reference did not converge" in words[0]
    assert all(row[3] == "not judged" for row in table_rows(s)[:2])


# ------------------------------------------------------------------ the command
def test_harness_model_default_question_on_hopper(tmp_path):
    code, out, err = cli(
        "model",
        "--env",
        "Hopper-v5",
        "--horizon",
        "0.5",
        "--states",
        "8",
        "--seeds",
        "2",
        "--out",
        str(tmp_path),
        "--json",
    )
    assert code == 0, err
    data = json.loads(out)
    assert data["collidable_pairs"] == 7 and data["reference"]["converged"]
    assert data["reference"]["h"] <= 0.002 / 16
    assert data["setting"]["frame_skip"] == 4 and data["setting"]["control_step_s"] == pytest.approx(0.008)
    assert len(data["candidates"]) == 15 and any(c["baseline"] and c["integrator"] == "rk4" for c in data["candidates"])
    assert (tmp_path / "report.md").is_file() and (tmp_path / "control_step.csv").is_file()
    assert (tmp_path / "charts" / "control_step_error_cost.png").stat().st_size > 0
    report = (tmp_path / "report.md").read_text()
    assert report.index("## The answer") < report.index("## Each integrator")
    assert "Drake, Newton and pybullet are not in this question" in report


def test_controls_from_a_file(tmp_path):
    m = compile_model(read_model_file(environment("Hopper-v5").path()))
    table = np.tile(np.linspace(-1, 1, m.nu), (5, 1))
    np.save(tmp_path / "u.npy", table)
    code, out, err = cli(
        "model",
        "--env",
        "Hopper-v5",
        "--controls",
        str(tmp_path / "u.npy"),
        "--horizon",
        "0.2",
        "--states",
        "4",
        "--seeds",
        "1",
        "--out",
        str(tmp_path / "o"),
        "--json",
    )
    assert code == 0, err
    assert "from" in json.loads(out)["setting"]["controls"]


@pytest.mark.parametrize(
    "argv, says",
    [
        (["--env", "Hopper-v9"], "unknown --env 'Hopper-v9' (valid: Hopper-v5"),
        (["--env", "Hopper-v5", "--frame-skip", "0"], "--frame-skip=0 is out of range"),
        (["--env", "Hopper-v5", "--seeds", "x"], "--seeds='x' is not an integer"),
        (["--env", "Hopper-v5", "--horizon", "-1"], "--horizon=-1 is out of range"),
        (["--env", "Hopper-v5", "--controls", "nope.npy"], "--controls 'nope.npy': no such file"),
        ([], "path: a model file is needed"),
    ],
)
def test_bad_input_is_one_line_before_any_engine_runs(tmp_path, argv, says):
    code, out, err = cli("model", *argv, "--out", str(tmp_path / "out"))
    assert code == 2 and out == "" and says in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_a_controls_file_with_the_wrong_width_is_refused(tmp_path):
    np.save(tmp_path / "u.npy", np.zeros((4, 7)))
    code, _, err = cli(
        "model", "--env", "Hopper-v5", "--controls", str(tmp_path / "u.npy"), "--out", str(tmp_path / "o")
    )
    assert code == 2 and "7 columns, the model has 3 actuators" in err


def test_packaged_model_without_its_package_names_the_extra(monkeypatch):
    import importlib.util

    from scenarios import environments

    monkeypatch.setattr(importlib.util, "find_spec", lambda name: None)
    with pytest.raises(InvalidInput, match=r"integrator-harness\[models\]"):
        environments.packaged_model("gymnasium", "hopper.xml")


# ------------------------------------------------------------------ the nightly
def test_nightly_appends_each_environments_question_to_its_report(tmp_path):
    from harness.cli.nightly import control_step_sections

    report = tmp_path / "report.md"
    report.write_text("# nightly\n")
    control_step_sections(
        [environment("Hopper-v5")],
        report,
        StudyConfig(horizon_s=0.3, states_per_seed=4, threads=1, timings=_timings(4)),
    )
    text = report.read_text()
    assert "## Model files at their control step" in text and "### Hopper-v5" in text
    assert "#### The answer" in text and "each control step is" in text
    assert (tmp_path / "control_step_Hopper-v5.csv").is_file()


def test_nightly_refuses_an_unknown_environment_before_anything_runs(tmp_path):
    code, out, err = cli(
        "nightly", "--model-env", "Nope-v1", "--out", str(tmp_path / "o"), "--db", str(tmp_path / "db")
    )
    assert code == 2 and "unknown --env 'Nope-v1'" in err and not (tmp_path / "db").exists()


# ------------------------------------------------------------------ Gymnasium itself
def _gymnasium_env(name, monkeypatch):
    """Gymnasium's own environment (its Python, not only its XML): imageio, which only its
    rendering needs, stubbed where it is not installed."""
    import importlib.util
    import sys
    import types

    if importlib.util.find_spec("imageio") is None:
        monkeypatch.setitem(sys.modules, "imageio", types.ModuleType("imageio"))
    gym = pytest.importorskip("gymnasium")
    return gym.make(name).unwrapped


@pytest.mark.parametrize("name", ["Ant-v5", "Humanoid-v5", "Hopper-v5"])
def test_the_observation_is_gymnasiums_own(name, monkeypatch):
    """env.step's observation from a harness start and control equals the study's observation of
    the same step as Gymnasium reads it (qpos, clipped qvel, the extras from what the last
    mj_step's forward pass left), to roundoff."""
    from adapters.mujoco.control import Stepper, full_state

    env = _gymnasium_env(name, monkeypatch)
    env.reset(seed=0)
    e = environment(name)
    setting = _setting(name)
    m = env.model
    q, v = setting.start(m, 0)
    u = setting.sequence(m, 0, 1)[0]
    env.set_state(q, v)
    obs = env.step(u)[0]
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:], d.ctrl[:] = q, v, u
    mujoco.mj_step(m, d, nstep=e.frame_skip - 1)
    stepper = Stepper(m, 1)
    before = np.empty(stepper.nstate)
    mujoco.mj_getState(m, d, before, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    mujoco.mj_step(m, d)
    end = np.empty(stepper.nstate)
    mujoco.mj_getState(m, d, end, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    from adapters.mujoco.control import integrator_name

    ours = stepper.observe(end[None], e.observation, u[None], integrator_name(m), m.opt.timestep, before[None])[0]
    assert ours.shape == obs.shape
    np.testing.assert_allclose(ours, obs, rtol=1e-9, atol=1e-9)
    assert full_state(m, q, v).shape == end.shape


def test_gymnasium_ends_the_hoppers_episodes_where_the_study_says(monkeypatch):
    """Gymnasium's own env.step from each harness start under the harness's controls terminates at
    the times the study reports (its Termination and your own setting's run, not the reference's)."""
    env = _gymnasium_env("Hopper-v5", monkeypatch)
    env.reset(seed=0)
    s = study_of("Hopper-v5")
    setting = _setting("Hopper-v5")
    for seed, said in zip(setting.seeds, s.episodes):
        q, v = setting.start(env.model, seed)
        env.set_state(q, v)
        ended = None
        for j, u in enumerate(setting.sequence(env.model, seed, 200)):
            if env.step(u)[2]:
                ended = (j + 1) * env.dt
                break
        assert ended == pytest.approx(said, abs=1e-12), (seed, ended, said)


def test_termination_rules_are_gymnasiums_at_their_edges():
    hop, ant = environment("Hopper-v5").termination, environment("Ant-v5").termination
    q = np.zeros(6)
    q[1] = 1.25
    v = np.zeros(6)
    assert not hop.terminated(q, v)
    assert hop.terminated(q, np.r_[0, 0, 0, 0, 0, 100.0])  # healthy_state_range is open at 100
    assert hop.terminated(np.r_[0, 1.25, 0.2, 0, 0, 0], v)  # healthy_angle_range is open
    qa = np.zeros(15)
    qa[2] = 1.0
    assert not ant.terminated(qa, np.zeros(14))  # Ant's z range is closed
    assert ant.terminated(qa, np.r_[np.nan, np.zeros(13)])  # and the state must be finite
