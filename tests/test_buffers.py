"""Monte-Carlo returns of the replay: episodes that end, and episodes cut by a time limit."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3.common.env_util import make_vec_env
from toy_envs import coin_env

from sb3_comm import CommDDPG
from sb3_comm.common.buffers import MonteCarloReplayBuffer

GAMMA = 0.9


def _buffer(**kwargs) -> MonteCarloReplayBuffer:
    box = spaces.Box(-1.0, 1.0, (2,), np.float32)
    return MonteCarloReplayBuffer(
        16, box, box, device="cpu", n_envs=2, gamma=GAMMA, store_mc_returns=True, **kwargs
    )


def _play(buffer: MonteCarloReplayBuffer) -> None:
    """Three steps in two envs: env 0 terminates at the third, env 1 is cut by its time limit."""
    for t, reward in enumerate([1.0, 2.0, 4.0]):
        last = t == 2
        infos = [{}, {"TimeLimit.truncated": last}]
        buffer.add(
            np.zeros((2, 2)), np.zeros((2, 2)), np.zeros((2, 2)), np.array([reward, reward]),
            np.array([last, last]), infos,
        )  # fmt: skip


def test_sum_gives_every_ended_episode_its_discounted_return() -> None:
    buffer = _buffer()
    _play(buffer)
    expected = [1 + GAMMA * 2 + GAMMA**2 * 4, 2 + GAMMA * 4, 4.0]
    for env in (0, 1):  # the cut episode is summed as if it had ended (the reference code's way)
        np.testing.assert_allclose(buffer.mc_returns[:3, env, 0], expected, rtol=1e-6)
        np.testing.assert_array_equal(buffer.mc_valid[:3, env], 1.0)


def test_skip_leaves_a_cut_episode_to_the_td_target() -> None:
    buffer = _buffer(mc_truncated="skip")
    _play(buffer)
    np.testing.assert_array_equal(buffer.mc_valid[:3, 0], 1.0)  # terminated: a true return
    np.testing.assert_allclose(buffer.mc_returns[2, 0, 0], 4.0)
    np.testing.assert_array_equal(buffer.mc_valid[:3, 1], 0.0)  # cut: no Monte-Carlo return
    # the next episode of env 1 starts afresh: nothing of the cut one is summed onto it
    buffer.add(np.zeros((2, 2)), np.zeros((2, 2)), np.zeros((2, 2)), np.array([8.0, 8.0]),
               np.array([True, True]), [{}, {}])  # fmt: skip
    np.testing.assert_allclose(buffer.mc_returns[3, 1, 0], 8.0)
    assert buffer.mc_valid[3, 1] == 1.0


def test_bootstrap_completes_a_cut_episode_at_the_cut() -> None:
    buffer = _buffer(mc_truncated="bootstrap")
    for t, reward in enumerate([1.0, 2.0, 4.0]):  # as _play, with next observations that name the step
        last = t == 2
        buffer.add(
            np.zeros((2, 2)), np.full((2, 2), 10.0 + t), np.zeros((2, 2)), np.array([reward, reward]),
            np.array([last, last]), [{}, {"TimeLimit.truncated": last}],
        )  # fmt: skip
    sums = [1 + GAMMA * 2 + GAMMA**2 * 4, 2 + GAMMA * 4, 4.0]
    for env in (0, 1):  # the rewards are summed either way; both episodes have a return
        np.testing.assert_allclose(buffer.mc_returns[:3, env, 0], sums, rtol=1e-6)
        np.testing.assert_array_equal(buffer.mc_valid[:3, env], 1.0)
    np.testing.assert_array_equal(buffer.mc_tail_discount[:3, 0], 0.0)  # terminated: nothing after
    np.testing.assert_allclose(buffer.mc_tail_discount[:3, 1], [GAMMA**3, GAMMA**2, GAMMA], rtol=1e-6)
    samples = buffer._gather(np.array([0, 1, 2, 0]), np.array([1, 1, 1, 0]))
    np.testing.assert_array_equal(samples.mc_tail_observations[:3].numpy(), 12.0)  # s_{T+1}, the cut's
    np.testing.assert_allclose(samples.mc_tail_discount[:, 0].numpy(), [GAMMA**3, GAMMA**2, GAMMA, 0.0])
    # the next episode of env 1 ends by termination: its steps get no bootstrap
    buffer.add(np.zeros((2, 2)), np.zeros((2, 2)), np.zeros((2, 2)), np.array([8.0, 8.0]),
               np.array([True, True]), [{}, {}])  # fmt: skip
    assert buffer.mc_tail_discount[3, 1] == 0.0 and buffer.mc_valid[3, 1] == 1.0
    summed = _buffer()
    _play(summed)
    assert summed.sample(2).mc_tail_observations is None  # "sum": no extra fields


def test_bad_mc_truncated_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match=r"mc_truncated must be one of \['sum', 'skip', 'bootstrap'\]"):
        _buffer(mc_truncated="nstep")
    for way in ("skip", "bootstrap"):
        with pytest.raises(ValueError, match=f"mc_truncated='{way}' needs handle_timeout_termination=True"):
            _buffer(mc_truncated=way, handle_timeout_termination=False)


def test_the_option_reaches_the_model_buffer() -> None:
    env = make_vec_env(coin_env, n_envs=2, seed=0)
    model = CommDDPG("NONE", env, mc_mixing=0.5, replay_buffer_kwargs={"mc_truncated": "skip"}, seed=0)
    model.learn(10)
    assert model.replay_buffer.mc_truncated == "skip"
    np.testing.assert_array_equal(model.replay_buffer.mc_valid[:5], 0.0)  # the coin game is cut at 4


def test_a_buffer_that_treats_cut_episodes_otherwise_is_refused(tmp_path) -> None:
    """A saved replay whose cut episodes carry another kind of Monte-Carlo return does not replace
    the model's silently (the targets would change): the error names both."""
    env = make_vec_env(coin_env, n_envs=2, seed=0)
    summed = CommDDPG("NONE", env, mc_mixing=0.5, seed=0)
    summed.learn(10)
    summed.save_replay_buffer(tmp_path / "summed.pkl")
    completed = CommDDPG("NONE", env, mc_mixing=0.5, replay_buffer_kwargs={"mc_truncated": "bootstrap"})
    before = completed.replay_buffer
    with pytest.raises(ValueError, match=r"mc_truncated 'sum' \(model: 'bootstrap'\).*unchanged"):
        completed.load_replay_buffer(tmp_path / "summed.pkl")
    assert completed.replay_buffer is before
    CommDDPG("NONE", env, mc_mixing=0.5).load_replay_buffer(tmp_path / "summed.pkl")  # the same way: fits


@pytest.mark.parametrize("explorer_envs", [0, 1])
def test_sample_fields_draws_the_transitions_of_sample(explorer_envs: int) -> None:
    """The GSN's light sample: the same transitions (and random draws) as ``sample``, only the fields
    asked for; the next draw after it is the one after a full sample."""
    from sb3_comm.comm_ddpg.buffers import JointReplayBuffer

    obs_space = spaces.Box(-1.0, 1.0, (2, 3), np.float32)
    act_space = spaces.Box(-1.0, 1.0, (2, 2), np.float32)
    buffer = JointReplayBuffer(50, obs_space, act_space, n_envs=3, explorer_envs=explorer_envs)
    rng = np.random.default_rng(0)
    for step in range(20):
        buffer.add(
            rng.normal(size=(3, 2, 3)).astype(np.float32),
            rng.normal(size=(3, 2, 3)).astype(np.float32),
            rng.uniform(-1, 1, size=(3, 2, 2)).astype(np.float32),
            np.zeros(3, dtype=np.float32),
            np.array([step == 9] * 3),
            [{"agent_rewards": rng.normal(size=2)} for _ in range(3)],
        )
    np.random.seed(7)
    full = buffer.sample(16)
    after_full = np.random.random()
    np.random.seed(7)
    light = buffer.sample_fields(16, ("observations", "rewards"))
    assert np.random.random() == after_full
    assert set(vars(light)) == {"observations", "rewards"}
    assert th.equal(light.observations, full.observations)
    assert th.equal(light.rewards, full.rewards)
    assert light.observations.dtype == full.observations.dtype
