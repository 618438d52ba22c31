"""Tests of the single-agent HFO tasks (Gymnasium environments and their batched cores)."""

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import envs
from envs.oracles import empty_goal_oracle, move_to_ball_oracle
from envs.soccer import physics, referee
from envs.soccer.state import SoccerState
from envs.tasks.hfo_actions import HYBRID_LAYOUT
from envs.tasks.single_agent import MoveToBallEnv, MoveToBallTask, ScoreEmptyGoalEnv, ScoreEmptyGoalTask

ENV_CLASSES = [MoveToBallEnv, ScoreEmptyGoalEnv]


def _prox(d):
    return 1.0 - 2.0 * np.clip(d / 62.55, 0.0, 1.0)


def _dash(n=1, power=100.0):
    action = np.zeros((n, 1, 8))
    action[..., :3] = [1.0, -1.0, -1.0]
    action[..., 3] = power
    return action


def _state(player, ball, ball_vel=(0.0, 0.0), body=0.0):
    state = SoccerState.zeros(1, 1)
    state.pos[0, 0] = player
    state.ball_pos[0] = ball
    state.ball_vel[0] = ball_vel
    state.body[0, 0] = body
    return state


@pytest.mark.filterwarnings("ignore:.*symmetric and normalized.*")
@pytest.mark.filterwarnings("ignore:.*alternative render modes.*")
@pytest.mark.parametrize("env_class", ENV_CLASSES)
def test_library_checkers(env_class):
    env = env_class()
    gym_check_env(env, skip_render_check=False)
    sb3_check_env(env_class(), warn=True)


@pytest.mark.parametrize("env_id", ["HFOMoveToBall-v0", "HFOScoreEmptyGoal-v0"])
def test_registered_ids(env_id):
    env = gymnasium.make(env_id, render_mode="rgb_array")
    obs, info = env.reset(seed=0)
    assert obs.shape == (58,) and obs.dtype == np.float32
    assert env.unwrapped.metadata["hybrid_action"] == HYBRID_LAYOUT
    assert env.unwrapped.hybrid_layout == HYBRID_LAYOUT
    obs, reward, _, _, info = env.step(env.action_space.sample())
    assert isinstance(reward, float) and "outcome" in info
    assert env.render().shape[2] == 3
    envs.register_envs()  # registering twice is harmless


def test_same_seed_same_trajectory():
    def rollout(seed):
        env = ScoreEmptyGoalEnv()
        env.action_space.seed(0)
        out = [env.reset(seed=seed)[0]]
        for _ in range(30):
            obs, reward, *_ = env.step(env.action_space.sample())
            out += [obs, reward]
        return out

    a, b, c = rollout(3), rollout(3), rollout(4)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not np.array_equal(a[0], c[0])


def test_move_to_ball_reward_and_termination():
    task = MoveToBallTask(noise=False, autoreset=False)
    task.load_state(_state((27.0, 0.0), (30.0, 0.0)))
    _, reward, terminated, _, _ = task.step(_dash())
    d = np.hypot(*(task.state.ball_pos[0] - task.state.pos[0, 0]))
    assert not terminated[0] and d > 1.085
    assert reward[0, 0] == pytest.approx(_prox(d) - _prox(3.0), abs=1e-6)
    previous_d = d
    for _ in range(5):
        _, reward, terminated, _, _ = task.step(_dash())
        d = np.hypot(*(task.state.ball_pos[0] - task.state.pos[0, 0]))
        if terminated[0]:
            break
        previous_d = d
    assert terminated[0] and physics.kickable(task.state, task.params)[0, 0]
    assert reward[0, 0] == pytest.approx(_prox(d) - _prox(previous_d) + 1.0, abs=1e-6)


def test_empty_goal_rewards_goal_and_possession():
    task = ScoreEmptyGoalTask(noise=False, autoreset=False)
    # the ball rolls into the goal while the player is far away
    task.load_state(_state((40.0, 0.0), (52.0, 0.0), ball_vel=(1.5, 0.0)))
    noop = np.zeros((1, 1, 8))
    noop[..., :3] = [-1.0, 1.0, -1.0]
    _, reward, terminated, _, info = task.step(noop)
    assert info["outcome"][0] == referee.GOAL and terminated[0]
    d0, d1 = 12.0, np.hypot(*(task.state.ball_pos[0] - task.state.pos[0, 0]))
    assert reward[0, 0] == pytest.approx(_prox(d1) - _prox(d0) + 5.0, abs=1e-5)

    # a kick towards the goal by the player in possession earns 3 x the goal-proximity change
    task.load_state(_state((39.5, 0.0), (40.0, 0.0)))
    task.step(noop)  # first step kickable: +1, possession starts
    kick = np.zeros((1, 1, 8))
    kick[..., :3] = [-1.0, -1.0, 1.0]
    kick[..., 6] = 100.0
    before = task.state.copy()
    _, reward, *_ = task.step(kick)
    ball_gain = _prox(np.hypot(*(task.state.ball_pos[0] - [52.5, 0]))) - _prox(
        np.hypot(*(before.ball_pos[0] - [52.5, 0]))
    )
    player_gain = _prox(np.hypot(*(task.state.ball_pos[0] - task.state.pos[0, 0]))) - _prox(
        np.hypot(*(before.ball_pos[0] - before.pos[0, 0]))
    )
    assert ball_gain > 0
    assert reward[0, 0] == pytest.approx(player_gain + 3.0 * ball_gain, abs=1e-5)


def test_empty_goal_defaults():
    task = ScoreEmptyGoalTask(n_games=4, seed=0)
    assert task.max_steps == 500 and task.untouched_cycles == 100
    assert np.all(task.state.ball_pos[:, 0] <= 0.2 * 52.5 + 1e-9)
    assert MoveToBallTask().max_steps == 100


@pytest.mark.parametrize("env_class", ENV_CLASSES)
def test_bad_actions_raise(env_class):
    env = env_class()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"\(8,\)"):
        env.step(np.zeros(9))
    bad = np.zeros(8)
    bad[0] = np.nan
    with pytest.raises(ValueError, match="player"):
        env.step(bad)


def _mixed_action(shell, rng, oracle, random_share):
    """The task's oracle action or, with probability ``random_share``, a random one."""
    if rng.random() < random_share:
        return rng.uniform(shell.action_space.low, shell.action_space.high).astype(np.float32)
    return oracle(shell.task)[0, 0].astype(np.float32)


@pytest.mark.parametrize("env_id", ["HFOMoveToBall-v0", "HFOScoreEmptyGoal-v0"])
def test_batched_vec_env_plays_the_gymnasium_games(env_id):
    """One game of the batched VecEnv is the Gymnasium shell's game, step for step and across
    resets: observations, rewards, ends, outcomes, and SB3's truncation flags."""
    from sb3_comm import make_comm_vec_env
    from sb3_comm.wrappers import BatchedSingleAgentVecEnv

    vec = make_comm_vec_env(env_id, n_envs=1, seed=3)
    assert isinstance(vec, BatchedSingleAgentVecEnv)
    shell = gymnasium.make(env_id).unwrapped
    assert vec.observation_space == shell.observation_space and vec.action_space == shell.action_space
    assert vec.get_attr("hybrid_layout")[0] == shell.hybrid_layout

    obs, (expected, _) = vec.reset(), shell.reset(seed=3)
    np.testing.assert_array_equal(obs[0], expected)
    oracle = move_to_ball_oracle if env_id == "HFOMoveToBall-v0" else empty_goal_oracle
    rng, ends = np.random.default_rng(0), []
    for _ in range(600):
        # oracle-led and random episodes in turn: they reach the ball, score and run out of time
        action = _mixed_action(shell, rng, oracle, 0.3 if len(ends) % 2 == 0 else 1.0)
        obs, reward, done, info = vec.step(action[None])
        expected, expected_reward, terminated, truncated, shell_info = shell.step(action)
        assert reward[0] == np.float32(expected_reward) and done[0] == (terminated or truncated)
        assert info[0]["outcome"] == shell_info["outcome"]
        if done[0]:
            ends.append((shell_info["outcome"], truncated))
            np.testing.assert_array_equal(info[0]["terminal_observation"], expected)
            assert info[0]["TimeLimit.truncated"] == (truncated and not terminated)
            expected, _ = shell.reset()
        np.testing.assert_array_equal(obs[0], expected)
    assert len(set(ends)) >= 2  # the comparison crossed episodes that ended in different ways


def test_batched_vec_env_checks_its_input():
    from sb3_comm import make_comm_vec_env
    from sb3_comm.wrappers import BatchedSingleAgentVecEnv

    vec = make_comm_vec_env("HFOScoreEmptyGoal-v0", n_envs=4, seed=0)
    vec.reset()
    with pytest.raises(ValueError, match=r"shape \(4, 7\); expected \(4, 8\)"):
        vec.step(np.zeros((4, 7), np.float32))
    bad = np.zeros((4, 8), np.float32)
    bad[2, 5] = np.nan
    with pytest.raises(ValueError, match=r"\['player'\] contains NaN"):
        vec.step(bad)
    with pytest.raises(ValueError, match="one-agent task with autoreset=True"):
        BatchedSingleAgentVecEnv(ScoreEmptyGoalTask(n_games=2, autoreset=False))


def test_hybrid_ddpg_trains_on_the_batched_vec_env():
    from sb3_comm import HybridDDPG, make_comm_vec_env

    vec = make_comm_vec_env("HFOScoreEmptyGoal-v0", n_envs=4, seed=0)
    model = HybridDDPG("MlpPolicy", vec, learning_starts=16, batch_size=8, policy_kwargs={"net_arch": [8]})
    model.learn(200)
    assert model.num_timesteps == 200 and model.replay_buffer.size() == 50
    assert model.policy.hybrid_layout is not None
