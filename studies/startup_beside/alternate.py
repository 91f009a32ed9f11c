"""What this study's A/Bs share: runs in fresh processes, one mode after the other, alternating, on this machine's CPU
or GPU, kept as results.json and rendered as report.md (scene_first.py, preload.py)."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from typing import Callable


def machine(device: str) -> str:
    """The CPU cores and, on a GPU, its name (nvidia-smi)."""
    if device.startswith("cuda"):
        done = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True,
                              text=True)  # fmt: skip
        if done.returncode == 0:
            return f"{os.cpu_count()} CPU cores, {done.stdout.strip().splitlines()[0]}"
    return f"{os.cpu_count()} CPU cores"


def per_mode(res: dict, key: str, modes) -> dict[str, tuple[float, float, float]] | None:
    """Each mode's mean, least and most of its runs' ``key``, in the order of ``modes``; None while a mode has no
    run."""
    values = {m: [r[key] for r in res["runs"] if r["mode"] == m] for m in modes}
    if not all(values.values()):
        return None
    return {m: (sum(v) / len(v), min(v), max(v)) for m, v in values.items()}


def warmup_note(res: dict, key: str, what: str) -> list[str]:
    """The report's lines on the warm-up runs (``--warmup``), their ``key`` beside: none where there were none."""
    runs = res.get("warmup") or []
    if not runs:
        return []
    return [f"Before them {len(runs)} warm-up run(s) of `{runs[0]['mode']}`, kept apart and out of the means "
            f"(results.json `warmup`): {what} " + ", ".join(f"{r[key]:.1f}" for r in runs) + " s.", ""]


def main(script: str, doc: str, modes, measure: Callable[[str, int, str], dict], report: Callable[[dict], str],
         argv: list[str] | None = None) -> None:
    """The command line of ``script``: ``--runs`` per mode of ``modes``, alternating, each ``measure(mode,
    num_envs, device)``, into ``--out`` (results.json, report.md); or ``--rebuild DIR``: report.md again."""
    p = argparse.ArgumentParser(description=doc.splitlines()[0])
    p.add_argument("--runs", type=int, default=2, help="runs per mode, alternating")
    p.add_argument("--warmup", type=int, default=0,
                   help="runs of the first mode before them, kept apart (results.json 'warmup'), not in the means")
    p.add_argument("--num_envs", type=int, default=4096)
    p.add_argument("--device", default="cpu")
    p.add_argument("--out", help="folder for results.json and report.md")
    p.add_argument("--rebuild", metavar="DIR", help="report.md again from DIR/results.json")
    a = p.parse_args(argv)
    if a.rebuild:
        with open(os.path.join(a.rebuild, "results.json")) as f:
            res = json.load(f)
    else:
        if not a.out or a.runs < 1:
            p.error("--out DIR and --runs >= 1 are needed")
        args = sys.argv[1:] if argv is None else argv
        res = {"command": f"python studies/startup_beside/{script} " + " ".join(args), "machine": machine(a.device),
               "num_envs": a.num_envs, "device": a.device, "warmup": [], "runs": []}  # fmt: skip
        for _ in range(a.warmup):  # a fresh machine's first process pays for its caches: not either mode's cost
            res["warmup"].append(measure(next(iter(modes)), a.num_envs, a.device))
            print(json.dumps(res["warmup"][-1]), flush=True)
        for _ in range(a.runs):
            for mode in modes:
                res["runs"].append(measure(mode, a.num_envs, a.device))
                print(json.dumps(res["runs"][-1]), flush=True)
        os.makedirs(a.out, exist_ok=True)
        with open(os.path.join(a.out, "results.json"), "w") as f:
            json.dump(res, f, indent=1)
    with open(os.path.join(a.rebuild or a.out, "report.md"), "w") as f:
        f.write(report(res))
