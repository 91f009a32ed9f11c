"""Every use of rsl-rl's ``Logger`` internals that hexnewton makes, in one place: rsl-rl has no hook per env step or
per iteration, so the runner (``runner.py``: the console line, the writer's start) and the deferred episode
bookkeeping (``episode_log.py``) replace methods of the runner's ``Logger`` instance and read its buffers.
``tests/learning/test_rsl_rl_private.py`` checks them against the pinned rsl-rl (:data:`PINNED`, pyproject's pin) and
fails, naming what moved, when another version changes one of them.

- :data:`LOGGER_METHODS`: the methods replaced on an instance (:func:`replace_logger_method`), with the parameters
  the replacements take and pass on;
- :data:`LOGGER_STATE`: the attributes read or written (the episode buffers and running sums ``process_env_step``
  keeps, the writer, the repositories whose git status a run records)."""

from __future__ import annotations

from typing import Callable

#: the rsl-rl-lib version whose Logger these names are (pyproject.toml's ``rsl-rl-lib==``)
PINNED = "5.5.1"
#: Logger methods hexnewton replaces on an instance -> the parameters (after ``self``) the replacements rely on
LOGGER_METHODS = {
    "process_env_step": ("rewards", "dones", "extras", "intrinsic_rewards"),
    "log": ("it", "start_it", "total_it", "collect_time", "learn_time", "loss_dict", "learning_rate", "action_std",
            "rnd_weight", "print_minimal", "width", "pad"),
    "init_logging_writer": (),
}  # fmt: skip
#: Logger attributes hexnewton reads or writes
LOGGER_STATE = ("writer", "ep_extras", "rewbuffer", "lenbuffer", "cur_reward_sum", "cur_episode_length",
                "git_status_repos")  # fmt: skip


def replace_logger_method(logger, name: str, replacement: Callable) -> Callable:
    """``logger.<name>`` (one of :data:`LOGGER_METHODS`) replaced by ``replacement`` on this instance; returns rsl-rl's
    bound method, which the replacement calls on."""
    if name not in LOGGER_METHODS:
        raise ValueError(f"{name!r} is not a Logger method hexnewton replaces ({', '.join(LOGGER_METHODS)})")
    original = getattr(logger, name)
    setattr(logger, name, replacement)
    return original


def set_git_status_repos(logger, paths: list[str]) -> None:
    """The repositories whose commit and diff the run's git/ folder records (rsl-rl's default: its own)."""
    logger.git_status_repos = list(paths)
