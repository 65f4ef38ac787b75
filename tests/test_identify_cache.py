"""The identity measure's candidate runs are stored on disk beside the kernels, keyed by what
determines them and by the code that computes them: a second process reads the same bits, and
code that changed never reads a run of the old."""

import numpy as np

from harness.measures import identify as ident
from harness.methods import get_method
from scenarios import make_scene


def _fresh(monkeypatch, tmp_path):
    monkeypatch.setenv("HARNESS_CACHE", str(tmp_path))
    monkeypatch.setattr(ident, "_CANDIDATES", {})


def test_a_candidate_run_is_read_back_bitwise_and_not_run_again(monkeypatch, tmp_path):
    _fresh(monkeypatch, tmp_path)
    scene, ref = make_scene("pendulum"), get_method("ref:rk4")
    first = ident.candidate_run(ref, scene, 0.01, 300)
    assert len(list((tmp_path / "candidates").glob("*.pickle"))) == 1
    monkeypatch.setattr(ident, "_CANDIDATES", {})  # another process: nothing in memory
    ran = []
    monkeypatch.setattr(type(ref), "simulate", lambda *a, **k: ran.append(a))
    again = ident.candidate_run(ref, scene, 0.01, 300)
    assert ran == [] and again.q.tobytes() == first.q.tobytes() and again.v.tobytes() == first.v.tobytes()
    assert again.status == first.status and np.array_equal(again.step, first.step)


def test_other_code_or_another_run_is_a_new_file(monkeypatch, tmp_path):
    _fresh(monkeypatch, tmp_path)
    scene, ref = make_scene("pendulum"), get_method("ref:rk4")
    ident.candidate_run(ref, scene, 0.01, 300)
    ident.candidate_run(ref, scene, 0.02, 300)  # another dt
    monkeypatch.setattr(ident, "_CANDIDATES", {})
    monkeypatch.setattr(ident, "_DIGEST", "edited source")  # the code changed
    ident.candidate_run(ref, scene, 0.01, 300)
    assert len(list((tmp_path / "candidates").glob("*.pickle"))) == 3


def test_an_unreadable_stored_run_is_run_again(monkeypatch, tmp_path):
    _fresh(monkeypatch, tmp_path)
    scene, ref = make_scene("pendulum"), get_method("ref:rk4")
    first = ident.candidate_run(ref, scene, 0.01, 300)
    (path,) = (tmp_path / "candidates").glob("*.pickle")
    path.write_bytes(b"half a fi")
    monkeypatch.setattr(ident, "_CANDIDATES", {})
    again = ident.candidate_run(ref, scene, 0.01, 300)
    assert again.q.tobytes() == first.q.tobytes()
