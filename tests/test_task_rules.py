"""Tests of the two rule sets of the paper's tasks (SPEC §6 items 6, 7): ``rules="paper"`` (the
default, the paper's text) and ``rules="dqn-hfo"`` (the authors' code), through the batched core,
the PettingZoo shell and the vectorised environment of sb3_comm (``env_kwargs``)."""

import numpy as np
import pytest

from envs import blind_soccer_v0, guess_my_number_v0
from envs.soccer import referee
from envs.soccer.state import SoccerState
from envs.tasks import BlindSoccerTask, GuessMyNumberTask
from envs.tasks.batched import RULES
from envs.tasks.blind_soccer import BLIND, SIGHTED


def _turns(task, messages=None):
    """Every agent turns by 0 (nothing moves); optional messages (P, channel) for every game."""
    actions = np.zeros((task.n_games, task.n_players, task.action_size))
    actions[..., :3] = [-1.0, 1.0, -1.0]
    if messages is not None:
        actions[..., 8:] = messages
    return actions


def _scene(n_games, ball, sighted, blind):
    state = SoccerState.zeros(n_games, 2)
    state.ball_pos[:] = ball
    state.pos[:, SIGHTED] = sighted
    state.pos[:, BLIND] = blind
    return state


def test_rules_default_and_accepted_values():
    assert RULES == ("paper", "dqn-hfo")
    assert BlindSoccerTask().rules == "paper"
    assert GuessMyNumberTask().rules == "paper"


@pytest.mark.parametrize("module", [blind_soccer_v0, guess_my_number_v0])
def test_invalid_rules_name_the_accepted_values(module):
    with pytest.raises(ValueError, match=r"rules must be one of 'paper', 'dqn-hfo', got 'dqn_hfo'"):
        module.batched_env(rules="dqn_hfo")
    with pytest.raises(ValueError, match="'paper', 'dqn-hfo'"):
        module.parallel_env(rules="code")


# ------------------------------------------------------------------------------------------------
# Blind Soccer: who ends the episode
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("rules", "ends"), [("paper", False), ("dqn-hfo", True)])
def test_blind_soccer_sighted_kickable_ends_only_under_dqn_hfo(rules, ends):
    task = blind_soccer_v0.batched_env(n_games=1, noise=False, autoreset=False, rules=rules)
    task.load_state(_scene(1, ball=(30.0, 0.0), sighted=(29.5, 0.0), blind=(10.0, 0.0)))
    _, _, terminated, truncated, info = task.step(_turns(task))
    assert bool(terminated[0]) is ends
    assert not truncated[0]
    assert info["outcome"][0] == referee.IN_GAME


@pytest.mark.parametrize("rules", RULES)
def test_blind_soccer_blind_kickable_ends_under_both(rules):
    task = blind_soccer_v0.batched_env(n_games=2, noise=False, autoreset=False, rules=rules)
    task.load_state(_scene(2, ball=(30.0, 0.0), sighted=(10.0, 10.0), blind=(29.0, 0.0)))
    state = task.state.copy()
    state.pos[1, BLIND] = (28.9, 0.0)  # 1.1 m: beyond librcsc's 1.03
    task.load_state(state)
    _, _, terminated, _, _ = task.step(_turns(task))
    np.testing.assert_array_equal(terminated, [True, False])


def test_blind_soccer_rules_in_the_parallel_env():
    env = blind_soccer_v0.parallel_env(noise=False, rules="dqn-hfo")
    env.reset(seed=0)
    assert env.task.rules == "dqn-hfo"
    env.task.load_state(_scene(1, ball=(30.0, 0.0), sighted=(29.5, 0.0), blind=(10.0, 0.0)))
    actions = {agent: _turns(env.task)[0, i] for i, agent in enumerate(env.possible_agents)}
    _, _, terminations, _, _ = env.step(actions)
    assert terminations == {"sighted": True, "blind": True}


# ------------------------------------------------------------------------------------------------
# Guess My Number: which message is rewarded, what ends an episode
# ------------------------------------------------------------------------------------------------
def test_guess_my_number_dqn_hfo_rewards_the_message_of_the_same_step():
    task = guess_my_number_v0.batched_env(n_games=1, seed=0, rules="dqn-hfo", hidden_numbers=(-0.3, 0.6))
    _, rewards, *_ = task.step(_turns(task, [[0.5], [-0.2]]))
    # agent 0 (h = -0.3) is rewarded for -0.2 sent by agent 1 now, agent 1 (h = 0.6) for 0.5
    np.testing.assert_allclose(rewards[0], [0.1 * np.exp(-50 * 0.01), 0.1 * np.exp(-50 * 0.01)], rtol=1e-6)
    paper = guess_my_number_v0.batched_env(n_games=1, seed=0, hidden_numbers=(-0.3, 0.6))
    _, rewards, *_ = paper.step(_turns(paper, [[0.5], [-0.2]]))
    # the paper's rule hears the previous message: 0 at the first step
    np.testing.assert_allclose(rewards[0], [0.1 * np.exp(-50 * 0.09), 0.1 * np.exp(-50 * 0.36)], rtol=1e-6)


@pytest.mark.parametrize(("rules", "best"), [("paper", 9.9), ("dqn-hfo", 10.0)])
def test_guess_my_number_maximum_return(rules, best):
    task = guess_my_number_v0.batched_env(n_games=2, seed=0, rules=rules)
    truthful = task.hidden_numbers[::-1, None]  # each agent sends its teammate's number
    for _ in range(task.max_steps):
        _, _, _, truncated, info = task.step(_turns(task, truthful))
    assert truncated.all()
    np.testing.assert_allclose(info["episode_return"], best, rtol=1e-5)


@pytest.mark.parametrize(("rules", "ends"), [("paper", False), ("dqn-hfo", True)])
def test_guess_my_number_ball_out_ends_only_under_dqn_hfo(rules, ends):
    task = guess_my_number_v0.batched_env(n_games=1, noise=False, autoreset=False, rules=rules)
    state = _scene(1, ball=(-0.5, 0.0), sighted=(10.0, 0.0), blind=(20.0, 0.0))
    task.load_state(state)  # the ball is already out: HFO judges the previous position
    _, _, terminated, truncated, info = task.step(_turns(task))
    assert bool(terminated[0]) is ends
    assert not truncated[0]
    assert info["outcome"][0] == (referee.OUT_OF_BOUNDS if ends else referee.IN_GAME)


def test_rules_reach_the_sb3_vec_env():
    """``env_kwargs`` of sb3_comm's ``make_comm_vec_env`` reach the task."""
    from sb3_comm import make_comm_vec_env

    vec_env = make_comm_vec_env("GuessMyNumber-v0", n_envs=2, seed=0, env_kwargs={"rules": "dqn-hfo"})
    tasks = [getattr(vec_env, name) for name in ("task", "batched", "env") if hasattr(vec_env, name)]
    found = [t for t in tasks if getattr(t, "rules", None) is not None]
    assert found and found[0].rules == "dqn-hfo"
    vec_env.close()
