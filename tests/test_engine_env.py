"""Engine environments and ``harness bisect`` (issue 34).

* A toy plugin engine whose releases are folders (``tests/toy_engine.py``; ``releases`` and
  ``ensure`` injected, no network): bisect names the first changed release, with both values,
  measuring the two ends and then ceil(log2(n - 1)) releases of the n in the range.
* Bad input: one line each, exit 2, nothing installed (an unknown engine, a release that does
  not exist, a range in the wrong order, a registry that does not answer, a release outside an
  adapter's declared range, a mode outside the engine).
* ``slow``: two MuJoCo releases built from the registry (cached), ``discrete`` in one and not the
  other, the unit spring's Euler trajectory bit for bit the same.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import pytest

from records import InvalidInput

from harness.cli import bisect as bisect_cli
from harness.cli import main
from harness.execution import engine_env

from tests.toy_engine import write_releases

ROOT = Path(__file__).resolve().parents[1]
TOY_VERSIONS = [f"1.{i}" for i in range(8)]


@pytest.fixture
def toy(tmp_path, monkeypatch):
    """Eight toy releases 1.0 ... 1.7, the step changed from 1.5 on; the plugin named in
    HARNESS_PLUGINS, so the measuring processes (which inherit the environment) load it."""
    monkeypatch.setenv("HARNESS_PLUGINS", "tests.toy_engine")
    monkeypatch.setenv("HARNESS_CACHE", str(tmp_path / "cache"))
    folders = write_releases(tmp_path / "releases", TOY_VERSIONS, first_changed="1.5")
    ensured = []

    def ensure(dist, version):
        ensured.append(version)
        return folders[version]

    return folders, (lambda dist: list(TOY_VERSIONS)), ensure, ensured


@pytest.mark.slow
def test_bisect_finds_the_toys_first_changed_release_in_log2_steps(toy):
    folders, releases, ensure, ensured = toy
    argv = bisect_cli.cell_argv("trajectory", "spring", "toyengine:euler", "0.1", "200", [])
    said = []
    result = bisect_cli.bisect("toyengine", "1.0", "1.7", argv, releases=releases, ensure=ensure, say=said.append)
    assert (result.first, result.before) == ("1.5", "1.4")
    # The two ends, then ceil(log2(7)) = 3 of the 7 releases after LOW: 1.3, 1.5, 1.4.
    n = len(TOY_VERSIONS)
    assert len(result.tried) == 2 + math.ceil(math.log2(n - 1)) == 5
    assert result.tried[:2] == ["1.0", "1.7"] and sorted(ensured) == sorted(result.tried)
    before, after = result.values["1.4"], result.values["1.5"]
    assert before["status"] == after["status"] == "ok" and before["rows"] != after["rows"]
    # Bit for bit: the releases before the change give LOW's cell exactly, those after HIGH's.
    assert result.values["1.0"] == before and result.values["1.7"] == after
    assert "first difference at step" in bisect_cli.difference(before, after)
    assert any("measuring 1.3" in line for line in said)


def test_bisect_says_unchanged_where_both_ends_agree(toy):
    folders, releases, ensure, ensured = toy
    argv = bisect_cli.cell_argv("trajectory", "spring", "toyengine:euler", "0.1", "50", [])
    result = bisect_cli.bisect("toyengine", "1.0", "1.4", argv, releases=releases, ensure=ensure)
    assert result.first is None and result.tried == ["1.0", "1.4"]


def test_find_change_measures_at_most_log2_of_the_range():
    for n in (2, 3, 5, 8, 17, 40):
        for first in range(1, n):
            calls = []

            def measure(release, calls=calls, first=first):
                calls.append(release)
                return release >= first

            found, before, tried, _ = bisect_cli.find_change(list(range(n)), measure)
            assert (found, before) == (first, first - 1)
            assert len(calls) <= 2 + math.ceil(math.log2(n - 1))


def test_a_release_imports_its_own_engine(toy):
    folders, *_ = toy
    done = engine_env.run_harness(
        folders["1.6"],
        ["run", "spring", "--method", "toyengine:euler", "--dt", "0.1", "--steps", "2", "--format", "json"],
    )
    assert done.returncode == 0, done.stderr
    meta = json.loads(done.stdout)["meta"]
    assert meta["engine_version"] == "1.6" and meta["settings"] == {"release": "1.6"}


# ---------------------------------------------------------------- bad input: one line, exit 2


def _one_line_exit_2(capsys, argv):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("harness: error: ")
    return err


def test_unknown_engine_names_the_engines(capsys, monkeypatch, tmp_path):
    monkeypatch.setenv("HARNESS_CACHE", str(tmp_path))
    err = _one_line_exit_2(capsys, ["bisect", "bullet", "1.0", "2.0", "--scene", "spring", "--method", "bullet:x"])
    assert "unknown engine 'bullet'" in err and "mujoco" in err and "rebound" in err
    assert not (tmp_path / "engines").exists()


def test_a_mode_of_another_engine_is_refused(capsys):
    err = _one_line_exit_2(
        capsys, ["bisect", "mujoco", "3.0.0", "3.3.7", "--scene", "spring", "--method", "rebound:whfast"]
    )
    assert "--method" in err and "mujoco:euler" in err


def test_unknown_measure_names_the_measures(capsys):
    err = _one_line_exit_2(
        capsys,
        ["bisect", "mujoco", "3.0.0", "3.3.7", "--scene", "spring", "--method", "mujoco:euler", "--measure", "speed"],
    )
    assert "--measure" in err and "trajectory" in err and "stability" in err


LISTED = ["2.3.6", "2.3.7", "3.0.0", "3.0.1", "3.3.7", "4.0.0"]


def test_a_release_that_does_not_exist_names_the_nearest():
    with pytest.raises(
        InvalidInput, match=r"mujoco has no release '3\.2\.9' \(nearest: 3\.0\.0, 3\.0\.1, 3\.3\.7, 4\.0\.0\)"
    ):
        engine_env.check_release("mujoco", "3.2.9", LISTED)
    assert engine_env.check_release("mujoco", "4.0", LISTED) == "4.0.0"


def test_a_range_in_the_wrong_order_says_so():
    with pytest.raises(InvalidInput, match="LOW, HIGH: mujoco 3.3.7 is not older than 3.0.0"):
        engine_env.check_range("mujoco", "3.3.7", "3.0.0", LISTED)
    assert engine_env.check_range("mujoco", "2.3.7", "3.3.7", LISTED) == ["2.3.7", "3.0.0", "3.0.1", "3.3.7"]


def test_a_release_outside_the_adapters_range_is_refused_before_installing(tmp_path):
    installed = []
    argv = bisect_cli.cell_argv("trajectory", "spring", "mujoco:euler", "0.1", "10", [])
    with pytest.raises(
        InvalidInput,
        match=r"LOW: mujoco 2\.3\.6 is outside the versions its adapter supports "
        r"\(mujoco>=2\.3\.7,<5",
    ):
        bisect_cli.bisect(
            "mujoco", "2.3.6", "3.0.0", argv, releases=lambda d: LISTED, ensure=lambda d, v: installed.append(v)
        )
    assert installed == []


def test_a_registry_that_does_not_answer_is_one_line(monkeypatch, tmp_path):
    # A registry on a closed local port: pip cannot connect (no network needed to test it).
    env = {
        **os.environ,
        "PIP_INDEX_URL": "http://127.0.0.1:9/simple",
        "PIP_EXTRA_INDEX_URL": "",
        "PIP_FIND_LINKS": "",
        "PIP_NO_INDEX": "",
        "PIP_CONFIG_FILE": os.devnull,
        "PIP_RETRIES": "0",
    }
    with pytest.raises(InvalidInput, match="the package registry did not answer") as info:
        engine_env.releases("mujoco", env=env)
    assert "\n" not in str(info.value)


def test_an_installed_version_outside_the_range_makes_the_mode_unavailable(monkeypatch):
    import adapters
    from adapters import _mode

    mode = adapters.ENGINE_METHODS["mujoco:euler"]
    monkeypatch.setattr(_mode, "engine_version", lambda dist: "2.2.0")
    ok, why = mode.available()
    assert (
        not ok
        and why
        == "mujoco 2.2.0 is outside the versions its adapter supports (mujoco>=2.3.7,<5; tested on "
        "2.3.7, 3.0.0, 3.3.7, 4.0.0)"
    )


def test_harness_run_on_an_engine_outside_the_range_is_one_line_exit_2(tmp_path):
    # A folder holding only a dist-info that says mujoco 2.2.0: the version is refused before import.
    info = tmp_path / "mujoco-2.2.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: mujoco\nVersion: 2.2.0\n")
    done = engine_env.run_harness(
        tmp_path, ["run", "spring", "--method", "mujoco:euler", "--dt", "0.1", "--steps", "2"]
    )
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        "harness: error: method mujoco:euler is unavailable: mujoco 2.2.0 is outside the versions its adapter "
        "supports (mujoco>=2.3.7,<5; tested on 2.3.7, 3.0.0, 3.3.7, 4.0.0)"
    ]


def test_version_order():
    from adapters import EngineVersions, version_key

    assert sorted(["3.10.0", "3.2.0", "2.3.1.post1", "2.3.1", "3.0.0rc1", "3.0.0"], key=version_key) == [
        "2.3.1",
        "2.3.1.post1",
        "3.0.0rc1",
        "3.0.0",
        "3.2.0",
        "3.10.0",
    ]
    assert "4.0" in EngineVersions("4.0.0", "6") and "6.0" not in EngineVersions("4.0.0", "6")


# ---------------------------------------------------------------- two real MuJoCo releases

#: Two releases either side of the discrete integrator's arrival (mjINT_DISCRETE: in 4.0.0, not
#: in 3.3.7, checked by the test itself).
OLD, NEW = "3.3.7", "4.0.0"


@pytest.mark.slow
def test_two_mujoco_releases_discrete_in_one_euler_bit_for_bit_in_both():
    folders = {v: engine_env.ensure("mujoco", v) for v in (OLD, NEW)}
    assert engine_env.ensure("mujoco", OLD) == folders[OLD]  # built once: the second call finds it

    def harness(v, *argv):
        return engine_env.run_harness(folders[v], list(argv), timeout=600)

    runs = {}
    for v in (OLD, NEW):
        done = harness(
            v, "run", "spring", "--method", "mujoco:euler", "--dt", "0.01", "--steps", "10000", "--format", "json"
        )
        assert done.returncode == 0, done.stderr
        out = json.loads(done.stdout)
        assert out["meta"]["engine_version"] == v
        runs[v] = out["rows"]
    assert runs[OLD] == runs[NEW]  # every q, v and energy, bit for bit (JSON keeps every double's bits)

    absent = harness(OLD, "run", "spring", "--method", "mujoco:discrete", "--dt", "0.1", "--steps", "2")
    assert (
        absent.returncode == 2
        and absent.stderr.strip() == f"harness: error: method mujoco:discrete is unavailable: not in mujoco {OLD}"
    )
    present = harness(NEW, "run", "spring", "--method", "mujoco:discrete", "--dt", "0.1", "--steps", "2")
    assert present.returncode == 0, present.stderr


def test_a_mode_missing_from_early_releases_is_one_cell_until_it_appears(toy):
    # "not in toyengine 1.2" and "not in toyengine 1.3" name the release, not a different cell.
    folders, releases, ensure, ensured = toy

    def measure(folder, argv):
        release = Path(folder).name.split("-", 1)[1]
        return (
            {"error": f"method toyengine:euler is unavailable: not in toyengine {release}"}
            if release < "1.5"
            else {"rows": [1.0]}
        )

    result = bisect_cli.bisect(
        "toyengine",
        "1.0",
        "1.7",
        ["run", "spring", "--method", "toyengine:euler"],
        releases=releases,
        ensure=ensure,
        measure=measure,
    )
    assert (result.first, result.before) == ("1.5", "1.4")
