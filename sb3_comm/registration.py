"""Gymnasium ids of the communication tasks and a fast vectorised constructor.

``import sb3_comm`` registers ``BlindSoccer-v0`` and ``GuessMyNumber-v0``: each is one two-agent
game seen through :class:`~sb3_comm.wrappers.TwoAgentEnv`, so ``gymnasium.make``, SB3's
``make_vec_env`` and rl-zoo3 find them. :func:`make_comm_vec_env` builds the same environment as a
batched VecEnv that steps all games in one call (much faster than one Python env per game).
"""

from __future__ import annotations

import importlib
from typing import Any

import gymnasium as gym
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import VecEnv

from sb3_comm.wrappers.batched_vec_env import BatchedTwoAgentVecEnv

__all__ = ["TASK_IDS", "make_comm_vec_env", "register_envs"]

TASK_IDS: dict[str, str] = {"BlindSoccer-v0": "blind_soccer_v0", "GuessMyNumber-v0": "guess_my_number_v0"}
"""Gymnasium id -> task module under ``envs``."""

_ENTRY_POINT = "sb3_comm.wrappers.two_agent:make_task_env"


def register_envs() -> None:
    """Register the task ids with Gymnasium (idempotent)."""
    for env_id, task in TASK_IDS.items():
        if env_id not in gym.registry:
            gym.register(env_id, entry_point=_ENTRY_POINT, kwargs={"task": task})


def make_comm_vec_env(
    env_id: str,
    n_envs: int = 1,
    seed: int | None = None,
    env_kwargs: dict[str, Any] | None = None,
    batched: bool = True,
) -> VecEnv:
    """``n_envs`` games of a communication task as one SB3 VecEnv.

    :param env_id: a registered id (``"BlindSoccer-v0"``, ``"GuessMyNumber-v0"``) or any other
        Gymnasium id (then SB3's ``make_vec_env`` is used).
    :param n_envs: number of parallel games.
    :param seed: seed of the first reset.
    :param env_kwargs: task options (``max_steps``, ``channel_size``, ...).
    :param batched: step the games in one vectorised call (the task's batched core); False gives
        SB3's ``DummyVecEnv`` of single games (same semantics, slower).
    """
    env_kwargs = dict(env_kwargs or {})
    if env_id in TASK_IDS and batched:
        module = importlib.import_module(f"envs.{TASK_IDS[env_id]}")
        env_kwargs.pop("render_mode", None)
        vec_env = BatchedTwoAgentVecEnv(module.batched_env(n_games=n_envs, **env_kwargs))
        vec_env.seed(seed)
        return vec_env
    return make_vec_env(env_id, n_envs=n_envs, seed=seed, env_kwargs=env_kwargs)
