"""Blind Soccer (paper §6.1; dqn-hfo task ``blind_move_to_ball``; SPEC §4).

Two offense players and no defenders. The **sighted** agent (index 0) sees the HFO low-level
features but cannot move: its Dash is a no-op (it can still turn and kick). The **blind** agent
(index 1) can move, but its features are constantly zero: all it observes is the message its
teammate sent at the previous step. Both agents get the same reward, the change of the blind
agent's ball proximity,

    r_t = prox_t - prox_{t-1} = 2 (d_{t-1} - d_t) / 62.55,   d = |blind agent - ball|,

so an episode's return is the blind agent's total normalised approach to the ball. An episode
terminates when the blind agent can kick the ball (HFO's kickable test, librcsc's 1.03); it also
terminates when HFO's referee ends the game (a goal, or the ball out of bounds, which only a kick
or a collision can cause), and is truncated after ``max_steps`` = 100 steps (terminated, with
``time_feature=True``, when the agents see the remaining time).

``rules="dqn-hfo"`` ends the episode as the authors' code does (SPEC §6 item 6): when *either*
agent can kick the ball, so an episode also ends when the ball starts or rolls within the
sighted agent's reach.
"""

from __future__ import annotations

import numpy as np

from envs.soccer import physics, referee
from envs.soccer.params import ServerParams
from envs.soccer.state import SoccerState
from envs.tasks.batched import BatchedTask, check_rules, proximity

__all__ = ["BLIND", "SIGHTED", "BlindSoccerTask", "blind_proximity"]

SIGHTED, BLIND = 0, 1
"""Agent indices: the sighted sender and the blind receiver."""


def blind_proximity(state: SoccerState, params) -> np.ndarray:
    """(N,) HFO ball proximity of the blind agent, ``1 - 2 * clip(d / 62.55, 0, 1)``."""
    delta = state.pos[:, BLIND] - state.ball_pos
    return proximity(np.hypot(delta[:, 0], delta[:, 1]), params)


class BlindSoccerTask(BatchedTask):
    """Blind Soccer in ``n_games`` parallel games; agents ``["sighted", "blind"]``.

    Observation per agent: 66 HFO features (all zero for the blind agent) followed by the
    teammate's message (``channel_size`` = 4 by default): 70 entries. Action per agent: the
    8-entry HFO action followed by the outgoing message.

    :param rules: ``"paper"`` (default): the episode ends when the blind agent can kick the
        ball; ``"dqn-hfo"``: when either agent can (the authors' code).
    :param time_feature: the agents observe the remaining time and the step limit terminates the
        episode (see :class:`BatchedTask`); the observation then has 71 entries.
    :param kwargs: see :class:`BatchedTask` (``max_steps`` defaults to 100).
    """

    name = "blind_soccer_v0"
    possible_agents = ("sighted", "blind")
    default_channel_size = 4
    default_max_steps = 100
    ball_x_range = (0.0, 0.8)

    def __init__(
        self,
        n_games: int = 1,
        seed: int | None = None,
        params: ServerParams | None = None,
        noise: bool = True,
        max_steps: int | None = None,
        autoreset: bool = True,
        channel_size: int | None = None,
        ball_x_range: tuple[float, float] | None = None,
        rules: str = "paper",
        time_feature: bool = False,
    ) -> None:
        self.rules = check_rules(rules)
        super().__init__(
            n_games, seed, params, noise, max_steps, autoreset, channel_size, ball_x_range, time_feature
        )

    def _post_init(self) -> None:
        self.can_dash = np.array([False, True])  # the sighted agent cannot move

    def _features(self, state: SoccerState, out: np.ndarray) -> None:
        super()._features(state, out)
        out[:, BLIND] = 0.0  # the blind agent's features are present but constantly zero

    def _evaluate(
        self,
        previous: SoccerState,
        state: SoccerState,
        received: np.ndarray,
        outcome: np.ndarray,
        sent: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        reward = blind_proximity(state, self.params) - blind_proximity(previous, self.params)
        rewards = np.repeat(reward[:, None], 2, axis=1)  # shared by both agents
        kickable = physics.kickable(state, self.params)
        ended = kickable[:, BLIND] if self.rules == "paper" else kickable.any(axis=1)
        terminated = ended | (outcome == referee.GOAL) | (outcome == referee.OUT_OF_BOUNDS)
        return rewards, terminated
