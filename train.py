"""Entry point: ``python train.py --num_envs N`` (see hexnewton/train.py)."""

import sys

from hexnewton.cli import run
from hexnewton.train import main

if __name__ == "__main__":
    sys.exit(run(main, "python train.py"))
