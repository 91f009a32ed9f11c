"""A directory given as a checkpoint (``play.py --checkpoint DIR``, ``evaluate --checkpoint cpg_rl=DIR``, ``export
--checkpoint DIR``, ``train.py --resume DIR``) is no checkpoint; one line says what it is, what is expected, and the
newest run's result it holds (a run's folder, an experiment's, a --log_dir), exit status 2, before anything is built."""

import os
import subprocess
import sys

import pytest

from hexnewton.apps.cli import check_checkpoint_file

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def _run(tmp_path, name: str, files: tuple[str, ...]) -> str:
    run_dir = tmp_path / "logs" / "hexnewton_flat" / name
    run_dir.mkdir(parents=True)
    for f in files:
        (run_dir / f).write_bytes(b"")
    return str(run_dir)


def test_a_directory_names_its_newest_checkpoint(tmp_path):
    old = _run(tmp_path, "2026-01-01_00-00-00", ("model_0.pt", "model_50.pt", "model_best.pt", "model_result.pt"))
    new = _run(tmp_path, "2026-01-02_00-00-00", ("model_0.pt", "model_50.pt", "model_299.pt", "model_100.pt"))
    for path, newest in ((old, os.path.join(old, "model_result.pt")), (new, os.path.join(new, "model_299.pt")),
                         (os.path.dirname(new), os.path.join(new, "model_299.pt")),
                         (str(tmp_path / "logs"), os.path.join(new, "model_299.pt"))):
        with pytest.raises(ValueError) as exc:
            check_checkpoint_file(path)
        assert str(exc.value) == (f"--checkpoint {path} is a directory: expected a checkpoint file (.pt, a run's "
                                  f"model_<iteration>.pt or model_result.pt); the newest there: --checkpoint {newest}")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match=r"is a directory: expected a checkpoint file .*\(it holds no model_\*\.pt\)"):
        check_checkpoint_file(str(tmp_path / "empty"))
    check_checkpoint_file(str(tmp_path / "missing.pt"))  # not a directory: the reader's own error follows


def test_play_given_a_directory_is_one_line_and_exit_2(tmp_path):
    run_dir = _run(tmp_path, "2026-01-01_00-00-00", ("model_0.pt", "model_1.pt"))
    proc = subprocess.run([sys.executable, "play.py", "--checkpoint", run_dir, "--device", "cpu"], capture_output=True,
                          text=True, cwd=ROOT, timeout=300)  # fmt: skip
    assert proc.returncode == 2 and proc.stdout == "", proc.stdout
    assert proc.stderr == (f"python play.py: error: --checkpoint {run_dir} is a directory: expected a checkpoint file "
                           f"(.pt, a run's model_<iteration>.pt or model_result.pt); the newest there: --checkpoint "
                           f"{os.path.join(run_dir, 'model_1.pt')}\n"), proc.stderr


EXPECTED = "is a directory: expected a checkpoint file (.pt, a run's model_<iteration>.pt or model_result.pt)"


@pytest.mark.parametrize("argv, flag", [
    (["-m", "hexnewton.apps.evaluate", "--controllers", "cpg_rl", "--checkpoint", "cpg_rl={}"], "--checkpoint cpg_rl="),
    (["-m", "hexnewton.apps.evaluate", "--terrains", "rugged", "--checkpoint", "cpg_rl:rugged={}"],
     "--checkpoint cpg_rl:rugged="),
    (["-m", "hexnewton.apps.export", "--checkpoint", "{}", "--out", "never_made"], "--checkpoint "),
    (["train.py", "--resume", "{}", "--device", "cpu"], "--resume "),
])  # fmt: skip
def test_evaluate_export_and_resume_given_a_directory_are_one_line_and_exit_2(tmp_path, argv, flag):
    run_dir = _run(tmp_path, "2026-01-01_00-00-00", ("model_0.pt", "model_best.pt"))
    argv = [os.path.join(ROOT, a) if a == "train.py" else a.format(run_dir) for a in argv]
    proc = subprocess.run([sys.executable, *argv], capture_output=True, text=True, cwd=tmp_path, timeout=300,
                          env=dict(os.environ, PYTHONPATH=ROOT))  # fmt: skip
    prog = "python train.py" if argv[0].endswith("train.py") else f"python -m {argv[1]}"
    assert proc.returncode == 2 and proc.stdout == "", proc.stdout
    assert proc.stderr == (f"{prog}: error: {flag}{run_dir} {EXPECTED}; the newest there: {flag}"
                           f"{os.path.join(run_dir, 'model_best.pt')}\n"), proc.stderr
    assert not (tmp_path / "never_made").exists()


def test_an_empty_directory_says_it_holds_no_checkpoint(tmp_path):
    (tmp_path / "empty").mkdir()
    proc = subprocess.run([sys.executable, "-m", "hexnewton.apps.evaluate", "--checkpoint", f"cpg_rl={tmp_path}/empty"],
                          capture_output=True, text=True, cwd=tmp_path, timeout=300,
                          env=dict(os.environ, PYTHONPATH=ROOT))  # fmt: skip
    assert proc.returncode == 2 and proc.stderr == (f"python -m hexnewton.apps.evaluate: error: --checkpoint "
                                                    f"cpg_rl={tmp_path}/empty {EXPECTED} (it holds no model_*.pt)\n")
