"""Where the rounds of a policy end that do not reach the goal: each such round's ending, step and position
(relative to its start), and whether it had walked 3 m. A fall at x ~ 5 m is a fall off the course patch's far end
(``TerrainConfig.x_max``), 1.5 m past a goal it passed without reaching it.

    python studies/time_to_skill/fall_positions.py --checkpoint CKPT --terrain rugged --rounds 256 --seed 3000 --device cpu
"""

import argparse
import os
import time

from hexnewton.analysis.metrics import round_metrics
from hexnewton.analysis.rollout import run_rounds
from hexnewton.mdp.status import STATUS_NAMES


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--checkpoint", required=True, help="a learnt CPG policy (cpg_rl)")
    p.add_argument("--terrain", default="rugged")
    p.add_argument("--rounds", type=int, default=256)
    p.add_argument("--seed", type=int, default=3000, help="terrain seed (validation rounds: 3000)")
    p.add_argument("--device", default="cpu")
    a = p.parse_args()
    if not os.path.isfile(a.checkpoint):
        p.error(f"no checkpoint {a.checkpoint}")
    t0 = time.time()
    ep = run_rounds("cpg_rl", a.checkpoint, a.terrain, a.rounds, a.device, 7000, progress=False, seed=a.seed)
    m = round_metrics(ep.pos, ep.rpy, ep.done, ep.status, ep.dt)
    last = m["steps"] - 1
    for i in range(a.rounds):
        if STATUS_NAMES[m["end"][i]] != "success":
            x, y = ep.pos[last[i], i, 0], ep.pos[last[i], i, 1]
            print(f"round {i}: {STATUS_NAMES[m['end'][i]]} at step {last[i]} x {x:.2f} y {y:.2f} "
                  f"walked3m {bool(m['reached'][-1][i])}", flush=True)
    ended = {STATUS_NAMES[c]: int((m["end"] == c).sum()) for c in range(len(STATUS_NAMES))}
    print("ended", ended, f"{time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
