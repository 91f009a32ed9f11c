"""The command lines' output checks (``hexnewton.apps.cli``)."""

import os

import pytest

from hexnewton.apps.cli import check_new_dir


def test_new_dir_may_have_missing_parents(tmp_path):
    """``evaluate``'s default ``eval/<date_time>`` is made with ``eval/`` on a fresh clone."""
    check_new_dir(os.path.join(tmp_path, "eval", "2026-01-01_00-00-00"))


def test_existing_dir_is_refused(tmp_path):
    with pytest.raises(ValueError, match="exists"):
        check_new_dir(str(tmp_path))
