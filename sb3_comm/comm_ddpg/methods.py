"""The communication methods, one object each (SPEC §1).

A method answers three questions, and nothing else in the package asks which method it is:

* **where a message comes from** (:meth:`CommMethod.messages`): zeros (``NONE``), the actor's
  extra outputs (``RIAL``, ``TCG``), or the message extractor ``M(o)`` of a grounded semantic
  network (``GSN``);
* **which message gradient the sender's actor gets** (:meth:`CommMethod.actor_gradient`): the
  sender's own critic (``RIAL``), the receiver's critic (``TCG``, paper §5), or none (``GSN`` and
  ``NONE`` have no message outputs);
* **which extra networks exist** (:meth:`CommMethod.make_networks`): the GSN for ``GSN``.
"""

from __future__ import annotations

from typing import ClassVar, Protocol

import torch as th
from torch import nn

from sb3_comm.comm_ddpg.gsn import GroundedSemanticNetwork
from sb3_comm.common.layout import CommLayout

__all__ = ["COMM_METHODS", "GSN", "METHODS", "NONE", "RIAL", "TCG", "CommMethod", "TeamPolicy"]


class TeamPolicy(Protocol):
    """What a method needs from the team's policy."""

    comm_layout: CommLayout
    env_action_dim: int
    gsn: GroundedSemanticNetwork | None
    activation_fn: type[nn.Module]
    share_parameters: bool
    gsn_net_arch: list[int]
    gsn_reward_net_arch: list[int]
    gsn_message_activation: str
    gsn_normalize_rewards: bool

    def actor_outputs(self, obs: th.Tensor, target: bool = False) -> th.Tensor: ...

    def q_values(self, obs: th.Tensor, actions: th.Tensor, target: bool = False) -> list[th.Tensor]: ...


class CommMethod:
    """Base: no messages of its own, no message gradient, no extra network."""

    name: ClassVar[str]
    comm_actions: ClassVar[bool] = False
    """Messages are actor outputs: explored like actions and seen by the critic."""

    def make_networks(self, policy: TeamPolicy) -> GroundedSemanticNetwork | None:
        """The method's extra trained network (None: none)."""
        return None

    def messages(self, policy: TeamPolicy, obs: th.Tensor, out: th.Tensor) -> th.Tensor:
        """Outgoing messages ``(B, n_agents, n)`` for observations ``obs`` and actor outputs ``out``."""
        return obs.new_zeros((*obs.shape[:-1], policy.comm_layout.channel_size))

    def actor_gradient(
        self,
        policy: TeamPolicy,
        grad: th.Tensor,
        out: th.Tensor,
        next_obs: th.Tensor,
        dones: th.Tensor,
        gain: float,
    ) -> th.Tensor:
        """The ascent direction of every actor output, given the own critic's ``grad = dQ_own/d out``.

        :param policy: the team's policy.
        :param grad: ``(B, n_agents, actor_out_dim)`` own-critic gradient (may be changed in place).
        :param out: ``(B, n_agents, actor_out_dim)`` bounded actor outputs (detached).
        :param next_obs: ``(B, n_agents, obs_dim)`` next observations.
        :param dones: ``(B, 1)`` terminal flags.
        :param gain: scale of a teammate's message gradient (``tcg_gain``).
        """
        return grad

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class NONE(CommMethod):
    """Baseline without communication: the channel carries zeros."""

    name = "NONE"


class RIAL(CommMethod):
    """RIAL: messages are extra actions trained by the sender's own critic, like any other action."""

    name = "RIAL"
    comm_actions = True

    def messages(self, policy: TeamPolicy, obs: th.Tensor, out: th.Tensor) -> th.Tensor:
        """The actor's communication outputs."""
        return out[..., policy.env_action_dim :]


class TCG(RIAL):
    """TCG: messages are extra actions trained by the *receiver's* critic (a continuous DIAL)."""

    name = "TCG"

    def actor_gradient(
        self,
        policy: TeamPolicy,
        grad: th.Tensor,
        out: th.Tensor,
        next_obs: th.Tensor,
        dones: th.Tensor,
        gain: float,
    ) -> th.Tensor:
        """The message part of ``grad`` is replaced by :meth:`teammate_message_gradients`."""
        grad[..., policy.env_action_dim :] = self.teammate_message_gradients(
            policy, out, next_obs, dones, gain
        )
        return grad

    @staticmethod
    def teammate_message_gradients(
        policy: TeamPolicy, out: th.Tensor, next_obs: th.Tensor, dones: th.Tensor, gain: float = 1.0
    ) -> th.Tensor:
        """Each sender's message gradient from its receiver's critic (paper §5).

        For sender ``i`` and receiver ``j``, with ``m = μ_i(o_i)`` the sender's current message put in
        the message slot of the receiver's next observation ``o'_j``::

            g_i = gain · ∂Q_j(o'_j[m], a'_j) / ∂m,    a'_j = μ_j(o'_j[m]) held fixed

        Terminal transitions give no gradient (there is no next step to hear the message).

        :param policy: the team's policy.
        :param out: ``(B, 2, actor_out_dim)`` bounded actor outputs (their last ``n`` are messages).
        :param next_obs: ``(B, 2, obs_dim)`` next observations.
        :param dones: ``(B, 1)`` terminal flags.
        :param gain: scale of the gradient (``tcg_gain``).
        :return: ``(B, 2, n)`` gradient for each sender's message outputs.
        """
        start = policy.comm_layout.obs_message_slice.start
        received = out[..., policy.env_action_dim :].detach().flip(1).clone().requires_grad_(True)
        next_rows = th.cat([next_obs[..., :start], received], dim=-1)
        with th.no_grad():
            next_actions = policy.actor_outputs(next_rows)
        receiver_q = policy.q_values(next_rows, next_actions)[0]
        grad_received = th.autograd.grad(receiver_q.sum(), received)[0]
        return gain * grad_received.flip(1) * (1.0 - dones).unsqueeze(-1)


class GSN(CommMethod):
    """GSN: messages are the hidden layer of a network predicting the teammate's reward (paper §3).

    The GSN is trained apart from the agents, by :class:`~sb3_comm.comm_ddpg.gsn.GSNTrainingCallback`.
    """

    name = "GSN"

    def make_networks(self, policy: TeamPolicy) -> GroundedSemanticNetwork | None:
        """The :class:`GroundedSemanticNetwork`, sized by the policy's ``gsn_*`` settings."""
        layout = policy.comm_layout
        return GroundedSemanticNetwork(
            layout.n_agents,
            layout.obs_dim,
            policy.env_action_dim,
            layout.channel_size,
            policy.gsn_net_arch,
            policy.gsn_reward_net_arch,
            policy.activation_fn,
            policy.share_parameters,
            policy.gsn_message_activation,
            policy.gsn_normalize_rewards,
        )

    def messages(self, policy: TeamPolicy, obs: th.Tensor, out: th.Tensor) -> th.Tensor:
        """``m = M(o_sender)``; no gradient flows into the GSN from the agents."""
        assert policy.gsn is not None
        with th.no_grad():
            return policy.gsn.message(obs)


METHODS = ("NONE", "RIAL", "TCG", "GSN")
"""Communication methods: no channel, reinforced, teammate gradients, grounded semantic network."""

COMM_METHODS: dict[str, type[CommMethod]] = {method.name: method for method in (NONE, RIAL, TCG, GSN)}
"""Method name -> its class."""
