"""The studies' kept checkpoints: policies that a device queue or a documented command evaluates again, held in git
history rather than in the tracked tree (each ~0.9 MB; the tree a device call carries stays small).

    python studies/house/kept.py                         # each kept file: where it is read, whether it is here
    python studies/house/kept.py fetch                   # all of them from git history into the tree
    python studies/house/kept.py fetch studies/learner   # those under a folder (or one file's path)

:data:`MANIFEST` (``kept.json``) names each file, the commit that holds it, its size and SHA-256 and what reads it.
``fetch`` writes the commit's blob to the file's own path (git ignores it there: ``/studies/**/*.pt``), checks the
size and hash, and leaves a file that is already there and matches alone. A clone without that commit (``git clone
--depth 1``) says so in one line: ``git fetch --unshallow`` brings it. ``rechunk.sh`` carries the kept files that
are here to the device in its last call (``present``: their paths, one a line).
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
MANIFEST = os.path.join(HERE, "kept.json")


def manifest() -> dict:
    """{path (from the repository root): {"commit", "bytes", "sha256", "read_by"}}."""
    with open(MANIFEST) as f:
        return json.load(f)["files"]


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def matches(path: str, entry: dict) -> bool:
    """Whether ``path`` (from the root) is here with the entry's size and hash."""
    full = os.path.join(ROOT, path)
    if not os.path.isfile(full) or os.path.getsize(full) != entry["bytes"]:
        return False
    with open(full, "rb") as f:
        return sha256(f.read()) == entry["sha256"]


def blob(path: str, entry: dict) -> bytes:
    """The file's bytes at its commit, checked against the entry; ValueError (one line) when git has no such blob."""
    done = subprocess.run(["git", "cat-file", "blob", f"{entry['commit']}:{path}"], cwd=ROOT, capture_output=True)
    if done.returncode != 0:
        shallow = subprocess.run(["git", "rev-parse", "--is-shallow-repository"], cwd=ROOT, capture_output=True,
                                 text=True).stdout.strip() == "true"  # fmt: skip
        hint = "this clone is shallow: git fetch --unshallow" if shallow else "git fetch origin main"
        raise ValueError(f"{path}: git has no {entry['commit'][:10]}:{path} here ({hint})")
    data = done.stdout
    if len(data) != entry["bytes"] or sha256(data) != entry["sha256"]:
        raise ValueError(f"{path}: {entry['commit'][:10]}:{path} is not the kept file (size or SHA-256 differ)")
    return data


def selected(files: dict, wanted: list[str]) -> list[str]:
    """The manifest's paths under each of ``wanted`` (a folder or a file, from the root); all when none."""
    if not wanted:
        return sorted(files)
    picked = []
    for w in wanted:
        w = os.path.relpath(os.path.abspath(w), ROOT).rstrip("/")
        under = [p for p in files if p == w or p.startswith(w + "/")]
        if not under:
            raise ValueError(f"{w}: no kept file there (python studies/house/kept.py lists them)")
        picked += [p for p in under if p not in picked]
    return sorted(picked)


def fetch(wanted: list[str]) -> list[str]:
    """Write each selected file from git history (those here and matching stay); the lines to print."""
    files = manifest()
    lines = []
    for path in selected(files, wanted):
        entry = files[path]
        if matches(path, entry):
            lines.append(f"{path}: here")
            continue
        data = blob(path, entry)
        full = os.path.join(ROOT, path)
        os.makedirs(os.path.dirname(full), exist_ok=True)
        tmp = full + ".part"
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, full)
        lines.append(f"{path}: fetched from {entry['commit'][:10]} ({entry['bytes'] / 1e6:.1f} MB)")
    return lines


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    try:
        files = manifest()
        if not argv or argv[0] in ("list", "present"):
            here = [p for p in sorted(files) if matches(p, files[p])]
            if argv and argv[0] == "present":
                print("\n".join(here))
                return 0
            for p in sorted(files):
                print(f"{p}: {'here' if p in here else 'in git history'} ({files[p]['commit'][:10]}); "
                      f"read by {files[p]['read_by']}")  # fmt: skip
            return 0
        if argv[0] != "fetch":
            raise ValueError(f"{argv[0]}: not a command (list, fetch [PATH ...], present)")
        print("\n".join(fetch(argv[1:])))
        return 0
    except ValueError as e:
        print(f"kept.py: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
