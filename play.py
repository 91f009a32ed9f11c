"""Entry point: ``python play.py --controller cpg --terrain flat`` (see hexnewton/apps/play.py)."""

import sys

from hexnewton.apps.cli import run
from hexnewton.apps.play import main

if __name__ == "__main__":
    sys.exit(run(main, "python play.py"))
