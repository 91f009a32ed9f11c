"""Compile, on a machine without a GPU, the CUDA kernels that the GPU runs will need.

A fresh GPU machine compiles Warp modules for minutes before its first iteration. Warp's NVRTC works without a CUDA
driver, and a module's cache name does not depend on the machine, so this script runs the same code paths on the CPU
(training, the fixed-CPG rollout, the benchmark's sim-only loop), then compiles every module that was loaded for
`--arch` (default 90: H100, H200), skipping those already there:

    python scripts/precompile.py --ship                    # hexnewton/physics/aot/warp-<version>-sm90.tar.xz
    python scripts/precompile.py --ship --add DIR_OR_TGZ   # first merge a GPU machine's Warp cache into it
    python scripts/precompile.py --cache runs/warpcache.tgz    # a kernel-cache archive to unpack by hand

`--ship` updates the archive the package carries (hexnewton.physics.precompile.install_shipped_modules puts its
modules into Warp's cache on each GPU start): module folders with only their `.meta` and cubin, older versions of
hexnewton's own import-time modules dropped. Modules that the GPU path alone uses (some of mujoco_warp's generated
kernels, Newton's narrow phase at its block sizes) come from a GPU machine's cache (`--add`: a folder such as
`~/.cache/warp/1.19.0` or a `.tgz` of it). After a change to a kernel of hexnewton's, `--ship` alone brings the
archive up to date (tests/physics/test_shipped_modules.py says when it is not).
"""

from __future__ import annotations

import argparse
import pathlib
import re
import shutil
import tarfile
import tempfile
import time


def exercise(workdir: pathlib.Path) -> None:
    """Run, tiny and on the CPU, every code path the GPU scripts use, so that their modules load."""
    from hexnewton.apps import bench, play, train

    log = workdir / "logs"
    for extra in (["--task", "complex", "--env.terrain.levels", "3"], ["--task", "complex-margin"],
                  ["--task", "complex-joint"], ["--task", "navigate-flat"]):  # fmt: skip
        train.main(["--num_envs", "4", "--max_iterations", "1", "--log_dir", str(log), "--experiment", "pre",
                    "--device", "cpu", "--agent.validation_rounds", "2", "--agent.validation_steps", "5", *extra])
    play.main(["--controller", "cpg", "--num_envs", "2", "--steps", "3", "--terrain", "rugged", "--device", "cpu",
               "--no-progress"])
    bench.main(["--device", "cpu", "--num_envs", "2", "--terrain", "flat", "--frames", "2", "--env_steps", "2",
                "--train_iterations", "1"])


def cuda_files(folder: pathlib.Path, arch: int) -> list[pathlib.Path]:
    """A module folder's files that a GPU of ``arch`` loads: its ``.meta`` and its cubin (none if either is missing)."""
    meta = sorted(folder.glob("*.meta"))
    cubin = sorted(folder.glob(f"*.sm{arch}.cubin"))
    return meta + cubin if meta and cubin else []


def add_modules(src: pathlib.Path, dest: pathlib.Path, arch: int) -> int:
    """Copy into ``dest`` the module folders of the Warp cache ``src`` (a folder, or a ``.tgz`` holding one) that hold a
    cubin for ``arch`` and that ``dest`` lacks, their ``.meta`` and cubin only; returns how many."""
    with tempfile.TemporaryDirectory() as tmp:
        if src.is_file():
            with tarfile.open(src) as tar:
                tar.extractall(tmp, filter="data")
            metas = list(pathlib.Path(tmp).rglob("*.meta"))
        else:
            metas = list(src.glob("*/*.meta"))
        added = 0
        for folder in sorted({m.parent for m in metas}):
            files = cuda_files(folder, arch)
            if not files or (dest / folder.name).exists():
                continue
            (dest / folder.name).mkdir(parents=True)
            for f in files:
                shutil.copy2(f, dest / folder.name / f.name)
            added += 1
    return added


def drop_older_own(dest: pathlib.Path, current: set[str]) -> list[str]:
    """Remove the folders of hexnewton's import-time modules (``wp_hexnewton.<module>_<hash>``) other than the current
    version of each (``current``: folder names); generated kernels keep every variant. Returns the removed names."""
    own = re.compile(r"^(wp_hexnewton\.[\w.]+)_[0-9a-f]{7}$")
    now = {own.match(n).group(1) for n in current if own.match(n)}
    removed = []
    for folder in sorted(dest.iterdir()):
        m = own.match(folder.name)
        if m and m.group(1) in now and folder.name not in current:
            shutil.rmtree(folder)
            removed.append(folder.name)
    return removed


def _normalized(info: tarfile.TarInfo) -> tarfile.TarInfo:
    """Archive members without their build's times and owners: the same modules give the same archive."""
    info.mtime, info.uid, info.gid, info.uname, info.gname = 0, 0, 0, "", ""
    return info


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    to = p.add_mutually_exclusive_group(required=True)
    to.add_argument("--ship", action="store_true", help="update the archive hexnewton/physics/aot/ carries")
    to.add_argument("--cache", type=pathlib.Path, help="warpcache.tgz to extend (created if missing)")
    p.add_argument("--add", type=pathlib.Path, nargs="+", default=[], help="GPU machines' Warp caches to merge first")
    p.add_argument("--arch", type=int, default=90)
    args = p.parse_args()

    import warp as wp

    from hexnewton.physics.precompile import SHIPPED_DIR, shipped_archive_name

    wp.init()
    archive = SHIPPED_DIR / shipped_archive_name(args.arch) if args.ship else args.cache
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        cache = tmp / "modules" if args.ship else tmp / "warp" / wp.__version__
        cache.mkdir(parents=True, exist_ok=True)
        if archive.exists():
            with tarfile.open(archive) as tar:
                tar.extractall(cache if args.ship else tmp, filter="data")
        for src in args.add:
            print(f"added {add_modules(src, cache, args.arch)} modules of {src}", flush=True)
        exercise(tmp / "work")

        from warp._src.context import user_modules

        done, current, t0 = 0, set(), time.time()
        for module in list(user_modules.values()):
            if not module.execs:        # never loaded by the paths above
                continue
            ident = module.get_module_identifier(block_dim=module.options["block_dim"])
            current.add(ident)
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
        if not args.ship:
            with tarfile.open(archive, "w:gz") as tar:
                tar.add(tmp / "warp", arcname="warp")
            return 0
        for name in drop_older_own(cache, current):
            print(f"dropped {name} (an older version)")
        for folder in list(cache.iterdir()):  # what compile_aot_module writes beside the cubin
            keep = cuda_files(folder, args.arch)
            for f in folder.iterdir():
                if f not in keep:
                    f.unlink()
            if not keep:
                folder.rmdir()
        archive.parent.mkdir(parents=True, exist_ok=True)
        with tarfile.open(archive, "w:xz") as tar:
            for folder in sorted(cache.iterdir()):
                tar.add(folder, arcname=folder.name, filter=_normalized)
        print(f"{archive}: {sum(1 for _ in cache.iterdir())} modules, {archive.stat().st_size / 1e6:.1f} MB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
