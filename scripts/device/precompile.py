"""Compile, on a machine without a GPU, the CUDA (sm_90) kernels that the GPU runs will need.

A cold start on the GPU machine compiles Warp modules for ~4 minutes of device time. Warp's NVRTC works
without a CUDA driver, and a module's cache name does not depend on the machine, so this script runs the
same code paths on the CPU (training, the fixed-CPG rollout, the benchmark's sim-only loop), then compiles
every module that was loaded for `--arch` into a Warp kernel-cache folder, skipping those already in it:

    git show device-cache:warpcache.tgz > runs/warpcache.tgz
    python scripts/device/precompile.py --cache runs/warpcache.tgz      # rewrites the archive in place

Carry the archive to the device machine and unpack it into /root/.cache (scripts/device/README.md). Modules
that the GPU path alone uses (some of mujoco_warp's) still compile there; the archive keeps them once a GPU
run has written its cache back.
"""

from __future__ import annotations

import argparse
import pathlib
import shutil
import tarfile
import tempfile
import time


def exercise(workdir: pathlib.Path) -> None:
    """Run, tiny and on the CPU, every code path the GPU scripts use, so that their modules load."""
    from hexnewton.apps import bench, play, train

    log = workdir / "logs"
    for extra in (["--task", "complex", "--env.terrain.levels", "3"], ["--task", "complex-joint"]):
        train.main(["--num_envs", "4", "--max_iterations", "1", "--log_dir", str(log), "--experiment", "pre",
                    "--device", "cpu", "--agent.validation_rounds", "2", "--agent.validation_steps", "5", *extra])
    play.main(["--controller", "cpg", "--num_envs", "2", "--steps", "3", "--terrain", "rugged", "--device", "cpu",
               "--no-progress"])
    bench.main(["--device", "cpu", "--num_envs", "2", "--terrain", "flat", "--frames", "2", "--env_steps", "2",
                "--train_iterations", "1"])


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cache", type=pathlib.Path, required=True, help="warpcache.tgz to extend (created if missing)")
    p.add_argument("--arch", type=int, default=90)
    args = p.parse_args()

    import warp as wp

    wp.init()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        if args.cache.exists():
            with tarfile.open(args.cache) as tar:
                tar.extractall(tmp, filter="data")
        cache = tmp / "warp" / wp.__version__
        cache.mkdir(parents=True, exist_ok=True)
        exercise(tmp / "work")

        from warp._src.context import user_modules

        done, t0 = 0, time.time()
        for module in list(user_modules.values()):
            if not module.execs:        # never loaded by the paths above
                continue
            ident = module.get_module_identifier(block_dim=module.options["block_dim"])
            if (cache / ident).exists():
                continue
            t1 = time.time()
            try:
                wp.compile_aot_module(module, arch=args.arch, module_dir=cache / ident)
            except RuntimeError as exc:  # a module of generic kernels only: nothing of its own to compile
                print(f"skipped {ident}: {exc}", flush=True)
                continue
            done += 1
            print(f"compiled {ident} for sm_{args.arch} in {time.time() - t1:.1f} s", flush=True)
        print(f"{done} modules compiled in {time.time() - t0:.0f} s")
        shutil.rmtree(tmp / "work")
        with tarfile.open(args.cache, "w:gz") as tar:
            tar.add(tmp / "warp", arcname="warp")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
