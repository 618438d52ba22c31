"""Actor-critic policy for a communicating team with hybrid (parameterised) actions.

Per agent, the actor outputs the environment action (for HFO: 3 action scores and 5 parameters)
and, for RIAL and TCG, ``n`` communication values. The executed action is the argmax score with
its parameters (the environment decodes it); the critic sees the observation and *all* actor
outputs. GSN and NONE messages are not actor outputs (they come from the GSN, or are zero), so their
critic does not see the outgoing message; RIAL and TCG messages are actions and their critic does.
Bounded hybrid outputs are linear and kept in range with inverting gradients (ICLR 2016); a plain
``Box`` action uses ``tanh`` heads as SB3's TD3 does. Everything works in SB3's scaled action
space [-1, 1]; ``predict`` rescales to the environment's bounds.

Where the outgoing message comes from depends on the method (SPEC §1):
``NONE`` zeros; ``RIAL``/``TCG`` the actor's communication outputs; ``GSN`` the message
extractor ``M(o)`` of the :class:`~sb3_comm.comm_ddpg.gsn.GroundedSemanticNetwork`.
"""

from __future__ import annotations

from typing import Any

import torch as th
from gymnasium import spaces
from stable_baselines3.common.policies import BasePolicy
from stable_baselines3.common.type_aliases import PyTorchObs, Schedule
from torch import nn

from sb3_comm.comm_ddpg.gsn import GroundedSemanticNetwork
from sb3_comm.common.layout import CommLayout
from sb3_comm.common.networks import AgentMLPs

__all__ = ["METHODS", "CommPolicy", "GSNPolicy", "NonePolicy", "RIALPolicy", "TCGPolicy"]

METHODS = ("NONE", "RIAL", "TCG", "GSN")
"""Communication methods: no channel, reinforced, teammate gradients, grounded semantic network."""


class CommPolicy(BasePolicy):
    """Actor, critic(s), their targets and (for GSN) the grounded semantic network.

    :param observation_space: stacked rows ``Box(n_agents, obs_dim)`` (or ``(obs_dim,)`` for one agent).
    :param action_space: stacked rows ``Box(n_agents, action_dim)`` (or ``(action_dim,)``).
    :param lr_schedule: critic learning-rate schedule (the algorithm sets the actor's and GSN's).
    :param comm_layout: where messages sit in the rows; see :class:`CommLayout`.
    :param method: one of ``METHODS``.
    :param net_arch: hidden widths of actor and critic, or a dict with keys ``pi`` and ``qf``.
    :param activation_fn: hidden activation (leaky ReLU, slope 0.01, as the reference code).
    :param share_parameters: one set of networks for both agents, or one per agent (paper).
    :param n_critics: 1 for DDPG, 2 for TD3's clipped double Q.
    :param gsn_net_arch: hidden widths of the GSN message extractor ``M``.
    :param gsn_reward_net_arch: hidden widths of the GSN reward model ``R``.
    :param gsn_message_activation: ``"tanh"`` or ``"linear"`` (see the GSN).
    :param gsn_normalize_rewards: standardise the GSN's regression targets (see the GSN).
    :param optimizer_class: optimizer of actor, critic and GSN.
    :param optimizer_kwargs: extra optimizer arguments (the reference used Adam betas (0.95, 0.999)).
    """

    method: str = "NONE"

    def __init__(
        self,
        observation_space: spaces.Box,
        action_space: spaces.Box,
        lr_schedule: Schedule,
        comm_layout: CommLayout,
        method: str | None = None,
        net_arch: list[int] | dict[str, list[int]] | None = None,
        activation_fn: type[nn.Module] = nn.LeakyReLU,
        share_parameters: bool = True,
        n_critics: int = 1,
        gsn_net_arch: list[int] | None = None,
        gsn_reward_net_arch: list[int] | None = None,
        gsn_message_activation: str = "tanh",
        gsn_normalize_rewards: bool = True,
        optimizer_class: type[th.optim.Optimizer] = th.optim.Adam,
        optimizer_kwargs: dict[str, Any] | None = None,
    ) -> None:
        super().__init__(
            observation_space,
            action_space,
            optimizer_class=optimizer_class,
            optimizer_kwargs=optimizer_kwargs,
            squash_output=True,
        )
        method = (method or self.method).upper()
        if method not in METHODS:
            raise ValueError(f"Unknown communication method {method!r}; accepted: {list(METHODS)}")
        if method != "NONE" and comm_layout.channel_size < 1:
            raise ValueError(f"Method {method} needs a message channel; the environment has none")
        self.method = method
        self.comm_layout = comm_layout
        if net_arch is None:
            net_arch = [256, 256]
        actor_arch, critic_arch = (
            (net_arch["pi"], net_arch["qf"]) if isinstance(net_arch, dict) else (net_arch, net_arch)
        )
        self.net_arch = net_arch
        self.activation_fn = activation_fn
        self.share_parameters = share_parameters
        self.n_critics = n_critics
        self.gsn_net_arch = gsn_net_arch if gsn_net_arch is not None else [128, 128]
        self.gsn_reward_net_arch = gsn_reward_net_arch if gsn_reward_net_arch is not None else [128, 128]
        self.gsn_message_activation = gsn_message_activation
        self.gsn_normalize_rewards = gsn_normalize_rewards

        layout = comm_layout
        self.hybrid = layout.hybrid is not None
        self.has_comm_actions = method in ("RIAL", "TCG")
        self.env_action_dim = layout.env_action_dim
        self.actor_out_dim = self.env_action_dim + (layout.channel_size if self.has_comm_actions else 0)
        n, obs_dim = layout.n_agents, layout.obs_dim

        def make_actor() -> AgentMLPs:
            return AgentMLPs(n, obs_dim, self.actor_out_dim, actor_arch, activation_fn, share_parameters)

        def make_critics() -> nn.ModuleList:
            return nn.ModuleList(
                AgentMLPs(n, obs_dim + self.actor_out_dim, 1, critic_arch, activation_fn, share_parameters)
                for _ in range(n_critics)
            )

        self.actor, self.actor_target = make_actor(), make_actor()
        self.critic, self.critic_target = make_critics(), make_critics()
        self.actor_target.load_state_dict(self.actor.state_dict())
        self.critic_target.load_state_dict(self.critic.state_dict())
        self.actor_target.requires_grad_(False)
        self.critic_target.requires_grad_(False)
        self.actor.optimizer = optimizer_class(
            self.actor.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs
        )
        self.critic.optimizer = optimizer_class(
            self.critic.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs
        )

        self.gsn: GroundedSemanticNetwork | None = None
        if method == "GSN":
            self.gsn = GroundedSemanticNetwork(
                n,
                obs_dim,
                self.env_action_dim,
                layout.channel_size,
                self.gsn_net_arch,
                self.gsn_reward_net_arch,
                activation_fn,
                share_parameters,
                gsn_message_activation,
                gsn_normalize_rewards,
            )
            self.gsn.optimizer = optimizer_class(
                self.gsn.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs
            )

    # ----------------------------------------------------------------------------- helpers --
    def rows(self, x: th.Tensor) -> th.Tensor:
        """View observations/actions as ``(batch, n_agents, width)`` (single agents get a row axis)."""
        return x if x.dim() == 3 else x.reshape(x.shape[0], self.comm_layout.n_agents, -1)

    def bound_outputs(self, out: th.Tensor) -> th.Tensor:
        """Raw actor outputs to actions in [-1, 1]: ``tanh`` for plain Box heads, identity otherwise.

        Hybrid heads are linear: inverting gradients keep them in range during training, and
        :meth:`assemble_actions` clips what is executed.
        """
        return out if self.hybrid else th.tanh(out)

    def messages(self, obs: th.Tensor, out: th.Tensor) -> th.Tensor:
        """Outgoing messages ``(B, n_agents, n)`` for observations ``obs`` and actor outputs ``out``."""
        if self.has_comm_actions:
            return out[..., self.env_action_dim :]
        if self.gsn is not None:
            with th.no_grad():
                return self.gsn.message(obs)
        return obs.new_zeros((*obs.shape[:-1], self.comm_layout.channel_size))

    def assemble_actions(self, obs: th.Tensor, out: th.Tensor) -> th.Tensor:
        """Full action rows ``[environment action | message]`` from bounded actor outputs."""
        return th.cat([out[..., : self.env_action_dim], self.messages(obs, out)], dim=-1)

    def actor_outputs(self, obs: th.Tensor, target: bool = False) -> th.Tensor:
        """Bounded actor outputs ``(B, n_agents, actor_out_dim)``."""
        actor = self.actor_target if target else self.actor
        return self.bound_outputs(actor(obs))

    def q_values(self, obs: th.Tensor, actions: th.Tensor, target: bool = False) -> list[th.Tensor]:
        """Each critic's ``Q(o, a)`` per agent, ``(B, n_agents)``.

        :param obs: ``(B, n_agents, obs_dim)``.
        :param actions: bounded actor outputs ``(B, n_agents, actor_out_dim)``, or full action rows
            ``(B, n_agents, action_dim)`` as stored in the replay buffer (the outgoing message of
            GSN and NONE, which is not an actor output, is then dropped).
        """
        critics = self.critic_target if target else self.critic
        x = th.cat([obs, actions[..., : self.actor_out_dim]], dim=-1)
        return [critic(x).squeeze(-1) for critic in critics]

    # ---------------------------------------------------------------------------- SB3 API --
    def forward(self, obs: th.Tensor, deterministic: bool = True) -> th.Tensor:
        """Deterministic scaled actions (same as :meth:`_predict`)."""
        return self._predict(obs, deterministic)

    def _predict(self, observation: PyTorchObs, deterministic: bool = True) -> th.Tensor:
        obs = self.rows(observation)  # type: ignore[arg-type]
        actions = self.assemble_actions(obs, self.actor_outputs(obs)).clamp(-1.0, 1.0)
        return actions.reshape(observation.shape[0], *self.action_space.shape)  # type: ignore[union-attr]

    def set_training_mode(self, mode: bool) -> None:
        """Train/eval mode of the trained networks (targets stay in eval mode)."""
        self.actor.train(mode)
        self.critic.train(mode)
        if self.gsn is not None:
            self.gsn.train(mode)
        self.training = mode

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data.update(
            comm_layout=self.comm_layout,
            method=self.method,
            net_arch=self.net_arch,
            activation_fn=self.activation_fn,
            share_parameters=self.share_parameters,
            n_critics=self.n_critics,
            gsn_net_arch=self.gsn_net_arch,
            gsn_reward_net_arch=self.gsn_reward_net_arch,
            gsn_message_activation=self.gsn_message_activation,
            gsn_normalize_rewards=self.gsn_normalize_rewards,
            lr_schedule=self._dummy_schedule,
            optimizer_class=self.optimizer_class,
            optimizer_kwargs=self.optimizer_kwargs,
        )
        return data

    @staticmethod
    def _dummy_schedule(_: float) -> float:
        return 0.0


class NonePolicy(CommPolicy):
    """Baseline without communication: the channel carries zeros."""

    method = "NONE"


class RIALPolicy(CommPolicy):
    """RIAL: messages are extra actions trained by the sender's own critic."""

    method = "RIAL"


class TCGPolicy(CommPolicy):
    """TCG: messages are extra actions trained by the receiver's critic (continuous DIAL)."""

    method = "TCG"


class GSNPolicy(CommPolicy):
    """GSN: messages are the hidden layer of a network predicting the teammate's reward."""

    method = "GSN"
