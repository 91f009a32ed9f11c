"""Fixtures shared by the test files: one short CPU training run of the flat task (train.py, 2 iterations),
made once by each pytest worker."""

import subprocess
import sys

import pytest


@pytest.fixture(scope="session")
def trained(tmp_path_factory):
    logs = tmp_path_factory.mktemp("logs")
    proc = subprocess.run(
        [sys.executable, "train.py", "--num_envs", "16", "--max_iterations", "2", "--device", "cpu", "--log_dir",
         str(logs), "--task", "flat", "--headless", "--agent.validation_rounds", "4", "--agent.validation_steps", "30",
         "--agent.validation_average", "true"],
        capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return logs, proc.stdout
