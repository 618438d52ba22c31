"""Record what a trained team says and does, and measure the causal influence of its messages.

:func:`collect_rollout` plays ``n_episodes`` games at once (one episode each, deterministic
policy) in the batched VecEnv of :func:`~sb3_comm.make_comm_vec_env`, whose observation at each
step is ``(n_games, n_agents, obs_dim)``: one row per agent in ``comm_layout.agent_names`` order,
the received message in ``comm_layout.obs_message_slice`` of each row. A message that agent i
sends at step t (the message slot of its action row, clipped to the channel's [-1, 1] as the task
clips it) is in its teammate's observation at step t + 1.

:func:`interventional_cic` forces messages into the receiver's observations and asks the model
what the receiver would do: the one-step CIC of SPEC §5 on a real policy.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm

from sb3_comm.analysis.metrics import causal_influence_of_communication
from sb3_comm.common.files import atomic_path
from sb3_comm.common.layout import CommLayout
from sb3_comm.registration import make_comm_vec_env

__all__ = ["ACTION_NAMES", "Rollout", "collect_rollout", "communication_directions", "interventional_cic"]

ACTION_NAMES = ("dash", "turn", "kick")
"""Names of the discrete HFO action types (index = argmax of the first three action scores)."""


@dataclass
class Rollout:
    """Per step, game and agent: observation, sent message, discrete action type.

    Step ``t`` of game ``g`` belongs to the recorded episode when ``alive[t, g]``; after a game's
    episode ends its later steps (the env resets it) are padding.

    :param observations: ``(T, n_games, n_agents, obs_dim)`` what each agent observed at step t.
    :param messages: ``(T, n_games, n_agents, channel_size)`` the message each agent sent at step t.
    :param action_types: ``(T, n_games, n_agents)`` discrete action type (0 dash, 1 turn, 2 kick).
    :param alive: ``(T, n_games)`` whether step t is part of game g's recorded episode.
    :param agent_names: agent of each row.
    :param env_id: the task.
    :param obs_dim: length of an observation row.
    :param channel_size: message size.
    :param n_action_types: number of discrete action types.
    :param metadata: anything JSON-friendly (e.g. the method, the seed).
    """

    observations: np.ndarray
    messages: np.ndarray
    action_types: np.ndarray
    alive: np.ndarray
    agent_names: tuple[str, ...]
    env_id: str = ""
    obs_dim: int = 0
    channel_size: int = 0
    n_action_types: int = len(ACTION_NAMES)
    metadata: dict[str, Any] = field(default_factory=dict)

    @property
    def obs_message_slice(self) -> slice:
        """Received message within an observation row (as :attr:`CommLayout.obs_message_slice`)."""
        return slice(self.obs_dim - self.channel_size, self.obs_dim)

    @property
    def n_steps(self) -> int:
        """Recorded steps over all games (alive entries)."""
        return int(self.alive.sum())

    def agent_index(self, agent: str | int) -> int:
        """Row of an agent given by name or index."""
        if isinstance(agent, str):
            try:
                return self.agent_names.index(agent)
            except ValueError:
                raise ValueError(f"Unknown agent {agent!r}; agents: {list(self.agent_names)}") from None
        return int(agent)

    def sent(self, sender: str | int) -> tuple[np.ndarray, np.ndarray]:
        """The sender's messages ``(N, n)`` and its action types ``(N,)`` at every recorded step."""
        i = self.agent_index(sender)
        return self.messages[:, :, i][self.alive], self.action_types[:, :, i][self.alive]

    def message_then_action(self, sender: str | int, receiver: str | int) -> tuple[np.ndarray, np.ndarray]:
        """Messages ``(N, n)`` sent at step t and the receiver's action type ``(N,)`` at t + 1.

        Only pairs whose step t + 1 is still in the recorded episode (the receiver heard the message).
        """
        i, j = self.agent_index(sender), self.agent_index(receiver)
        pair = self.alive[1:]  # alive[t + 1] implies alive[t]
        return self.messages[:-1, :, i][pair], self.action_types[1:, :, j][pair]

    def save(self, path: str | Path) -> None:
        """Write a compressed ``.npz`` (arrays plus a JSON header), atomically."""
        header = {
            "agent_names": list(self.agent_names),
            "env_id": self.env_id,
            "obs_dim": self.obs_dim,
            "channel_size": self.channel_size,
            "n_action_types": self.n_action_types,
            "metadata": self.metadata,
        }
        path = Path(path) if str(path).endswith(".npz") else Path(f"{path}.npz")  # as NumPy names it
        with atomic_path(path) as tmp:
            np.savez_compressed(
                tmp,
                observations=self.observations,
                messages=self.messages,
                action_types=self.action_types,
                alive=self.alive,
                header=np.array(json.dumps(header)),
            )

    @classmethod
    def load(cls, path: str | Path) -> Rollout:
        """Read a file written by :meth:`save`."""
        with np.load(path, allow_pickle=False) as data:
            header = json.loads(str(data["header"]))
            return cls(
                observations=data["observations"],
                messages=data["messages"],
                action_types=data["action_types"],
                alive=data["alive"].astype(bool),
                agent_names=tuple(header["agent_names"]),
                env_id=header["env_id"],
                obs_dim=int(header["obs_dim"]),
                channel_size=int(header["channel_size"]),
                n_action_types=int(header.get("n_action_types", len(ACTION_NAMES))),
                metadata=header.get("metadata", {}),
            )


def _n_action_types(layout: CommLayout) -> int:
    if layout.hybrid is None:
        raise ValueError("Action types need a parameterised (hybrid) action layout; this task has none")
    return layout.hybrid.n_actions


def collect_rollout(
    model: BaseAlgorithm,
    env_id: str,
    n_episodes: int = 10,
    seed: int = 0,
    env_kwargs: dict[str, Any] | None = None,
) -> Rollout:
    """Play one deterministic episode in each of ``n_episodes`` parallel games and record it.

    :param model: a trained :class:`~sb3_comm.CommDDPG` (anything with ``predict``).
    :param env_id: registered id of a two-agent task with a hybrid action layout.
    :param n_episodes: episodes (= parallel games).
    :param seed: seed of the games.
    :param env_kwargs: task options.
    """
    vec_env = make_comm_vec_env(env_id, n_envs=n_episodes, seed=seed, env_kwargs=env_kwargs)
    layout: CommLayout = vec_env.get_attr("comm_layout", indices=[0])[0]
    n_types = _n_action_types(layout)
    observations, messages, action_types, alive = [], [], [], []
    running = np.ones(n_episodes, dtype=bool)
    obs = vec_env.reset()
    while running.any():
        action, _ = model.predict(obs, deterministic=True)
        action = np.asarray(action, dtype=np.float32).reshape(n_episodes, layout.n_agents, layout.action_dim)
        observations.append(obs.astype(np.float32, copy=True))
        messages.append(np.clip(action[..., layout.action_message_slice], -1.0, 1.0))
        action_types.append(np.argmax(action[..., :n_types], axis=-1).astype(np.int8))
        alive.append(running.copy())
        obs, _, dones, _ = vec_env.step(action)
        running &= ~np.asarray(dones, dtype=bool)
    vec_env.close()
    return Rollout(
        observations=np.stack(observations),
        messages=np.stack(messages),
        action_types=np.stack(action_types),
        alive=np.stack(alive),
        agent_names=tuple(layout.agent_names),
        env_id=env_id,
        obs_dim=layout.obs_dim,
        channel_size=layout.channel_size,
        n_action_types=n_types,
        metadata={"n_episodes": n_episodes, "seed": seed, "method": getattr(model, "method", None)},
    )


def communication_directions(agent_names: tuple[str, ...] | list[str]) -> list[tuple[int, int]]:
    """The ``(sender, receiver)`` rows whose channel is worth measuring.

    Blind Soccer (agents ``sighted`` and ``blind``): sighted -> blind only, the blind agent sees
    nothing it could tell. Any other two-agent task (Guess My Number): both directions.
    """
    names = list(agent_names)
    if "sighted" in names and "blind" in names:
        return [(names.index("sighted"), names.index("blind"))]
    if len(names) != 2:
        return []
    return [(0, 1), (1, 0)]


def interventional_cic(
    model: BaseAlgorithm,
    rollout: Rollout,
    sender: str | int,
    receiver: str | int,
    n_messages: int = 16,
    max_states: int = 256,
    seed: int = 0,
) -> dict[str, Any]:
    """One-step CIC of the sender's messages on the receiver's action type (SPEC §5).

    For up to ``max_states`` recorded steps (the team's full observation at that step), the
    receiver's message slot is replaced by each of ``K = n_messages`` messages drawn from the
    sender's sent messages; the receiver's deterministic action type under each gives a one-hot
    p(a | do m), and p(m) = 1 / K. The CIC is then in ``[0, log min(K, n_action_types)]``.

    :param model: the model that produced ``rollout`` (anything with ``predict``).
    :param rollout: a :class:`Rollout` of the model on its task.
    :param sender: sender agent (name or row).
    :param receiver: receiver agent (name or row).
    :param n_messages: K, messages drawn (without replacement when there are enough).
    :param max_states: receiver states used (drawn at random when there are more).
    :param seed: seed of both draws.
    :return: ``cic`` (nats), ``n_states``, ``n_messages`` and, as arrays, ``messages`` ``(K, n)``
        (the forced messages), ``p_action_do_message`` ``(n_states, K, n_action_types)`` and
        ``p_message`` ``(K,)``.
    """
    i, j = rollout.agent_index(sender), rollout.agent_index(receiver)
    rng = np.random.default_rng(seed)
    sent, _ = rollout.sent(i)
    states = rollout.observations[rollout.alive]  # (N, n_agents, obs_dim)
    n_types = rollout.n_action_types
    if sent.shape[0] == 0 or states.shape[0] == 0 or rollout.channel_size == 0:
        return {
            "cic": float("nan"),
            "n_states": 0,
            "n_messages": 0,
            "messages": np.zeros((0, rollout.channel_size)),
            "p_action_do_message": np.zeros((0, 0, n_types)),
            "p_message": np.zeros(0),
        }
    k = int(n_messages)
    picks = rng.choice(sent.shape[0], size=k, replace=sent.shape[0] < k)
    forced = sent[picks]  # (K, n)
    if states.shape[0] > max_states:
        states = states[rng.choice(states.shape[0], size=max_states, replace=False)]
    n_states = states.shape[0]
    batch = np.repeat(states[:, None], k, axis=1).copy()  # (S, K, n_agents, obs_dim)
    batch[:, :, j, rollout.obs_message_slice] = forced[None]
    action, _ = model.predict(batch.reshape(n_states * k, *states.shape[1:]), deterministic=True)
    action = np.asarray(action).reshape(n_states, k, states.shape[1], -1)
    types = np.argmax(action[:, :, j, :n_types], axis=-1)  # (S, K)
    p_action = np.eye(n_types)[types]  # one-hot: the policy is deterministic
    p_message = np.full(k, 1.0 / k)
    return {
        "cic": causal_influence_of_communication(p_action, p_message),
        "n_states": int(n_states),
        "n_messages": k,
        "messages": forced,
        "p_action_do_message": p_action,
        "p_message": p_message,
    }
