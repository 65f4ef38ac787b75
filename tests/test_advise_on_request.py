"""``harness advise SCENE`` on a built-in scene answers in seconds: the engines whose start-up, not
the scene, is the cost (``harness.cli.advise.ON_REQUEST``) run only when named, and the command says
so before it starts; named, they run."""

from __future__ import annotations

from harness.cli.advise import ON_REQUEST, default_patterns
from harness.methods import all_methods


def test_the_default_advice_leaves_the_slow_starting_engines_to_a_request_and_keeps_the_rest():
    default = set(default_patterns())
    every = set(all_methods())
    left = every - default
    assert left and all(m.split(":")[0] in ON_REQUEST for m in left)
    assert any(m.startswith("ref:") for m in default) and any(m.startswith("mujoco:") for m in default)


def test_the_command_says_what_it_left_out_and_a_named_engine_runs(capsys):
    from harness.cli import main

    assert main(["advise", "spring", "--hz", "60", "--methods", "ref:rk4", "--json"]) == 0
    named = capsys.readouterr()
    assert "left out" not in named.err  # nothing left out where methods were named
    assert main(["advise", "spring", "--hz", "60", "--horizon", "1", "--max-substeps", "1", "--jobs", "2"]) == 0
    out = capsys.readouterr()
    assert all(f"{engine}'s modes left out" in out.err for engine in ON_REQUEST)
