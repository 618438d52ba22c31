"""A replay buffer that keeps the agents of one game together.

Every transition stores both agents' rows side by side (``(n_agents, width)``), so one sample
yields the joint tuple the methods need: the sender's observation, the teammate's action and
reward (GSN), and the teammate's next observation (TCG). Rewards are per agent, read from the
``agent_rewards`` entry that the two-agent wrappers put in each step's info.

Optionally the buffer also keeps each transition's Monte-Carlo return ``G_t`` (filled in when the
episode ends), for the critic target mixing of the reference DDPG: ``y = β·G + (1 − β)·y_TD``.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.buffers import BaseBuffer
from stable_baselines3.common.vec_env import VecNormalize

__all__ = ["JointReplayBuffer", "JointReplayBufferSamples"]


class JointReplayBufferSamples(NamedTuple):
    """A batch of joint transitions; agent rows on axis 1."""

    observations: th.Tensor  # (B, n_agents, obs_dim)
    actions: th.Tensor  # (B, n_agents, action_dim), scaled to [-1, 1]
    next_observations: th.Tensor  # (B, n_agents, obs_dim)
    dones: th.Tensor  # (B, 1): 1 if the episode terminated (not truncated)
    rewards: th.Tensor  # (B, n_agents)
    mc_returns: th.Tensor  # (B, n_agents); valid where mc_valid is 1
    mc_valid: th.Tensor  # (B, 1)


class JointReplayBuffer(BaseBuffer):
    """Replay of joint transitions of ``n_envs`` parallel games.

    :param buffer_size: number of transitions kept (over all envs, as in SB3).
    :param observation_space: stacked rows ``(n_agents, obs_dim)`` (or ``(obs_dim,)`` for one agent).
    :param action_space: stacked rows ``(n_agents, action_dim)`` (or ``(action_dim,)``).
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
        if optimize_memory_usage:
            raise ValueError("JointReplayBuffer does not support optimize_memory_usage=True")
        super().__init__(buffer_size, observation_space, action_space, device, n_envs=n_envs)
        self.buffer_size = max(buffer_size // n_envs, 1)
        self.n_agents = n_agents
        self.gamma = gamma
        self.store_mc_returns = store_mc_returns
        self.handle_timeout_termination = handle_timeout_termination
        obs_width = int(np.prod(observation_space.shape)) // n_agents
        act_width = int(np.prod(action_space.shape)) // n_agents
        shape = (self.buffer_size, n_envs, n_agents)
        self.observations = np.zeros((*shape, obs_width), dtype=np.float32)
        self.next_observations = np.zeros((*shape, obs_width), dtype=np.float32)
        self.actions = np.zeros((*shape, act_width), dtype=np.float32)
        self.rewards = np.zeros(shape, dtype=np.float32)
        self.dones = np.zeros((self.buffer_size, n_envs), dtype=np.float32)
        self.timeouts = np.zeros((self.buffer_size, n_envs), dtype=np.float32)
        self.mc_returns = np.zeros(shape, dtype=np.float32)
        self.mc_valid = np.zeros((self.buffer_size, n_envs), dtype=np.float32)
        self._episode_positions: list[list[int]] = [[] for _ in range(n_envs)]

    def add(
        self,
        obs: np.ndarray,
        next_obs: np.ndarray,
        action: np.ndarray,
        reward: np.ndarray,
        done: np.ndarray,
        infos: list[dict[str, Any]],
    ) -> None:
        """Store one step of every env; per-agent rewards come from ``infos[i]["agent_rewards"]``."""
        p = self.pos
        rows = (self.n_envs, self.n_agents, -1)
        self.observations[p] = np.asarray(obs).reshape(rows)
        self.next_observations[p] = np.asarray(next_obs).reshape(rows)
        self.actions[p] = np.asarray(action).reshape(rows)
        if self.n_agents == 1:
            self.rewards[p] = np.asarray(reward, dtype=np.float32).reshape(self.n_envs, 1)
        else:
            try:
                self.rewards[p] = [info["agent_rewards"] for info in infos]
            except KeyError as error:
                raise KeyError(
                    "JointReplayBuffer needs per-agent rewards in info['agent_rewards']; wrap the "
                    "environment with sb3_comm.wrappers.TwoAgentEnv or BatchedTwoAgentVecEnv"
                ) from error
        self.dones[p] = done
        self.mc_valid[p] = 0.0
        if self.handle_timeout_termination:
            self.timeouts[p] = [info.get("TimeLimit.truncated", False) for info in infos]
        if self.store_mc_returns:
            self._track_episodes(p, np.asarray(done))
        self.pos += 1
        if self.pos == self.buffer_size:
            self.full = True
            self.pos = 0

    def _track_episodes(self, position: int, done: np.ndarray) -> None:
        """Fill the Monte-Carlo returns of every episode that ended at this step."""
        for env in range(self.n_envs):
            self._episode_positions[env].append(position)
            if done[env]:
                running = np.zeros(self.n_agents, dtype=np.float32)
                for p in reversed(self._episode_positions[env]):
                    running = self.rewards[p, env] + self.gamma * running
                    self.mc_returns[p, env] = running
                    self.mc_valid[p, env] = 1.0
                self._episode_positions[env] = []

    def sample(self, batch_size: int, env: VecNormalize | None = None) -> JointReplayBufferSamples:
        """Uniform sample of ``batch_size`` joint transitions (game and step drawn uniformly)."""
        upper = self.buffer_size if self.full else self.pos
        batch_inds = np.random.randint(0, upper, size=batch_size)
        return self._get_samples(batch_inds, env)

    def _get_samples(
        self, batch_inds: np.ndarray, env: VecNormalize | None = None
    ) -> JointReplayBufferSamples:
        env_inds = np.random.randint(0, high=self.n_envs, size=(len(batch_inds),))
        dones = self.dones[batch_inds, env_inds] * (1.0 - self.timeouts[batch_inds, env_inds])
        data = (
            self.observations[batch_inds, env_inds],
            self.actions[batch_inds, env_inds],
            self.next_observations[batch_inds, env_inds],
            dones.reshape(-1, 1),
            self.rewards[batch_inds, env_inds],
            self.mc_returns[batch_inds, env_inds],
            self.mc_valid[batch_inds, env_inds].reshape(-1, 1),
        )
        return JointReplayBufferSamples(*(self.to_torch(array) for array in data))
