"""The report's first section (``reports.answer_section``): a line per scene with the advised method,
why, and the runner-up; frames whose costs lie within their timing spread are a tie, named as one
and decided by accuracy, then evaluations, never by which timing came out lower. Timings injected:
nothing here reads a clock."""

from __future__ import annotations

from records.cell import Cell
from records.contact import ContactCellFigures
from records.figures import AdviceFigures

from reports.answer_section import answer_section

REQUEST = {"energy_tol": 1e-3, "horizon": 10.0}


def advise(method, cost, spread, error, evals=4, energy=None):
    row = {
        "substeps": 2,
        "cost_per_frame_s": cost,
        "position_error": error,
        "evals_per_frame": evals,
        "energy_error": energy,
    }
    figures = AdviceFigures(hz=60.0, request=REQUEST, position_tol=0.05, rows=[row], best=0)
    return Cell("spring", method, method.split(":")[0], "advise", figures=figures, extra={"cost_rel_spread": spread})


def test_the_cheapest_frame_is_advised_with_its_runner_up():
    lines = answer_section([advise("ref:a", 1e-6, 0.01, 1e-3), advise("ref:b", 2e-6, 0.01, 1e-6)])
    line = next(x for x in lines if x.startswith("- `spring`"))
    assert "**`ref:a`**" in line and "the cheapest frame that meets the tolerances" in line
    assert "runner-up `ref:b`" in line and "energy error ≤ 0.001 and position error ≤ 0.05 over 10 s" in line


def test_frames_within_their_timing_spread_are_a_tie_decided_by_accuracy_then_evaluations():
    # b is 5% dearer than a, inside a's 10% spread: a tie, and b is the more accurate
    lines = answer_section([advise("ref:a", 1.00e-6, 0.10, 1e-3), advise("ref:b", 1.05e-6, 0.10, 1e-6)])
    line = next(x for x in lines if x.startswith("- `spring`"))
    assert "**`ref:b`**" in line and "(a tie)" in line and "`ref:a`" in line
    # the same, timings the other way round: the pick does not move with the clock
    flipped = answer_section([advise("ref:a", 1.05e-6, 0.10, 1e-3), advise("ref:b", 1.00e-6, 0.10, 1e-6)])
    assert "**`ref:b`**" in next(x for x in flipped if x.startswith("- `spring`"))
    # equal accuracy: the fewer evaluations a frame
    even = answer_section([advise("ref:a", 1.00e-6, 0.10, 1e-6, 8), advise("ref:b", 1.05e-6, 0.10, 1e-6, 4)])
    assert "**`ref:b`**" in next(x for x in even if x.startswith("- `spring`"))
    # outside the spread: no tie, the cheaper
    apart = answer_section([advise("ref:a", 1.00e-6, 0.01, 1e-3), advise("ref:b", 1.5e-6, 0.01, 1e-6)])
    assert "**`ref:a`**" in next(x for x in apart if x.startswith("- `spring`"))


def test_a_contact_scene_is_advised_at_each_profiles_step_by_its_profiles_tolerances():
    def contact(method, cpu, game_ok, robotics_ok):
        runs = [
            {
                "dt": dt,
                "status": "ok",
                "cpu_per_s": cpu,
                "by_profile": {"game": {"stop": game_ok}, "robotics": {"stop": robotics_ok}},
            }
            for dt in (1 / 1000, 1 / 60)
        ]
        figures = ContactCellFigures(scene="slide", scene_params={"mu": 0.5}, runs=runs)
        return Cell("slide", method, method.split(":")[0], "contact", figures=figures)

    lines = answer_section([contact("e:cheap", 0.01, False, True), contact("e:dear", 1.0, True, True)])
    game = next(x for x in lines if "60 Hz, game profile" in x)
    robot = next(x for x in lines if "1000 Hz, robotics profile" in x)
    assert "**`e:dear`**" in game and "1 of 2 modes" in game
    assert "**`e:cheap`**" in robot and "runner-up `e:dear`" in robot
    # Within the contact's timing noise (10% without a measured spread): a tie, named by name, and the
    # line never calls the pick the cheapest when the other timed lower.
    tied = answer_section([contact("z:first", 0.00100, True, True), contact("a:second", 0.00103, True, True)])
    game = next(x for x in tied if "60 Hz, game profile" in x)
    assert "**`a:second`**" in game and "as cheap as `z:first` (0.001) within timing noise (a tie" in game
    assert "the cheapest within" not in game


def test_a_scene_with_no_advice_says_what_was_measured():
    cell = Cell("kepler", "ref:a", "ref", "energy")
    assert any("`kepler`: no advice asked of it in this suite (measured: energy)" in x for x in answer_section([cell]))


def test_a_tie_is_not_decided_by_roundoff_in_the_position_error():
    """Leapfrog and velocity Verlet compute the same positions; the stored errors differ by 1e-17
    (a nightly's damped spring): they are one figure, and the energy error decides, said as such."""
    lf = advise("ref:leapfrog", 1.00e-6, 0.10, 0.0022627099176206504, 1, 6.23e-4)
    vv = advise("ref:velocity_verlet", 1.02e-6, 0.10, 0.00226270991762185, 1, 5.04e-4)
    for cells in ([lf, vv], [vv, lf]):
        line = next(x for x in answer_section(cells) if x.startswith("- `spring`"))
        assert "**`ref:velocity_verlet`**" in line and "the more accurate in energy (their positions alike)" in line
    same = [advise("ref:b", 1.00e-6, 0.10, 1e-3, 4, 1e-4), advise("ref:a", 1.02e-6, 0.10, 1e-3, 4, 1e-4)]
    line = next(x for x in answer_section(same) if x.startswith("- `spring`"))
    assert "**`ref:a`**" in line and "first by name among those alike in accuracy and evaluations" in line
    # Two alike, a third less accurate: the name decides between the two, and the line says so.
    three = same + [advise("ref:z", 1.01e-6, 0.10, 2e-3, 4, 1e-4)]
    line = next(x for x in answer_section(three) if x.startswith("- `spring`"))
    assert "**`ref:a`**" in line and "the more accurate" not in line and "first by name among those alike" in line
