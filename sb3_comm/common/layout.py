"""Where each part lives in the stacked observation and action of a communicating team.

A two-agent environment made by :class:`sb3_comm.wrappers.TwoAgentEnv` (or the batched
:class:`sb3_comm.wrappers.BatchedTwoAgentVecEnv`) has observations of shape
``(n_agents, obs_dim)`` and actions of shape ``(n_agents, action_dim)``. Each agent's row is::

    observation = [own features, zero padded | role one-hot (n_agents) | received message (n)]
    action      = [own action, zero padded | outgoing message (n)]

:class:`CommLayout` records those slices so that policies and algorithms never guess.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

__all__ = ["CommLayout", "HybridActionLayout"]


@dataclass(frozen=True)
class HybridActionLayout:
    """A parameterised action: ``n_actions`` scores then the continuous parameters.

    :param n_actions: number of discrete actions (their scores are entries ``0..n_actions-1``).
    :param parameters: for each discrete action, the indices of its parameters.
    """

    n_actions: int
    parameters: tuple[tuple[int, ...], ...]

    @classmethod
    def from_dict(cls, spec: dict[str, Any] | HybridActionLayout | None) -> HybridActionLayout | None:
        """Build from an environment's ``metadata["hybrid_action"]`` dictionary (or pass through)."""
        if spec is None or isinstance(spec, HybridActionLayout):
            return spec
        try:
            n_actions = int(spec["n_actions"])
            parameters = tuple(tuple(int(i) for i in group) for group in spec["parameters"])
        except (KeyError, TypeError, ValueError) as error:
            raise ValueError(
                "A hybrid action description must be a dict with 'n_actions' (int) and 'parameters' "
                f"(one list of indices per action), got {spec!r}"
            ) from error
        if len(parameters) != n_actions:
            raise ValueError(f"'parameters' must list one group per action ({n_actions}), got {parameters!r}")
        return cls(n_actions=n_actions, parameters=parameters)

    @property
    def size(self) -> int:
        """Number of entries of the action vector that the layout covers."""
        return max([self.n_actions - 1, *(i for group in self.parameters for i in group)]) + 1


@dataclass(frozen=True)
class CommLayout:
    """Shapes and slices of a communicating team's stacked observation and action.

    :param n_agents: number of agents (rows). 2 for the communication tasks, 1 for a single agent.
    :param obs_dim: length of one agent's observation row.
    :param action_dim: length of one agent's action row.
    :param channel_size: message size ``n`` (0: no channel).
    :param agent_names: the environment's agent names, in row order.
    :param hybrid: the parameterised-action layout of the (non-message) action, or None.
    """

    n_agents: int
    obs_dim: int
    action_dim: int
    channel_size: int
    agent_names: tuple[str, ...] = field(default=())
    hybrid: HybridActionLayout | None = None

    @property
    def obs_message_slice(self) -> slice:
        """Received message: the last ``channel_size`` entries of an observation row."""
        return slice(self.obs_dim - self.channel_size, self.obs_dim)

    @property
    def action_message_slice(self) -> slice:
        """Outgoing message: the last ``channel_size`` entries of an action row."""
        return slice(self.action_dim - self.channel_size, self.action_dim)

    @property
    def env_action_dim(self) -> int:
        """Length of the part of an action row that acts on the environment (without the message)."""
        return self.action_dim - self.channel_size
