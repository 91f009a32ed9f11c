"""The curriculum study's arms: how the robots meet the complex recipe's terrain curriculum (their train.py flags).

    python studies/curriculum/arms.py --flags anchor     # one arm's flags (queue.sh reads them here)
"""

from __future__ import annotations

import argparse
import sys

#: arm -> (train.py flags beside ``--task complex --seed N``, what it changes)
ARMS = {
    "recipe": ("", "the complex recipe: robots start on lanes 0-2 of 10, one lane up per goal reached"),
    "anchor": ("--env.terrain.start_levels 6 --env.terrain.climb 2",
               "start and promotion nearer the anchors' (legged_gym, Isaac Lab, mjlab start on lanes 0-5): "
               "robots start on lanes 0-5, two lanes up per goal reached"),
    "spread": ("--env.terrain.start_progress 2.0",
               "more, shorter episodes: each training episode starts 0-2 m along its lane (uniform), toward the same "
               "goal, so the stairs and the far blocks come sooner and more often"),
    "both": ("--env.terrain.start_levels 6 --env.terrain.climb 2 --env.terrain.start_progress 2.0",
             "anchor and spread together"),
}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, allow_abbrev=False)
    p.add_argument("--flags", metavar="ARM", help="print an arm's train.py flags")
    a = p.parse_args(argv)
    if a.flags is not None:
        if a.flags not in ARMS:
            print(f"arms.py: no arm '{a.flags}': choose among {', '.join(ARMS)}", file=sys.stderr)
            return 2
        print(ARMS[a.flags][0])
        return 0
    for arm, (flags, what) in ARMS.items():
        print(f"{arm}: {what} ({flags or 'no flags'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
