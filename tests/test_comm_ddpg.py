"""CommDDPG on a toy two-agent game: gradient wiring per method, save/load, errors."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from stable_baselines3.common.env_util import make_vec_env
from toy_envs import coin_env

from sb3_comm import METHODS, CommDDPG
from sb3_comm.comm_ddpg import GSNTrainingCallback
from sb3_comm.common.networks import inverting_gradients


def make_model(method: str, **kwargs) -> CommDDPG:
    vec = make_vec_env(coin_env, n_envs=2, seed=0)
    kwargs.setdefault("learning_starts", 20)
    kwargs.setdefault("policy_kwargs", {"net_arch": [32, 32]})
    return CommDDPG(method, vec, batch_size=16, seed=0, device="cpu", **kwargs)


def filled(model: CommDDPG, steps: int = 60) -> CommDDPG:
    model.learn(steps)
    return model


def batch(model: CommDDPG):
    return model.replay_buffer.sample(16)


def test_tcg_message_gradient_is_the_receivers_critic_gradient() -> None:
    model = filled(make_model("TCG", share_parameters=False))
    policy, layout = model.policy, model.comm_layout
    data = batch(model)
    out = policy.actor_outputs(data.observations).detach()
    got = model.teammate_message_gradients(out, data.next_observations, data.dones)

    # Hand computation for sender 0 -> receiver 1 with autograd on the receiver's own critic.
    env_dim, n = policy.env_action_dim, layout.channel_size
    m = out[:, 0, env_dim:].clone().requires_grad_(True)
    o_next = data.next_observations[:, 1].clone()
    o_next_m = th.cat([o_next[:, : layout.obs_dim - n], m], dim=-1)
    with th.no_grad():
        rows = data.next_observations.clone()
        rows[:, 1, layout.obs_dim - n :] = m.detach()
        a_next = policy.actor_outputs(rows)[:, 1]
    receiver_critic = policy.critic[0].nets[1]
    q = receiver_critic(th.cat([o_next_m, a_next], dim=-1)).sum()
    expected = th.autograd.grad(q, m)[0] * (1 - data.dones)
    th.testing.assert_close(got[:, 0], expected)
    assert got.abs().sum() > 0

    # The message part of the actor's ascent direction is exactly that (no inversion: tanh heads),
    # and the sender's own critic contributes nothing: zeroing the receivers' critics zeroes it.
    grad, _ = model.actor_output_gradients(data.observations, out, data.next_observations, data.dones)
    th.testing.assert_close(grad[..., env_dim:], got)
    with th.no_grad():
        for net in policy.critic[0].nets:
            net[-1].weight.zero_()
    grad_zero, _ = model.actor_output_gradients(data.observations, out, data.next_observations, data.dones)
    assert th.count_nonzero(grad_zero[..., env_dim:]) == 0


def test_rial_message_gradient_comes_from_own_critic() -> None:
    model = filled(make_model("RIAL"))
    policy, layout = model.policy, model.comm_layout
    data = batch(model)
    out = policy.actor_outputs(data.observations).detach()
    grad, _ = model.actor_output_gradients(data.observations, out, data.next_observations, data.dones)
    actions = policy.assemble_actions(data.observations, out).requires_grad_(True)
    q = policy.q_values(data.observations, actions)[0].sum()
    expected = th.autograd.grad(q, actions)[0][..., layout.action_message_slice]
    th.testing.assert_close(grad[..., policy.env_action_dim :], expected)


def test_gsn_loss_and_agent_losses_touch_disjoint_parameters() -> None:
    # a constant actor rate: after learn, the default decaying rate is at 0 and would move nothing
    model = filled(make_model("GSN", actor_learning_rate=1e-4))
    policy = model.policy
    gsn_before = [p.detach().clone() for p in policy.gsn.parameters()]
    agents_before = [p.detach().clone() for p in [*policy.actor.parameters(), *policy.critic.parameters()]]

    model.train(gradient_steps=3, batch_size=16)  # actor and critic updates
    assert all(th.equal(a, b) for a, b in zip(gsn_before, policy.gsn.parameters(), strict=False))
    assert not all(th.equal(a, b) for a, b in zip(agents_before, policy.actor.parameters(), strict=False))

    agents_mid = [p.detach().clone() for p in [*policy.actor.parameters(), *policy.critic.parameters()]]
    gsn_training = GSNTrainingCallback(model.gsn_learning_rate, batch_size=16)
    gsn_training.init_callback(model)
    gsn_training.train_gsn(3)  # GSN updates only
    after = [*policy.actor.parameters(), *policy.critic.parameters()]
    assert all(th.equal(a, b) for a, b in zip(agents_mid, after, strict=False))
    assert not all(th.equal(a, b) for a, b in zip(gsn_before, policy.gsn.parameters(), strict=False))

    # and the GSN loss has no path into actor or critic at all
    data = batch(model)
    for p in [*policy.actor.parameters(), *policy.critic.parameters()]:
        p.grad = None
    policy.gsn.loss(data.observations, data.actions, data.rewards).backward()
    assert all(p.grad is None for p in [*policy.actor.parameters(), *policy.critic.parameters()])


def test_gsn_predicts_the_teammates_reward_from_the_teammates_action() -> None:
    model = make_model("GSN")
    gsn = model.policy.gsn
    obs = th.randn(5, 2, model.comm_layout.obs_dim)
    actions = th.randn(5, 2, model.comm_layout.action_dim)
    rewards = th.randn(5, 2)
    gsn.eval()  # no update of the running reward moments
    with th.no_grad():
        gsn.reward_mean.fill_(0.3)
        gsn.reward_var.fill_(4.0)
    # Row i predicts agent j's reward from agent j's action, in standardised units.
    manual = (((gsn.predict_teammate_reward(obs, actions.flip(1)) - rewards.flip(1)) / 2.0) ** 2).mean()
    th.testing.assert_close(gsn.loss(obs, actions, rewards), manual)
    gsn.normalize_rewards = False  # the paper's plain loss
    plain = ((gsn.predict_teammate_reward(obs, actions.flip(1)) - rewards.flip(1)) ** 2).mean()
    th.testing.assert_close(gsn.loss(obs, actions, rewards), plain)


def test_gsn_reward_statistics_are_the_moments_of_all_teammate_rewards() -> None:
    gsn = make_model("GSN").policy.gsn
    gsn.train()
    obs = th.zeros(4, 2, gsn.message_extractor.nets[0][0].in_features)
    actions = th.zeros(4, 2, 8 + 2)
    batches = [th.randn(4, 2) * 0.01 + 0.02 for _ in range(5)]
    for rewards in batches:
        gsn.loss(obs, actions, rewards)
    everything = th.cat([b.flip(1) for b in batches]).flatten().double()
    assert gsn.reward_count.item() == everything.numel()
    assert gsn.reward_mean.item() == pytest.approx(everything.mean().item(), rel=1e-4)
    assert gsn.reward_var.item() == pytest.approx(everything.var(unbiased=False).item(), rel=1e-3)


def test_gsn_is_trained_once_per_agent_update() -> None:
    model = make_model("GSN", learning_starts=10)
    model.learn(100)
    assert model.n_updates > 0
    assert model.gsn_callback.n_updates == model.n_updates


@pytest.mark.parametrize("method", METHODS)
def test_messages_come_from_the_right_source(method: str) -> None:
    model = make_model(method)
    policy, layout = model.policy, model.comm_layout
    obs = th.randn(4, 2, layout.obs_dim)
    actions = policy._predict(obs)
    messages = actions[..., layout.action_message_slice]
    out = policy.actor_outputs(obs)
    if method == "NONE":
        assert th.count_nonzero(messages) == 0
    elif method in ("GSN", "GSN-MAX"):
        th.testing.assert_close(messages, policy.gsn.message(obs).clamp(-1, 1))
    else:
        th.testing.assert_close(messages, out[..., policy.env_action_dim :].clamp(-1, 1))


def test_exploration_never_randomises_gsn_or_none_messages() -> None:
    for method in ("NONE", "GSN"):
        model = make_model(method)
        model._last_obs = model.env.reset()
        model.num_timesteps = 0  # warm-up: epsilon = 1
        _, buffer_action = model._sample_action(learning_starts=100, n_envs=2)
        expected = model.policy._predict(th.as_tensor(model._last_obs)).detach().numpy()
        sl = model.comm_layout.action_message_slice
        np.testing.assert_allclose(buffer_action[..., sl], expected[..., sl], atol=1e-6)
        assert not np.allclose(buffer_action[..., : sl.start], expected[..., : sl.start])


def test_epsilon_gaussian_exploration_adds_noise_to_the_policy_rows_and_keeps_gsn_messages() -> None:
    model = make_model("GSN", exploration="epsilon+gaussian", gaussian_noise_std=0.1)
    model._last_obs = model.env.reset()
    model.num_timesteps = 1_000  # after warm-up
    sl = model.comm_layout.action_message_slice
    expected = model.policy._predict(th.as_tensor(model._last_obs)).detach().numpy()
    model.exploration_rate = 0.0  # no random rows: the noise alone
    deviations = []
    for _ in range(200):
        _, buffer_action = model._sample_action(learning_starts=100, n_envs=2)
        np.testing.assert_allclose(buffer_action[..., sl], expected[..., sl], atol=1e-6)
        assert np.all(np.abs(buffer_action) <= 1.0)
        deviations.append((buffer_action - expected)[..., : sl.start])
    inside = np.abs(expected[..., : sl.start]) < 0.7  # unclipped entries: the noise's own spread
    spread = np.stack(deviations)[:, inside]
    assert abs(spread.std() - 0.1) < 0.01 and abs(spread.mean()) < 0.01
    model.exploration_rate = 1.0  # every row random: uniform over [-1, 1], not near the policy
    rows = np.stack([model._sample_action(learning_starts=100, n_envs=2)[1] for _ in range(200)])
    assert np.abs(rows[..., : sl.start] - expected[..., : sl.start]).mean() > 0.4  # E|U − x| ≥ 0.5


def test_inverting_gradients_formula() -> None:
    grad = th.tensor([1.0, -1.0, 2.0, -2.0, 1.0])
    value = th.tensor([0.5, 0.5, -1.0, -1.0, 1.5])
    expected = th.tensor([1.0 * 0.5 / 2, -1.0 * 1.5 / 2, 2.0 * 2.0 / 2, 0.0, 1.0 * -0.5 / 2])
    th.testing.assert_close(inverting_gradients(grad, value), expected)


@pytest.mark.parametrize("method", METHODS)
def test_save_load_round_trip(method: str, tmp_path) -> None:
    model = filled(make_model(method))
    obs = model.env.reset()
    before, _ = model.predict(obs, deterministic=True)
    path = tmp_path / f"model_{method}.zip"
    model.save(path)
    loaded = CommDDPG.load(path, device="cpu")
    after, _ = loaded.predict(obs, deterministic=True)
    np.testing.assert_array_equal(before, after)
    assert loaded.method == method
    # every optimizer state travels with the model
    assert loaded.actor.optimizer.state_dict()["state"]
    assert loaded.critic.optimizer.state_dict()["state"]
    if method in ("GSN", "GSN-MAX"):
        assert loaded.policy.gsn.optimizer.state_dict()["state"]
        assert loaded.gsn_learning_rate == model.gsn_learning_rate
    loaded.set_env(make_vec_env(coin_env, n_envs=2, seed=1))
    loaded.learn(40, reset_num_timesteps=False)


def test_bad_input_errors() -> None:
    vec = make_vec_env(coin_env, n_envs=1)
    with pytest.raises(ValueError, match=r"Unknown communication method 'DIAL'.*GSN"):
        CommDDPG("DIAL", vec)
    with pytest.raises(ValueError, match="two-agent environment"):
        CommDDPG("GSN", gym.make("Pendulum-v1"))
    with pytest.raises(ValueError, match="channel_size=3 does not match"):
        CommDDPG("GSN", vec, channel_size=3)
    with pytest.raises(ValueError, match="exploration"):
        CommDDPG("GSN", vec, exploration="boltzmann")
