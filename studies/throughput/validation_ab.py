"""The end-of-training validation's seconds, its courses one env after another against side by side in one env
(``AgentConfig.validation_together``), in one process on one GPU, with train.py's validation of the complex recipe:
4 candidates, 256 rounds each per course, the rugged, stepped and complex courses, at most 3000 control steps.

    python studies/throughput/validation_ab.py --out DIR [--device cuda]   # measure and report
    python studies/throughput/validation_ab.py --rebuild DIR       # DIR/raw.json -> report.md, results.json

Every candidate is the same checkpoint (the shipped complex policy by default): what is timed is the validation, and
each course's shares are then one policy's on 1024 rounds, those of the courses one by one against side by side (other
rounds: each course its own lane group with its own block seed). A short warm-up validation loads the Warp modules
first; then, in turn, one by one, side by side, one by one, side by side (``--repeats`` 2). Writes DIR/raw.json,
DIR/report.md and DIR/results.json.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time

MODES = ("one_by_one", "side_by_side")
COURSES = ("rugged", "stepped", "complex")


def measure(args) -> dict:
    from hexnewton.analysis.report import git_rev
    from hexnewton.analysis.validation import Candidate, combine_courses, validate_share

    cands = [Candidate(i, args.checkpoint, "the same checkpoint") for i in range(args.candidates)]
    validate_share(cands[:1], "cpg_rl", list(COURSES[:1]), 4, args.device, 5)  # Warp modules loaded, not timed
    runs = []
    for _ in range(args.repeats):
        for mode in MODES:
            t0 = time.perf_counter()
            got = validate_share(cands, "cpg_rl", list(COURSES), args.rounds, args.device, args.steps,
                                 together=mode == "side_by_side")  # fmt: skip
            seconds = time.perf_counter() - t0
            _, per = combine_courses(cands, list(COURSES), got)
            runs.append({"mode": mode, "seconds": seconds, "courses": {
                c: {k: statistics.fmean(r[k] for r in rs) for k in ("goal", "fell_before_goal", "fell", "walk_3m")}
                for c, rs in per.items()}})  # fmt: skip
            print(f"{mode}: {seconds:.1f} s", flush=True)
    import torch

    gpu = torch.cuda.get_device_name() if args.device.startswith("cuda") else "cpu"
    return {"device": gpu, "revision": git_rev(), "checkpoint": args.checkpoint, "candidates": args.candidates,
            "rounds": args.rounds, "steps": args.steps, "command": " ".join(["python", *sys.argv]), "runs": runs}


def summarize(raw: dict) -> dict:
    """Each mode's seconds (every run and the mean) and the policy's shares per course (the mean over its runs: the
    rounds are the same in every run of a mode)."""
    out = {}
    for mode in MODES:
        runs = [r for r in raw["runs"] if r["mode"] == mode]
        secs = [r["seconds"] for r in runs]
        out[mode] = {"seconds": secs, "mean_s": statistics.fmean(secs) if secs else None,
                     "courses": runs[0]["courses"] if runs else {}}  # fmt: skip
    one, side = out["one_by_one"]["mean_s"], out["side_by_side"]["mean_s"]
    saved = one - side if one is not None and side is not None else None
    return {"device": raw["device"], "revision": raw["revision"], "command": raw["command"], "modes": out,
            "saved_s": saved}


def report(raw: dict, res: dict) -> str:
    lines = ["# Validation: the courses one by one against side by side in one env", "",
             f"`{res['command']}` ({res['device']}, code {res['revision']}): {raw['candidates']} candidates (each "
             f"`{raw['checkpoint']}`), {raw['rounds']} rounds each per course, at most {raw['steps']} control steps, "
             "the runs in the order shown, one process, alone on the GPU. Numbers: results.json.", "",
             "| run | mode | seconds |", "|---|---|---:|"]
    lines += [f"| {i + 1} | {r['mode'].replace('_', ' ')} | {r['seconds']:.1f} |" for i, r in enumerate(raw["runs"])]
    m = res["modes"]
    lines += ["", f"Mean: one by one {m['one_by_one']['mean_s']:.1f} s, side by side {m['side_by_side']['mean_s']:.1f} "
              f"s ({-res['saved_s']:+.1f} s).", "",
              "The policy's shares on each mode's rounds (its candidates' mean; other rounds side by side):", "",
              "| course | goal one by one | side by side | fell before the goal one by one | side by side |",
              "|---|---:|---:|---:|---:|"]  # fmt: skip
    for c in COURSES:
        a, b = m["one_by_one"]["courses"].get(c), m["side_by_side"]["courses"].get(c)
        if a and b:
            lines.append(f"| {c} | {100 * a['goal']:.1f} % | {100 * b['goal']:.1f} % | "
                         f"{100 * a['fell_before_goal']:.1f} % | {100 * b['fell_before_goal']:.1f} % |")
    return "\n".join(lines) + "\n"


def write(folder: str, raw: dict) -> None:
    res = summarize(raw)
    with open(os.path.join(folder, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
    with open(os.path.join(folder, "report.md"), "w") as f:
        f.write(report(raw, res))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", help="folder for raw.json, report.md, results.json")
    p.add_argument("--rebuild", help="a folder whose raw.json to report again")
    p.add_argument("--device", default="cuda")
    p.add_argument("--checkpoint", default="results/policies/cpg_rl_complex.pt")
    p.add_argument("--candidates", type=int, default=4)
    p.add_argument("--rounds", type=int, default=256)
    p.add_argument("--steps", type=int, default=3000)
    p.add_argument("--repeats", type=int, default=2)
    args = p.parse_args(argv)
    if args.rebuild:
        path = os.path.join(args.rebuild, "raw.json")
        if not os.path.exists(path):
            print(f"validation_ab.py: no {path}", file=sys.stderr)
            return 2
        with open(path) as f:
            write(args.rebuild, json.load(f))
        return 0
    if not args.out:
        print("validation_ab.py: --out DIR or --rebuild DIR", file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    raw = measure(args)
    with open(os.path.join(args.out, "raw.json"), "w") as f:
        json.dump(raw, f, indent=1)
    write(args.out, raw)
    return 0


if __name__ == "__main__":
    sys.exit(main())
