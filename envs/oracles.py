"""Scripted reference policies and a batched evaluation loop.

The oracles read the true world state (``task.state``), which no learning agent sees: their
returns measure what the tasks allow, and every learned result is reported as a fraction of them
(SPEC §4, §5). A policy here is a function ``policy(task) -> actions`` of shape
(n_games, n_agents, action_size); learned policies read ``task.obs``.

* :func:`blind_soccer_oracle`: the blind agent steered by the true ball position (turn towards
  the ball when it is off by more than a few degrees, otherwise dash at full power); the sighted
  agent does nothing useful; messages are zero.
* :func:`guess_my_number_oracle`: each agent sends its teammate's hidden number.
* :func:`move_to_ball_oracle`, :func:`empty_goal_oracle`: the single-agent tasks.
* :func:`blind_soccer_visible_oracle`: the Blind Soccer oracle limited to what the sighted agent
  sees: steered by the true ball position while the blind agent is in the sighted agent's
  features, waiting while HFO 2016's teammate filter hides it (x <= 0).
* :func:`blind_dash_forward`: a communication-free Blind Soccer baseline (the blind agent dashes
  straight ahead, what the paper's GSN policy did with its messages disabled).
* :func:`random_policy`: uniform in the action bounds.
* :func:`evaluate`: mean returns over a fixed number of episodes, without the bias towards short
  episodes that "first episodes to finish" would have.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from envs.soccer import physics, referee
from envs.soccer.state import SoccerState
from envs.tasks.batched import BatchedTask
from envs.tasks.blind_soccer import BLIND, SIGHTED
from envs.tasks.hfo_actions import N_HFO_ACTION

__all__ = [
    "TURN_THRESHOLD",
    "blind_dash_forward",
    "blind_soccer_oracle",
    "blind_soccer_visible_oracle",
    "empty_goal_oracle",
    "evaluate",
    "guess_my_number_oracle",
    "hidden_from_sighted",
    "move_to_ball_oracle",
    "random_policy",
    "steer_to_ball",
]

Policy = Callable[[BatchedTask], np.ndarray]

TURN_THRESHOLD = 10.0
"""Degrees: a scripted player turns towards its target when it is off by more than this."""

_GOAL_CENTRE = np.array([52.5, 0.0])
_DASH, _TURN, _KICK = 0, 1, 2


def _relative_angle(state: SoccerState, player: int, target: np.ndarray) -> np.ndarray:
    """(N,) direction of ``target`` (N, 2) seen from where ``player`` will be after its current
    velocity has carried it one cycle, relative to its body, in [-180, 180)."""
    origin = state.pos[:, player] + state.vel[:, player]
    rel = target - origin
    angle = np.degrees(np.arctan2(rel[:, 1], rel[:, 0])) - state.body[:, player]
    return (angle + 180.0) % 360.0 - 180.0


def _hfo_action(n: int, kind: np.ndarray) -> np.ndarray:
    """(n, 8) HFO actions whose scores select ``kind`` (parameters zero)."""
    action = np.zeros((n, N_HFO_ACTION))
    action[:, :3] = -1.0
    action[np.arange(n), kind] = 1.0
    return action


def steer_to_ball(state: SoccerState, player: int, threshold: float = TURN_THRESHOLD) -> np.ndarray:
    """(N, 8) HFO actions taking ``player`` to the ball: turn towards the ball (where it will be
    next cycle) when it is off by more than ``threshold`` degrees, otherwise dash at full power."""
    target = state.ball_pos + state.ball_vel
    angle = _relative_angle(state, player, target)
    turn = np.abs(angle) > threshold
    action = _hfo_action(state.n_games, np.where(turn, _TURN, _DASH))
    action[:, 3] = 100.0  # dash power
    action[:, 5] = angle  # turn direction (the decoder pre-scales it with the speed)
    return action


def blind_soccer_oracle(task: BatchedTask, threshold: float = TURN_THRESHOLD) -> np.ndarray:
    """Full-information Blind Soccer policy: the blind agent runs to the true ball position.

    The sighted agent turns by 0 degrees (it cannot dash anyway) and both messages are zero, so
    the oracle needs no communication at all. Its return bounds what a protocol can reach, but no
    protocol reaches it: in the games whose blind agent HFO 2016's features hide from the sighted
    agent (x <= 0) nothing can be told (:func:`blind_soccer_visible_oracle`).
    """
    actions = np.zeros((task.n_games, task.n_players, task.action_size))
    actions[:, SIGHTED, :N_HFO_ACTION] = _hfo_action(task.n_games, np.full(task.n_games, _TURN))
    actions[:, BLIND, :N_HFO_ACTION] = steer_to_ball(task.state, BLIND, threshold)
    return actions


def hidden_from_sighted(state: SoccerState) -> np.ndarray:
    """(N,) whether the blind agent is missing from the sighted agent's features in each game.

    HFO 2016's low-level extractor skips a teammate whose x <= 0 (``teammate->pos().x > 0`` in
    ``ExtractFeatures``; SPEC §6 item 1), as :mod:`envs.soccer.features` does: the sighted agent
    then sees nothing of the blind agent, and no message can tell the blind agent where the ball
    is relative to it.
    """
    return state.pos[:, BLIND, 0] <= 0.0


def blind_soccer_visible_oracle(task: BatchedTask, threshold: float = TURN_THRESHOLD) -> np.ndarray:
    """Blind Soccer's oracle limited to what the sighted agent sees.

    While the sighted agent sees the blind agent (:func:`hidden_from_sighted` is False), the blind
    agent runs to the true ball position as with :func:`blind_soccer_oracle`; while it is hidden
    (x <= 0), it waits (turns by 0), since nothing the sighted agent sees says where to go. Dashing
    ahead instead scores lower (a random heading walks away from the ball as often as towards it).
    It is the return of a protocol that conveys everything the sighted agent sees, at once (real
    messages arrive a step later): a reference for what communication can reach, which the
    full-information oracle's return overstates by the games whose blind agent starts hidden
    (about 10 % of resets; ``benchmarks/hidden_teammate.py``). It is neither a bound nor a
    learned policy: a team could search for the visible half-field (dash, and turn back while the
    sighted agent still cannot see it), which this reference does not try.
    """
    actions = blind_soccer_oracle(task, threshold)
    hidden = hidden_from_sighted(task.state)
    n_hidden = int(hidden.sum())
    if n_hidden:
        actions[hidden, BLIND, :N_HFO_ACTION] = _hfo_action(n_hidden, np.full(n_hidden, _TURN))
    return actions


def blind_dash_forward(task: BatchedTask) -> np.ndarray:
    """Blind Soccer without communication: the blind agent dashes straight ahead at full power
    (the sighted agent turns by 0, messages are zero)."""
    actions = np.zeros((task.n_games, task.n_players, task.action_size))
    actions[:, SIGHTED, :N_HFO_ACTION] = _hfo_action(task.n_games, np.full(task.n_games, _TURN))
    actions[:, BLIND, :N_HFO_ACTION] = _hfo_action(task.n_games, np.full(task.n_games, _DASH))
    actions[:, BLIND, 3] = 100.0
    return actions


def guess_my_number_oracle(task: BatchedTask) -> np.ndarray:
    """Guess My Number policy: each agent sends its teammate's hidden number (and turns by 0)."""
    hidden = np.asarray(task.hidden_numbers)
    actions = np.zeros((task.n_games, task.n_players, task.action_size))
    actions[..., :N_HFO_ACTION] = _hfo_action(1, np.array([_TURN]))[0]
    actions[:, :, N_HFO_ACTION] = hidden[::-1]  # agent i tells its teammate j its number h_j
    return actions


def move_to_ball_oracle(task: BatchedTask, threshold: float = TURN_THRESHOLD) -> np.ndarray:
    """Single-agent move-to-ball policy: turn towards the ball, then dash at full power."""
    return steer_to_ball(task.state, 0, threshold)[:, None, :]


def empty_goal_oracle(task: BatchedTask, threshold: float = TURN_THRESHOLD) -> np.ndarray:
    """Single-agent empty-goal policy: go to the ball; when it is kickable, kick it at full power
    towards the goal centre (and follow it for the next kick when it falls short)."""
    state = task.state
    action = steer_to_ball(state, 0, threshold)
    kickable = physics.kickable(state, task.params)[:, 0]
    if kickable.any():
        # the kick accelerates the ball along body + direction: aim from the ball at the goal
        rel = _GOAL_CENTRE - state.ball_pos
        aim = np.degrees(np.arctan2(rel[:, 1], rel[:, 0])) - state.body[:, 0]
        aim = (aim + 180.0) % 360.0 - 180.0
        kick = _hfo_action(state.n_games, np.full(state.n_games, _KICK))
        kick[:, 6] = 100.0
        kick[:, 7] = aim
        action = np.where(kickable[:, None], kick, action)
    return action[:, None, :]


def random_policy(task: BatchedTask, rng: np.random.Generator) -> np.ndarray:
    """Actions drawn uniformly in the task's action bounds (scores, parameters and messages)."""
    shape = (task.n_games, task.n_players, task.action_size)
    return rng.uniform(task.action_low, task.action_high, size=shape)


def _summary(values: np.ndarray) -> dict[str, float]:
    n = values.shape[0]
    std = float(values.std(ddof=1)) if n > 1 else 0.0
    return {
        "mean": float(values.mean()),
        "std": std,
        "ci95": 1.96 * std / math.sqrt(n),
        "min": float(values.min()),
        "max": float(values.max()),
    }


def evaluate(
    task_or_env: Any,
    policy: Policy,
    n_episodes: int,
    seed: int | None = None,
) -> dict[str, Any]:
    """Run ``n_episodes`` episodes of ``policy`` and summarise the returns.

    The episodes are split among the task's games in advance (game g plays its first k_g
    episodes, sum k_g = ``n_episodes``), so that short episodes are not over-represented.

    :param task_or_env: a :class:`BatchedTask`, or one of the environment shells (its batched
        core ``.task`` is stepped directly; reset the shell afterwards).
    :param policy: ``policy(task) -> actions`` (n_games, n_agents, action_size).
    :param n_episodes: number of episodes.
    :param seed: seed of the task's resets and physics.
    :return: ``agents`` (names), per agent ``return[agent]`` = {mean, std, ci95, min, max},
        ``team_return`` (summary of the agents' mean return per episode; for Blind Soccer's shared
        reward it equals each agent's), ``length`` (summary of episode lengths), ``outcomes``
        (count per referee code name; a Blind Soccer success is ``IN_GAME``), ``terminated``
        (episodes that ended by termination rather than truncation), the raw ``returns``
        (n_episodes, n_agents) and ``lengths`` (n_episodes,) arrays, in the order the episodes
        ended, and ``games`` (n_episodes,), the game each was played in (with one episode per game,
        ``returns[np.argsort(games)]`` lists them game by game).
    """
    task: BatchedTask = getattr(task_or_env, "task", task_or_env)
    if n_episodes < 1:
        raise ValueError(f"n_episodes must be >= 1, got {n_episodes}.")
    n, p = task.n_games, task.n_players
    quota = np.full(n, n_episodes // n)
    quota[: n_episodes % n] += 1
    done_count = np.zeros(n, dtype=np.int64)
    running = np.zeros((n, p))
    returns, lengths, outcomes, terminal, games = [], [], [], [], []

    task.reset(seed=seed)
    while (done_count < quota).any():
        _, rewards, terminated, truncated, info = task.step(policy(task))
        running += rewards
        done = terminated | truncated
        if done.any():
            keep = np.flatnonzero(done & (done_count < quota))
            returns.append(running[keep].copy())
            lengths.append(info["episode_length"][keep].copy())
            outcomes.append(info["outcome"][keep].copy())
            terminal.append(terminated[keep].copy())
            games.append(keep)
            done_count += done
            running[done] = 0.0
            if not task.autoreset:
                task.reset_games(done)

    ret = np.concatenate(returns)
    length = np.concatenate(lengths).astype(np.int64)
    outcome = np.concatenate(outcomes)
    names = {
        referee.IN_GAME: "IN_GAME",
        referee.GOAL: "GOAL",
        referee.OUT_OF_BOUNDS: "OUT_OF_BOUNDS",
        referee.OUT_OF_TIME: "OUT_OF_TIME",
    }
    return {
        "n_episodes": int(ret.shape[0]),
        "agents": list(task.possible_agents),
        "return": {agent: _summary(ret[:, i]) for i, agent in enumerate(task.possible_agents)},
        "team_return": _summary(ret.mean(axis=1)),
        "length": _summary(length.astype(np.float64)),
        "outcomes": {name: int((outcome == code).sum()) for code, name in names.items()},
        "terminated": int(np.concatenate(terminal).sum()),
        "returns": ret,
        "lengths": length,
        "games": np.concatenate(games),
    }
