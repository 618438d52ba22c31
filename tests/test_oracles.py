"""Tests of the scripted policies and the evaluation loop (behaviour, not benchmark numbers)."""

import numpy as np
import pytest

from envs import blind_soccer_v0, guess_my_number_v0
from envs.oracles import (
    blind_dash_forward,
    blind_soccer_oracle,
    blind_soccer_visible_oracle,
    empty_goal_oracle,
    evaluate,
    guess_my_number_oracle,
    hidden_from_sighted,
    move_to_ball_oracle,
    random_policy,
)
from envs.soccer import referee
from envs.tasks.blind_soccer import BLIND, SIGHTED
from envs.tasks.single_agent import MoveToBallEnv, MoveToBallTask, ScoreEmptyGoalTask

N_EPISODES = 50


def _random(seed=0):
    rng = np.random.default_rng(seed)
    return lambda task: random_policy(task, rng)


def test_blind_soccer_oracle_far_above_random():
    task = blind_soccer_v0.batched_env(n_games=N_EPISODES)
    oracle = evaluate(task, blind_soccer_oracle, N_EPISODES, seed=0)
    random = evaluate(task, _random(), N_EPISODES, seed=0)
    dash = evaluate(task, blind_dash_forward, N_EPISODES, seed=0)
    assert oracle["n_episodes"] == random["n_episodes"] == N_EPISODES
    assert oracle["team_return"]["mean"] > random["team_return"]["mean"] + 0.2
    assert oracle["team_return"]["mean"] > dash["team_return"]["mean"] + 0.2
    # the oracle reaches the ball in most episodes, well within the time limit
    assert oracle["outcomes"]["IN_GAME"] >= 0.8 * N_EPISODES
    assert oracle["length"]["mean"] < random["length"]["mean"]
    # the shared reward: both agents' returns are identical
    np.testing.assert_allclose(oracle["returns"][:, 0], oracle["returns"][:, 1])


def test_guess_my_number_oracle_reaches_the_analytic_maximum():
    task = guess_my_number_v0.batched_env(n_games=10)
    oracle = evaluate(task, guess_my_number_oracle, 20, seed=0)
    random = evaluate(task, _random(), 20, seed=0)
    # 99 rewarded steps of 0.1 (the first step hears the initial message 0)
    assert oracle["team_return"]["mean"] == pytest.approx(9.9, abs=1e-5)
    assert random["team_return"]["mean"] < 0.5 * oracle["team_return"]["mean"]
    np.testing.assert_array_equal(oracle["lengths"], 100)


def test_single_agent_oracles_far_above_random():
    task = MoveToBallTask(n_games=N_EPISODES)
    oracle = evaluate(task, move_to_ball_oracle, N_EPISODES, seed=0)
    random = evaluate(task, _random(), N_EPISODES, seed=0)
    assert oracle["team_return"]["mean"] > random["team_return"]["mean"] + 0.5
    assert oracle["outcomes"]["IN_GAME"] >= 0.8 * N_EPISODES  # became kickable

    task = ScoreEmptyGoalTask(n_games=N_EPISODES)
    oracle = evaluate(task, empty_goal_oracle, N_EPISODES, seed=0)
    random = evaluate(task, _random(), N_EPISODES, seed=0)
    assert oracle["outcomes"]["GOAL"] >= 0.5 * N_EPISODES
    assert random["outcomes"]["GOAL"] < oracle["outcomes"]["GOAL"]
    assert oracle["team_return"]["mean"] > random["team_return"]["mean"] + 2.0


def test_evaluate_counts_exactly_and_is_deterministic():
    task = blind_soccer_v0.batched_env(n_games=7)
    first = evaluate(task, blind_soccer_oracle, 20, seed=3)
    again = evaluate(task, blind_soccer_oracle, 20, seed=3)
    assert first["returns"].shape == (20, 2) and first["lengths"].shape == (20,)
    assert sum(first["outcomes"].values()) == 20
    np.testing.assert_array_equal(first["returns"], again["returns"])
    summary = first["return"]["blind"]
    assert summary["ci95"] == pytest.approx(1.96 * summary["std"] / np.sqrt(20))


def test_evaluate_accepts_environment_shells():
    env = blind_soccer_v0.parallel_env()
    result = evaluate(env, blind_soccer_oracle, 3, seed=0)
    assert result["n_episodes"] == 3 and result["agents"] == ["sighted", "blind"]
    result = evaluate(MoveToBallEnv(), move_to_ball_oracle, 3, seed=0)
    assert result["agents"] == ["player"]
    assert set(result["outcomes"]) == {"IN_GAME", "GOAL", "OUT_OF_BOUNDS", "OUT_OF_TIME"}
    assert referee.IN_GAME == 0


def test_a_team_evaluation_plays_the_games_the_oracle_is_scored_on():
    """The premise of judging a learner against the oracle on the same games
    (benchmarks/stability.py): the team VecEnv that ``evaluate_team`` builds for a seed starts the
    games the reference evaluation of that seed starts, and steps them alike."""
    from envs.registry import get_task
    from sb3_comm import make_comm_vec_env

    spec = get_task("BlindSoccer-v0")
    task = spec.batched_env(n_games=20)
    venv = make_comm_vec_env("BlindSoccer-v0", n_envs=20, seed=10_000)
    features = np.asarray(task.reset(seed=10_000))[..., :58]
    rows = venv.reset().reshape(20, 2, -1)
    np.testing.assert_array_equal(rows[..., :58], features)
    oracle = spec.reference_policies(np.random.default_rng(1))["oracle"]
    for _ in range(5):
        actions = oracle(task)
        expected = np.asarray(task.step(actions)[0])[..., :58]
        rows = venv.step(actions)[0].reshape(20, 2, -1)
        np.testing.assert_allclose(rows[..., :58], expected, atol=1e-6)


# The sighted agent's teammate block: features 58-65 of HFO's 2016 layout with one teammate.
TEAMMATE_BLOCK = slice(58, 66)


def test_hidden_from_sighted_marks_the_games_whose_sighted_agent_sees_no_teammate():
    """HFO 2016 hides a teammate at x <= 0 (SPEC §6 item 1): the games flagged hidden are exactly
    those whose sighted agent's teammate block is all zero, at reset and while the game is played."""
    task = blind_soccer_v0.batched_env(n_games=400)
    obs = np.asarray(task.reset(seed=3))
    for _ in range(2):
        hidden = hidden_from_sighted(task.state)
        block = obs[:, SIGHTED, TEAMMATE_BLOCK]
        assert 0 < hidden.sum() < 400  # about 10 % of resets
        assert not block[hidden].any()
        assert (np.abs(block[~hidden]).max(axis=1) > 0).all()
        obs = np.asarray(task.step(blind_soccer_oracle(task))[0])


def test_visible_oracle_plays_the_oracle_while_seen_and_waits_while_hidden():
    task = blind_soccer_v0.batched_env(n_games=400)
    task.reset(seed=4)
    hidden = hidden_from_sighted(task.state)
    visible, full = blind_soccer_visible_oracle(task), blind_soccer_oracle(task)
    np.testing.assert_array_equal(visible[~hidden], full[~hidden])
    np.testing.assert_array_equal(visible[:, SIGHTED], full[:, SIGHTED])
    waiting = visible[hidden, BLIND]
    assert (waiting[:, :3].argmax(axis=1) == 1).all()  # Turn
    assert not waiting[:, 3:].any()  # by 0 degrees, and no message
    assert (full[hidden, BLIND, :3].argmax(axis=1) != 1).any()  # where the oracle itself moves


def test_visible_oracle_loses_exactly_the_games_that_start_hidden():
    """A blind agent that waits where no one sees it earns nothing; elsewhere the visible oracle
    scores what the oracle scores (up to the rare game whose blind agent walks into x <= 0)."""
    n = 300
    task = blind_soccer_v0.batched_env(n_games=n)
    task.reset(seed=5)
    hidden = hidden_from_sighted(task.state)
    returns = {}
    for name, policy in (("oracle", blind_soccer_oracle), ("visible", blind_soccer_visible_oracle)):
        result = evaluate(task, policy, n, seed=5)
        assert sorted(result["games"]) == list(range(n))  # one episode per game
        returns[name] = result["returns"][np.argsort(result["games"]), 0]
    assert hidden.any()
    np.testing.assert_array_equal(returns["visible"][hidden], 0.0)
    assert returns["oracle"][hidden].mean() > 0.3  # the full-information oracle scores there
    assert abs(returns["visible"][~hidden].mean() - returns["oracle"][~hidden].mean()) < 0.01
