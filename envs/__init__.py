"""Environments of sb3-comm: half-field soccer tasks with a learned communication channel.

* ``envs.soccer``: the vectorised half-field soccer simulator (rcssserver physics, HFO features).
* ``envs.tasks``: the batched task cores and their PettingZoo / Gymnasium shells.
* ``from envs import blind_soccer_v0, guess_my_number_v0``: PettingZoo-style task modules with
  ``parallel_env()`` and ``batched_env(n_games=...)``.
* ``envs.registry`` (re-exported: ``from envs import TASKS, TaskSpec, get_task``): the one list of
  communication tasks, each a :class:`~envs.registry.TaskSpec` with its Gymnasium id, batched and
  PettingZoo constructors, channel size, oracle and reference policies.
* Gymnasium ids ``HFOMoveToBall-v0`` and ``HFOScoreEmptyGoal-v0`` (registered on import of
  ``envs``).

Submodules are imported lazily, so that importing ``envs.soccer`` stays cheap.
"""

from __future__ import annotations

import importlib
from typing import Any

import gymnasium

__all__ = [
    "TASKS",
    "TaskSpec",
    "UnknownTaskError",
    "blind_soccer_v0",
    "get_task",
    "guess_my_number_v0",
    "register_envs",
    "task_ids",
]

_REGISTRY_NAMES = ("TASKS", "TaskSpec", "UnknownTaskError", "get_task", "task_ids")

_GYM_IDS = {
    "HFOMoveToBall-v0": "envs.tasks.single_agent:MoveToBallEnv",
    "HFOScoreEmptyGoal-v0": "envs.tasks.single_agent:ScoreEmptyGoalEnv",
}


def register_envs() -> None:
    """Register the single-agent HFO tasks with Gymnasium (a no-op for ids already registered)."""
    for env_id, entry_point in _GYM_IDS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=entry_point)


register_envs()


def __getattr__(name: str) -> Any:
    """Import the task modules and the task registry on first use (``envs.blind_soccer_v0``,
    ``envs.get_task`` after ``import envs``)."""
    if name in ("blind_soccer_v0", "guess_my_number_v0"):
        return importlib.import_module(f"envs.{name}")
    if name in _REGISTRY_NAMES:
        from envs import registry

        return getattr(registry, name)
    raise AttributeError(f"module 'envs' has no attribute {name!r}")
