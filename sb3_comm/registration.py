"""Gymnasium ids of the communication tasks and a fast vectorised constructor.

The tasks come from the registry :data:`envs.registry.TASKS`. ``import sb3_comm`` registers each
task's id (``BlindSoccer-v0``, ``GuessMyNumber-v0``): each is one two-agent game seen through
:class:`~sb3_comm.wrappers.TwoAgentEnv` (entry point :func:`~sb3_comm.wrappers.make_task_env`,
kwargs ``{"task": <id>}``), so ``gymnasium.make``, SB3's ``make_vec_env`` and rl-zoo3 find them.
:func:`make_comm_vec_env` builds the same environment as a batched VecEnv that steps all games in
one call (much faster than one Python env per game).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import VecEnv

from envs.registry import TASKS, task_ids
from envs.tasks.single_agent import SINGLE_AGENT_TASKS
from sb3_comm.wrappers.batched_vec_env import BatchedSingleAgentVecEnv, BatchedTwoAgentVecEnv

__all__ = ["FOREIGN_IDS", "TASK_IDS", "make_comm_vec_env", "register_envs"]

TASK_IDS: tuple[str, ...] = task_ids()
"""Gymnasium ids of the communication tasks (the keys of :data:`envs.registry.TASKS`)."""

_ENTRY_POINT = "sb3_comm.wrappers.two_agent:make_task_env"


_FOREIGN_ENTRY_POINTS = {
    "MPESimpleReference-v0": "sb3_comm.foreign.simple_reference:simple_reference_env",  # own channel silenced
}

_SIMPLE_REFERENCE = "MPESimpleReference-v0"

FOREIGN_IDS: tuple[str, ...] = tuple(_FOREIGN_ENTRY_POINTS)
"""Gymnasium ids of benchmarks from outside the project (their packages are optional extras)."""


def register_envs() -> None:
    """Register the task ids, and the foreign benchmarks' ids, with Gymnasium (idempotent)."""
    for env_id in TASKS:
        if env_id not in gym.registry:
            gym.register(env_id, entry_point=_ENTRY_POINT, kwargs={"task": env_id})
    for env_id, entry_point in _FOREIGN_ENTRY_POINTS.items():
        if env_id not in gym.registry:
            gym.register(env_id, entry_point=entry_point)


def make_comm_vec_env(
    env_id: str,
    n_envs: int = 1,
    seed: int | None = None,
    env_kwargs: dict[str, Any] | None = None,
    batched: bool = True,
) -> VecEnv:
    """``n_envs`` games of a communication task (or of a single-agent HFO task) as one SB3 VecEnv.

    :param env_id: a task id (``"BlindSoccer-v0"``, ``"GuessMyNumber-v0"``: see
        :data:`envs.registry.TASKS`), a single-agent HFO id (``"HFOMoveToBall-v0"``,
        ``"HFOScoreEmptyGoal-v0"``, :class:`~sb3_comm.wrappers.BatchedSingleAgentVecEnv`),
        ``"MPESimpleReference-v0"`` (batched: sb3-comm's numpy re-implementation of mpe2's game,
        :mod:`sb3_comm.foreign.batched_simple_reference`, which needs no mpe2) or any other
        Gymnasium id (then SB3's ``make_vec_env`` is used).
    :param n_envs: number of parallel games.
    :param seed: seed of the first reset.
    :param env_kwargs: task options (``max_steps``, ``channel_size``, ...).
    :param batched: step the games in one vectorised call (the task's batched core); False gives
        SB3's ``DummyVecEnv`` of single games (same semantics, slower; for
        ``"MPESimpleReference-v0"``, mpe2's own environment).
    """
    env_kwargs = dict(env_kwargs or {})
    batchable = env_id in TASKS or env_id in SINGLE_AGENT_TASKS or env_id == _SIMPLE_REFERENCE
    if not batched or not batchable:
        return make_vec_env(env_id, n_envs=n_envs, seed=seed, env_kwargs=env_kwargs)
    env_kwargs.pop("render_mode", None)
    vec_env: BatchedTwoAgentVecEnv | BatchedSingleAgentVecEnv
    if env_id in TASKS:
        vec_env = BatchedTwoAgentVecEnv(TASKS[env_id].batched_env(n_games=n_envs, **env_kwargs))
    elif env_id == _SIMPLE_REFERENCE:
        from sb3_comm.foreign.batched_simple_reference import SimpleReferenceTask

        vec_env = BatchedTwoAgentVecEnv(SimpleReferenceTask(n_games=n_envs, **env_kwargs))
    else:
        vec_env = BatchedSingleAgentVecEnv(SINGLE_AGENT_TASKS[env_id](n_games=n_envs, **env_kwargs))
    vec_env.seed(seed)
    return vec_env
