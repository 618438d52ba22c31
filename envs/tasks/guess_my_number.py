"""Guess My Number (paper §7.1; dqn-hfo task ``say_my_tid``; SPEC §4).

Each agent i owns a fixed hidden number h_i in [-1, 1] (default -0.8 for ``agent_0`` and +0.8
for ``agent_1``, as in the authors' code), shown in its own observation right after the 66 HFO
features. The channel carries one value. The reward of agent i depends only on the message m^(j)
its teammate sent at the previous step (the one in agent i's observation when it acts),

    r_t^(i) = 0.1 * exp(-50 * (h_i - m_{t-1}^(j))^2),

and the soccer world runs alongside without any effect on the reward. Episodes are truncated
after ``max_steps`` = 100 steps; the referee never ends them (a ball out of bounds keeps
rolling). At the first step the received message is 0, so the maximum return is one near-zero
reward (0.1 * exp(-50 h^2), 1.3e-15 for |h| = 0.8) plus 99 rewarded steps of 0.1: about 9.9
(the paper's "maximum achievable reward is 10").

``rules="dqn-hfo"`` runs the task as the authors' code does (SPEC §6 items 6, 7): the reward
uses the message the teammate sends at the same step, r_t^(i) = 0.1 exp(-50 (h_i - m_t^(j))^2)
(maximum return 10.0), and HFO's referee ends an episode on any status other than IN_GAME (a
goal, or the ball out of bounds).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from envs.soccer import referee
from envs.soccer.params import ServerParams
from envs.soccer.state import SoccerState
from envs.tasks.batched import BatchedTask, check_rules

__all__ = ["ALPHA", "BETA", "GuessMyNumberTask", "guess_reward"]

ALPHA, BETA = 0.1, 50.0
"""Magnitude and decay of the Guess My Number reward (paper §7.1)."""


def guess_reward(hidden: np.ndarray, received: np.ndarray) -> np.ndarray:
    """``ALPHA * exp(-BETA * (hidden - received)^2)``: the reward for hearing ``received``."""
    return ALPHA * np.exp(-BETA * np.square(hidden - received))


class GuessMyNumberTask(BatchedTask):
    """Guess My Number in ``n_games`` parallel games; agents ``["agent_0", "agent_1"]``.

    Observation per agent: 66 HFO features, its own hidden number, the teammate's message
    (68 entries with the default channel of 1). Only the first entry of the received message
    enters the reward when ``channel_size`` > 1.

    :param hidden_numbers: the two hidden numbers, each in [-1, 1].
    :param rules: ``"paper"`` (default): reward for the teammate's previous message, only the
        time limit ends an episode; ``"dqn-hfo"``: reward for the message sent in the same step,
        and HFO's referee ends episodes (the authors' code).
    :param time_feature: the agents observe the remaining time (after the hidden number) and the
        step limit terminates the episode (see :class:`BatchedTask`).
    :param kwargs: see :class:`BatchedTask` (``max_steps`` defaults to 100, ``channel_size`` to 1).
    """

    name = "guess_my_number_v0"
    possible_agents = ("agent_0", "agent_1")
    default_channel_size = 1
    default_max_steps = 100

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
        hidden_numbers: Sequence[float] = (-0.8, 0.8),
        rules: str = "paper",
        time_feature: bool = False,
    ) -> None:
        self.rules = check_rules(rules)
        hidden = np.asarray(hidden_numbers, dtype=np.float64)
        if hidden.shape != (2,) or not np.all(np.isfinite(hidden)) or np.any(np.abs(hidden) > 1.0):
            raise ValueError(f"hidden_numbers must be two numbers in [-1, 1], got {hidden_numbers!r}.")
        self.hidden_numbers = hidden
        if channel_size is not None and int(channel_size) < 1:
            raise ValueError("Guess My Number needs a channel: channel_size must be >= 1.")
        super().__init__(
            n_games, seed, params, noise, max_steps, autoreset, channel_size, ball_x_range, time_feature
        )

    def _extra_observation(self) -> np.ndarray:
        return self.hidden_numbers.astype(np.float32)[:, None]  # agent i sees h_i

    def _judge(self, previous: SoccerState, state: SoccerState) -> np.ndarray:
        if self.rules == "dqn-hfo":
            return super()._judge(previous, state)
        return np.full(state.n_games, referee.IN_GAME, dtype=np.int64)  # only the time limit ends a game

    def _evaluate(
        self,
        previous: SoccerState,
        state: SoccerState,
        received: np.ndarray,
        outcome: np.ndarray,
        sent: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        if self.rules == "paper":  # the teammate's message of the previous step, m_{t-1}
            heard = received[..., 0]
            terminated = np.zeros(state.n_games, dtype=bool)
        else:  # dqn-hfo: the teammate's message of this step, m_t; any end of play ends it
            heard = sent[:, self._teammate, 0]
            terminated = (outcome == referee.GOAL) | (outcome == referee.OUT_OF_BOUNDS)
        rewards = guess_reward(self.hidden_numbers[None, :], heard.astype(np.float64))
        return rewards, terminated
