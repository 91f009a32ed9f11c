"""CPU sim-only throughput per candidate: hexnewton.analysis.bench.bench_one with the candidate's SimConfig
(so rigid_gap works too). 16 envs, flat + complex, best of `reps` runs.

    python studies/physics_screen/bench_cpu.py A B C ... [--json out]
"""
import json
import sys
import warnings
from dataclasses import replace

from hexnewton.analysis.bench import bench_one
from hexnewton.config import SimConfig

sys.path.insert(0, "studies/physics_screen")
from candidates import CANDIDATES  # noqa: E402

args = sys.argv[1:]
out = None
if "--json" in args:
    i = args.index("--json"); out = args[i + 1]; del args[i:i + 2]  # noqa: E702
reps, sim_seconds = 3, 3.0
res = {}
for name in args:
    sim = replace(SimConfig(), **CANDIDATES[name])
    frames = int(round(sim_seconds / sim.frame_dt))
    row = {}
    for terrain in ("flat", "complex"):
        runs = []
        for _ in range(reps):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                r = bench_one(terrain, 16, "cpu", frames, sim)
            runs.append(r)
        best = max(runs, key=lambda r: r.robot_s_per_s)
        row[terrain] = dict(robot_s_per_s=best.robot_s_per_s, all=[r.robot_s_per_s for r in runs],
                            overflow=best.overflow, not_converged_worlds=best.not_converged_worlds,
                            forward=best.mean_forward_m, upright=best.upright_frac)
    res[name] = row
    print(f"{name:4s} {CANDIDATES[name]}  flat {row['flat']['robot_s_per_s']:.1f} {['%.1f' % x for x in row['flat']['all']]} "
          f"ovf={row['flat']['overflow']}  complex {row['complex']['robot_s_per_s']:.1f} "
          f"{['%.1f' % x for x in row['complex']['all']]} ovf={row['complex']['overflow'][:60]}", flush=True)
    if out:
        json.dump(res, open(out, "w"), indent=1)
