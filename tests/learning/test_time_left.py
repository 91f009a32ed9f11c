"""The time left that long work prints (hexnewton/learning/progress.py): the mean time per item since the first report
times the items left, at most what a time cap leaves. The formula on made-up times: no clock is read."""

import pytest

from hexnewton.learning.progress import TimeLeft, clock, time_left


def test_the_mean_time_per_item_times_the_items_left():
    assert time_left(0, 100, 5.0) is None  # nothing ended yet: no estimate
    assert time_left(10, 100, 20.0) == pytest.approx(180.0)  # 2 s per item, 90 left
    assert time_left(100, 100, 200.0) == 0.0 and time_left(120, 100, 200.0) == 0.0


def test_the_first_reports_one_time_costs_are_left_out_once_a_later_report_gives_a_rate():
    # the first iteration took 11 s (kernels compiled, graphs captured), the next nine 1 s each
    assert time_left(10, 100, 20.0, first=(1, 11.0)) == pytest.approx(90.0)
    assert time_left(1, 100, 11.0, first=(1, 11.0)) == pytest.approx(99 * 11.0)  # the first alone: its own rate
    # the baselines report every 4 vector steps: the rate since the first report
    assert time_left(12, 96, 7.0, first=(4, 3.0)) == pytest.approx(84 * 0.5)


def test_a_time_cap_bounds_the_time_left():
    assert time_left(10, 1500, 60.0, cap=420.0) == pytest.approx(360.0)  # 1490 x 6 s, but the cap in 6 min
    assert time_left(10, 20, 60.0, cap=420.0) == pytest.approx(60.0)  # the iterations end first
    assert time_left(10, 1500, 500.0, cap=420.0) == 0.0


def test_time_left_reported_as_items_end_on_a_made_up_clock():
    now = [100.0]
    left = TimeLeft(100, now=lambda: now[0])
    assert left.seconds() is None and left.text() == ""
    now[0] = 111.0
    assert left.update(1) == pytest.approx(99 * 11.0) and left.first == (1, 11.0)
    now[0] = 120.0
    assert left.update(10) == pytest.approx(90.0) and left.text() == "0:01:30 left"
    assert left.elapsed() == pytest.approx(20.0) and left.text(lambda s: f"{s:.0f} s") == "90 s left"
    capped = TimeLeft(1500, cap=420.0, now=lambda: now[0])
    now[0] += 60.0
    capped.update(10)
    assert capped.capped() and capped.text() == "0:06:00 left (time cap)"
    left.start()
    assert left.done == 0 and left.first is None and left.seconds() is None


def test_clock_reads_as_hours_minutes_seconds():
    assert (clock(0), clock(59.6), clock(3725)) == ("0:00:00", "0:01:00", "1:02:05")


def test_the_iteration_line_ends_with_the_time_left():
    from hexnewton.learning.runner import progress_line

    stats = {"success_rate": 0.5, "fell_rate": 0.1, "off_course_rate": 0.0, "distance_m": 1.0, "episodes": 3}
    line = progress_line({"it": 9, "total_it": 300, "start_it": 0}, stats, 65.0, left="0:30:00 left")
    assert line.endswith("s/it  0:01:05  0:30:00 left"), line
    assert progress_line({"it": 0, "total_it": 300}, stats, 1.0).endswith("0:00:01")  # no estimate yet: nothing
