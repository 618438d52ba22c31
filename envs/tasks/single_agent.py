"""Single-agent HFO tasks as Gymnasium environments (SPEC §4, "Single-agent HFO tasks").

One offense player, no teammates, HFO's 58 low-level features and the 8-entry HFO action. They
validate the hybrid DDPG agent against Hausknecht & Stone (ICLR 2016), whose agent learned to
score reliably on an empty goal. Each task has a batched core (:class:`MoveToBallTask`,
:class:`ScoreEmptyGoalTask`, vectorised over games like the two-agent tasks) and a thin
Gymnasium shell (:class:`MoveToBallEnv`, :class:`ScoreEmptyGoalEnv`), registered as
``HFOMoveToBall-v0`` and ``HFOScoreEmptyGoal-v0``.

Rewards, in HFO's normalised units (a distance d counts as 2 d / 62.55, the change of a
proximity ``1 - 2 d / 62.55``), following the reward of HFO's DDPG agent:

* move to ball: ball-proximity change, +1 the first time the player can kick the ball.
  Terminates when it can (or on a goal / out of bounds); truncated after 100 steps.
* score on an empty goal: ball-proximity change, +1 the first time the player can kick the ball,
  3 x the decrease of the ball-to-goal-centre distance while the player is in possession of the
  ball, +5 for a goal. "In possession" is HFO's player-on-ball: the last player that could kick
  the ball; with one player, every step from the one at which it first could kick the ball, so
  the kick itself is rewarded as the ball flies towards the goal. Terminates on a goal or when
  the ball leaves the field; truncated when the ball stays untouched for 100 cycles (HFO's
  rule) or after 500 steps. The ball starts in HFO's default range, x in [0, 0.2] * 52.5.
"""

from __future__ import annotations

from typing import Any, ClassVar, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from envs.soccer import physics, referee
from envs.soccer.params import ServerParams
from envs.soccer.state import SoccerState
from envs.tasks.batched import BatchedTask, proximity
from envs.tasks.hfo_actions import ACTION_HIGH, ACTION_LOW, HYBRID_LAYOUT, N_HFO_ACTION

__all__ = [
    "GOAL_BONUS",
    "GOAL_CENTRE",
    "GOAL_DISTANCE_WEIGHT",
    "KICKABLE_BONUS",
    "SINGLE_AGENT_TASKS",
    "MoveToBallEnv",
    "MoveToBallTask",
    "ScoreEmptyGoalEnv",
    "ScoreEmptyGoalTask",
]

GOAL_CENTRE = np.array([52.5, 0.0])
KICKABLE_BONUS = 1.0
"""Reward the first time the player can kick the ball."""
GOAL_DISTANCE_WEIGHT = 3.0
"""Weight of the ball-to-goal proximity change while the player has the ball."""
GOAL_BONUS = 5.0
"""Reward for a goal."""


def _ball_proximity(state: SoccerState, params: ServerParams) -> np.ndarray:
    delta = state.pos[:, 0] - state.ball_pos
    return proximity(np.hypot(delta[:, 0], delta[:, 1]), params)


def _goal_proximity(state: SoccerState, params: ServerParams) -> np.ndarray:
    delta = state.ball_pos - GOAL_CENTRE
    return proximity(np.hypot(delta[:, 0], delta[:, 1]), params)


class MoveToBallTask(BatchedTask):
    """Batched *move to ball*: one agent (``"player"``), 58 features, 8-entry HFO action."""

    name = "hfo_move_to_ball"
    possible_agents = ("player",)
    default_channel_size = 0
    default_max_steps = 100
    ball_x_range = (0.0, 0.8)

    def _post_init(self) -> None:
        self._got_kickable = np.zeros(self.n_games, dtype=bool)
        """(N,) the player could kick the ball at some step of the episode (HFO's possession)."""

    def _on_reset(self, games: np.ndarray) -> None:
        self._got_kickable[games] = False

    def _kickable_bonus(self, state: SoccerState) -> tuple[np.ndarray, np.ndarray]:
        kickable = physics.kickable(state, self.params)[:, 0]
        first = kickable & ~self._got_kickable
        self._got_kickable |= kickable
        return kickable, KICKABLE_BONUS * first

    def _evaluate(
        self,
        previous: SoccerState,
        state: SoccerState,
        received: np.ndarray,
        outcome: np.ndarray,
        sent: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        kickable, bonus = self._kickable_bonus(state)
        reward = _ball_proximity(state, self.params) - _ball_proximity(previous, self.params) + bonus
        terminated = kickable | (outcome == referee.GOAL) | (outcome == referee.OUT_OF_BOUNDS)
        return reward[:, None], terminated


class ScoreEmptyGoalTask(MoveToBallTask):
    """Batched *score on an empty goal*: one agent (``"player"``), 58 features, 8-entry HFO action."""

    name = "hfo_score_empty_goal"
    default_max_steps = 500
    ball_x_range = (0.0, 0.2)
    untouched_cycles = 100

    def _evaluate(
        self,
        previous: SoccerState,
        state: SoccerState,
        received: np.ndarray,
        outcome: np.ndarray,
        sent: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        _, bonus = self._kickable_bonus(state)
        reward = _ball_proximity(state, self.params) - _ball_proximity(previous, self.params) + bonus
        ball_to_goal = _goal_proximity(state, self.params) - _goal_proximity(previous, self.params)
        reward += GOAL_DISTANCE_WEIGHT * np.where(self._got_kickable, ball_to_goal, 0.0)
        goal = outcome == referee.GOAL
        reward += GOAL_BONUS * goal
        terminated = goal | (outcome == referee.OUT_OF_BOUNDS)
        return reward[:, None], terminated


class _SingleAgentEnv(gym.Env):
    """Gymnasium shell over one game of a one-agent batched task."""

    task_class: ClassVar[type[BatchedTask]]
    metadata: ClassVar[dict[str, Any]] = {
        "render_modes": ["rgb_array"],
        "render_fps": 10,
        "hybrid_action": HYBRID_LAYOUT,
    }

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}.")
        for imposed in ("n_games", "autoreset", "channel_size"):
            if imposed in kwargs:
                raise TypeError(f"{imposed!r} is fixed by the single-game environment.")
        self.render_mode = render_mode
        self.task = self.task_class(n_games=1, autoreset=False, **kwargs)
        self.hybrid_layout = HYBRID_LAYOUT
        self.observation_space = spaces.Box(
            self.task.observation_low, self.task.observation_high, dtype=np.float32
        )
        self.action_space = spaces.Box(ACTION_LOW, ACTION_HIGH, dtype=np.float32)

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        """Start an episode; a ``seed`` re-creates the task's generator."""
        super().reset(seed=seed)
        obs = self.task.reset(seed=seed)
        return obs[0, 0].copy(), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict]:
        """Execute one HFO action (8 entries: 3 scores, 5 parameters).

        :raises ValueError: on a wrong shape or a NaN / infinite entry.
        """
        try:
            action = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError) as err:
            raise ValueError(f"The action must be numeric with shape ({N_HFO_ACTION},).") from err
        if action.shape != (N_HFO_ACTION,):
            raise ValueError(
                f"The action of agent 'player' has shape {action.shape}, expected ({N_HFO_ACTION},)."
            )
        obs, rewards, terminated, truncated, info = self.task.step(action[None, None])
        step_info = {"outcome": int(info["outcome"][0])}
        return obs[0, 0].copy(), float(rewards[0, 0]), bool(terminated[0]), bool(truncated[0]), step_info

    def render(self) -> np.ndarray | None:
        """An RGB frame of the game when ``render_mode="rgb_array"``."""
        if self.render_mode is None:
            return None
        return self.task.render(0)


class MoveToBallEnv(_SingleAgentEnv):
    """HFO *move to ball* (``HFOMoveToBall-v0``).

    :param render_mode: ``None`` or ``"rgb_array"``.
    :param kwargs: ``seed``, ``params``, ``noise``, ``max_steps`` (100), ``ball_x_range``.
    """

    task_class = MoveToBallTask


class ScoreEmptyGoalEnv(_SingleAgentEnv):
    """HFO *score on an empty goal* (``HFOScoreEmptyGoal-v0``).

    :param render_mode: ``None`` or ``"rgb_array"``.
    :param kwargs: ``seed``, ``params``, ``noise``, ``max_steps`` (500), ``ball_x_range``.
    """

    task_class = ScoreEmptyGoalTask


SINGLE_AGENT_TASKS: dict[str, type[BatchedTask]] = {
    "HFOMoveToBall-v0": MoveToBallTask,
    "HFOScoreEmptyGoal-v0": ScoreEmptyGoalTask,
}
"""The batched core of each single-agent Gymnasium id (``sb3_comm.make_comm_vec_env`` steps all
games of one in a single call)."""
