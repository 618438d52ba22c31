"""A PettingZoo ``ParallelEnv`` shell over a :class:`~envs.tasks.batched.BatchedTask`.

The shell runs one game (``n_games=1``, ``autoreset=False``) and only converts between the
batched arrays and PettingZoo's per-agent dictionaries; every rule lives in the batched core,
so the two APIs give the same trajectory for the same seed and actions.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from envs.tasks.batched import BatchedTask
from envs.tasks.hfo_actions import HYBRID_LAYOUT

__all__ = ["CommParallelEnv"]


class CommParallelEnv(ParallelEnv):
    """Two agents, one game, PettingZoo's parallel API.

    :param task_factory: builds the batched core from keyword arguments (e.g.
        :class:`~envs.tasks.blind_soccer.BlindSoccerTask`); ``n_games=1`` and
        ``autoreset=False`` are imposed.
    :param render_mode: ``None`` or ``"rgb_array"``.
    :param kwargs: passed to ``task_factory`` (``seed``, ``params``, ``noise``, ``max_steps``,
        ``channel_size``, task-specific options).
    """

    metadata: ClassVar[dict[str, Any]] = {
        "name": "comm_parallel_env",
        "render_modes": ["rgb_array"],
        "render_fps": 10,
        "is_parallelizable": True,
        "hybrid_action": HYBRID_LAYOUT,
    }

    def __init__(
        self, task_factory: Callable[..., BatchedTask], render_mode: str | None = None, **kwargs: Any
    ) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}.")
        for imposed in ("n_games", "autoreset"):
            if imposed in kwargs:
                raise TypeError(f"{imposed!r} is fixed by the single-game ParallelEnv; use batched_env().")
        self.task = task_factory(n_games=1, autoreset=False, **kwargs)
        self.metadata = dict(type(self).metadata, name=self.task.name)
        self.render_mode = render_mode
        self.possible_agents = list(self.task.possible_agents)
        self.agents: list[str] = []
        self.channel_size = self.task.channel_size
        self.time_feature = self.task.time_feature
        self.hybrid_layout = self.task.hybrid_layout
        self._observation_spaces = {
            agent: spaces.Box(self.task.observation_low, self.task.observation_high, dtype=np.float32)
            for agent in self.possible_agents
        }
        self.state_space = spaces.Box(-1.0, 1.0, shape=(self.task.state_size,), dtype=np.float32)
        self._action_spaces = {
            agent: spaces.Box(self.task.action_low, self.task.action_high, dtype=np.float32)
            for agent in self.possible_agents
        }

    def observation_space(self, agent: str) -> spaces.Box:
        """The (cached) observation space of ``agent``: features, task entries, received message."""
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        """The (cached) action space of ``agent``: the 8 HFO entries, then the outgoing message."""
        return self._action_spaces[agent]

    def reset(
        self, seed: int | None = None, options: dict | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, dict]]:
        """Start an episode; a ``seed`` re-creates the task's generator."""
        obs = self.task.reset(seed=seed)
        self.agents = list(self.possible_agents)
        return self._per_agent(obs[0]), {agent: {} for agent in self.agents}

    def step(self, actions: dict[str, np.ndarray]) -> tuple[dict, dict, dict, dict, dict]:
        """Step the game with one action per live agent.

        :raises ValueError: when an agent's action is missing, has the wrong shape or is not
            finite (the message names the agent and the expected shape).
        """
        if not self.agents:
            raise RuntimeError("The episode is over: call reset() before step().")
        batch = np.empty((1, len(self.possible_agents), self.task.action_size), dtype=np.float64)
        expected = (self.task.action_size,)
        for i, agent in enumerate(self.possible_agents):
            if agent not in actions:
                raise ValueError(
                    f"Missing action for agent {agent!r}: expected an array of shape {expected}."
                )
            try:
                action = np.asarray(actions[agent], dtype=np.float64)
            except (TypeError, ValueError) as err:
                raise ValueError(
                    f"Action of agent {agent!r} is not numeric: expected shape {expected}."
                ) from err
            if action.shape != expected:
                raise ValueError(f"Action of agent {agent!r} has shape {action.shape}, expected {expected}.")
            if not np.all(np.isfinite(action)):
                raise ValueError(
                    f"Action of agent {agent!r} contains NaN or inf (expected shape {expected})."
                )
            batch[0, i] = action
        obs, rewards, terminated, truncated, info = self.task.step(batch)
        term, trunc = bool(terminated[0]), bool(truncated[0])
        outcome = int(info["outcome"][0])
        infos = {agent: {"outcome": outcome} for agent in self.agents}
        result = (
            self._per_agent(obs[0]),
            {agent: float(rewards[0, i]) for i, agent in enumerate(self.possible_agents)},
            dict.fromkeys(self.possible_agents, term),
            dict.fromkeys(self.possible_agents, trunc),
            infos,
        )
        if term or trunc:
            self.agents = []
        return result

    def render(self) -> np.ndarray | None:
        """An RGB frame of the game (``render_mode="rgb_array"``), messages in flight as bars."""
        if self.render_mode is None:
            return None
        return self.task.render(0)

    def state(self) -> np.ndarray:
        """Full-information global state (:meth:`BatchedTask.global_state`; nobody blinded)."""
        return self.task.global_state()[0]

    def close(self) -> None:
        """Nothing to release."""
        self.task.close()

    def _per_agent(self, obs: np.ndarray) -> dict[str, np.ndarray]:
        return {agent: obs[i].copy() for i, agent in enumerate(self.possible_agents)}
