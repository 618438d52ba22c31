"""``TwoAgentEnv(time_limit=T)``: time awareness for any two-agent ParallelEnv (the tasks'
``time_feature``, Pardo et al. 2018), and mpe2's own simple_reference made time-aware with it."""

from __future__ import annotations

import numpy as np
import pytest

from envs.blind_soccer_v0 import parallel_env as blind_soccer
from sb3_comm.foreign.batched_simple_reference import SimpleReferenceTask
from sb3_comm.foreign.simple_reference import simple_reference_env
from sb3_comm.wrappers import BatchedTwoAgentVecEnv, TwoAgentEnv
from tests.test_batched_simple_reference import _copy_world, _mpe_world
from tests.toy_envs import CoinParallelEnv


def test_rows_end_their_features_with_the_remaining_time() -> None:
    plain = TwoAgentEnv(CoinParallelEnv(length=4), channel_size=2)
    timed = TwoAgentEnv(CoinParallelEnv(length=4), channel_size=2, time_limit=4)
    # features (speaker 3, listener 2, each + 1 time entry, padded to 4), role one-hot, message
    assert timed.observation_space.shape == (2, 4 + 2 + 2) and plain.observation_space.shape == (2, 3 + 2 + 2)
    assert timed.observation_space.low[0, 3] == 0 and timed.observation_space.high[0, 3] == 1
    assert timed.observation_space.high[1, 2] == 1 and timed.observation_space.high[1, 3] == 0  # padding
    obs_p, _ = plain.reset(seed=3)
    obs_t, _ = timed.reset(seed=3)
    seen = [(obs_t[0, 3], obs_t[1, 2])]
    np.testing.assert_array_equal(obs_t[0, :3], obs_p[0, :3])  # speaker's own features untouched
    np.testing.assert_array_equal(obs_t[:, -4:], obs_p[:, -4:])  # role and message untouched
    rng = np.random.default_rng(0)
    for step in range(1, 5):
        action = rng.uniform(-1, 1, size=plain.action_space.shape).astype(np.float32)
        obs_p, reward_p, term_p, trunc_p, info_p = plain.step(action)
        obs_t, reward_t, term_t, trunc_t, info_t = timed.step(action)
        seen.append((obs_t[0, 3], obs_t[1, 2]))
        assert reward_t == reward_p
        np.testing.assert_array_equal(obs_t[:, -4:], obs_p[:, -4:])  # messages arrive as before
        assert trunc_p == (step == 4) and not term_p  # the coin game truncates at its length ...
        assert term_t == (step == 4) and not trunc_t  # ... which the time-aware rows terminate
    np.testing.assert_allclose(seen, [(1 - t / 4, 1 - t / 4) for t in range(5)])
    np.testing.assert_array_equal(info_t["agent_returns"], info_p["agent_returns"])


def test_limit_before_the_env_ends_terminates_and_an_earlier_truncation_stays() -> None:
    short = TwoAgentEnv(CoinParallelEnv(length=10), channel_size=1, time_limit=3)
    short.reset(seed=0)
    ends = [short.step(np.zeros(short.action_space.shape, np.float32))[2:4] for _ in range(3)]
    assert ends == [(False, False), (False, False), (True, False)]
    long = TwoAgentEnv(CoinParallelEnv(length=2), channel_size=1, time_limit=5)
    obs, _ = long.reset(seed=0)
    for _ in range(2):
        obs, _, terminated, truncated, _ = long.step(np.zeros(long.action_space.shape, np.float32))
    assert truncated and not terminated  # the environment's own end, before the limit the agents see
    np.testing.assert_allclose(obs[0, 3], 1 - 2 / 5)


@pytest.mark.parametrize("bad", [0, -2, 2.5, True, "25"])
def test_bad_time_limit_is_a_clear_error(bad) -> None:
    with pytest.raises(ValueError, match="time_limit must be a whole number of steps >= 1"):
        TwoAgentEnv(CoinParallelEnv(), channel_size=1, time_limit=bad)


def test_time_limit_on_a_task_that_shows_the_time_is_refused() -> None:
    TwoAgentEnv(blind_soccer(max_steps=10), time_limit=10)  # the plain task: allowed
    with pytest.raises(ValueError, match="already shows it"):
        TwoAgentEnv(blind_soccer(max_steps=10, time_feature=True), time_limit=10)


def test_mpe2_time_aware_equals_the_batched_time_aware_game_step_for_step() -> None:
    """mpe2's own game with ``time_feature=True`` (TwoAgentEnv's time_limit) gives the same rows,
    rewards and endings as the batched game's own option, from the same worlds."""
    games, max_cycles, channel = 2, 5, 3
    envs = [
        simple_reference_env(channel_size=channel, max_cycles=max_cycles, time_feature=True)
        for _ in range(games)
    ]
    first = [env.reset(seed=20 + i)[0] for i, env in enumerate(envs)]
    task = SimpleReferenceTask(games, seed=0, channel_size=channel, max_cycles=max_cycles, time_feature=True)
    vec = BatchedTwoAgentVecEnv(task)
    rows = vec._rows(task.load_state(*_copy_world([_mpe_world(e) for e in envs])))
    np.testing.assert_array_equal(rows, np.stack(first))
    assert envs[0].observation_space == vec.observation_space
    rng = np.random.default_rng(4)
    for t in range(max_cycles):
        actions = rng.uniform(0, 1, size=(games, *vec.action_space.shape)).astype(np.float32)
        vec.step_async(actions)
        batched_rows, batched_reward, done, infos = vec.step_wait()
        for i, env in enumerate(envs):
            obs, reward, terminated, truncated, _ = env.step(actions[i])
            final = infos[i]["terminal_observation"] if done[i] else batched_rows[i]
            np.testing.assert_array_equal(final, obs)
            assert batched_reward[i] == np.float32(reward)
            assert terminated == done[i] == (t == max_cycles - 1) and not truncated
            assert not infos[i].get("TimeLimit.truncated", False)
