"""Small two-agent environments with no soccer in them, for testing the generic machinery."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv


class CoinParallelEnv(ParallelEnv):
    """A speaker sees a coin value in [-1, 1]; a listener must output it. No channel of its own.

    Observation sizes (3 and 2) and action sizes (1 and 2) differ between the agents, to exercise
    padding. Both agents get ``-(listener_action[0] - coin)**2``. Episodes last ``length`` steps.
    """

    metadata: ClassVar[dict] = {"name": "coin_v0", "render_modes": []}

    def __init__(self, length: int = 4, n_agents: int = 2) -> None:
        self.possible_agents = ["speaker", "listener", "extra"][:n_agents]
        self.length = length
        self._obs_spaces = {
            "speaker": spaces.Box(-1.0, 1.0, (3,), np.float32),
            "listener": spaces.Box(-1.0, 1.0, (2,), np.float32),
            "extra": spaces.Box(-1.0, 1.0, (2,), np.float32),
        }
        self._act_spaces = {
            "speaker": spaces.Box(-1.0, 1.0, (1,), np.float32),
            "listener": spaces.Box(-1.0, 1.0, (2,), np.float32),
            "extra": spaces.Box(-1.0, 1.0, (1,), np.float32),
        }
        self.rng = np.random.default_rng()
        self.coin = 0.0
        self.t = 0

    def observation_space(self, agent: str) -> spaces.Box:
        return self._obs_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        return self._act_spaces[agent]

    def _obs(self) -> dict[str, np.ndarray]:
        phase = self.t / self.length
        obs = {
            "speaker": np.array([self.coin, 0.5, phase], dtype=np.float32),
            "listener": np.array([phase, 0.0], dtype=np.float32),
            "extra": np.zeros(2, dtype=np.float32),
        }
        return {a: obs[a] for a in self.possible_agents}

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self.agents = list(self.possible_agents)
        self.coin = float(self.rng.uniform(-1, 1))
        self.t = 0
        return self._obs(), {a: {} for a in self.agents}

    def step(self, actions: dict[str, np.ndarray]) -> tuple[dict, dict, dict, dict, dict]:
        self.last_actions = {a: np.array(v) for a, v in actions.items()}
        self.t += 1
        reward = -float((actions["listener"][0] - self.coin) ** 2)
        done = self.t >= self.length
        agents = self.agents
        obs = self._obs()
        if done:
            self.agents = []
        return (
            obs,
            {a: reward for a in agents},
            {a: False for a in agents},
            {a: done for a in agents},
            {a: {} for a in agents},
        )


def coin_env(**kwargs: Any):
    """The coin game seen through TwoAgentEnv with a channel of size 2 added by the wrapper."""
    from sb3_comm.wrappers import TwoAgentEnv

    return TwoAgentEnv(CoinParallelEnv(**kwargs), channel_size=2)
