"""Episode status codes (§2.4.4): 0 running, else why the episode ended. ``mdp/terms/terminations.py``'s
``TERMINATIONS`` gives each code after 0 its condition and writes them; plain Python, so that command lines, reports
and C MuJoCo's closed loop read them without loading Warp. ``STATUS_NAMES[code]`` is the name
(``Episode/<name>_rate`` in the training log)."""

RUNNING, FELL, OFF_COURSE, SUCCESS, TIMEOUT, NONFINITE = 0, 1, 2, 3, 4, 5
STATUS_NAMES = ("running", "fell", "off_course", "success", "timeout", "nonfinite")
