"""The two-agent wrapper: layout, padding, roles, one-step message delay, errors."""

from __future__ import annotations

import numpy as np
import pytest
from toy_envs import CoinParallelEnv, coin_env

from sb3_comm.wrappers import TwoAgentEnv


def test_layout_pads_features_and_appends_role_and_message() -> None:
    env = coin_env()
    layout = env.comm_layout
    # features padded to 3, role one-hot of 2, channel of 2
    assert env.observation_space.shape == (2, 3 + 2 + 2)
    assert env.action_space.shape == (2, 2 + 2)
    assert layout.obs_message_slice == slice(5, 7)
    assert layout.action_message_slice == slice(2, 4)
    obs, _ = env.reset(seed=3)
    assert obs.shape == (2, 7) and obs.dtype == np.float32
    np.testing.assert_array_equal(obs[:, 3:5], np.eye(2))
    assert obs[1, 2] == 0.0  # listener's padding
    assert obs[0, 0] == pytest.approx(env.env.coin)
    assert env.observation_space.contains(obs)


def test_message_arrives_exactly_one_step_later() -> None:
    env = coin_env(length=5)
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(obs[:, 5:], 0.0)  # nothing received at the first step
    action = np.zeros((2, 4), dtype=np.float32)
    action[0, 2:] = [0.25, -0.5]  # speaker says this at t=0
    action[1, 2:] = [0.75, 0.1]  # listener says this at t=0
    obs1, *_ = env.step(action)
    np.testing.assert_allclose(obs1[1, 5:], [0.25, -0.5])  # listener hears the speaker at t=1
    np.testing.assert_allclose(obs1[0, 5:], [0.75, 0.1])
    obs2, *_ = env.step(np.zeros((2, 4), dtype=np.float32))
    np.testing.assert_array_equal(obs2[:, 5:], 0.0)  # the t=0 message is gone at t=2
    # messages are clipped to the channel's range
    loud = np.zeros((2, 4), dtype=np.float32)
    loud[0, 2:] = [3.0, -7.0]
    obs3, *_ = env.step(loud)
    np.testing.assert_array_equal(obs3[1, 5:], [1.0, -1.0])
    # a reset clears the channel
    obs0, _ = env.reset()
    np.testing.assert_array_equal(obs0[:, 5:], 0.0)


def test_own_actions_are_unpadded_and_rewards_reported_per_agent() -> None:
    env = coin_env(length=2)
    env.reset(seed=1)
    action = np.array([[0.3, 0.9, 0.0, 0.0], [0.5, -0.2, 0.0, 0.0]], dtype=np.float32)
    _, reward, terminated, truncated, info = env.step(action)
    np.testing.assert_allclose(env.env.last_actions["speaker"], [0.3])
    np.testing.assert_allclose(env.env.last_actions["listener"], [0.5, -0.2])
    expected = -((0.5 - env.env.coin) ** 2)
    np.testing.assert_allclose(info["agent_rewards"], [expected, expected], rtol=1e-6)
    assert reward == pytest.approx(expected, rel=1e-6)
    assert not terminated and not truncated
    _, _, terminated, truncated, info = env.step(action)
    assert truncated and not terminated
    np.testing.assert_allclose(info["agent_returns"], [2 * expected] * 2, rtol=1e-5)


def test_bad_actions_raise_naming_agent_and_shape() -> None:
    env = coin_env()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"expected \(2, 4\)"):
        env.step(np.zeros((2, 3), dtype=np.float32))
    bad = np.zeros((2, 4), dtype=np.float32)
    bad[1, 0] = np.nan
    with pytest.raises(ValueError, match="listener"):
        env.step(bad)


def test_wrapper_rejects_wrong_agent_count_and_channel() -> None:
    with pytest.raises(ValueError, match="exactly 2 agents"):
        TwoAgentEnv(CoinParallelEnv(n_agents=3), channel_size=1)
    with pytest.raises(ValueError, match="channel_size >= 1"):
        TwoAgentEnv(CoinParallelEnv())
