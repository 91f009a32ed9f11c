"""The weight average of a run's checkpoints (``--agent.validation_average``): every float tensor of the actor and
the critic averaged, the normalisers' std from their averaged variance, counts and metadata from the last."""

import pytest
import torch

from hexnewton.learning.agent import AgentConfig
from hexnewton.learning.checkpoint import average_checkpoints


def _ckpt(seed: int, it: int) -> dict:
    g = torch.Generator().manual_seed(seed)

    def net(out: int) -> dict:
        var = torch.rand((1, 5), generator=g) + 0.1
        return {"obs_normalizer._mean": torch.randn((1, 5), generator=g), "obs_normalizer._var": var,
                "obs_normalizer._std": var.sqrt(), "obs_normalizer.count": torch.tensor(100 * it),
                "mlp.0.weight": torch.randn((out, 5), generator=g), "mlp.0.bias": torch.randn(out, generator=g)}

    return {"actor_state_dict": net(4), "critic_state_dict": net(1), "optimizer_state_dict": {"it": it}, "iter": it,
            "infos": {"hexnewton": {"task": "complex", "iter": it}}}


def test_average_of_checkpoints(tmp_path):
    paths = []
    for k, it in enumerate((200, 250, 299)):
        paths.append(str(tmp_path / f"model_{it}.pt"))
        torch.save(_ckpt(k, it), paths[-1])
    out = average_checkpoints(paths, str(tmp_path / "model_average.pt"))
    avg = torch.load(out, weights_only=False)
    ckpts = [torch.load(p, weights_only=False) for p in paths]
    for key in ("actor_state_dict", "critic_state_dict"):
        for name in ("obs_normalizer._mean", "obs_normalizer._var", "mlp.0.weight", "mlp.0.bias"):
            ref = sum(c[key][name].double() for c in ckpts) / 3  # float64 reference
            assert torch.allclose(avg[key][name].double(), ref, atol=1e-6), (key, name)
        assert torch.allclose(avg[key]["obs_normalizer._std"], avg[key]["obs_normalizer._var"].sqrt())
        assert int(avg[key]["obs_normalizer.count"]) == 29900
    assert avg["iter"] == 299 and avg["infos"] == ckpts[-1]["infos"] and avg["optimizer_state_dict"] == {"it": 299}


def test_average_refuses_one_checkpoint_and_other_runs(tmp_path):
    a, b = str(tmp_path / "a.pt"), str(tmp_path / "b.pt")
    torch.save(_ckpt(0, 1), a)
    with pytest.raises(ValueError, match="two checkpoints or more"):
        average_checkpoints([a], str(tmp_path / "x.pt"))
    other = _ckpt(1, 2)
    other["actor_state_dict"]["mlp.0.weight"] = torch.zeros((3, 5))
    torch.save(other, b)
    with pytest.raises(ValueError, match="differs in shape"):
        average_checkpoints([a, b], str(tmp_path / "x.pt"))


def test_the_switch_is_off_by_default():
    assert AgentConfig().validation_average is False


def test_policy_only_keeps_what_evaluation_loads(tmp_path):
    """A study keeps a result's policy without its training state: the actor, iteration and metadata of an rsl-rl
    checkpoint, the policy and normaliser of a skrl baseline's; anything else is one clear error."""
    from hexnewton.learning.checkpoint import load_checkpoint, policy_only, save_policy_only

    src, dst = str(tmp_path / "model_299.pt"), str(tmp_path / "policy.pt")
    torch.save(_ckpt(0, 299), src)
    save_policy_only(src, dst)
    kept = load_checkpoint(dst)
    assert sorted(kept) == ["actor_state_dict", "infos", "iter"] and kept["iter"] == 299
    assert torch.equal(kept["actor_state_dict"]["mlp.0.weight"], _ckpt(0, 299)["actor_state_dict"]["mlp.0.weight"])
    skrl = {"format": "hexnewton-skrl-1", "modules": {"policy": {"w": torch.ones(1)}, "value": {}, "optimizer": {}}}
    assert sorted(policy_only(skrl)["modules"]) == ["policy"] and policy_only(skrl)["format"] == "hexnewton-skrl-1"
    with pytest.raises(ValueError, match="not a training checkpoint"):
        policy_only({"x": 1})
