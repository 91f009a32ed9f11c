"""The modules compiled ahead of time (hexnewton/physics/aot/): installing an archive into Warp's cache, and the shipped
archive holding the current version of every module of hexnewton's that the complex task's step loads (after a kernel
change: ``python scripts/precompile.py --ship``)."""

import dataclasses
import io
import os
import tarfile

import pytest

from hexnewton.physics.precompile import SHIPPED_DIR, install_shipped_modules, shipped_archive, shipped_archive_name


def _archive(path, modules):
    with tarfile.open(path, "w:xz") as tar:
        for name, files in modules.items():
            for fname, data in files.items():
                info = tarfile.TarInfo(f"{name}/{fname}")
                info.size = len(data)
                tar.addfile(info, io.BytesIO(data))


def test_install_copies_what_the_cache_lacks(tmp_path):
    archive = tmp_path / "a.tar.xz"
    _archive(archive, {"wp_a_1234567": {"wp_a_1234567.meta": b"{}", "wp_a_1234567.sm90.cubin": b"x" * 10},
                       "wp_b_89abcde": {"wp_b_89abcde.meta": b"{}", "wp_b_89abcde.sm90.cubin": b"y"}})  # fmt: skip
    cache = tmp_path / "cache"
    (cache / "wp_b_89abcde").mkdir(parents=True)
    (cache / "wp_b_89abcde" / "own").write_text("kept")
    assert install_shipped_modules("cpu", archive, str(cache)) == 1
    assert (cache / "wp_a_1234567" / "wp_a_1234567.sm90.cubin").read_bytes() == b"x" * 10
    assert os.listdir(cache / "wp_b_89abcde") == ["own"]  # a module Warp has is left as it is
    assert not [n for n in os.listdir(cache) if n.startswith(".hexnewton-") and (cache / n).is_dir()]  # no leftovers
    (cache / "wp_a_1234567" / "wp_a_1234567.sm90.cubin").unlink()
    assert install_shipped_modules("cpu", archive, str(cache)) == 0  # installed once: the marker skips it
    _archive(archive, {"wp_c_0000000": {"wp_c_0000000.meta": b"{}", "wp_c_0000000.sm90.cubin": b"z"}})
    assert install_shipped_modules("cpu", archive, str(cache)) == 1  # another archive's content


def test_no_archive_on_the_cpu():
    assert shipped_archive("cpu") is None


def test_the_shipped_archive_is_current():
    """Every module of hexnewton's that the complex task's env loads (its import-time modules and the generated reward
    and status kernels) is in the sm_90 archive under its current name (the name holds the hash of its source)."""
    import torch
    from warp._src.context import user_modules

    from hexnewton.mdp.env import make_env
    from hexnewton.tasks import task

    archive = SHIPPED_DIR / shipped_archive_name(90)
    assert archive.is_file(), f"{archive} is missing: python scripts/precompile.py --ship"
    with tarfile.open(archive) as tar:
        shipped = {m.name.split("/", 1)[0] for m in tar.getmembers()}
    t = task("complex")
    cfg = dataclasses.replace(t.env, sim=dataclasses.replace(t.env.sim, num_envs=2, device="cpu"),
                              terrain=dataclasses.replace(t.env.terrain, rugged_half_width=0.3))
    # generated kernels of other tests' configs may be loaded in this process already: only this env's count
    before = {id(m) for m in list(user_modules.values())}
    env = make_env(cfg, t.action_mode)
    env.step(torch.zeros(2, env.num_actions))
    own = [m for m in list(user_modules.values()) if m.execs and m.name.startswith("hexnewton.")]
    generated = [m for m in list(user_modules.values()) if m.execs and id(m) not in before
                 and ("rewards_kernel" in m.name or "status_kernel" in m.name)]  # fmt: skip
    assert len(own) >= 5
    stale = [m.get_module_identifier(block_dim=m.options["block_dim"]) for m in own + generated]
    stale = [ident for ident in stale if ident not in shipped]
    if stale:
        pytest.fail(f"the shipped modules lack {', '.join(stale)}: python scripts/precompile.py --ship")
