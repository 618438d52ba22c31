"""Evaluate a team on many games at once, with the message channel intact, zeroed or shuffled.

All games of the evaluation run in one batched VecEnv, one episode each, so 100 evaluation
episodes cost about as much as one. The message ablation of the paper (§7) is a switch:
``"zero"`` replaces every received message by 0, ``"shuffle"`` gives each receiver the message
received at the same step in another, randomly chosen game (a real message of the protocol that
carries no information about this game).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv

from sb3_comm.common.layout import CommLayout
from sb3_comm.registration import make_comm_vec_env

__all__ = ["ABLATIONS", "TeamEvaluation", "evaluate_team"]

ABLATIONS = ("none", "zero", "shuffle")
"""What happens to received messages during evaluation."""


@dataclass
class TeamEvaluation:
    """Returns of one evaluation: one episode per game.

    :param team_returns: per episode, the team's mean return.
    :param agent_returns: per episode and agent, shape ``(n_episodes, n_agents)``.
    :param lengths: per episode, its length.
    """

    team_returns: np.ndarray
    agent_returns: np.ndarray
    lengths: np.ndarray

    @property
    def mean(self) -> float:
        """Mean team return."""
        return float(self.team_returns.mean())

    def summary(self) -> dict[str, Any]:
        """JSON-friendly mean, standard deviation, per-agent means and mean length."""
        return {
            "mean_return": self.mean,
            "std_return": float(self.team_returns.std()),
            "agent_mean_returns": self.agent_returns.mean(axis=0).tolist(),
            "mean_length": float(self.lengths.mean()),
            "n_episodes": int(self.team_returns.size),
        }

    def to_dict(self) -> dict[str, Any]:
        """Everything, as lists."""
        return {k: np.asarray(v).tolist() for k, v in asdict(self).items()}


def _ablate(obs: np.ndarray, layout: CommLayout, ablation: str, rng: np.random.Generator) -> np.ndarray:
    if ablation == "none" or layout.channel_size == 0:
        return obs
    obs = obs.copy()
    sl = layout.obs_message_slice
    if ablation == "zero":
        obs[..., sl] = 0.0
    else:
        obs[..., sl] = obs[rng.permutation(obs.shape[0])][..., sl]
    return obs


def evaluate_team(
    model: BaseAlgorithm,
    env: str | VecEnv,
    n_episodes: int = 100,
    seed: int = 0,
    deterministic: bool = True,
    ablation: str = "none",
    env_kwargs: dict[str, Any] | None = None,
) -> TeamEvaluation:
    """Play one episode in each of ``n_episodes`` parallel games and collect the returns.

    :param model: a trained :class:`~sb3_comm.CommDDPG` (anything with ``predict``).
    :param env: an env id (a batched VecEnv of ``n_episodes`` games is built) or a VecEnv whose
        ``num_envs`` is the number of episodes.
    :param n_episodes: episodes (= games) when ``env`` is an id.
    :param seed: seed of the evaluation games.
    :param deterministic: act without exploration.
    :param ablation: ``"none"``, ``"zero"`` or ``"shuffle"`` (see the module docstring).
    :param env_kwargs: task options when ``env`` is an id.
    """
    if ablation not in ABLATIONS:
        raise ValueError(f"Unknown ablation {ablation!r}; accepted: {list(ABLATIONS)}")
    if isinstance(env, str):
        vec_env = make_comm_vec_env(env, n_envs=n_episodes, seed=seed, env_kwargs=env_kwargs)
    else:
        vec_env = env
    layout: CommLayout = vec_env.get_attr("comm_layout", indices=[0])[0]
    rng = np.random.default_rng(seed)
    n = vec_env.num_envs
    team = np.full(n, np.nan)
    agents = np.full((n, layout.n_agents), np.nan)
    lengths = np.zeros(n, dtype=np.int64)
    obs = vec_env.reset()
    while np.isnan(team).any():
        action, _ = model.predict(_ablate(obs, layout, ablation, rng), deterministic=deterministic)
        obs, _, dones, infos = vec_env.step(action)
        for i in np.flatnonzero(dones):
            if np.isnan(team[i]):
                returns = np.asarray(infos[i]["agent_returns"], dtype=np.float64)
                agents[i] = returns
                team[i] = returns.mean()
                lengths[i] = infos[i]["episode"]["l"] if "episode" in infos[i] else 0
    return TeamEvaluation(team_returns=team, agent_returns=agents, lengths=lengths)
