"""Entry point: ``python train.py --num_envs N`` (see hexnewton/apps/train.py)."""

import sys

from hexnewton.apps.cli import run
from hexnewton.apps.train import main

if __name__ == "__main__":
    sys.exit(run(main, "python train.py"))
