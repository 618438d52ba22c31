"""Replay buffers with Monte-Carlo returns, for one agent and for a team of agents.

:class:`MonteCarloReplayBuffer` is SB3's replay for the single-agent DDPG of the ICLR 2016 paper,
plus each transition's Monte-Carlo return ``G_t`` (filled in when the episode ends) for the critic
target mixing of the reference code: ``y = β·G + (1 − β)·y_TD``. Samples have SB3's shapes:
observations ``(B, obs_dim)``, rewards ``(B, 1)``.

:class:`~sb3_comm.comm_ddpg.buffers.JointReplayBuffer` subclasses it for a team: every transition
keeps the agents' rows side by side, and the rewards come per agent from the step infos.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any, NamedTuple

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.buffers import BaseBuffer
from stable_baselines3.common.vec_env import VecNormalize

__all__ = ["MC_TRUNCATED", "MonteCarloReplayBuffer", "MonteCarloReplayBufferSamples"]

MC_TRUNCATED = ("sum", "skip", "bootstrap")
"""What a time-limit cut gives the Monte-Carlo returns of its episode (:class:`MonteCarloReplayBuffer`)."""


class MonteCarloReplayBufferSamples(NamedTuple):
    """A batch of transitions; for a team, agent rows on axis 1."""

    observations: th.Tensor  # (B, obs_dim) or (B, n_agents, obs_dim)
    actions: th.Tensor  # (B, action_dim) or (B, n_agents, action_dim), scaled to [-1, 1]
    next_observations: th.Tensor  # like observations
    dones: th.Tensor  # (B, 1): 1 if the episode terminated (not truncated)
    rewards: th.Tensor  # (B, 1) or (B, n_agents)
    mc_returns: th.Tensor  # like rewards; valid where mc_valid is 1
    mc_valid: th.Tensor  # (B, 1)
    # mc_truncated="bootstrap" only (None otherwise): the next observation at the time limit's cut
    # of the transition's episode, and the discount γ^(T−t+1) of its value (0: the episode ended)
    mc_tail_observations: th.Tensor | None = None  # like observations
    mc_tail_discount: th.Tensor | None = None  # (B, 1)


class MonteCarloReplayBuffer(BaseBuffer):
    """Replay of the transitions of ``n_envs`` parallel environments, with Monte-Carlo returns.

    :param buffer_size: number of transitions kept (over all envs, as in SB3).
    :param observation_space: observation space of one environment.
    :param action_space: action space of one environment.
    :param device: torch device of the samples.
    :param n_envs: number of parallel environments.
    :param gamma: discount for the Monte-Carlo returns.
    :param store_mc_returns: keep Monte-Carlo returns (needed when β > 0).
    :param handle_timeout_termination: a truncated episode is not a terminal state (SB3 default).
    :param optimize_memory_usage: not supported (SB3 passes it; True raises).
    :param mc_truncated: what an episode cut by a time limit (``TimeLimit.truncated``) gives its
        transitions: ``"sum"`` (the reference code's way and the default) sums its rewards as if it
        had ended there, a return biased towards 0 the closer the cut; ``"skip"`` gives them no
        Monte-Carlo return, so that they train on the TD target alone (``mc_valid`` 0);
        ``"bootstrap"`` completes their sum at the cut by the value of the state there,
        ``G_t = Σ_{k=t}^{T} γ^{k−t} r_k + γ^{T−t+1} V(s_{T+1})``: the samples carry that state
        (``mc_tail_observations``) and its discount (``mc_tail_discount``), and the learner adds
        the target critic's value, so that a cut episode gets an n-step return instead of a sum
        biased towards 0. ``"skip"`` and ``"bootstrap"`` need ``handle_timeout_termination``.
    """

    mc_truncated: str = "sum"  # buffers pickled before the option existed load with the old way

    def __init__(
        self,
        buffer_size: int,
        observation_space: spaces.Space,
        action_space: spaces.Space,
        device: th.device | str = "auto",
        n_envs: int = 1,
        gamma: float = 0.99,
        store_mc_returns: bool = False,
        handle_timeout_termination: bool = True,
        optimize_memory_usage: bool = False,
        mc_truncated: str = "sum",
    ) -> None:
        if optimize_memory_usage:
            raise ValueError(f"{type(self).__name__} does not support optimize_memory_usage=True")
        if mc_truncated not in MC_TRUNCATED:
            raise ValueError(f"mc_truncated must be one of {list(MC_TRUNCATED)}, got {mc_truncated!r}")
        if mc_truncated != "sum" and not handle_timeout_termination:
            raise ValueError(
                f"mc_truncated={mc_truncated!r} needs handle_timeout_termination=True (the time limits)"
            )
        self.mc_truncated = mc_truncated
        super().__init__(buffer_size, observation_space, action_space, device, n_envs=n_envs)
        self.buffer_size = max(buffer_size // n_envs, 1)
        self.gamma = gamma
        self.store_mc_returns = store_mc_returns
        self.handle_timeout_termination = handle_timeout_termination
        self.obs_rows = self._rows(observation_space)
        self.action_rows = self._rows(action_space)
        steps = (self.buffer_size, n_envs)
        self.observations = np.zeros((*steps, *self.obs_rows), dtype=np.float32)
        self.next_observations = np.zeros((*steps, *self.obs_rows), dtype=np.float32)
        self.actions = np.zeros((*steps, *self.action_rows), dtype=np.float32)
        self.rewards = np.zeros((*steps, self.reward_width), dtype=np.float32)
        self.dones = np.zeros(steps, dtype=np.float32)
        self.timeouts = np.zeros(steps, dtype=np.float32)
        self.mc_returns = np.zeros((*steps, self.reward_width), dtype=np.float32)
        self.mc_valid = np.zeros(steps, dtype=np.float32)
        if mc_truncated == "bootstrap":
            self.mc_tail_positions = np.zeros(steps, dtype=np.int64)
            """(steps, n_envs) buffer position of the last transition of a cut episode."""
            self.mc_tail_discount = np.zeros(steps, dtype=np.float32)
            """(steps, n_envs) γ^(T−t+1) where the episode was cut at T, else 0."""
        self._episode_positions: list[list[int]] = [[] for _ in range(n_envs)]

    @property
    def reward_width(self) -> int:
        """Rewards stored per transition (one for a single agent)."""
        return 1

    def _rows(self, space: spaces.Space) -> tuple[int, ...]:
        """Shape in which one environment's observation or action is stored."""
        return (int(np.prod(space.shape)),)

    def step_rewards(self, reward: np.ndarray, infos: list[dict[str, Any]]) -> np.ndarray:
        """The rewards of one step of every env, ``(n_envs, reward_width)``."""
        return np.asarray(reward, dtype=np.float32).reshape(self.n_envs, 1)

    def add(
        self,
        obs: np.ndarray,
        next_obs: np.ndarray,
        action: np.ndarray,
        reward: np.ndarray,
        done: np.ndarray,
        infos: list[dict[str, Any]],
    ) -> None:
        """Store one step of every env."""
        p = self.pos
        self.observations[p] = np.asarray(obs).reshape(self.n_envs, *self.obs_rows)
        self.next_observations[p] = np.asarray(next_obs).reshape(self.n_envs, *self.obs_rows)
        self.actions[p] = np.asarray(action).reshape(self.n_envs, *self.action_rows)
        self.rewards[p] = self.step_rewards(reward, infos)
        self.dones[p] = done
        self.mc_valid[p] = 0.0
        if self.mc_truncated == "bootstrap":
            self.mc_tail_discount[p] = 0.0
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
            if done[env] and self.mc_truncated == "skip" and self.timeouts[position, env]:
                self._episode_positions[env] = []  # cut by the time limit: TD target only
            elif done[env]:
                positions = self._episode_positions[env]
                running = np.zeros(self.reward_width, dtype=np.float32)
                for p in reversed(positions):
                    running = self.rewards[p, env] + self.gamma * running
                    self.mc_returns[p, env] = running
                    self.mc_valid[p, env] = 1.0
                if self.mc_truncated == "bootstrap" and self.timeouts[position, env]:
                    # the cut's value, discounted from each step: γ for the last, γ² before it, …
                    steps_to_cut = np.arange(len(positions), 0, -1, dtype=np.float64)
                    self.mc_tail_discount[positions, env] = self.gamma**steps_to_cut
                    self.mc_tail_positions[positions, env] = position
                self._episode_positions[env] = []

    def close_open_episodes(self) -> None:
        """Forget the episodes still running (after a load: the environments restart).

        Their transitions keep no Monte-Carlo return (``mc_valid`` 0, the TD target); without this,
        the first episode after the restart would be summed onto them.
        """
        self._episode_positions = [[] for _ in range(self.n_envs)]

    def sample(self, batch_size: int, env: VecNormalize | None = None) -> MonteCarloReplayBufferSamples:
        """Uniform sample of ``batch_size`` transitions (env and step drawn uniformly)."""
        return self._get_samples(self._draw_steps(batch_size), env)

    def sample_fields(self, batch_size: int, fields: tuple[str, ...]) -> Any:
        """Only ``fields`` (e.g. ``("observations", "actions", "rewards")``) of a uniform sample, drawn
        with the random numbers :meth:`sample` would draw: the same transitions, without gathering
        and copying what the caller does not read.

        :return: an object with one ``(B, ...)`` tensor attribute per field, the values of
            :meth:`sample`'s fields of that name.
        """
        batch_inds = self._draw_steps(batch_size)
        env_inds = self._draw_envs(len(batch_inds))
        gathered = {name: getattr(self, name)[batch_inds, env_inds] for name in fields}
        return SimpleNamespace(**{name: self.to_torch(array, copy=False) for name, array in gathered.items()})

    def _draw_steps(self, batch_size: int) -> np.ndarray:
        """The stored step of each sampled transition, uniform over the steps held (drawn first)."""
        upper = self.buffer_size if self.full else self.pos
        return np.random.randint(0, upper, size=batch_size)

    def _draw_envs(self, batch_size: int) -> np.ndarray:
        """The environment of each sampled transition (after its step index, in :meth:`sample`)."""
        return np.random.randint(0, high=self.n_envs, size=(batch_size,))

    def _get_samples(
        self, batch_inds: np.ndarray, env: VecNormalize | None = None
    ) -> MonteCarloReplayBufferSamples:
        return self._gather(batch_inds, self._draw_envs(len(batch_inds)))

    def _gather(self, batch_inds: np.ndarray, env_inds: np.ndarray) -> MonteCarloReplayBufferSamples:
        """The transitions at steps ``batch_inds`` of envs ``env_inds``, as tensors."""
        dones = self.dones[batch_inds, env_inds] * (1.0 - self.timeouts[batch_inds, env_inds])
        tail: tuple[np.ndarray, ...] = ()
        if self.mc_truncated == "bootstrap":
            tail = (
                self.next_observations[self.mc_tail_positions[batch_inds, env_inds], env_inds],
                self.mc_tail_discount[batch_inds, env_inds].reshape(-1, 1),
            )
        data = (
            self.observations[batch_inds, env_inds],
            self.actions[batch_inds, env_inds],
            self.next_observations[batch_inds, env_inds],
            dones.reshape(-1, 1),
            self.rewards[batch_inds, env_inds],
            self.mc_returns[batch_inds, env_inds],
            self.mc_valid[batch_inds, env_inds].reshape(-1, 1),
            *tail,
        )
        # every array is a fresh gather: the tensors may share it (no second copy on the CPU)
        return MonteCarloReplayBufferSamples(*(self.to_torch(array, copy=False) for array in data))
