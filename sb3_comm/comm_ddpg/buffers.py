"""A replay buffer that keeps the agents of one game together.

Every transition stores the agents' rows side by side (``(n_agents, width)``), so one sample
yields the joint tuple the methods need: the sender's observation, the teammate's action and
reward (GSN), and the teammate's next observation (TCG). Rewards are per agent, read from the
``agent_rewards`` entry that the two-agent wrappers put in each step's info. Monte-Carlo returns
are kept per agent, as in :class:`~sb3_comm.common.buffers.MonteCarloReplayBuffer`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from sb3_comm.common.buffers import MonteCarloReplayBuffer
from sb3_comm.common.buffers import MonteCarloReplayBufferSamples as JointReplayBufferSamples

__all__ = ["JointReplayBuffer", "JointReplayBufferSamples"]


class JointReplayBuffer(MonteCarloReplayBuffer):
    """Replay of joint transitions of ``n_envs`` parallel games; agent rows on axis 1 of a sample.

    Takes the arguments of :class:`~sb3_comm.common.buffers.MonteCarloReplayBuffer` (its
    observation and action spaces are the stacked rows ``(n_agents, obs_dim)`` and
    ``(n_agents, action_dim)``), plus:

    :param n_agents: agents per game.
    """

    def __init__(self, *args: Any, n_agents: int = 2, **kwargs: Any) -> None:
        self.n_agents = n_agents  # read by _rows() while the base class allocates the storage
        super().__init__(*args, **kwargs)

    @property
    def reward_width(self) -> int:
        """One reward per agent."""
        return self.n_agents

    def _rows(self, space: spaces.Space) -> tuple[int, ...]:
        return (self.n_agents, int(np.prod(space.shape)) // self.n_agents)

    def step_rewards(self, reward: np.ndarray, infos: list[dict[str, Any]]) -> np.ndarray:
        """Per-agent rewards ``(n_envs, n_agents)`` from ``infos[i]["agent_rewards"]``."""
        try:
            return np.asarray([info["agent_rewards"] for info in infos], dtype=np.float32)
        except KeyError as error:
            raise KeyError(
                "JointReplayBuffer needs per-agent rewards in info['agent_rewards']; wrap the "
                "environment with sb3_comm.wrappers.TwoAgentEnv or BatchedTwoAgentVecEnv"
            ) from error
