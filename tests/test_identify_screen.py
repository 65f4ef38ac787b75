"""The identity's screen: a short interpreted run rules out the schemes that part from the method
beyond the tolerance, and only the others (and the runner-up) run in full. Its verdict is the one
full runs of every scheme give: the same matches and max |diff|; the schemes it rules out do not
match over the full run, and what it shows of them is at most their full run's max |diff|."""

import pytest

from harness.measures import identify as ident
from reference import RefMethod
from scenarios import make_scene

STEPS = 200
CASES = [
    # (method, scene, parameters): a match, a match on a nonlinear scene, no match on a damped chain
    ("ref:semi_implicit_euler_velocity_implicit", "spring", {}),
    ("ref:position_first_euler_decay_after_kick", "pendulum", {}),
    ("ref:semi_implicit_euler", "chain", {"N": 4, "c": 20.0}),
]


def _both(monkeypatch, method, scene):
    """(the screened result, the result of full runs of every scheme, the schemes run in full)."""
    monkeypatch.setattr(ident, "_CANDIDATES", {})
    monkeypatch.setattr(ident, "_SCREENS", {})
    monkeypatch.setattr(ident, "_stored", lambda key, run: run())  # nothing read back from the disk
    ran = []
    real = RefMethod.simulate

    def counting(self, *args, **kwargs):
        ran.append(self.id)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(RefMethod, "simulate", counting)
    screened = ident.identify(method, scene, steps=STEPS)
    in_full = list(ran)
    with monkeypatch.context() as m:
        m.setattr(ident, "UNSCREENED_STEPS", STEPS)  # a run too short to screen: every scheme in full
        full = ident.identify(method, scene, steps=STEPS)
    return screened, full, in_full


@pytest.mark.parametrize("method, scene_id, params", CASES, ids=[f"{m}-{s}" for m, s, _ in CASES])
def test_the_screen_gives_the_verdict_of_full_runs(monkeypatch, method, scene_id, params):
    scene = make_scene(scene_id, **params)
    screened, full, in_full = _both(monkeypatch, method, scene)
    assert full.screen_steps is None and screened.screen_steps == ident.screen_length(STEPS) == STEPS // 2
    assert (screened.matches, screened.match, screened.max_deviation, screened.tolerance) == (
        full.matches,
        full.match,
        full.max_deviation,
        full.tolerance,
    )
    # The verdict's line is the same text.
    assert ident.format_report(screened).splitlines()[:2] == ident.format_report(full).splitlines()[:2]
    by_full = {c.method: c for c in full.candidates}
    ruled_out = [c for c in screened.candidates if c.steps < STEPS]
    for c in ruled_out:
        # Ruled out: not a match over the full run, beyond the tolerance where it parts, and what is
        # shown of it is a lower bound of its full run's max |diff| (the same steps, the same bits).
        assert not by_full[c.method].matches and not c.matches
        assert screened.tolerance < c.max_deviation <= by_full[c.method].max_deviation
        assert c.within == c.steps - 1 < screened.screen_steps
    # Only the others step their full run; the screen's runs are interpreted and short.
    assert sorted(in_full) == sorted([method, *(c.method for c in screened.candidates if c.steps == STEPS)])
    if full.matches:
        assert ruled_out, "nothing ruled out: the screen saved no run"
        # The runner-up's figure is its full run's, at least the closest non-match's.
        runner = screened.runner_up
        assert runner.steps == STEPS and runner.max_deviation == by_full[runner.method].max_deviation
        assert runner.max_deviation >= full.runner_up.max_deviation
    else:
        # Nothing matches: every scheme runs in full, the closest and the runner-up are the full runs'.
        assert screened.candidates == full.candidates and not ruled_out


def test_a_short_or_unstable_run_is_not_screened(monkeypatch):
    scene = make_scene("spring")
    res = ident.identify("ref:semi_implicit_euler_velocity_implicit", scene, steps=ident.UNSCREENED_STEPS)
    assert res.screen_steps is None and all(c.steps == ident.UNSCREENED_STEPS for c in res.candidates)
    # A longer run is screened over half its steps, up to SCREEN_STEPS.
    assert ident.screen_length(100) == 50 and ident.screen_length(10_000) == ident.SCREEN_STEPS
    # Explicit Euler far past its limit blows up: its recorded steps end early, every scheme runs in full.
    blown = ident.identify("ref:explicit_euler", scene, dt=2.5, steps=400)
    assert blown.status == "unstable" and blown.screen_steps is None
