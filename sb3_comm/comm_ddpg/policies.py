"""Actor-critic policy of a communicating team with hybrid (parameterised) actions.

:class:`CommPolicy` is the single-agent :class:`~sb3_comm.hybrid_ddpg.policies.HybridPolicy` run
on every agent's row ``(B, n_agents, width)``, with one set of networks for all agents (the role
one-hot in the observation tells them apart) or one per agent. Per agent, the actor outputs the
environment action and, where messages are actions (RIAL, TCG), ``n`` communication values; the
critic sees the observation and all actor outputs. Where the outgoing message comes from, and
which extra network exists, is the business of the policy's
:class:`~sb3_comm.comm_ddpg.methods.CommMethod` (SPEC §1): ``NONE`` zeros, ``RIAL``/``TCG`` the
actor's communication outputs, ``GSN`` and ``GSN-MAX`` the message extractor ``M(o)`` of the
:class:`~sb3_comm.comm_ddpg.gsn.GroundedSemanticNetwork`.

``NonePolicy``, ``RIALPolicy``, ``TCGPolicy``, ``GSNPolicy`` and ``GSNMAXPolicy`` are the policy aliases of
:class:`~sb3_comm.CommDDPG` (and the class paths saved in model files).
"""

from __future__ import annotations

from typing import Any, ClassVar

import torch as th
from gymnasium import spaces
from stable_baselines3.common.type_aliases import Schedule
from torch import nn

from sb3_comm.comm_ddpg.gsn import GroundedSemanticNetwork
from sb3_comm.comm_ddpg.methods import COMM_METHODS, GSN, GSNMAX, METHODS, NONE, RIAL, TCG, CommMethod
from sb3_comm.common.layout import CommLayout
from sb3_comm.common.networks import AgentMLPs
from sb3_comm.hybrid_ddpg.policies import HybridPolicy

__all__ = ["METHODS", "CommPolicy", "GSNMAXPolicy", "GSNPolicy", "NonePolicy", "RIALPolicy", "TCGPolicy"]


class CommPolicy(HybridPolicy):
    """Actor, critic(s), their targets and the method's extra network (the GSN) for a team.

    :param observation_space: stacked rows ``Box(n_agents, obs_dim)``.
    :param action_space: stacked rows ``Box(n_agents, action_dim)``.
    :param lr_schedule: critic learning-rate schedule (the algorithm sets the actor's and GSN's).
    :param comm_layout: where messages sit in the rows; see :class:`CommLayout`.
    :param method: one of ``METHODS`` (default: the class's method).
    :param net_arch: hidden widths of actor and critic, or a dict with keys ``pi`` and ``qf``.
    :param activation_fn: hidden activation (leaky ReLU, slope 0.01, as the reference code).
    :param share_parameters: one set of networks for both agents, or one per agent (paper).
    :param n_critics: 1 for DDPG, 2 for TD3's clipped double Q.
    :param score_gradient: what moves the action scores (see :class:`HybridPolicy`).
    :param critic_layer_norm: normalised hidden layers in the critics (see :class:`HybridPolicy`).
    :param actor_guard: move the actor back towards the target actor where the critic prefers
        the target actor's outputs (see :class:`HybridPolicy`).
    :param averaged_actor: the team plays the target actor, the actor's Polyak average, outside
        training (see :class:`HybridPolicy`); the messages of RIAL and TCG, actor outputs, then come
        from it too, a GSN's messages from the GSN as always.
    :param actor_average_tau: the rate of that average (None: the target actor's, ``tau``; a
        number, or ``"auto"``: a separate average, the rate set from the run's budget; see
        :class:`HybridPolicy`).
    :param precision: ``"float32"`` or ``"bfloat16"``: the arithmetic of the hidden layers of every
        network, the GSN's included (see :class:`HybridPolicy`).
    :param gsn_net_arch: hidden widths of the GSN message extractor ``M``.
    :param gsn_reward_net_arch: hidden widths of the GSN reward model ``R``.
    :param gsn_message_activation: ``"tanh"`` or ``"linear"`` (see the GSN).
    :param gsn_normalize_rewards: standardise the GSN's regression targets (see the GSN).
    :param gsn_reward_hears: the GSN's reward model also sees the message the teammate heard
        (an option tried for GSN-MAX; off, as in the paper's GSN).
    :param gsn_reward_sees_teammate: the GSN's reward model also sees the teammate's own
        observation (without the message it heard): ``R(M(o_i), a_j, o_j)``, trained centrally; the
        message still depends on the sender's observation alone (off, as in the paper's GSN).
    :param gsn_maximising_head: GSN-MAX only: send ``m = M(o) + H(o)``, where the head ``H`` alone
        follows the receiver critic's gradient and ``M`` the regression alone
        (:class:`~sb3_comm.comm_ddpg.methods.GSNMAX`, "head design"); off: one extractor ``M``
        trained by the mix of both signals.
    :param gsn_effect_model: GSN-MAX only: its maximising signal comes from two centralised
        one-step effect models ``E_1, E_2`` of the receiver's reward (the situation without
        messages, the message heard, the receiver's action): the effect search
        (:meth:`~sb3_comm.comm_ddpg.methods.GSNMAX.search_targets`, the default for a new GSN-MAX
        model), or with ``gsn_max_search=0`` the model's gradient
        (:meth:`~sb3_comm.comm_ddpg.methods.GSNMAX.effect_gradients`); off: the receiver's critic.
    :param gsn_effect_paths: with ``gsn_max_search=0``, which paths of the message's effect the
        gradient follows: ``"total"`` (both), ``"action"`` (only through the receiver's action) or
        ``"direct"`` (only ``∂E/∂m``).
    :param optimizer_class: optimizer of actor, critic and GSN.
    :param optimizer_kwargs: extra optimizer arguments (the reference used Adam betas (0.95, 0.999)).
    """

    method_class: ClassVar[type[CommMethod]] = NONE
    gsn: GroundedSemanticNetwork | None

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
        score_gradient: str = "critic",
        critic_layer_norm: bool = False,
        actor_guard: bool = False,
        averaged_actor: bool = False,
        actor_average_tau: float | str | None = None,
        precision: str = "float32",
        gsn_net_arch: list[int] | None = None,
        gsn_reward_net_arch: list[int] | None = None,
        gsn_message_activation: str = "tanh",
        gsn_normalize_rewards: bool = True,
        gsn_reward_hears: bool = False,
        gsn_maximising_head: bool = False,
        gsn_reward_sees_teammate: bool = False,
        gsn_effect_model: bool = False,
        gsn_effect_paths: str = "total",
        optimizer_class: type[th.optim.Optimizer] = th.optim.Adam,
        optimizer_kwargs: dict[str, Any] | None = None,
    ) -> None:
        name = (method or self.method_class.name).upper()
        if name not in COMM_METHODS:
            raise ValueError(f"Unknown communication method {name!r}; accepted: {list(METHODS)}")
        if name != "NONE" and comm_layout.channel_size < 1:
            raise ValueError(f"Method {name} needs a message channel; the environment has none")
        # Set before HybridPolicy.__init__, which builds the networks (plain values, no modules).
        self.comm_method = COMM_METHODS[name]()
        self.comm_layout = comm_layout
        self.share_parameters = share_parameters
        self.gsn_net_arch = gsn_net_arch if gsn_net_arch is not None else [128, 128]
        self.gsn_reward_net_arch = gsn_reward_net_arch if gsn_reward_net_arch is not None else [128, 128]
        self.gsn_message_activation = gsn_message_activation
        self.gsn_normalize_rewards = gsn_normalize_rewards
        self.gsn_reward_hears = bool(gsn_reward_hears)  # None in models saved with the first version
        self.gsn_maximising_head = bool(gsn_maximising_head)
        self.gsn_reward_sees_teammate = bool(gsn_reward_sees_teammate)
        self.gsn_effect_model = bool(gsn_effect_model)
        self.gsn_effect_paths = gsn_effect_paths
        if self.gsn_effect_model and name != "GSN-MAX":
            raise ValueError(
                f"policy_kwargs gsn_effect_model=True applies to GSN-MAX only (it gives GSN-MAX's "
                f"maximising signal); method {name} would never use it: leave it False"
            )
        if self.gsn_effect_model and self.gsn_maximising_head:
            raise ValueError(
                "policy_kwargs gsn_effect_model=True and gsn_maximising_head=True are two GSN-MAX designs; "
                "choose one"
            )
        if self.gsn_maximising_head and name != "GSN-MAX":
            raise ValueError(
                f"policy_kwargs gsn_maximising_head=True applies to GSN-MAX only (a head trained by the "
                f"receiver's critic); method {name} would never train it: leave it False"
            )
        super().__init__(
            observation_space,
            action_space,
            lr_schedule,
            hybrid_layout=comm_layout.hybrid,
            net_arch=net_arch,
            activation_fn=activation_fn,
            n_critics=n_critics,
            score_gradient=score_gradient,
            critic_layer_norm=critic_layer_norm,
            actor_guard=actor_guard,
            averaged_actor=averaged_actor,
            actor_average_tau=actor_average_tau,
            precision=precision,
            optimizer_class=optimizer_class,
            optimizer_kwargs=optimizer_kwargs,
        )

    @property
    def method(self) -> str:
        """The communication method's name: ``"NONE"``, ``"RIAL"``, ``"TCG"``, ``"GSN"`` or ``"GSN-MAX"``."""
        return self.comm_method.name

    @property
    def has_comm_actions(self) -> bool:
        """Messages are actor outputs (RIAL, TCG)."""
        return self.comm_method.comm_actions

    # ------------------------------------------------------------------------------ build --
    def _env_action_dim(self) -> int:
        return self.comm_layout.env_action_dim

    def _actor_out_dim(self) -> int:
        return self.env_action_dim + (self.comm_layout.channel_size if self.has_comm_actions else 0)

    def make_actor(self) -> nn.Module:
        """The actor of every agent row."""
        layout = self.comm_layout
        return AgentMLPs(
            layout.n_agents, layout.obs_dim, self.actor_out_dim, self.actor_arch, self.activation_fn,
            self.share_parameters,
        )  # fmt: skip

    def make_critic(self) -> nn.Module:
        """The critic of every agent row."""
        layout = self.comm_layout
        return AgentMLPs(
            layout.n_agents, layout.obs_dim + self.actor_out_dim, 1, self.critic_arch, self.activation_fn,
            self.share_parameters, self.critic_layer_norm,
        )  # fmt: skip

    def _build(self, lr_schedule: Schedule) -> None:
        super()._build(lr_schedule)
        self.gsn = self.comm_method.make_networks(self)
        if self.gsn is not None:
            head = self.gsn.maximising_head
            if head is None:
                self.gsn.optimizer = self.make_optimizer(self.gsn, lr_schedule(1))
            else:  # the regression's optimizer must not move the head
                grounding = nn.ModuleList([self.gsn.message_extractor, self.gsn.reward_model])
                self.gsn.optimizer = self.make_optimizer(grounding, lr_schedule(1))
                self.gsn.head_optimizer = self.make_optimizer(head, lr_schedule(1))

    # ---------------------------------------------------------------------------- helpers --
    def critic_value(self, critic: nn.Module, x: th.Tensor) -> th.Tensor:
        """One critic's ``Q`` per agent, ``(B, n_agents)``."""
        return critic(x).squeeze(-1)

    def q_values(self, obs: th.Tensor, actions: th.Tensor, target: bool = False) -> list[th.Tensor]:
        """Each critic's ``Q(o, a)`` per agent, ``(B, n_agents)``.

        :param obs: ``(B, n_agents, obs_dim)``.
        :param actions: bounded actor outputs ``(B, n_agents, actor_out_dim)``, or full action rows
            ``(B, n_agents, action_dim)`` as stored in the replay buffer (the outgoing message of
            GSN and NONE, which is not an actor output, is then dropped).
        :param target: use the target critics.
        """
        return super().q_values(obs, actions, target)

    def messages(self, obs: th.Tensor, out: th.Tensor) -> th.Tensor:
        """Outgoing messages ``(B, n_agents, n)`` for observations ``obs`` and actor outputs ``out``."""
        return self.comm_method.messages(self, obs, out)

    def assemble_actions(self, obs: th.Tensor, out: th.Tensor) -> th.Tensor:
        """Full action rows ``[environment action | message]`` from bounded actor outputs."""
        return th.cat([out[..., : self.env_action_dim], self.messages(obs, out)], dim=-1)

    # ---------------------------------------------------------------------------- SB3 API --
    def observation_agents(self) -> tuple[str, ...]:
        """Names of the agent rows of an observation, for error messages."""
        return tuple(self.comm_layout.agent_names)

    def scaled_actions(self, observation: th.Tensor, averaged: bool = False) -> th.Tensor:
        """The team's full action rows ``[environment action | message]`` in scaled units, from
        the actor or (``averaged``) its average, the target actor or ``actor_average``; see
        :meth:`HybridPolicy.played_outputs`."""
        obs = observation.reshape(observation.shape[0], *self.observation_space.shape)  # type: ignore[union-attr, misc]
        actions = self.assemble_actions(obs, self.played_outputs(obs, averaged)).clamp(-1.0, 1.0)
        return actions.reshape(observation.shape[0], *self.action_space.shape)  # type: ignore[union-attr]

    def _trained_submodules(self) -> list[nn.Module]:
        """The actor, the critics and the GSN (its mode decides whether it updates its reward
        statistics)."""
        gsn = [] if self.gsn is None else list(self.gsn.modules())
        return [*super()._trained_submodules(), *gsn]

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        del data["hybrid_layout"]  # part of the comm_layout
        data.update(
            comm_layout=self.comm_layout,
            method=self.method,
            share_parameters=self.share_parameters,
            gsn_net_arch=self.gsn_net_arch,
            gsn_reward_net_arch=self.gsn_reward_net_arch,
            gsn_message_activation=self.gsn_message_activation,
            gsn_normalize_rewards=self.gsn_normalize_rewards,
            gsn_reward_hears=self.gsn_reward_hears,
            gsn_maximising_head=self.gsn_maximising_head,
            gsn_reward_sees_teammate=self.gsn_reward_sees_teammate,
            gsn_effect_model=self.gsn_effect_model,
            gsn_effect_paths=self.gsn_effect_paths,
        )
        return data


class NonePolicy(CommPolicy):
    """Baseline without communication: the channel carries zeros."""

    method_class = NONE


class RIALPolicy(CommPolicy):
    """RIAL: messages are extra actions trained by the sender's own critic."""

    method_class = RIAL


class TCGPolicy(CommPolicy):
    """TCG: messages are extra actions trained by the receiver's critic (continuous DIAL)."""

    method_class = TCG


class GSNPolicy(CommPolicy):
    """GSN: messages are the hidden layer of a network predicting the teammate's reward."""

    method_class = GSN


class GSNMAXPolicy(CommPolicy):
    """GSN-MAX: GSN messages whose extractor is also trained along the receiver critic's gradient."""

    method_class = GSNMAX
