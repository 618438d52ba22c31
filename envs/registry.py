"""The one list of communication tasks: how to build each, its channel and its reference policies.

Every piece of code that needs a task by name reads it here instead of importing a module by a
name string: ``sb3_comm`` registers the Gymnasium ids from it, builds vectorised environments and
the :class:`~sb3_comm.wrappers.TwoAgentEnv` entry point with it, and the report and
``benchmarks/oracles.py`` take their oracle and random reference returns from it.

>>> from envs import get_task
>>> spec = get_task("BlindSoccer-v0")
>>> spec.key, spec.channel_size
('blind_soccer', 4)
>>> task = spec.batched_env(n_games=8)  # the vectorised core
>>> env = spec.parallel_env()  # one game, PettingZoo ParallelEnv

A task is found by its Gymnasium id (``"BlindSoccer-v0"``), its short key (``"blind_soccer"``, the
key of ``benchmarks/results/oracles.json``) or its PettingZoo name (``"blind_soccer_v0"``, the
module ``envs.blind_soccer_v0``). To add a task, append a :class:`TaskSpec` to :data:`TASKS`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from envs import blind_soccer_v0, guess_my_number_v0, oracles
from envs.tasks.batched import BatchedTask
from envs.tasks.parallel import CommParallelEnv

__all__ = ["TASKS", "Policy", "TaskSpec", "UnknownTaskError", "get_task", "task_ids"]

Policy = Callable[[BatchedTask], np.ndarray]
"""A scripted policy: ``policy(task) -> actions`` (n_games, n_agents, action_size)."""


class UnknownTaskError(KeyError):
    """A task name that no :class:`TaskSpec` answers to (a ``KeyError`` and a readable message)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


@dataclass(frozen=True)
class TaskSpec:
    """One communication task: identities, constructors, channel and reference policies.

    :param env_id: Gymnasium id registered by ``sb3_comm`` (e.g. ``"BlindSoccer-v0"``).
    :param key: short name used in result files (e.g. ``"blind_soccer"`` in
        ``benchmarks/results/oracles.json``).
    :param name: PettingZoo name of the task, also its module under ``envs``
        (e.g. ``"blind_soccer_v0"``).
    :param batched_env: ``batched_env(n_games=..., **options)``: the vectorised core.
    :param parallel_env: ``parallel_env(render_mode=None, **options)``: one game as a PettingZoo
        ``ParallelEnv``.
    :param channel_size: default size n of a message (the paper's: 4 and 1).
    :param agents: the task's agent names, in player order.
    :param oracle: the full-information scripted policy whose return bounds what a protocol can
        reach (SPEC §4, §5).
    :param baselines: further scripted reference policies by name, evaluated after the oracle and
        the random policy (e.g. Blind Soccer's ``blind_dash_forward``).
    """

    env_id: str
    key: str
    name: str
    batched_env: Callable[..., BatchedTask]
    parallel_env: Callable[..., CommParallelEnv]
    channel_size: int
    agents: tuple[str, ...]
    oracle: Policy
    baselines: Mapping[str, Policy] = field(default_factory=dict)

    def random_policy(self, rng: np.random.Generator) -> Policy:
        """The uniform random reference policy, drawing from ``rng``."""
        return lambda task: oracles.random_policy(task, rng)

    def reference_policies(self, rng: np.random.Generator) -> dict[str, Policy]:
        """Every reference policy in report order: ``oracle``, ``random`` (from ``rng``), then the
        task's :attr:`baselines`."""
        return {"oracle": self.oracle, "random": self.random_policy(rng), **self.baselines}


TASKS: Mapping[str, TaskSpec] = MappingProxyType(
    {
        spec.env_id: spec
        for spec in (
            TaskSpec(
                env_id="BlindSoccer-v0",
                key="blind_soccer",
                name="blind_soccer_v0",
                batched_env=blind_soccer_v0.batched_env,
                parallel_env=blind_soccer_v0.parallel_env,
                channel_size=4,
                agents=("sighted", "blind"),
                oracle=oracles.blind_soccer_oracle,
                baselines=MappingProxyType(
                    {
                        "blind_dash_forward": oracles.blind_dash_forward,
                        "visible_oracle": oracles.blind_soccer_visible_oracle,
                    }
                ),
            ),
            TaskSpec(
                env_id="GuessMyNumber-v0",
                key="guess_my_number",
                name="guess_my_number_v0",
                batched_env=guess_my_number_v0.batched_env,
                parallel_env=guess_my_number_v0.parallel_env,
                channel_size=1,
                agents=("agent_0", "agent_1"),
                oracle=oracles.guess_my_number_oracle,
            ),
        )
    }
)
"""Every communication task by Gymnasium id, in the order reports and benchmarks list them."""


def task_ids() -> tuple[str, ...]:
    """The Gymnasium ids of the tasks, in :data:`TASKS` order."""
    return tuple(TASKS)


def get_task(name: str) -> TaskSpec:
    """The task called ``name``: its Gymnasium id, short key or PettingZoo name.

    :raises UnknownTaskError: (a ``KeyError``) naming the accepted names.
    """
    for spec in TASKS.values():
        if name in (spec.env_id, spec.key, spec.name):
            return spec
    accepted = ", ".join(f"{s.env_id!r} (or {s.key!r}, {s.name!r})" for s in TASKS.values())
    raise UnknownTaskError(f"unknown task {name!r}; accepted: {accepted}")
