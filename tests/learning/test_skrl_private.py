"""skrl's private names the baselines use (hexnewton/learning/baselines/skrl_private.py) are those of the installed
skrl, the pinned series: another version, a name gone or with another signature, fails here naming it."""

import importlib
import inspect
import os
import tomllib

import pytest

from hexnewton.learning.baselines import skrl_private

skrl = pytest.importorskip("skrl")
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def test_the_pin_is_the_installed_series_and_pyprojects():
    extras = tomllib.load(open(os.path.join(ROOT, "pyproject.toml"), "rb"))["project"]["optional-dependencies"]
    assert f"skrl=={skrl_private.PINNED}.*" in extras["baselines"], extras["baselines"]
    assert skrl.__version__.startswith(skrl_private.PINNED + "."), (
        f"skrl {skrl.__version__} is installed, hexnewton/learning/baselines/skrl_private.py is checked against "
        f"{skrl_private.PINNED}.*: check its names and update PINNED")


def test_get_internal_value_is_a_modules_state_dict():
    import torch
    from skrl.agents.torch import Agent

    method = getattr(Agent, skrl_private.INTERNAL_VALUE, None)
    assert callable(method), f"skrl {skrl.__version__}'s Agent has no {skrl_private.INTERNAL_VALUE}"
    assert list(inspect.signature(method).parameters) == ["self", "_module"]
    layer = torch.nn.Linear(2, 1)
    agent = type("A", (), {skrl_private.INTERNAL_VALUE: method})()
    state = skrl_private.module_state(agent, layer)
    assert set(state) == {"weight", "bias"} and skrl_private.module_state(agent, 3) == 3


@pytest.mark.parametrize("module, name", skrl_private.AGENTS)
def test_the_agents_set_their_observation_preprocessor(module, name):
    """SAC's, TD3's and A2C's ``__init__`` set the normaliser (the scaler, or skrl's identity) and ``act`` reads it."""
    cls = getattr(importlib.import_module(module), name)
    init, act = inspect.getsource(cls.__init__), inspect.getsource(cls.act)
    attr = skrl_private.PREPROCESSOR
    assert f"self.{attr} = self.cfg.observation_preprocessor(" in init and f"self.{attr} = self._empty_preprocessor" \
        in init, f"skrl {skrl.__version__}'s {name}.__init__ no longer sets {attr}"  # fmt: skip
    assert f"self.{attr}(" in act, f"skrl {skrl.__version__}'s {name}.act no longer reads {attr}"
