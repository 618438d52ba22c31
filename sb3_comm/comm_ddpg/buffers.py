"""A replay buffer that keeps the agents of one game together.

Every transition stores the agents' rows side by side (``(n_agents, width)``), so one sample
yields the joint tuple the methods need: the sender's observation, the teammate's action and
reward (GSN), and the teammate's next observation (TCG). Rewards are per agent, read from the
``agent_rewards`` entry that the two-agent wrappers put in each step's info. Monte-Carlo returns
are kept per agent, as in :class:`~sb3_comm.common.buffers.MonteCarloReplayBuffer`.

Messages that are a function of the sender's observation (GSN's ``m = M(o)``) can be **relabelled**
at sample time: the buffer knows where each transition's previous step lies, so a
:data:`MessageRelabeler` (set by :class:`~sb3_comm.CommDDPG` with ``relabel_messages``) can replace
the heard messages stored at acting time by what the current message network sends for the same
observations. Without it, replayed observations carry messages of the GSN as it was when they were
stored, up to a buffer's length ago.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecNormalize

from sb3_comm.common.buffers import MonteCarloReplayBuffer
from sb3_comm.common.buffers import MonteCarloReplayBufferSamples as JointReplayBufferSamples

__all__ = ["JointReplayBuffer", "JointReplayBufferSamples", "MessageRelabeler"]

MessageRelabeler = Callable[[th.Tensor, th.Tensor, th.Tensor, th.Tensor], tuple[th.Tensor, th.Tensor]]
"""``(observations, next_observations, previous_observations, has_previous) -> (observations,
next_observations)`` with the heard messages recomputed; ``previous_observations`` are the rows of
each transition's previous step in the same game, valid where ``has_previous`` is 1."""


class JointReplayBuffer(MonteCarloReplayBuffer):
    """Replay of joint transitions of ``n_envs`` parallel games; agent rows on axis 1 of a sample.

    Takes the arguments of :class:`~sb3_comm.common.buffers.MonteCarloReplayBuffer` (its
    observation and action spaces are the stacked rows ``(n_agents, obs_dim)`` and
    ``(n_agents, action_dim)``), plus:

    :param n_agents: agents per game.
    :param explorer_envs: GSN-MAX's *explorer games*: the last ``explorer_envs`` of the parallel
        games send random messages for its effect model; :meth:`sample` (the agents' and the GSN's
        batches) draws from the other games only, :meth:`sample_explorers` from these only.
    """

    message_relabeler: MessageRelabeler | None = None
    """Recomputes the heard messages of every sample (None: as stored). Not saved with the buffer."""
    episode_starts: np.ndarray | None = None  # None in buffers pickled before it existed

    explorer_envs: int = 0  # 0 in buffers pickled before it existed

    def __init__(
        self,
        *args: Any,
        n_agents: int = 2,
        shared_reward: bool = False,
        explorer_envs: int = 0,
        **kwargs: Any,
    ) -> None:
        self.n_agents = n_agents  # read by _rows() while the base class allocates the storage
        self.shared_reward = bool(shared_reward)
        """Store the agents' mean reward for every agent (the team's reward) instead of each one's own."""
        super().__init__(*args, **kwargs)
        self.episode_starts = np.zeros((self.buffer_size, self.n_envs), dtype=bool)
        """(steps, n_envs) the transition's observation is the first of an episode."""
        self._next_starts = np.ones(self.n_envs, dtype=bool)
        if not 0 <= explorer_envs < self.n_envs:
            raise ValueError(
                f"explorer_envs must leave at least one of the {self.n_envs} parallel games to the agents "
                f"(0 <= explorer_envs < {self.n_envs}), got {explorer_envs}"
            )
        self.explorer_envs = int(explorer_envs)

    def sample_explorers(self, batch_size: int) -> JointReplayBufferSamples:
        """A uniform sample of the explorer games' transitions (as stored: no relabelling)."""
        if not self.explorer_envs:
            raise ValueError("sample_explorers: this buffer has no explorer games (explorer_envs=0)")
        batch_inds = self._draw_steps(batch_size)
        env_inds = np.random.randint(self.n_envs - self.explorer_envs, self.n_envs, size=batch_size)
        return self._gather(batch_inds, env_inds)

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state.pop("message_relabeler", None)  # a bound method of the model: not part of the data
        return state

    def add(
        self,
        obs: np.ndarray,
        next_obs: np.ndarray,
        action: np.ndarray,
        reward: np.ndarray,
        done: np.ndarray,
        infos: list[dict[str, Any]],
    ) -> None:
        """Store one step of every env, and whether it begins an episode."""
        if self.episode_starts is not None:
            self.episode_starts[self.pos] = self._next_starts
            self._next_starts = np.asarray(done, dtype=bool).reshape(self.n_envs).copy()
        super().add(obs, next_obs, action, reward, done, infos)

    def close_open_episodes(self) -> None:
        """Forget the running episodes (after a load): the next stored step begins one in every env."""
        super().close_open_episodes()
        self._next_starts = np.ones(self.n_envs, dtype=bool)

    def previous_observations(
        self, batch_inds: np.ndarray, env_inds: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The observation rows of each transition's previous step in the same game.

        :param batch_inds: ``(B,)`` step indices in the buffer.
        :param env_inds: ``(B,)`` env indices.
        :return: ``(B, n_agents, obs_dim)`` rows and ``(B,)`` whether they are valid: False where
            the transition begins an episode (its heard messages are the zeros of a reset) or its
            previous step is no longer (or not yet) stored.
        """
        previous = (batch_inds - 1) % self.buffer_size
        if self.episode_starts is not None:
            has_previous = ~self.episode_starts[batch_inds, env_inds]
        else:
            has_previous = self.dones[previous, env_inds] == 0
        oldest = self.pos if self.full else 0
        has_previous &= batch_inds != oldest
        return self.observations[previous, env_inds], has_previous

    def _draw_envs(self, batch_size: int) -> np.ndarray:
        agents_envs = self.n_envs - self.explorer_envs  # the explorer games only train the effect model
        return np.random.randint(0, high=agents_envs, size=(batch_size,))

    def sample_fields(self, batch_size: int, fields: tuple[str, ...]) -> Any:
        """See :meth:`MonteCarloReplayBuffer.sample_fields`; with a :attr:`message_relabeler`, the
        fields of a full :meth:`sample` (the observations are relabelled)."""
        if self.message_relabeler is not None:
            return self.sample(batch_size)
        return super().sample_fields(batch_size, fields)

    def _get_samples(
        self, batch_inds: np.ndarray, env: VecNormalize | None = None
    ) -> JointReplayBufferSamples:
        env_inds = self._draw_envs(len(batch_inds))
        samples = self._gather(batch_inds, env_inds)
        if self.message_relabeler is None:
            return samples
        observations, next_observations = self._relabelled(
            samples.observations, samples.next_observations, batch_inds, env_inds
        )
        samples = samples._replace(observations=observations, next_observations=next_observations)
        if samples.mc_tail_observations is not None:  # the states at the time limits' cuts, likewise
            tail_inds = self.mc_tail_positions[batch_inds, env_inds]
            tail_obs = self.to_torch(self.observations[tail_inds, env_inds])
            _, tail = self._relabelled(tail_obs, samples.mc_tail_observations, tail_inds, env_inds)
            samples = samples._replace(mc_tail_observations=tail)
        return samples

    def _relabelled(
        self, obs: th.Tensor, next_obs: th.Tensor, batch_inds: np.ndarray, env_inds: np.ndarray
    ) -> tuple[th.Tensor, th.Tensor]:
        """``obs`` and ``next_obs`` of the transitions at ``batch_inds``/``env_inds``, with the heard
        messages recomputed by :attr:`message_relabeler` (given their previous steps' rows)."""
        assert self.message_relabeler is not None
        previous, has_previous = self.previous_observations(batch_inds, env_inds)
        return self.message_relabeler(
            obs, next_obs, self.to_torch(previous), self.to_torch(has_previous.astype(np.float32))
        )

    @property
    def reward_width(self) -> int:
        """One reward per agent."""
        return self.n_agents

    def _rows(self, space: spaces.Space) -> tuple[int, ...]:
        return (self.n_agents, int(np.prod(space.shape)) // self.n_agents)

    def step_rewards(self, reward: np.ndarray, infos: list[dict[str, Any]]) -> np.ndarray:
        """Per-agent rewards ``(n_envs, n_agents)`` from ``infos[i]["agent_rewards"]``; with
        ``shared_reward`` their mean, the team's reward, for every agent."""
        try:
            rewards = np.asarray([info["agent_rewards"] for info in infos], dtype=np.float32)
        except KeyError as error:
            raise KeyError(
                "JointReplayBuffer needs per-agent rewards in info['agent_rewards']; wrap the "
                "environment with sb3_comm.wrappers.TwoAgentEnv or BatchedTwoAgentVecEnv"
            ) from error
        if getattr(self, "shared_reward", False):  # a buffer pickled before the option has none
            rewards[:] = rewards.mean(axis=1, keepdims=True)
        return rewards
