"""The kept checkpoints: each is out of the tracked tree, git ignores it where fetch writes it, git history holds it
with the manifest's size and hash (skipped in a clone without that commit), and bad input is one line, exit 2."""

import importlib.util
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)
HERE = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location("house_kept", os.path.join(HERE, "kept.py"))
kept = importlib.util.module_from_spec(spec)
spec.loader.exec_module(kept)


def _git(*args):
    return subprocess.run(["git", *args], cwd=kept.ROOT, capture_output=True, text=True)


def test_kept_files_are_untracked_and_ignored():
    files = kept.manifest()
    assert len(files) == 7 and all(p.startswith("studies/") and p.endswith(".pt") for p in files)
    assert _git("ls-files", "--", *files).stdout == ""
    assert sorted(_git("check-ignore", "--no-index", *files).stdout.split()) == sorted(files)


def test_git_history_holds_each_kept_file():
    files = kept.manifest()
    commits = {e["commit"] for e in files.values()}
    if any(_git("cat-file", "-e", f"{c}^{{commit}}").returncode for c in commits):
        pytest.skip("this clone lacks the kept files' commit (a shallow clone)")
    for path, entry in files.items():
        data = kept.blob(path, entry)
        assert len(data) == entry["bytes"] and kept.sha256(data) == entry["sha256"]
        assert data[:2] == b"PK"  # a torch checkpoint (a zip file)


def test_selection_and_bad_input():
    files = kept.manifest()
    assert kept.selected(files, []) == sorted(files)
    learner = kept.selected(files, [os.path.join(kept.ROOT, "studies", "learner")])
    assert learner == [f"studies/learner/runs/gate_s{i}/policy.pt" for i in (1, 2, 3)]
    for argv, message in ((["fetch", "studies/fig1"], "studies/fig1: no kept file there"),
                          (["bogus"], "bogus: not a command")):  # fmt: skip
        done = subprocess.run([sys.executable, os.path.join(HERE, "kept.py"), *argv], cwd=kept.ROOT,
                              capture_output=True, text=True)  # fmt: skip
        err = done.stderr.strip().splitlines()
        assert done.returncode == 2 and len(err) == 1 and message in err[0], done.stderr
    entry = dict(next(iter(files.values())), commit="0" * 40)
    with pytest.raises(ValueError, match="git has no 0000000000"):
        kept.blob("studies/x.pt", entry)
