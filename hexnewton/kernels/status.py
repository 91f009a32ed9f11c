"""Episode status codes (``kernels/terminations.py`` writes them, §2.4.4); plain Python, so that command lines and
reports use them without loading Warp. ``terminations.TERMINATIONS`` gives each code after 0 its condition, one row
per code; ``STATUS_NAMES[code]`` is its name (``Episode/<name>_rate`` in the training log)."""

RUNNING, FELL, OFF_COURSE, SUCCESS, TIMEOUT, NONFINITE = 0, 1, 2, 3, 4, 5
STATUS_NAMES = ("running", "fell", "off_course", "success", "timeout", "nonfinite")
