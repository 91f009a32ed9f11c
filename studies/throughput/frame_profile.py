"""Where a control step's GPU time goes: a task's env stepped uncaptured (``sim.use_graph false``) under Warp's CUDA
activity timing (``wp.timing_begin``), every kernel's time summed by the part of the stack that launched it, and the
step's phases (``HexapodEnv._control_step``'s calls) timed with CUDA events.

    python studies/throughput/frame_profile.py --task complex --num_envs 16384 --out studies/throughput/profile

writes ``report.md`` and ``results.json`` in ``--out``. Kernel times are GPU time; without the graph the host's
launches also cost wall time, which the report gives beside them (a captured graph does not pay it)."""

from __future__ import annotations

import argparse
import gc
import json
import os
import re
import sys
import time
from collections import defaultdict
from dataclasses import replace

#: the part of the stack a kernel's module belongs to, first match wins
PARTS = (("collision (Newton)", r"^newton\._src\.(geometry|sim\.collide|collision)"),
         ("solver (MuJoCo-Warp)", r"^mujoco_warp"),
         ("solver glue (Newton's MuJoCo solver)", r"^newton\._src\.solvers"),
         ("Newton (other)", r"^newton"),
         # the physics level's own kernels (hexnewton.kernels, .physics, .terrain; the
         # label stays as the committed results.json name it)
         ("CPG and mapping (hexnewton.physics)", r"^hexnewton\.(kernels|physics|terrain|robot)"),
         ("MDP terms (hexnewton.mdp)", r"^hexnewton\.mdp"),
         ("hexnewton (other)", r"^hexnewton"),
         ("Warp built-ins", r"^warp"))  # fmt: skip
#: HexapodEnv._control_step's calls, in its order
PHASES = ("_delay_and_push", "_apply_actions", "_simulate", "_end_episodes", "_pay_rewards", "_switch_goals",
          "_count_episodes", "_keep_last_state", "_change_lanes", "_reset", "_observe")  # fmt: skip


def part_of(module: str) -> str:
    for name, pattern in PARTS:
        if re.match(pattern, module):
            return name
    return "other"


def kernel_modules() -> dict[str, str]:
    """Each loaded Warp kernel's key -> its module's name (kernels built by factories included: every live
    ``wp.Kernel``), from the Python module that defines its function (a kernel in a ``module="unique"`` Warp module
    has a hashed module name)."""
    import warp as wp

    return {k.key: getattr(k.func, "__module__", None) or k.module.name for k in gc.get_objects()
            if issubclass(type(k), wp.Kernel)}  # type(): no attribute lookup on other objects (torch's lazy ones)


def kernel_key(activity: str) -> str:
    """``forward kernel NAME_HASH`` (wp.timing_end's name of a launch) -> NAME."""
    name = activity.removeprefix("forward kernel ").removeprefix("backward kernel ")
    return re.sub(r"_[0-9a-f]{8}$", "", name)


def timed_phases(env, events: dict):
    """Wrap the env's phase methods so that each records a CUDA event before and after it (no sync)."""
    import warp as wp

    for name in PHASES:
        method = getattr(env, name)

        def wrapped(*a, _m=method, _n=name, **k):
            start, end = wp.Event(enable_timing=True), wp.Event(enable_timing=True)
            wp.record_event(start)
            out = _m(*a, **k)
            wp.record_event(end)
            events[_n].append((start, end))
            return out

        setattr(env, name, wrapped)


def profile(task_name: str, num_envs: int, steps: int, warmup: int, seed: int) -> dict:
    import torch
    import warp as wp

    from hexnewton.mdp.env import make_env
    from hexnewton.tasks import task

    t = task(task_name)
    cfg = replace(t.env, sim=replace(t.env.sim, num_envs=num_envs, device="cuda", use_graph=False))
    env = make_env(cfg, t.action_mode)
    gen = torch.Generator(device=env.device_torch).manual_seed(seed)
    actions = torch.rand((8, num_envs, env.num_actions), generator=gen, device=env.device_torch) * 2 - 1
    env.reset()
    for k in range(warmup):  # loads every module, fills the contact buffers
        env.step(actions[k % 8])
    wp.synchronize()
    t0 = time.perf_counter()  # the uncaptured step's wall time, without the profiler
    for k in range(steps):
        env.step(actions[k % 8])
    wp.synchronize()
    wall_ms = (time.perf_counter() - t0) / steps * 1e3
    events: dict[str, list] = defaultdict(list)
    timed_phases(env, events)
    wp.timing_begin(cuda_filter=wp.TIMING_KERNEL | wp.TIMING_KERNEL_BUILTIN | wp.TIMING_MEMCPY | wp.TIMING_MEMSET)
    for k in range(steps):
        env.step(actions[k % 8])
    activities = wp.timing_end()
    phases = {n: sum(wp.get_event_elapsed_time(a, b) for a, b in events[n]) / steps for n in PHASES}
    modules = kernel_modules()
    kernels: dict[str, dict] = {}
    for r in activities:
        if r.filter == wp.TIMING_KERNEL:
            key = kernel_key(r.name)
            part = part_of(modules.get(key, "?"))
        else:
            key = r.name
            part = "Warp built-ins" if r.filter == wp.TIMING_KERNEL_BUILTIN else "copies and memsets"
        row = kernels.setdefault(key, {"kernel": key, "module": modules.get(key, ""), "part": part, "ms": 0.0,
                                       "launches": 0})  # fmt: skip
        row["ms"] += r.elapsed
        row["launches"] += 1
    for row in kernels.values():
        row["ms_per_step"] = row.pop("ms") / steps
        row["launches_per_step"] = row.pop("launches") / steps
    gpu_ms = sum(r["ms_per_step"] for r in kernels.values())
    parts: dict[str, float] = defaultdict(float)
    for r in kernels.values():
        parts[r["part"]] += r["ms_per_step"]
    report = env.world.check_contacts()
    return {"task": task_name, "num_envs": num_envs, "steps": steps, "warmup": warmup,
            "frames_per_step": env.decimation, "control_dt": cfg.task.control_dt, "substeps": cfg.sim.substeps,
            "device": wp.get_device().name,
            "wall_ms_per_step_uncaptured": wall_ms, "gpu_ms_per_step": gpu_ms,
            "launches_per_step": sum(r["launches_per_step"] for r in kernels.values()),
            "parts_ms_per_step": dict(sorted(parts.items(), key=lambda kv: -kv[1])),
            "phases_ms_per_step": phases, "overflow": str(report),
            "kernels": sorted(kernels.values(), key=lambda r: -r["ms_per_step"])}  # fmt: skip


def markdown(r: dict, command: str, git: str) -> str:
    gpu = r["gpu_ms_per_step"]
    lines = [f"# Where a control step's GPU time goes: task {r['task']}, {r['num_envs']} envs, {r['device']}", "",
             f"- command: `{command}` (git {git})",
             f"- {r['steps']} profiled steps after {r['warmup']} warm-up steps; {r['frames_per_step']} physics frames "
             f"per step, {r['substeps']} substeps each; {r['launches_per_step']:.0f} launches per step",
             f"- GPU time per step (sum of its kernels, copies and memsets): {gpu:.2f} ms; wall time per step "
             f"uncaptured (no profiler): {r['wall_ms_per_step_uncaptured']:.2f} ms; the GPU time alone would give "
             f"{r['num_envs'] * r['control_dt'] / gpu * 1e3:,.0f} robot-s/s",
             f"- contacts after the profiled steps: {r['overflow']}", "",
             "## By part of the stack", "", "| part | ms per step | share |", "|---|---:|---:|"]  # fmt: skip
    lines += [f"| {p} | {ms:.3f} | {ms / gpu:.1%} |" for p, ms in r["parts_ms_per_step"].items()]
    total = sum(r["phases_ms_per_step"].values())
    lines += ["", "## By phase of the control step", "",
              "CUDA events around `HexapodEnv._control_step`'s calls: the stream's time from a phase's first launch to "
              "its last kernel's end, so it includes the GPU's waits for the host's uncaptured launches.", "",
              "| phase | ms per step | share |", "|---|---:|---:|"]  # fmt: skip
    lines += [f"| `{p}` | {ms:.3f} | {ms / total:.1%} |" for p, ms in r["phases_ms_per_step"].items()]
    lines += ["", "## The 30 costliest kernels", "",
              "| kernel | module | part | launches per step | ms per step | share |",
              "|---|---|---|---:|---:|---:|"]  # fmt: skip
    lines += [f"| `{k['kernel']}` | {k['module']} | {k['part']} | {k['launches_per_step']:.0f} | "
              f"{k['ms_per_step']:.3f} "
              f"| {k['ms_per_step'] / gpu:.1%} |" for k in r["kernels"][:30]]  # fmt: skip
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--task", default="complex")
    p.add_argument("--num_envs", type=int, default=16384)
    p.add_argument("--steps", type=int, default=20, help="profiled control steps")
    p.add_argument("--warmup", type=int, default=20)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "profile"))
    p.add_argument("--rebuild", metavar="DIR", help="rewrite DIR/report.md from DIR/results.json (no GPU)")
    args = p.parse_args(argv)
    if args.rebuild:
        try:
            with open(os.path.join(args.rebuild, "results.json")) as f:
                r = json.load(f)
        except (OSError, ValueError) as exc:
            print(f"frame_profile.py: --rebuild {args.rebuild}: {exc}", file=sys.stderr)
            return 2
        with open(os.path.join(args.rebuild, "report.md"), "w") as f:
            f.write(markdown(r, r["command"], r["git"]))
        return 0
    import warp as wp

    if not wp.is_cuda_available():
        print("frame_profile.py: needs a CUDA GPU (Warp's activity timing is CUDA's)", file=sys.stderr)
        return 2
    from hexnewton.analysis.report import git_rev

    r = profile(args.task, args.num_envs, args.steps, args.warmup, args.seed)
    command = "python studies/throughput/frame_profile.py " + " ".join(sys.argv[1:] if argv is None else argv)
    git = git_rev()
    md = markdown(r, command, git)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump({"command": command, "git": git, **r}, f, indent=1)
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(md)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
