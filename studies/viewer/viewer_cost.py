"""What one frame of the browser viewer costs a CPU control step, with headless Chromium connected to the page:

    taskset -c 0 python studies/viewer/viewer_cost.py --num_envs 64 --port 8093

Prints the mean time [ms] of a control step (flat task, zero actions) without a client, then with Chromium on the
page (moved to the cores this process is not pinned to): a drawn frame in the caller's thread (``RolloutViewer.render``), a control step, and a control step with a frame
drawn every step (the difference holds viser's server thread too). studies/viewer/report.md."""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "scripts"))


def mean_ms(fn, n: int = 20) -> float:
    t = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - t) / n * 1000.0


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--num_envs", type=int, default=64)
    p.add_argument("--port", type=int, default=8093)
    args = p.parse_args()
    import torch

    import browser_screenshot
    from hexnewton.mdp.env import make_env
    from hexnewton.physics.viewer import RolloutViewer
    from hexnewton.tasks import task

    cfg = task("flat").env
    env = make_env(dataclasses.replace(cfg, sim=dataclasses.replace(cfg.sim, num_envs=args.num_envs, device="cpu")),
                   "cpg")  # fmt: skip
    actions = torch.zeros(env.num_envs, env.num_actions)
    mean_ms(lambda: env.step(actions), 5)  # warm-up: the kernels load on the first steps
    print(f"control step, no client: {mean_ms(lambda: env.step(actions)):.1f} ms")
    view = RolloutViewer("viser", robots=3, title="cost", control_dt=cfg.task.control_dt, port=args.port)
    driver = browser_screenshot.browser()
    other = sorted(set(range(os.cpu_count() or 1)) - os.sched_getaffinity(0))
    if other:  # Chromium on the cores this process does not use (it inherited this process's)
        import subprocess

        pids = subprocess.run(["pgrep", "-f", "chrom"], capture_output=True, text=True).stdout.split()
        for pid in pids:
            subprocess.run(["taskset", "-a", "-p", "-c", ",".join(map(str, other)), pid], capture_output=True)
        print(f"Chromium ({len(pids)} processes) moved to cores {other}")
    try:
        driver.get(view.url)
        for i in range(5):
            env.step(actions)
            view.render(env.world, i * cfg.task.control_dt)
        time.sleep(15)  # the page loads and receives the scene
        print(f"one drawn frame (render): {mean_ms(lambda: view.render(env.world, 1.0)):.1f} ms")
        print(f"control step, Chromium on the page: {mean_ms(lambda: env.step(actions)):.1f} ms")
        print(f"control step + a drawn frame: {mean_ms(lambda: (env.step(actions), view.render(env.world, 1.0))):.1f} ms")
    finally:
        driver.quit()
        view.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
