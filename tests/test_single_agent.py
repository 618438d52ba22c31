"""Tests of the single-agent HFO tasks (Gymnasium environments and their batched cores)."""

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import envs
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
