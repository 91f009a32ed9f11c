"""Episode status codes (``kernels/terminations.py`` writes them, §2.4.4); plain Python, so that command lines and
reports use them without loading Warp."""

RUNNING, FELL, OFF_COURSE, SUCCESS, TIMEOUT, NONFINITE = 0, 1, 2, 3, 4, 5
STATUS_NAMES = ("running", "fell", "off_course", "success", "timeout", "nonfinite")
