"""One engine, one package (issue 52): each engine's ``Engine`` entry (``adapters/<engine>/``,
``ENGINE``) is the one place its modes, poses, model builder, bare loops, releases and
distributions are written; every list of engines the harness keeps is read from ``adapters.ENGINES``,
so that a release of any engine, Drake's and Newton's included, is named where two runs differ."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import adapters
from harness.history.series import FAMILY_PACKAGES, NOTHING_DIFFERS, what_differs
from harness.history.storage import History

ROOT = Path(__file__).resolve().parents[1]
ENGINES = tuple(adapters.ENGINES.values())


def test_every_engine_entry_is_its_modes_own():
    """An entry's modes name it: their family, import, distribution, releases and builder are the
    entry's, and ``ENGINE_METHODS`` is every entry's modes, nothing more."""
    assert adapters.ENGINE_METHODS == {mid: m for e in ENGINES for mid, m in e.methods.items()}
    for e in ENGINES:
        assert e.methods and e.poses and e.bare_loops is not None, e.id
        for mid, mode in e.methods.items():
            assert mid.split(":")[0] == e.id and mode.engine == e.id, mid
            assert (mode.module, mode.dist, mode.versions) == (e.module, e.dist, e.versions), mid
            assert mode.build is e.build and set(mode.scenes) <= set(e.poses), mid
        # An engine loads a user's model file exactly where it poses one.
        assert bool(e.model_loader) == ("model" in e.poses), e.id
        assert e.loader_without_contact is None or e.model_loader, e.id


def test_every_package_list_is_read_from_the_engines():
    """The fingerprint a Dask worker must share, the packages every run records, those a family's
    figures depend on, the engines' series, the model-file loaders, the engine environments and
    the worker's preloads: each holds every engine's distributions (Newton's Warp included)."""
    from harness.execution import engine_env, isolation
    from harness.execution.environment import COMPUTING_PACKAGES, RECORDED_PACKAGES, run_metadata
    from harness.history import storage
    from harness.nightly import models
    from harness.nightly.run import engine_versions

    dists = [d for e in ENGINES for d in e.dists]
    assert "drake" in dists and "newton" in dists and "warp-lang" in dists
    assert set(dists) <= set(COMPUTING_PACKAGES) and set(dists) <= set(RECORDED_PACKAGES)
    assert set(dists) <= set(run_metadata()[1])
    assert FAMILY_PACKAGES == {e.id: e.dists for e in ENGINES}
    assert storage.ENGINE_DISTS == tuple(dict.fromkeys(dists))
    assert set(engine_versions()) == set(dists)  # Warp's release alone starts a series too
    assert models.MODEL_ENGINES == tuple(e.id for e in ENGINES if e.model_loader)
    assert set(models.WITHOUT_CONTACT) == {e.id for e in ENGINES if e.loader_without_contact}
    assert {e.id: e.dist for e in ENGINES}.items() <= engine_env.engines().items()
    assert isolation.engine_modules([f"{e.id}:x" for e in ENGINES]) == {e.module for e in ENGINES}


def test_every_engine_is_an_extra_of_the_project_with_its_distributions():
    """``pip install 'integrator-harness[<engine>]'`` (what an unavailable mode says to run) installs
    the entry's distributions, and ``[engines]`` every engine's."""
    import tomllib

    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]

    def names(specs):
        return {re.split(r"[=<>!~\[; ]", s, maxsplit=1)[0] for s in specs}

    for e in ENGINES:
        assert names(extras[e.id]) == set(e.dists), e.id
    assert names(extras["engines"]) == set(adapters.ENGINE_DISTS)


def test_no_engine_is_written_out_by_hand_outside_its_package():
    """No module outside ``adapters/`` keeps a list of engine ids or branches on one: the bench
    asks the mode's entry for its bare loops."""
    ids = "|".join(adapters.ENGINES)
    listed = re.compile(rf"[\"']({ids})[\"']\s*[,:]\s*\(?[\"']({ids})[\"']")
    branch = re.compile(rf"\.(engine|family)\s*(==|!=)\s*[\"']({ids})[\"']")
    hits = [
        f"{path.relative_to(ROOT)}:{n}"
        for package in ("harness", "reports", "scenarios", "records")
        for path in sorted((ROOT / package).rglob("*.py"))
        for n, line in enumerate(path.read_text().splitlines(), 1)
        if listed.search(line) or branch.search(line)
    ]
    assert hits == []


def _versions(release: dict) -> dict:
    """A run's versions as ``harness nightly`` records them: every recorded package at top level
    (``run_metadata``), each engine's own release again under ``engines`` (its series)."""
    from harness.execution.environment import RECORDED_PACKAGES

    top = {pkg: release.get(pkg, "1.0") for pkg in RECORDED_PACKAGES}
    return {"python": "3.11.9", **top, "engines": {e.dist: top[e.dist] for e in ENGINES}}


def _stored(history: History, versions: dict, machine: dict | None = None) -> dict:
    run_id = history.start_run(
        started="2026-11-28T00:00:00",
        suite="toy",
        git_commit="a" * 40,
        versions=versions,
        machine=machine or {"node": "host-a", "system": "Linux", "machine": "x86_64"},
        settings={},
    )
    history.finish_run(run_id, finished="2026-11-28T00:01:00", wall_s=1.0, timing={}, regressions=0)
    return history.run(run_id)


@pytest.mark.parametrize("engine", ENGINES, ids=lambda e: e.id)
def test_what_differs_names_a_release_of_every_engine(engine, tmp_path):
    """Two stored runs that differ only in one of an engine's distributions: ``what_differs`` names
    that release for the engine's cells, and nothing for another engine's or a reference scheme's."""
    h = History(tmp_path / "h.sqlite")
    before = _stored(h, _versions({}))
    for dist in engine.dists:
        after = _stored(h, _versions({dist: "2.0"}))
        assert what_differs(before, after, engine.id) == f"{dist} 1.0 -> 2.0"
        for family in [e.id for e in ENGINES if e is not engine and dist not in e.dists] + ["ref"]:
            assert what_differs(before, after, family, deterministic=False) == NOTHING_DIFFERS


def test_what_differs_reads_a_release_recorded_only_among_the_engines():
    """A run stored before an engine's distribution was recorded on its own (Drake's, Newton's) has
    its release under ``versions["engines"]``: that release is compared."""
    a = {
        "run_id": 1,
        "suite": "toy",
        "started": "t",
        "measurement_version": 7,
        "git_commit": "a" * 40,
        "versions": {"numpy": "2", "engines": {"drake": "1.50.0"}},
        "machine": {},
    }
    b = {**a, "versions": {"numpy": "2", "engines": {"drake": "1.51.1"}}}
    assert what_differs(a, b, "drake") == "drake 1.50.0 -> 1.51.1"


def test_what_differs_names_another_host_of_the_same_platform(tmp_path):
    h = History(tmp_path / "h.sqlite")
    a = _stored(h, _versions({}), {"node": "host-a", "system": "Linux", "machine": "x86_64", "processor": "x86_64"})
    b = _stored(h, _versions({}), {"node": "host-b", "system": "Linux", "machine": "x86_64", "processor": "x86_64"})
    assert what_differs(a, b, "mujoco", deterministic=False) == "platform host host-a -> host-b"
    assert what_differs(a, a, "mujoco", deterministic=False) == NOTHING_DIFFERS
