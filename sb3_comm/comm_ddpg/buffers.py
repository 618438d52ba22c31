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
import torch as th
from gymnasium import spaces

from sb3_comm.common.buffers import MonteCarloReplayBuffer
from sb3_comm.common.buffers import MonteCarloReplayBufferSamples as JointReplayBufferSamples

__all__ = ["JointReplayBuffer", "JointReplayBufferSamples"]


class JointReplayBuffer(MonteCarloReplayBuffer):
    """Replay of joint transitions of ``n_envs`` parallel games; agent rows on axis 1 of a sample.

    :param buffer_size: number of transitions kept (over all envs, as in SB3).
    :param observation_space: stacked rows ``(n_agents, obs_dim)``.
    :param action_space: stacked rows ``(n_agents, action_dim)``.
    :param device: torch device of the samples.
    :param n_envs: number of parallel games.
    :param n_agents: agents per game.
    :param gamma: discount for the Monte-Carlo returns.
    :param store_mc_returns: keep Monte-Carlo returns (needed when β > 0).
    :param handle_timeout_termination: a truncated episode is not a terminal state (SB3 default).
    :param optimize_memory_usage: not supported (SB3 passes it; True raises).
    """

    def __init__(
        self,
        buffer_size: int,
        observation_space: spaces.Space,
        action_space: spaces.Space,
        device: th.device | str = "auto",
        n_envs: int = 1,
        n_agents: int = 2,
        gamma: float = 0.99,
        store_mc_returns: bool = False,
        handle_timeout_termination: bool = True,
        optimize_memory_usage: bool = False,
    ) -> None:
        self.n_agents = n_agents
        super().__init__(
            buffer_size,
            observation_space,
            action_space,
            device,
            n_envs=n_envs,
            gamma=gamma,
            store_mc_returns=store_mc_returns,
            handle_timeout_termination=handle_timeout_termination,
            optimize_memory_usage=optimize_memory_usage,
        )

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
