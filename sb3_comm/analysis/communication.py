"""All communication measures of one trained team, as a JSON-friendly dict (SPEC §5)."""

from __future__ import annotations

from typing import Any

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm

from sb3_comm.analysis.metrics import (
    default_n_bins,
    instantaneous_coordination,
    linear_probe,
    speaker_consistency,
)
from sb3_comm.analysis.rollout import (
    ACTION_NAMES,
    Rollout,
    collect_rollout,
    communication_directions,
    interventional_cic,
)

__all__ = ["analyse_communication", "direction_key"]


def direction_key(sender: str, receiver: str) -> str:
    """Name of a channel direction in the output, e.g. ``"sighted->blind"``."""
    return f"{sender}->{receiver}"


def _float(value: float) -> float | None:
    """JSON has no NaN: undefined numbers become None."""
    return None if value is None or not np.isfinite(value) else float(value)


def analyse_communication(
    model: BaseAlgorithm,
    env_id: str,
    n_episodes: int = 10,
    seed: int = 0,
    rollout: Rollout | None = None,
    n_messages: int = 16,
    max_states: int = 256,
    n_bins: int | None = None,
    env_kwargs: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Measure the protocol of ``model`` on ``env_id`` in every direction worth measuring.

    Directions come from :func:`~sb3_comm.analysis.rollout.communication_directions` (Blind
    Soccer: sighted -> blind; Guess My Number: both). Per direction:

    * ``cic``: interventional one-step CIC in nats (SUM over K forced messages; in
      ``[0, log min(K, 3)]``), see :func:`~sb3_comm.analysis.rollout.interventional_cic`;
    * ``speaker_consistency``: I(a_sender; m_t) in nats;
    * ``instantaneous_coordination``: I(m_t; a_receiver_{t+1}) in nats;
    * ``probe_accuracy`` / ``majority_rate``: cross-validated logistic regression from m_t to the
      receiver's action type at t + 1, and the rate of its most common action type;
    * ``n_pairs`` and ``next_action_counts`` (per action type name).

    :param model: a trained :class:`~sb3_comm.CommDDPG`.
    :param env_id: its task.
    :param n_episodes: episodes of the rollout when ``rollout`` is None.
    :param seed: seed of the rollout and of the random draws.
    :param rollout: a recorded :class:`Rollout` of ``model`` (skips playing new episodes).
    :param n_messages: K of the CIC.
    :param max_states: receiver states of the CIC.
    :param n_bins: bins per message dimension for the mutual informations (default
        :func:`~sb3_comm.analysis.metrics.default_n_bins`).
    :param env_kwargs: task options for the rollout.
    """
    if rollout is None:
        rollout = collect_rollout(model, env_id, n_episodes=n_episodes, seed=seed, env_kwargs=env_kwargs)
    bins = n_bins if n_bins is not None else default_n_bins(rollout.channel_size)
    names = rollout.agent_names
    directions: dict[str, Any] = {}
    for i, j in communication_directions(names):
        messages, sender_actions = rollout.sent(i)
        heard, next_actions = rollout.message_then_action(i, j)
        cic = interventional_cic(
            model, rollout, i, j, n_messages=n_messages, max_states=max_states, seed=seed
        )
        probe = linear_probe(heard, next_actions, seed=seed)
        counts = np.bincount(next_actions.astype(np.int64), minlength=rollout.n_action_types)
        directions[direction_key(names[i], names[j])] = {
            "sender": names[i],
            "receiver": names[j],
            "cic": _float(cic["cic"]),
            "cic_n_states": cic["n_states"],
            "cic_n_messages": cic["n_messages"],
            "speaker_consistency": _float(speaker_consistency(sender_actions, messages, bins)),
            "instantaneous_coordination": _float(instantaneous_coordination(heard, next_actions, bins)),
            "probe_accuracy": _float(probe["accuracy"]),
            "majority_rate": _float(probe["majority_rate"]),
            "probe_n_splits": probe["n_splits"],
            "n_pairs": int(next_actions.size),
            "next_action_counts": {
                (ACTION_NAMES[a] if a < len(ACTION_NAMES) else str(a)): int(c) for a, c in enumerate(counts)
            },
        }
    return {
        "env_id": env_id,
        "method": getattr(model, "method", None),
        "n_episodes": int(rollout.alive.shape[1]),
        "n_steps": rollout.n_steps,
        "channel_size": rollout.channel_size,
        "units": "nats",
        "discretisation": {
            "scheme": "per-dimension equal-frequency bins (mid-rank), combined into one symbol",
            "n_bins": int(bins),
        },
        "directions": directions,
    }
