"""Long work's progress (hexnewton/analysis/rollout.py): plain lines with the time left where no terminal shows a
bar (validation in a training log, evaluation and sweeps)."""

import re

from hexnewton.analysis.rollout import duration, progress_lines


def test_progress_lines_say_how_far_and_at_most_how_long(capsys):
    assert list(progress_lines(range(50), "validation")) == list(range(50))
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 9  # a line at each tenth but the last
    assert lines[0].startswith("validation: 5 of 50 control steps, ") and lines[-1].startswith("validation: 45 of 50")
    assert all(re.search(r", \d+ s, at most \d+ s left$", line) for line in lines), lines


def test_progress_lines_of_a_short_run_print_once_per_step_at_most(capsys):
    list(progress_lines(range(3), "x"))
    assert len(capsys.readouterr().out.strip().splitlines()) <= 3


def test_durations_read_as_seconds_minutes_hours():
    assert (duration(45), duration(360), duration(5400)) == ("45 s", "6 min", "1.5 h")
