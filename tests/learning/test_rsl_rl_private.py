"""rsl-rl's Logger internals that hexnewton uses (hexnewton/learning/rsl_rl_private.py) are those of the installed
rsl-rl, the pinned one: another version, a method gone or with other parameters, an attribute gone, fails here naming
it."""

import inspect
import os
import tomllib
from importlib.metadata import version

import pytest
from rsl_rl.utils.logger import Logger

from hexnewton.learning import rsl_rl_private

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def _logger() -> Logger:
    return Logger(None, {"algorithm": {}}, {}, 3, False, 1, 0, "cpu")


def test_the_pin_is_the_installed_version_and_pyprojects():
    deps = tomllib.load(open(os.path.join(ROOT, "pyproject.toml"), "rb"))["project"]["dependencies"]
    assert f"rsl-rl-lib=={rsl_rl_private.PINNED}" in deps, deps
    assert version("rsl-rl-lib") == rsl_rl_private.PINNED, (
        f"rsl-rl-lib {version('rsl-rl-lib')} is installed, hexnewton/learning/rsl_rl_private.py is checked against "
        f"{rsl_rl_private.PINNED}: check its Logger names and update PINNED")


@pytest.mark.parametrize("name", sorted(rsl_rl_private.LOGGER_METHODS))
def test_the_replaced_methods_take_the_parameters_hexnewton_passes(name):
    method = getattr(Logger, name, None)
    assert callable(method), f"rsl-rl {version('rsl-rl-lib')}'s Logger has no {name}"
    params = tuple(inspect.signature(method).parameters)[1:]
    assert params == rsl_rl_private.LOGGER_METHODS[name], f"Logger.{name}{params}: rsl_rl_private.py expects " \
                                                          f"{rsl_rl_private.LOGGER_METHODS[name]}"


def test_the_state_hexnewton_reads_is_there():
    lg = _logger()
    missing = [name for name in rsl_rl_private.LOGGER_STATE if not hasattr(lg, name)]
    assert not missing, f"rsl-rl {version('rsl-rl-lib')}'s Logger has no {missing}"
    assert lg.cur_reward_sum.shape == lg.cur_episode_length.shape == (3,)
    assert hasattr(lg.rewbuffer, "extend") and hasattr(lg.lenbuffer, "extend") and isinstance(lg.ep_extras, list)


def test_replace_a_method_on_one_instance():
    """The replacement answers on that instance only; rsl-rl's bound method comes back; another name is refused."""
    lg, other = _logger(), _logger()
    calls = []
    original = rsl_rl_private.replace_logger_method(lg, "init_logging_writer", lambda: calls.append(1))
    lg.init_logging_writer()
    assert calls == [1] and original.__self__ is lg and original.__func__ is Logger.init_logging_writer
    assert other.init_logging_writer.__func__ is Logger.init_logging_writer
    with pytest.raises(ValueError, match="not a Logger method"):
        rsl_rl_private.replace_logger_method(lg, "save", print)
    rsl_rl_private.set_git_status_repos(lg, ["/x"])
    assert lg.git_status_repos == ["/x"]
