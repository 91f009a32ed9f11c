"""Fixtures of the deployment tests: a robot file some of whose joints turn the other way (the MX-Phoenix's MJCF with
their axes reversed) and its bundle, exported from the shipped flat policy by ``hexnewton.apps.export``."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
POLICY = os.path.join(ROOT, "results", "policies", "cpg_rl_flat.pt")
#: the MX-Phoenix MJCF's joints the flipped file turns round: hips, knees and ankles of both sides (the file's left
#: knees and ankles turn the other way already: lf_femur comes back to hexnewton's sense)
FLIPPED = ("rf_coxa", "rm_femur", "rr_tibia", "lf_femur", "lr_coxa")


def flip_joints(src: str, out: str, names=FLIPPED) -> str:
    """The MJCF file ``src`` with the hinge joints ``names`` turned round, written to ``out``: each axis reversed, its
    range and the keyframes' angles negated, so that it is the same robot whose joints ``names`` count their angles
    the other way."""
    root = ET.parse(src).getroot()
    hinges = list(root.iter("joint"))  # the free joint is a <freejoint>
    for j in hinges:
        if j.get("name") in names:
            j.set("axis", " ".join(f"{-float(v):.12g}" for v in j.get("axis", "0 0 1").split()))
            lo, hi = (float(v) for v in j.get("range").split())
            j.set("range", f"{-hi:.12g} {-lo:.12g}")
    for key in root.iter("key"):
        qpos = key.get("qpos").split()
        for k, j in enumerate(hinges):
            if j.get("name") in names:
                qpos[7 + k] = f"{-float(qpos[7 + k]):.12g}"
        key.set("qpos", " ".join(qpos))
    ET.ElementTree(root).write(out)
    return out


@pytest.fixture(scope="session")
def flipped_names() -> tuple[str, ...]:
    """The joints the flipped file turns round (:data:`FLIPPED`)."""
    return FLIPPED


@pytest.fixture(scope="session")
def flipped_mjcf(tmp_path_factory) -> str:
    """The MX-Phoenix MJCF with the joints :data:`FLIPPED` turned round."""
    from hexnewton.robot.mx_phoenix import MJCF

    return flip_joints(MJCF, str(tmp_path_factory.mktemp("flipped") / "flipped.xml"))


@pytest.fixture(scope="session")
def flipped_bundle(tmp_path_factory, flipped_mjcf) -> str:
    """The shipped flat policy's checkpoint given the flipped file's robot (``with_robot``), exported as a bundle
    (``--robot`` the file)."""
    import torch

    from hexnewton.config import config_from_dict
    from hexnewton.robot.loader import load_robot
    from hexnewton.robot.registry import with_robot

    folder = tmp_path_factory.mktemp("flipped_bundle")
    ck = torch.load(POLICY, map_location="cpu", weights_only=False)
    cfg = with_robot(config_from_dict(ck["infos"]["hexnewton"]["config"]), load_robot(flipped_mjcf))
    ck["infos"]["hexnewton"]["config"] = dataclasses.asdict(cfg)
    torch.save(ck, folder / "flipped.pt")
    out = str(folder / "bundle")
    proc = subprocess.run([sys.executable, "-m", "hexnewton.apps.export", "--checkpoint", str(folder / "flipped.pt"),
                           "--out", out, "--steps", "10", "--robots", "1", "--robot", flipped_mjcf],
                          capture_output=True, text=True, timeout=900, cwd=ROOT)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out
