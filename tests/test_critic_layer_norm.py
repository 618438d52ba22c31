"""``policy_kwargs={"critic_layer_norm": True}``: normalised hidden layers in the critics only."""

from __future__ import annotations

import pytest
import torch as th
from torch import nn

from sb3_comm import CommDDPG, HybridDDPG, make_comm_vec_env

SMALL = {"net_arch": [16, 16], "gsn_net_arch": [8]}


def _layer_norms(module: nn.Module) -> list[nn.LayerNorm]:
    return [m for m in module.modules() if isinstance(m, nn.LayerNorm)]


def test_only_the_critics_are_normalised_and_the_linear_layers_start_the_same() -> None:
    env = make_comm_vec_env("BlindSoccer-v0", n_envs=2, seed=0)
    plain = CommDDPG("GSN", env, seed=3, device="cpu", policy_kwargs=SMALL)
    normed = CommDDPG("GSN", env, seed=3, device="cpu", policy_kwargs={**SMALL, "critic_layer_norm": True})
    assert not _layer_norms(plain.policy)
    for name in ("critic", "critic_target"):
        assert len(_layer_norms(getattr(normed.policy, name))) == 2  # one per hidden layer
    assert not _layer_norms(normed.policy.actor) and not _layer_norms(normed.policy.gsn)
    # LayerNorm draws no random numbers: every Linear layer starts as without it
    linears = [
        [m.weight for m in p.modules() if isinstance(m, nn.Linear)] for p in (plain.policy, normed.policy)
    ]
    assert len(linears[0]) == len(linears[1])
    for a, b in zip(*linears, strict=True):
        th.testing.assert_close(a, b)

    # a normalised hidden layer: zero mean, unit variance over its units (before the affine part)
    obs = th.randn(5, 2, normed.policy.comm_layout.obs_dim)
    out = normed.policy.actor_outputs(obs).detach()
    net = normed.policy.critic[0].nets[0]
    hidden = net[1](net[0](th.cat([obs, out], dim=-1).reshape(10, -1)))
    th.testing.assert_close(hidden.mean(dim=-1), th.zeros(10), atol=1e-5, rtol=0)
    th.testing.assert_close(hidden.var(dim=-1, unbiased=False), th.ones(10), atol=1e-3, rtol=0)


def test_the_normalised_critic_trains_and_survives_save_and_load(tmp_path) -> None:
    model = HybridDDPG(
        "MlpPolicy", "HFOMoveToBall-v0", learning_starts=50, seed=0, device="cpu",
        policy_kwargs={"net_arch": [16, 16], "critic_layer_norm": True},
    )  # fmt: skip
    norm = _layer_norms(model.policy.critic)[0]
    before = norm.weight.detach().clone()
    model.learn(120)
    assert not th.equal(norm.weight.detach(), before)  # the critic's gains are trained
    model.save(tmp_path / "model")
    loaded = HybridDDPG.load(tmp_path / "model", device="cpu")
    assert loaded.policy.critic_layer_norm is True
    obs = model.replay_buffer.sample(4).observations
    out = model.policy.actor_outputs(obs).detach()
    th.testing.assert_close(loaded.policy.q_values(obs, out)[0], model.policy.q_values(obs, out)[0])


def test_a_value_that_is_not_a_flag_is_refused() -> None:
    env = make_comm_vec_env("BlindSoccer-v0", n_envs=2, seed=0)
    with pytest.raises(TypeError, match=r"critic_layer_norm.*True or False"):
        CommDDPG("GSN", env, policy_kwargs={"critic_layer_norm": "yes"})
