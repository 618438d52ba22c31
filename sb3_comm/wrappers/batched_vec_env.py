"""SB3 VecEnvs over a batched task: N games stepped at once, no Python loop per game.

:class:`BatchedTwoAgentVecEnv` drives the two-agent communication tasks,
:class:`BatchedSingleAgentVecEnv` the one-player HFO tasks of the ICLR 2016 agent. The batched
task follows the protocol of ``envs.tasks.batched.BatchedTask``: ``reset(seed)`` gives
``(N, P, obs_size)``, ``step(actions (N, P, action_size))`` gives observations, per-agent rewards
``(N, P)``, ``terminated``/``truncated`` ``(N,)`` and an info dict with ``final_observation``, and
it resets finished games itself. Two-agent rows are laid out exactly as :class:`TwoAgentEnv` lays
them out, so a model trained on one runs on the other; a single agent's observation and action
are its Gymnasium shell's (``HFOScoreEmptyGoal-v0``...), one row per game.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvStepReturn

from sb3_comm.common.layout import HybridActionLayout
from sb3_comm.common.validation import check_observation
from sb3_comm.wrappers.two_agent import RowCodec, check_action

__all__ = ["BatchedSingleAgentVecEnv", "BatchedTwoAgentVecEnv"]


class _BatchedTaskVecEnv(VecEnv):
    """What the VecEnvs over a batched task share: seeding, reset, attributes and rendering.

    :param task: the batched task (``num_envs`` is its number of games).
    :param observation_space: the space of one env's observation.
    :param action_space: the space of one env's action.
    """

    def __init__(self, task: Any, observation_space: spaces.Space, action_space: spaces.Space) -> None:
        self.task = task
        self.render_mode = "rgb_array"
        super().__init__(int(task.n_games), observation_space, action_space)
        self._actions: np.ndarray | None = None
        self._seed: int | None = None

    def _rows(self, obs: np.ndarray) -> np.ndarray:
        """The envs' observations from the task's ``(N, P, observation_size)``."""
        raise NotImplementedError

    def reset(self) -> np.ndarray:
        """Reset every game (seeded by :meth:`seed` if it was called)."""
        obs = self.task.reset(seed=self._seed)
        self._seed = None
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return self._rows(obs)

    def step_async(self, actions: np.ndarray) -> None:
        """Store the actions for :meth:`step_wait`."""
        self._actions = actions

    def close(self) -> None:
        """Nothing to release."""

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seed the next :meth:`reset` (SB3 convention)."""
        self._seed = seed
        return [seed] * self.num_envs

    def get_images(self) -> Sequence[np.ndarray | None]:
        """RGB frame of every game (slow for many games: meant for a handful)."""
        return [self.task.render(game=i) for i in range(self.num_envs)]

    def render(self, mode: str | None = None) -> np.ndarray | None:
        """RGB frame of the first game."""
        return self.task.render(game=0)

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """Attribute of the wrapper (e.g. ``comm_layout``) or of the task, once per env."""
        value = getattr(self, attr_name) if hasattr(self, attr_name) else getattr(self.task, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of the task (shared by all games)."""
        setattr(self.task, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any
    ) -> list[Any]:
        """Call a method of the task once per requested env."""
        method = getattr(self.task, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type, indices: VecEnvIndices = None) -> list[bool]:
        """The games are not Gymnasium environments, so they are never wrapped."""
        return [False for _ in self._get_indices(indices)]


class BatchedTwoAgentVecEnv(_BatchedTaskVecEnv):
    """``num_envs`` = number of games of the batched task; each env is one two-agent game.

    :param task: a batched two-agent task (``envs.<task>.batched_env(n_games=...)``).
    """

    def __init__(self, task: Any) -> None:
        agents = tuple(task.possible_agents)
        if len(agents) != 2:
            raise ValueError(f"BatchedTwoAgentVecEnv needs a task with 2 agents; got {list(agents)}")
        self.agent_names = agents
        n = int(task.channel_size)
        size_obs, size_act = int(task.observation_size), int(task.action_size)
        self.codec = RowCodec([size_obs - n] * 2, [size_act - n] * 2, n)
        obs_low, obs_high = np.asarray(task.observation_low), np.asarray(task.observation_high)
        act_low, act_high = np.asarray(task.action_low), np.asarray(task.action_high)
        observation_space, action_space = self.codec.spaces(
            [(obs_low[: size_obs - n], obs_high[: size_obs - n])] * 2,
            [(act_low[: size_act - n], act_high[: size_act - n])] * 2,
        )
        super().__init__(task, observation_space, action_space)
        self.comm_layout = self.codec.layout(agents, HybridActionLayout.from_dict(task.hybrid_layout))

    def _rows(self, obs: np.ndarray) -> np.ndarray:
        n = self.codec.channel_size
        size = obs.shape[-1]
        rows = self.codec.observations([obs[:, 0, : size - n], obs[:, 1, : size - n]], obs[:, :, size - n :])
        check_observation(rows, self.agent_names, batch_name="games")  # blame the task, not the actions
        return rows

    def step_wait(self) -> VecEnvStepReturn:
        """Step all games; finished games are reset and their last observation put in the info."""
        assert self._actions is not None, "step_async must be called first"
        actions = check_action(self._actions, (self.num_envs, *self.action_space.shape), self.agent_names)
        # Rows are the task's own action layout [own action | outgoing message]; the task clips messages.
        obs, rewards, terminated, truncated, info = self.task.step(actions)
        dones = terminated | truncated
        rows = self._rows(obs)
        mean_rewards = rewards.mean(axis=1).astype(np.float32)
        infos: list[dict[str, Any]] = [{"agent_rewards": rewards[i]} for i in range(self.num_envs)]
        if dones.any():
            final_rows = self._rows(info["final_observation"])
            for i in np.flatnonzero(dones):
                returns = np.asarray(info["episode_return"][i], dtype=np.float32)
                infos[i].update(
                    terminal_observation=final_rows[i],
                    agent_returns=returns,
                    episode={"r": float(returns.mean()), "l": int(info["episode_length"][i]), "t": 0.0},
                )
                infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return rows, mean_rewards, dones, infos


class BatchedSingleAgentVecEnv(_BatchedTaskVecEnv):
    """``num_envs`` = number of games of a batched one-player task (``MoveToBallTask``,
    ``ScoreEmptyGoalTask``); each env is one game, with the observation, action, reward and
    ``info["outcome"]`` of its Gymnasium shell (``HFOMoveToBall-v0``, ``HFOScoreEmptyGoal-v0``).

    :param task: a batched one-player task with ``autoreset=True``.
    """

    def __init__(self, task: Any) -> None:
        agents = tuple(task.possible_agents)
        if len(agents) != 1 or not task.autoreset:
            raise ValueError(
                f"BatchedSingleAgentVecEnv needs a one-agent task with autoreset=True; got agents "
                f"{list(agents)}, autoreset={task.autoreset}"
            )
        self.agent_names = agents
        observation_space = spaces.Box(task.observation_low, task.observation_high, dtype=np.float32)
        action_space = spaces.Box(task.action_low, task.action_high, dtype=np.float32)
        super().__init__(task, observation_space, action_space)
        self.hybrid_layout = task.hybrid_layout

    def _rows(self, obs: np.ndarray) -> np.ndarray:
        rows = obs[:, 0]
        check_observation(rows, batch_name="games")  # blame the task, not the actions
        return rows

    def step_wait(self) -> VecEnvStepReturn:
        """Step all games; finished games are reset and their last observation put in the info.

        :raises ValueError: actions not of shape ``(num_envs, action_size)``, or not finite.
        """
        assert self._actions is not None, "step_async must be called first"
        expected = (self.num_envs, *self.action_space.shape)
        if np.shape(self._actions) != expected:
            raise ValueError(
                f"Action has shape {np.shape(self._actions)}; expected {expected} (one row per game)"
            )
        actions = check_action(
            np.asarray(self._actions)[:, None], (self.num_envs, 1, expected[1]), self.agent_names
        )
        obs, rewards, terminated, truncated, info = self.task.step(actions)
        dones = terminated | truncated
        outcome = info["outcome"]
        infos: list[dict[str, Any]] = [{"outcome": int(outcome[i])} for i in range(self.num_envs)]
        if dones.any():
            final_rows = self._rows(info["final_observation"])
            for i in np.flatnonzero(dones):
                infos[i].update(
                    terminal_observation=final_rows[i],
                    episode={
                        "r": float(info["episode_return"][i, 0]),
                        "l": int(info["episode_length"][i]),
                        "t": 0.0,
                    },
                )
                infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return self._rows(obs), rewards[:, 0].astype(np.float32), dones, infos
