"""Every private name of skrl that the baselines use, in one place: skrl 2.1 has no public way to run an agent's
observation normaliser outside its ``act`` (whose TD3 adds exploration noise) or to read a module's state as its
checkpoints store it. ``tests/learning/test_skrl_private.py`` checks them against the pinned skrl (:data:`PINNED`,
pyproject's ``skrl==2.1.*``) and fails, naming what moved, when another version changes one of them.

- ``Agent._observation_preprocessor``: the agent's observation normaliser (a ``RunningStandardScaler``, or skrl's
  identity without ``observation_preprocessor``), set by SAC's, TD3's and A2C's ``__init__``
  (:func:`preprocess_observations`);
- ``Agent._get_internal_value(module)``: a module's ``state_dict()`` (the value itself for a plain variable), what
  skrl's own checkpoints store per ``checkpoint_modules`` entry (:func:`module_state`).

No import of skrl here: the functions take an agent that exists."""

from __future__ import annotations

#: the skrl version series these names are from (pyproject.toml's ``skrl==2.1.*``)
PINNED = "2.1"
#: the agents whose ``__init__`` sets :data:`PREPROCESSOR` (module, class)
AGENTS = (("skrl.agents.torch.sac", "SAC"), ("skrl.agents.torch.td3", "TD3"), ("skrl.agents.torch.a2c", "A2C"))
PREPROCESSOR = "_observation_preprocessor"
INTERNAL_VALUE = "_get_internal_value"


def preprocess_observations(agent, observations):
    """``observations`` through the agent's observation normaliser (evaluation mode: its statistics unchanged)."""
    return getattr(agent, PREPROCESSOR)(observations)


def module_state(agent, module):
    """What skrl's checkpoints store for ``module`` (a ``checkpoint_modules`` value): its state dict, or the value."""
    return getattr(agent, INTERNAL_VALUE)(module)
