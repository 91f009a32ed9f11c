"""Entry point: ``python play.py --controller cpg --terrain flat`` (see hexnewton/play.py)."""

import sys

from hexnewton.cli import run
from hexnewton.play import main

if __name__ == "__main__":
    sys.exit(run(main, "python play.py"))
