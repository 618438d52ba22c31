"""Reference returns of a task: its oracle, the uniform random policy and its other baselines.

The policies come from the task registry (:class:`envs.registry.TaskSpec`): the full-information
oracle, the random policy and the task's ``baselines`` (Blind Soccer's ``blind_dash_forward``: the
blind agent dashes straight ahead, what the paper's GSN policy did with its messages disabled).
:func:`reference_returns` is what the report divides learned returns by (SPEC §5);
:func:`cached_references` reuses the values an earlier ``report.json`` holds.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["REFERENCE_SEED", "cached_references", "reference_returns"]

REFERENCE_SEED = 0
"""Seed of the oracle and random-policy evaluations (as ``benchmarks/oracles.py``)."""


def reference_returns(
    env_id: str, n_episodes: int = 1000, seed: int = REFERENCE_SEED
) -> dict[str, Any] | None:
    """Mean team return of each reference policy of a task (None if the task is unknown).

    :param env_id: a task of :data:`envs.registry.TASKS` (Gymnasium id, short key or PettingZoo
        name).
    :param n_episodes: episodes per policy (played on up to 1,000 parallel games).
    :param seed: seed of the task's resets and physics; the random policy draws from
        ``seed + 1``.
    :return: ``n_episodes``, ``seed`` and, per policy (``oracle``, ``random``, then the task's
        baselines), its mean team return ``<name>`` and its 95% half-width ``<name>_ci95``.
    """
    from envs import oracles
    from envs.registry import UnknownTaskError, get_task

    try:
        spec = get_task(env_id)
    except UnknownTaskError:
        return None
    policies = spec.reference_policies(np.random.default_rng(seed + 1))
    out: dict[str, Any] = {"n_episodes": n_episodes, "seed": seed}
    for name, policy in policies.items():
        task = spec.batched_env(n_games=min(n_episodes, 1000))
        summary = oracles.evaluate(task, policy, n_episodes, seed=seed)["team_return"]
        out[name] = summary["mean"]
        out[f"{name}_ci95"] = summary["ci95"]
    return out


def cached_references(report_dir: Path, n_episodes: int) -> dict[str, Any]:
    """References by task from ``report_dir/report.json``, those computed with ``n_episodes``
    episodes and :data:`REFERENCE_SEED` (``{}`` when there is no readable report)."""
    try:
        cached = json.loads((report_dir / "report.json").read_text()).get("references", {})
    except (OSError, ValueError, AttributeError):
        return {}
    return {
        task: ref
        for task, ref in cached.items()
        if isinstance(ref, dict) and ref.get("n_episodes") == n_episodes and ref.get("seed") == REFERENCE_SEED
    }
