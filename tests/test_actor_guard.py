"""``policy_kwargs={"actor_guard": True}``: on the rows where the critic rates the target actor's
outputs above the actor's, the ascent direction points at the target actor's outputs, with the
length of the critic's gradient; the other rows keep the critic's gradient."""

from __future__ import annotations

import pytest
import torch as th

from sb3_comm import CommDDPG, HybridDDPG, make_comm_vec_env

SMALL = {"net_arch": [16, 16]}


def _pull_target_actor_away(policy: th.nn.Module) -> None:
    """Make the target actor differ from the actor, so that the critic ranks the two."""
    with th.no_grad():
        generator = th.Generator().manual_seed(1)
        for parameter in policy.actor_target.parameters():
            parameter.add_(0.3 * th.randn(parameter.shape, generator=generator))


def _expected(policy, obs: th.Tensor, out: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
    """The guarded direction written out, and which rows it redirects."""
    current = out.clone().requires_grad_(True)
    plain = th.autograd.grad(policy.q_values(obs, current)[0].sum(), current)[0]
    with th.no_grad():
        anchor = policy.actor_outputs(obs, target=True)
        worse = policy.q_values(obs, anchor)[0] > policy.q_values(obs, out)[0]
        pull = anchor - out
    if worse.dim() < plain.dim():
        worse = worse.unsqueeze(-1)
    scaled = pull * (plain.norm(dim=-1, keepdim=True) / pull.norm(dim=-1, keepdim=True))
    return th.where(worse, scaled, plain), worse


def test_rows_the_critic_rates_worse_point_at_the_target_actor_with_the_critic_gradient_length() -> None:
    model = HybridDDPG(
        "MlpPolicy", "HFOMoveToBall-v0", learning_starts=50, seed=0, device="cpu",
        policy_kwargs={**SMALL, "actor_guard": True},
    )  # fmt: skip
    model.learn(120)
    policy = model.policy
    _pull_target_actor_away(policy)
    obs = model.replay_buffer.sample(64).observations
    out = policy.actor_outputs(obs).detach()

    grad, own_q = policy.critic_action_gradients(obs, out)
    expected, worse = _expected(policy, obs, out)
    assert 0 < int(worse.sum()) < len(worse), "the sample must hold rows of both kinds"
    th.testing.assert_close(grad, expected)
    th.testing.assert_close(own_q, policy.q_values(obs, out)[0])
    th.testing.assert_close(policy.guarded_fraction, worse.float().mean())
    # a redirected row points from the actor's outputs to the target actor's
    row = int(worse.squeeze(-1).nonzero()[0])
    anchor = policy.actor_outputs(obs[row : row + 1], target=True).detach()[0]
    cosine = th.nn.functional.cosine_similarity(grad[row], anchor - out[row], dim=0)
    assert float(cosine) == pytest.approx(1.0, abs=1e-5)

    policy.actor_guard = False
    plain, _ = policy.critic_action_gradients(obs, out)
    th.testing.assert_close(plain[~worse.squeeze(-1)], grad[~worse.squeeze(-1)])
    assert not th.allclose(plain[worse.squeeze(-1)], grad[worse.squeeze(-1)])


def test_a_team_is_guarded_per_agent_logs_the_share_and_keeps_it_through_save_and_load(tmp_path) -> None:
    env = make_comm_vec_env("BlindSoccer-v0", n_envs=2, seed=0)
    model = CommDDPG(
        "GSN", env, learning_starts=40, seed=0, device="cpu",
        policy_kwargs={**SMALL, "gsn_net_arch": [8], "actor_guard": True},
    )  # fmt: skip
    model.learn(80)
    model.train(gradient_steps=1, batch_size=8)
    assert "train/actor_guarded" in model.train_log
    policy = model.policy
    _pull_target_actor_away(policy)
    obs = model.replay_buffer.sample(32).observations
    out = policy.actor_outputs(obs).detach()
    grad, _ = policy.critic_action_gradients(obs, out)
    expected, worse = _expected(policy, obs, out)
    assert worse.shape == (32, 2, 1)
    th.testing.assert_close(grad, expected)

    model.save(tmp_path / "model.zip")
    loaded = CommDDPG.load(tmp_path / "model.zip", device="cpu")
    assert loaded.policy.actor_guard is True


def test_a_non_boolean_actor_guard_is_a_clear_error() -> None:
    with pytest.raises(TypeError, match=r"policy_kwargs\['actor_guard'\] must be True or False, got 'yes'"):
        HybridDDPG("MlpPolicy", "HFOMoveToBall-v0", policy_kwargs={"actor_guard": "yes"}, device="cpu")
