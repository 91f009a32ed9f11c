"""How long long work has left, for its console lines: training iterations (:mod:`hexnewton.learning.runner`), the
skrl baselines' vector steps (:mod:`hexnewton.learning.baselines.trainer`) and the points of ``evaluate --sweep``
(:mod:`hexnewton.apps.evaluate`). Plain Python: no torch, no Warp.

The estimate is the mean time per item since the first report times the items left. The items up to the first report
carry the one-time costs (kernels compiled, a course built, CUDA graphs captured, a replay buffer filled), so the rate
leaves them out once a later report gives one; until then the first report's own rate stands. A time cap
(``--agent.max_minutes``, the baselines' ``--max_minutes``) ends the work sooner when it comes first.
"""

from __future__ import annotations

import datetime
import time


def time_left(done: int, total: int, elapsed: float, first: tuple[int, float] | None = None,
              cap: float | None = None) -> float | None:
    """Seconds left of ``total`` like items when ``done`` of them took ``elapsed`` seconds: the mean time per item
    since ``first`` (the first report: items done, seconds) times the items left, or the mean over all ``done`` items
    while no item ended after ``first``; at most what the cap leaves (``cap``: seconds from the same start). None
    before an item has ended."""
    if done <= 0 or elapsed < 0:
        return None
    left = max(total - done, 0)
    if first is not None and done > first[0] and elapsed > first[1]:
        per_item = (elapsed - first[1]) / (done - first[0])
    else:
        per_item = elapsed / done
    seconds = per_item * left
    if cap is not None:
        seconds = min(seconds, max(cap - elapsed, 0.0))
    return seconds


def clock(seconds: float) -> str:
    """``0:04:10``: whole seconds as hours, minutes and seconds."""
    return str(datetime.timedelta(seconds=int(round(seconds))))


class TimeLeft:
    """The time left of ``total`` items, reported as they end: :meth:`seconds` after :meth:`update` with the items
    done so far (its clock starts at construction, or at :meth:`start`). ``cap``: a time cap's seconds from the
    start, or None."""

    def __init__(self, total: int, cap: float | None = None, now=time.monotonic):
        self.total, self.cap, self._now = total, cap, now
        self.start()

    def start(self) -> None:
        """The clock from now; no item done yet."""
        self.t0, self.done, self.first = self._now(), 0, None

    def update(self, done: int) -> float | None:
        """``done`` items have ended (counted from the start); returns :meth:`seconds`."""
        self.done = done
        if self.first is None and done > 0:
            self.first = (done, self.elapsed())
        return self.seconds()

    def elapsed(self) -> float:
        return self._now() - self.t0

    def seconds(self) -> float | None:
        """:func:`time_left` of the items done so far."""
        return time_left(self.done, self.total, self.elapsed(), self.first, self.cap)

    def capped(self) -> bool:
        """Whether the time cap, not the items left, bounds :meth:`seconds`."""
        left = time_left(self.done, self.total, self.elapsed(), self.first)
        return self.cap is not None and left is not None and left > self.cap - self.elapsed()

    def text(self, fmt=clock) -> str:
        """``0:04:10 left``, ``0:02:00 left (time cap)`` (``fmt`` writes the seconds); '' before an item has ended."""
        seconds = self.seconds()
        if seconds is None:
            return ""
        return f"{fmt(seconds)} left" + (" (time cap)" if self.capped() else "")
