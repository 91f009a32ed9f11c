"""Episode status codes (§2.4.4): 0 running, else why the episode ended. Defined with the episode's other rules in
``hexnewton/deploy/rules.py`` (NumPy only, so that command lines, reports, the robot runtime and C MuJoCo's closed loop
read them without loading Warp); ``mdp/terms/terminations.py``'s ``TERMINATIONS`` gives each code after 0 its Warp
condition and writes them. ``STATUS_NAMES[code]`` is the name (``Episode/<name>_rate`` in the training log)."""

from hexnewton.deploy.rules import FELL, NONFINITE, OFF_COURSE, RUNNING, STATUS_NAMES, SUCCESS, TIMEOUT

__all__ = ["FELL", "NONFINITE", "OFF_COURSE", "RUNNING", "STATUS_NAMES", "SUCCESS", "TIMEOUT"]
