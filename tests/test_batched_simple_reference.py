"""The batched simple_reference is mpe2's game behind TwoAgentEnv, step for step."""

from __future__ import annotations

import numpy as np
import pytest
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_comm import CommDDPG, make_comm_vec_env
from sb3_comm.evaluation import evaluate_team
from sb3_comm.foreign.batched_simple_reference import LANDMARK_COLOURS, SimpleReferenceTask
from sb3_comm.foreign.simple_reference import ENV_ID, NoCommTeam, OracleTeam, simple_reference_env
from sb3_comm.wrappers import BatchedTwoAgentVecEnv

GAMES = 3
CHANNEL = 4


def _mpe_world(env):
    """mpe2's world behind a TwoAgentEnv (silenced: SilenceNativeChannel, then the parallel env)."""
    return env.env.env.aec_env.unwrapped.world


def _copy_world(worlds) -> tuple[np.ndarray, ...]:
    agents = [w.agents for w in worlds]
    return (
        np.array([[a.state.p_pos for a in ag] for ag in agents]),
        np.array([[a.state.p_vel for a in ag] for ag in agents]),
        np.array([[lm.state.p_pos for lm in w.landmarks] for w in worlds]),
        np.array([[w.landmarks.index(a.goal_b) for a in w.agents] for w in worlds]),
    )


@pytest.mark.parametrize("local_ratio", [0.5, 0.2])
def test_every_step_equals_mpe2_behind_two_agent_env(local_ratio: float) -> None:
    """From the same worlds, with the same actions (some out of bounds, messages included):
    identical rows, rewards, returns and truncation at max_cycles, for every game."""
    max_cycles = 7
    envs = [
        simple_reference_env(channel_size=CHANNEL, max_cycles=max_cycles, local_ratio=local_ratio)
        for _ in range(GAMES)
    ]
    first = [env.reset(seed=10 + i)[0] for i, env in enumerate(envs)]
    task = SimpleReferenceTask(
        GAMES, seed=0, channel_size=CHANNEL, max_cycles=max_cycles, local_ratio=local_ratio
    )
    vec = BatchedTwoAgentVecEnv(task)
    rows = vec._rows(task.load_state(*_copy_world([_mpe_world(e) for e in envs])))
    np.testing.assert_array_equal(rows, np.stack(first))
    rng = np.random.default_rng(0)
    for t in range(max_cycles):
        actions = rng.uniform(-0.3, 1.3, size=(GAMES, *vec.action_space.shape)).astype(np.float32)
        vec.step_async(actions)
        batched_rows, batched_reward, done, infos = vec.step_wait()
        for i, env in enumerate(envs):
            obs, reward, terminated, truncated, info = env.step(actions[i])  # mpe2 clips, with a warning
            final = infos[i]["terminal_observation"] if done[i] else batched_rows[i]
            np.testing.assert_array_equal(final, obs)
            np.testing.assert_array_equal(infos[i]["agent_rewards"], info["agent_rewards"])
            assert batched_reward[i] == np.float32(reward)
            assert done[i] == (terminated or truncated) == (t == max_cycles - 1)
            if done[i]:
                assert infos[i]["TimeLimit.truncated"] and truncated and not terminated
                np.testing.assert_array_equal(infos[i]["agent_returns"], info["agent_returns"])
                assert infos[i]["episode"]["l"] == max_cycles
    # after the end every game starts afresh: zero velocity and no message heard
    np.testing.assert_array_equal(batched_rows[:, :, 0:2], 0.0)
    np.testing.assert_array_equal(batched_rows[:, :, -CHANNEL:], 0.0)


def test_reset_draws_mpe2_distribution_and_observation_layout() -> None:
    task = SimpleReferenceTask(2000, seed=1, channel_size=2)
    obs = task.obs
    assert obs.shape == (2000, 2, 11 + 2) and obs.dtype == np.float32
    assert set(np.unique(task.goal)) == {0, 1, 2}
    assert np.abs(task.agent_pos).max() <= 1 and np.abs(task.landmark_pos).max() <= 1
    assert 0.4 < task.agent_pos.std() / (2 / np.sqrt(12)) < 1.1  # roughly uniform on [-1, 1]
    np.testing.assert_array_equal(obs[..., 0:2], 0.0)
    relative = task.landmark_pos[:, None] - task.agent_pos[:, :, None]
    np.testing.assert_allclose(obs[..., 2:8], relative.reshape(2000, 2, 6), atol=1e-6)
    np.testing.assert_array_equal(obs[..., 8:11], LANDMARK_COLOURS[task.goal].astype(np.float32))
    again = SimpleReferenceTask(2000, seed=1, channel_size=2)
    np.testing.assert_array_equal(again.obs, obs)  # seeded
    np.testing.assert_array_equal(task.reset(seed=1), obs)


def test_message_is_heard_by_the_teammate_one_step_later_clipped() -> None:
    task = SimpleReferenceTask(2, seed=0, channel_size=3)
    actions = np.zeros((2, 2, 8), dtype=np.float32)
    actions[:, 0, 5:] = [0.5, -2.0, 0.25]  # agent 0 says, clipped to [-1, 1]
    actions[:, 1, 5:] = [1.0, 0.0, -0.75]
    obs, *_ = task.step(actions)
    np.testing.assert_array_equal(obs[:, 1, -3:], [[0.5, -1.0, 0.25]] * 2)  # agent 1 hears agent 0
    np.testing.assert_array_equal(obs[:, 0, -3:], [[1.0, 0.0, -0.75]] * 2)


def test_physics_and_reward_by_hand() -> None:
    """One push right from rest: v = 5 · 1 · 0.1 = 0.5, the position moves only at the next step."""
    task = SimpleReferenceTask(1, seed=0, channel_size=1, local_ratio=0.5)
    pos = np.array([[[0.0, 0.0], [0.3, -0.4]]])
    landmarks = np.array([[[1.0, 0.0], [0.0, 0.0], [-1.0, 1.0]]])
    task.load_state(pos, np.zeros((1, 2, 2)), landmarks, np.array([[1, 0]]))
    push = np.zeros((1, 2, 6), dtype=np.float32)
    push[0, 0, 2] = 1.0  # agent 0: right
    obs, rewards, *_ = task.step(push)
    np.testing.assert_allclose(obs[0, 0, 0:2], [0.5, 0.0])
    # agent 0 knows landmark 1 (0, 0): its teammate at (0.3, -0.4) is 0.5 away;
    # agent 1 knows landmark 0 (1, 0): agent 0, still at the origin, is 1.0 away
    own = np.array([-0.5, -1.0])
    np.testing.assert_allclose(rewards[0], 0.5 * own.mean() + 0.5 * own, rtol=1e-6)
    obs, *_ = task.step(np.zeros_like(push))
    np.testing.assert_allclose(task.agent_pos[0, 0], [0.05, 0.0])
    np.testing.assert_allclose(obs[0, 0, 0:2], [0.375, 0.0])  # damped by 0.75


def test_make_comm_vec_env_batches_the_id_and_keeps_mpe2_on_request() -> None:
    batched = make_comm_vec_env(ENV_ID, n_envs=4, seed=0, env_kwargs={"channel_size": 2})
    assert isinstance(batched, BatchedTwoAgentVecEnv)
    plain = make_comm_vec_env(ENV_ID, n_envs=4, seed=0, env_kwargs={"channel_size": 2}, batched=False)
    assert isinstance(plain, DummyVecEnv)
    assert batched.observation_space == plain.observation_space
    assert batched.action_space == plain.action_space
    assert batched.get_attr("comm_layout")[0] == plain.get_attr("comm_layout")[0]
    assert batched.render().shape[-1] == 3


def test_scripted_references_on_the_batched_game_match_mpe2() -> None:
    """The oracle and no-comm teams score the same on both, within sampling error (200 games)."""
    scores = {}
    for batched in (True, False):
        env = make_comm_vec_env(ENV_ID, n_envs=200, seed=5, env_kwargs={"channel_size": 2}, batched=batched)
        scores[batched] = [evaluate_team(team(env), env).mean for team in (OracleTeam, NoCommTeam)]
    for ours, theirs in zip(scores[True], scores[False], strict=True):
        assert abs(ours - theirs) < 1.5  # the standard error of a 200-game mean is about 0.4
    assert scores[True][0] > scores[True][1] + 4.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"silence": False}, "no native channel"),
        ({"channel_size": 0}, "channel_size must be >= 1"),
        ({"local_ratio": 1.5}, "local_ratio is a proportion"),
        ({"max_cycles": 0}, "max_cycles must be >= 1"),
        ({"n_games": 0}, "n_games must be >= 1"),
    ],
)
def test_bad_options_are_clear_errors(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        SimpleReferenceTask(**kwargs)


def test_bad_actions_are_clear_errors() -> None:
    task = SimpleReferenceTask(2, seed=0, channel_size=2)
    with pytest.raises(ValueError, match=r"shape \(n_games, 2, 5 \+ channel_size\)"):
        task.step(np.zeros((2, 2, 5)))
    bad = np.zeros((2, 2, 7))
    bad[1, 1, 3] = np.nan
    with pytest.raises(ValueError, match=r"agent\(s\) \['agent_1'\] contains NaN"):
        task.step(bad)
    with pytest.raises(ValueError, match="goal must hold landmark indices"):
        task.load_state(np.zeros((2, 2, 2)), np.zeros((2, 2, 2)), np.zeros((2, 3, 2)), np.full((2, 2), 3))


def test_comm_ddpg_trains_on_the_batched_game() -> None:
    vec = make_comm_vec_env(ENV_ID, n_envs=4, seed=0, env_kwargs={"channel_size": 2})
    model = CommDDPG("GSN", vec, learning_starts=40, batch_size=16, seed=0, device="cpu")
    model.learn(200)
    assert model.num_timesteps >= 200 and model.replay_buffer.size() > 0
