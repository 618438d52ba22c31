"""The communication methods, one object each (SPEC §1).

A method answers three questions, and nothing else in the package asks which method it is:

* **where a message comes from** (:meth:`CommMethod.messages`): zeros (``NONE``), the actor's
  extra outputs (``RIAL``, ``TCG``), or the message extractor ``M(o)`` of a grounded semantic
  network (``GSN``);
* **which message gradient the sender's actor gets** (:meth:`CommMethod.actor_gradient`): the
  sender's own critic (``RIAL``), the receiver's critic (``TCG``, paper §5), or none (``GSN`` and
  ``NONE`` have no message outputs);
* **which extra networks exist** (:meth:`CommMethod.make_networks`): the GSN for ``GSN`` and
  ``GSN-MAX``.

Beyond the paper, ``GSN-MAX`` (:class:`GSNMAX`) trains the GSN's message extractor ``M`` with
GSN's grounding regression and a pull towards messages with a better *effect* on the teammate's
reward (the effect search, the default)::

    E_1, E_2(s_j, s_i, m_j, a_j) ≈ r_j        m_j: the message j heard; fitted on explorer games
    m* = argmax_c E_1(s'_j, s'_i, c, a'_j)    K candidates c for i's message m_i, a'_j = μ_j(o'_j ⊕ m_i)
    pulled ⇔ E_2 gain of m* over m_i > max(√(1 − R²_E), 0.1, |gain_1 − gain_2|)
    L = L_g(M, R) + L_E(E_1, E_2) + λ · ½ mean_pulled ‖M(o_i) − atanh(m*)‖²,  λ = w/(1 − w) · R²_E

The earlier designs (options) mix TCG's receiver-critic gradient into the grounding instead.
"""

from __future__ import annotations

from typing import ClassVar, Protocol

import torch as th
from torch import nn

from sb3_comm.comm_ddpg.gsn import GroundedSemanticNetwork
from sb3_comm.common.layout import CommLayout
from sb3_comm.common.networks import inverting_gradients
from sb3_comm.common.validation import GSN_MAX_SIGNALS

__all__ = [
    "COMM_METHODS",
    "GSN",
    "GSNMAX",
    "GSN_MAX_SIGNALS",
    "METHODS",
    "NONE",
    "PAPER_METHODS",
    "RIAL",
    "TCG",
    "CommMethod",
    "TeamPolicy",
]


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
    gsn_reward_hears: bool
    gsn_reward_sees_teammate: bool

    def actor_outputs(self, obs: th.Tensor, target: bool = False) -> th.Tensor: ...

    def q_values(self, obs: th.Tensor, actions: th.Tensor, target: bool = False) -> list[th.Tensor]: ...

    def critic_action_gradients(self, obs: th.Tensor, out: th.Tensor) -> tuple[th.Tensor, th.Tensor]: ...


class CommMethod:
    """Base: no messages of its own, no message gradient, no extra network."""

    name: ClassVar[str]
    comm_actions: ClassVar[bool] = False
    """Messages are actor outputs: explored like actions and seen by the critic."""
    explore_messages: ClassVar[bool] = False
    """Messages that are not actor outputs are still explored (ε-random messages are sent)."""

    def make_networks(self, policy: TeamPolicy) -> GroundedSemanticNetwork | None:
        """The method's extra trained network (None: none)."""
        return None

    def messages(self, policy: TeamPolicy, obs: th.Tensor, out: th.Tensor) -> th.Tensor:
        """Outgoing messages ``(B, n_agents, n)`` for observations ``obs`` and actor outputs ``out``."""
        return obs.new_zeros((*obs.shape[:-1], policy.comm_layout.channel_size))

    def actor_gradients(
        self,
        policy: TeamPolicy,
        obs: th.Tensor,
        out: th.Tensor,
        next_obs: th.Tensor,
        dones: th.Tensor,
        gain: float,
    ) -> tuple[th.Tensor, th.Tensor]:
        """The ascent direction of every actor output (before inverting gradients) and the own
        critic's ``Q``: ``dQ_own/d out`` at ``out``, then :meth:`actor_gradient`.

        :param policy: the team's policy.
        :param obs: ``(B, n_agents, obs_dim)`` observations.
        :param out: ``(B, n_agents, actor_out_dim)`` bounded actor outputs (detached).
        :param next_obs: ``(B, n_agents, obs_dim)`` next observations.
        :param dones: ``(B, 1)`` terminal flags.
        :param gain: scale of a teammate's message gradient (``tcg_gain``).
        :return: ``grad`` shaped like ``out`` and ``own_q`` ``(B, n_agents)`` (detached).
        """
        grad, own_q = policy.critic_action_gradients(obs, out)
        return self.actor_gradient(policy, grad, out, next_obs, dones, gain), own_q

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

    def actor_gradients(
        self,
        policy: TeamPolicy,
        obs: th.Tensor,
        out: th.Tensor,
        next_obs: th.Tensor,
        dones: th.Tensor,
        gain: float,
    ) -> tuple[th.Tensor, th.Tensor]:
        """The own critic's ``dQ_own/d out`` and the receivers' message gradient
        (:meth:`teammate_message_gradients`) from **one** pass of the critic over both batches,
        the senders' rows and the receivers' next rows stacked: the same values as two passes
        (each row's ``Q`` depends on its own inputs only), with half the calls."""
        batch = obs.shape[0]
        messages = out[..., policy.env_action_dim :]
        received, next_rows, next_actions = self._receiver_inputs(policy, messages, next_obs)
        current = out.detach().requires_grad_(True)
        q = policy.q_values(th.cat([obs, next_rows]), th.cat([current, next_actions]))[0]
        grad, grad_received = th.autograd.grad(q.sum(), [current, received])
        grad[..., policy.env_action_dim :] = gain * grad_received.flip(1) * (1.0 - dones).unsqueeze(-1)
        return grad, q[:batch].detach()

    @staticmethod
    def _receiver_inputs(
        policy: TeamPolicy, messages: th.Tensor, next_obs: th.Tensor
    ) -> tuple[th.Tensor, th.Tensor, th.Tensor]:
        """Each sender's message in its receiver's next row: the message leaf (requires grad),
        the receivers' next rows ``o'_j[m_i]`` and their next actions ``a'_j`` (held fixed)."""
        start = policy.comm_layout.obs_message_slice.start
        received = messages.detach().flip(1).requires_grad_(True)  # flip copies: a leaf of its own
        next_rows = th.cat([next_obs[..., :start], received], dim=-1)
        with th.no_grad():
            next_actions = policy.actor_outputs(next_rows)
        return received, next_rows, next_actions

    @staticmethod
    def receiver_message_gradients(
        policy: TeamPolicy, messages: th.Tensor, next_obs: th.Tensor, dones: th.Tensor, gain: float = 1.0
    ) -> th.Tensor:
        """``gain · ∂Q_j(o'_j[m_i], a'_j)/∂m_i`` for each sender ``i`` of ``messages`` ``(B, 2, n)``,
        its receiver ``j``; see :meth:`teammate_message_gradients`."""
        received, next_rows, next_actions = TCG._receiver_inputs(policy, messages, next_obs)
        receiver_q = policy.q_values(next_rows, next_actions)[0]
        grad_received = th.autograd.grad(receiver_q.sum(), received)[0]
        return gain * grad_received.flip(1) * (1.0 - dones).unsqueeze(-1)

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
        messages = out[..., policy.env_action_dim :]
        return TCG.receiver_message_gradients(policy, messages, next_obs, dones, gain)


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
            heard_dim=layout.channel_size if policy.gsn_reward_hears else 0,
            maximising_head=getattr(policy, "gsn_maximising_head", False),
            teammate_obs_dim=layout.obs_message_slice.start if policy.gsn_reward_sees_teammate else 0,
            effect_obs_dim=layout.obs_message_slice.start
            if getattr(policy, "gsn_effect_model", False)
            else 0,
        )

    def messages(self, policy: TeamPolicy, obs: th.Tensor, out: th.Tensor) -> th.Tensor:
        """``m = M(o_sender)``; no gradient flows into the GSN from the agents."""
        assert policy.gsn is not None
        with th.no_grad():
            return policy.gsn.message(obs)


class GSNMAX(GSN):
    r"""GSN-MAX (beyond the paper, its §8): grounded messages that also maximise the teammate's return.

    The message is the GSN's hidden layer ``m_i = tanh(M(o_i; θm))``, as in GSN.

    **Effect search** (the packaged design: ``policy_kwargs`` ``gsn_effect_model=True``,
    ``gsn_max_search=K``, ``gsn_max_explorers``). A message can raise the teammate's reward in two
    ways: by what it *says* about the situation (Blind Soccer: where the ball is; the teammate
    acts on it) and by what it *does* (Guess My Number: the reward is a function of the heard
    message). GSN's grounding regression shapes the first. TCG's signal, ``∂Q_j(o'_j ⊕ m, a'_j)/∂m``
    with the receiver's own critic, confounds the two: that critic knows the situation only from
    the message, so its slope in the message is "which situation would make this action look
    good", and following it makes the message say what the receiver wishes were true (on Blind
    Soccer every design that followed it stood still). GSN-MAX's maximising signal is instead the
    message's effect with the situation in view, learned apart from what the message says:

    * **explorer games**: in a fraction ``gsn_max_explorers`` of the parallel games every agent
      sends a uniformly random message; their transitions train only the effect models (never the
      agents or the grounding), so in their data the message is independent of the situation;
    * **effect models** ``E_1, E_2``: two centralised one-step models of an agent's own reward,
      ``E_k(s_j, s_i, m_j, a_j) ≈ r_j`` (``s``: both agents' observations without the messages
      heard), regressed on the explorer games' transitions (standardised rewards);
    * **search**: for each message of a replayed batch, ``K`` candidates (half uniform in
      [-1, 1], half around the sent message), judged by their *direct* effect at the next step,
      the receiver's action held at its response to the sent message; ``E_1`` picks, ``E_2``
      judges (as double Q-learning: the best of K noisy estimates is biased upwards)::

          m* = argmax_c E_1(s'_j, s'_i, c, a'_j),    a'_j = μ_j(o'_j ⊕ m_i)
          gain_k = E_k(s'_j, s'_i, m*, a'_j) − E_k(s'_j, s'_i, m_i, a'_j)
          pulled ⇔ gain_2 > max(√(1 − R²_E), 0.1, |gain_1 − gain_2|) (reward std), transition goes on

    * **one Adam step** of the GSN per agent update on

          L = L_g(M, R) + L_E(E_1, E_2) + λ · ½ mean_pulled ‖M(o_i) − atanh(m*)‖²,
          λ = w / (1 − w) · R²_E

      (the pull before the ``tanh``, so that a saturated message still moves), where ``R²_E`` is
      the share of the reward's variance the effect models explain (a running average): no pull
      while they know nothing. Where nothing is pulled the step is GSN's. On Blind Soccer a
      message's direct effect is nil, so the search rarely pulls and the grounding solves the task
      as GSN does; on Guess My Number the reward is the message's direct effect, and the pull moves
      each message onto its teammate's number. ``gsn_max_signals`` switches either part off (the
      ablations). Limits: one step ahead only (a message whose effect comes later is not
      searched), and the effect models need parallel games to spare.

    **Earlier designs** (options, measured in ``benchmarks/results/gsn_max_variants*.md``): the
    extractor trained, in one Adam step per agent update, along a mix of two gradients *at the
    message*:

    * **grounding** (GSN, paper eq. 2): ``d_g = ∂L_g/∂m`` with ``L_g = E[(R(m_i, a_j) − r_j)²]``;
      the reward model ``R`` is trained by ``L_g`` alone, as in GSN;
    * **maximising** (TCG's signal, paper §5): ``d_m = −g``, with
      ``g_i = (1 − d)·∂Q_j(o'_j ⊕ m_i, a'_j)/∂m_i`` the receiver's critic gradient
      (``a'_j = μ_j(o'_j ⊕ m_i)`` held fixed).

    Each is scaled to unit root-mean-square over the batch, so that the mix does not depend on the
    units (a standardised reward error against return units that change as the critic learns),
    and the mix passes through the inverting gradients of a bounded output (SPEC §2), which keep
    messages in [-1, 1] without a saturating ``tanh`` (GSN-MAX's configuration uses linear
    messages: ``gsn_message_activation="linear"``)::

        d = rms(d_g) · [(1 − w) · d_g / rms(d_g) + w · d_m / rms(d_m)]
        θm ← θm − η · Adam(Jᵀ inv(d)),        J = ∂m/∂θm

    ``w`` (``gsn_max_weight``, default 0.5) is the maximising share. One optimizer sees the sum,
    so a signal that is mostly noise (the receiver's critic early on) averages out in Adam's
    momentum instead of being amplified to full steps, as it is with one optimizer per signal.
    ``gsn_max_signals="grounding"`` or ``"maximising"`` uses one signal alone (the ablations).
    ``gsn_max_warmup`` (a fraction of training, default 0) raises ``w`` linearly from 0 over that
    share of training, so that the grounding acts alone first (tried, not packaged: README).
    ``gsn_max_centred`` replaces ``d_m`` by ``d_m − mean_B d_m`` (still divided by ``rms(d_m)``), so
    that a slope that is the same in every state moves no message (tried, not packaged: README).
    ``gsn_max_gain=κ`` mixes the signals unscaled, ``d = (1 − w)·d_g + w·κ·d_m``, and
    ``gsn_max_sgd=c`` gives the grounding its own Adam step and the maximising signal a plain step
    ``θm ← θm − c·η·Jᵀ inv(d_m)`` (both tried, not packaged: README).

    Tried and left as an option: ``policy_kwargs`` ``gsn_reward_hears=True`` also gives ``R`` the
    message the teammate heard (the sender's previous one), so that a reward caused by that
    message is not asked of the new one; on Blind Soccer the heard message says nearly what the new
    one says, and explains the reward away from it. Every variant tried, and what it reached:
    ``benchmarks/results/gsn_max_variants.md``.

    Messages are explored like RIAL's and TCG's (with probability ε a uniformly random message is
    sent; ``gsn_max_explore_messages``), so that the receiver's critic sees the effect of messages
    other than the current ones.

    **Head design** (``policy_kwargs`` ``gsn_maximising_head=True``): the two signals train two
    networks instead of one mix. The message is ``m = M(o) + H(o)``; ``M`` and ``R`` take GSN's
    regression step on ``M(o)`` (paper eq. 2, GSN's optimizer and learning rate), and the head
    ``H`` (output layer zero at the start, so that training starts as GSN) takes its own Adam step
    at the actor's learning rate, as TCG's message outputs do, along the maximising signal alone::

        θm, θr ← GSN's step on L_g(M(o))
        θh ← θh − η_actor · Adam(J_Hᵀ · inv(d_m)),        d_m at m = M(o) + H(o)

    A maximising signal that is noise (the receiver's critic before it uses the messages) then
    moves ``H`` by a random walk of small steps instead of mixing into ``M``'s regression.

    Status of the earlier designs: none solved either task reliably (README, "Beyond the paper").
    ``policy_kwargs`` ``gsn_effect_model=True`` without ``gsn_max_search`` follows the effect
    models' gradient instead of the receiver critic's (:meth:`effect_gradients`; tried, not packaged).
    """

    name = "GSN-MAX"
    explore_messages = True

    @staticmethod
    def message_gradient(
        policy: TeamPolicy,
        messages: th.Tensor,
        grounding: th.Tensor,
        next_obs: th.Tensor,
        dones: th.Tensor,
        weight: float = 0.5,
        signals: str = "both",
        centred: bool = False,
        gain: float | None = None,
    ) -> tuple[th.Tensor, dict[str, th.Tensor]]:
        """The gradient ``d`` that trains the message extractor, at the messages.

        :param policy: the team's policy (its actor and critic give the maximising signal).
        :param messages: ``(B, 2, n)`` the senders' current messages ``M(o)`` (detached).
        :param grounding: ``(B, 2, n)`` ``∂L_g/∂m``, the regression's gradient at them.
        :param next_obs: ``(B, 2, obs_dim)`` next observations.
        :param dones: ``(B, 1)`` terminal flags.
        :param weight: ``w``, the maximising share when ``signals`` is ``"both"``.
        :param signals: ``"both"``, ``"grounding"`` (``d = d_g``) or ``"maximising"`` (``d = d_m``).
        :param centred: replace ``d_m`` by ``d_m − mean_B d_m`` (the mean over the batch's
            non-terminal transitions, per sender and message entry), still divided by the RMS of
            the uncentred ``d_m`` in the mix: the part of the signal that is the same in every
            state, which a critic that does not read the messages yet gives, moves no message.
        :param gain: None: each signal scaled to unit RMS (above); a number κ: the raw mix
            ``d = (1 − w)·d_g + w·κ·d_m``.
        :return: ``d`` ``(B, 2, n)`` and the root-mean-squares of the signals used, for the log.
        """
        sent = messages.detach()
        rms_g = grounding.pow(2).mean().sqrt()
        stats = {"gsn/grounding_grad_rms": rms_g}
        if signals == "grounding":  # no pass through the receivers' critics
            return -inverting_gradients(-grounding, sent), stats
        maximising = GSNMAX._maximising(policy, sent, next_obs, dones)
        rms_m = maximising.pow(2).mean().sqrt()
        stats["gsn/maximising_grad_rms"] = rms_m
        if centred:
            live = (1.0 - dones).reshape(-1, 1, 1)  # terminal rows have no maximising signal
            mean = (maximising * live).sum(dim=0, keepdim=True) / live.sum().clamp_min(1.0)
            maximising = (maximising - mean) * live
            tiny = th.finfo(sent.dtype).tiny
            stats["gsn/maximising_state_share"] = maximising.pow(2).mean().sqrt() / rms_m.clamp_min(tiny)
        if signals == "maximising":
            mixed = maximising
        elif gain is not None:
            mixed = (1.0 - weight) * grounding + weight * gain * maximising
        else:
            tiny = th.finfo(sent.dtype).tiny
            unit_g, unit_m = grounding / rms_g.clamp_min(tiny), maximising / rms_m.clamp_min(tiny)
            mixed = rms_g * ((1.0 - weight) * unit_g + weight * unit_m)
        # the message is a bounded output: inverting gradients on its ascent direction −d
        return -inverting_gradients(-mixed, sent), stats

    @staticmethod
    def _maximising(policy: TeamPolicy, sent: th.Tensor, next_obs: th.Tensor, dones: th.Tensor) -> th.Tensor:
        """``d_m``: the gradient of ``−E[Q_j]`` over the batch at the sent messages (or, with an
        effect model, of ``−E[E_j]``: :meth:`effect_gradients`)."""
        if policy.gsn is not None and policy.gsn.effect_model is not None:
            ascent = GSNMAX.effect_gradients(policy, sent, next_obs, dones)
        else:
            ascent = TCG.receiver_message_gradients(policy, sent, next_obs, dones)
        return -ascent / ascent.shape[0]  # the gradient of −E[Q] in the batch mean's units

    @staticmethod
    def effect_gradients(
        policy: TeamPolicy, sent: th.Tensor, next_obs: th.Tensor, dones: th.Tensor
    ) -> th.Tensor:
        r"""Each sender's message gradient from the effect model: the total derivative of the
        receiver's one-step reward in the message, the situation held fixed::

            g_i = (1 − d) · d/dm E_j(s'_j, s'_i, m, μ_j(o'_j ⊕ m)) at m = m_i

        ``s'`` are the next observations without the messages heard, so the message's content
        (which the situation already holds) is not what the gradient moves: only its effect, direct
        (``∂E/∂m``, a reward caused by the message itself) and through the receiver's action
        (``∂E/∂a · ∂μ_j/∂m``, the receiver's current actor).

        :param policy: the team's policy (its GSN has an effect model).
        :param sent: ``(B, 2, n)`` the senders' messages.
        :param next_obs: ``(B, 2, obs_dim)`` next observations.
        :param dones: ``(B, 1)`` terminal flags.
        :return: ``(B, 2, n)`` ascent direction for each sender's message (the policy's
            ``gsn_effect_paths`` may keep one path only: ``"action"`` or ``"direct"``).
        """
        gsn = policy.gsn
        assert gsn is not None and gsn.effect_model is not None
        start = policy.comm_layout.obs_message_slice.start
        received = sent.detach().flip(1).clone().requires_grad_(True)  # row j hears its teammate
        situation = next_obs[..., :start]
        paths = getattr(policy, "gsn_effect_paths", "total")
        with th.set_grad_enabled(paths != "direct"):  # the receiver's response to the message
            response = policy.actor_outputs(th.cat([situation, received], dim=-1))
        heard = received if paths != "action" else received.detach()
        value = gsn.effect(situation, heard, response)
        grad_received = th.autograd.grad(value.sum(), received)[0]
        return grad_received.flip(1) * (1.0 - dones).unsqueeze(-1)

    SEARCH_LOCAL_STD = 0.1
    """Standard deviation of the effect search's local candidates around the sent message."""

    SEARCH_MARGIN = 0.1
    """The least gain (in standard deviations of the reward) of a candidate's direct effect over
    the sent message's, by the judging effect model, for the effect search to pull towards it;
    the gain must also exceed the effect models' error (their RMS residual, ``sqrt(1 − R²_E)``)
    and the two models' disagreement about it."""

    @staticmethod
    def search_targets(
        policy: TeamPolicy, sent: th.Tensor, next_obs: th.Tensor, dones: th.Tensor, candidates: int
    ) -> tuple[th.Tensor, th.Tensor, th.Tensor]:
        r"""The effect search's targets: for each sender ``i`` and receiver ``j``, the best of
        ``candidates`` messages (half uniformly random, half the sent message plus Gaussian noise
        of :data:`SEARCH_LOCAL_STD`, clipped) by the *direct* effect on the receiver's reward,
        the receiver's action held at its response to the sent message, picked by the first
        effect model and judged by the second (as double Q-learning: the best of many noisy
        estimates is biased upwards, an independent one is not)::

            m* = argmax_c E_1(s'_j, s'_i, c, a_j),    a_j = μ_j(o'_j ⊕ m_i)
            gain = E_2(s'_j, s'_i, m*, a_j) − E_2(s'_j, s'_i, m_i, a_j)

        It is a target where the gain exceeds the effect models' error, ``sqrt(1 − R²_E)`` (their
        RMS residual in reward standard deviations, at least :data:`SEARCH_MARGIN`: a gain smaller
        than what the models get wrong is not trusted), and the models' disagreement about it,
        ``|gain_1 − gain_2|`` (a gain one model invents is not confirmed), and the transition goes
        on (there is a next step to hear it); elsewhere the sent message is its own target.
        A message that only describes the situation changes nothing here (the situation is in
        ``s'``); one that causes the receiver's reward (Guess My Number) does.

        :param policy: the team's policy (its GSN has an effect model).
        :param sent: ``(B, 2, n)`` the senders' messages.
        :param next_obs: ``(B, 2, obs_dim)`` next observations.
        :param dones: ``(B, 1)`` terminal flags.
        :param candidates: number of random candidates per message.
        :return: targets ``(B, 2, n)``, whether each sender's message is pulled ``(B, 2)`` (float),
            and the best candidate's gain over the sent message ``(B, 2)``.
        """
        gsn = policy.gsn
        assert gsn is not None and gsn.effect_model is not None
        start = policy.comm_layout.obs_message_slice.start
        with th.no_grad():
            received = sent.detach().flip(1)  # row j hears its teammate
            situation = next_obs[..., :start]
            response = policy.actor_outputs(th.cat([situation, received], dim=-1))
            batch, agents, size = received.shape
            tried = (
                th.rand((candidates, batch, agents, size), dtype=sent.dtype, device=sent.device) * 2.0 - 1.0
            )
            local = candidates // 2  # the second half near the sent message, to refine a found bump
            if local:
                noise = th.randn((local, batch, agents, size), dtype=sent.dtype, device=sent.device)
                tried[candidates - local :] = (received + GSNMAX.SEARCH_LOCAL_STD * noise).clamp(-1.0, 1.0)
            # the sent message last: E_1 judges the candidates and it, and picks the best candidate
            picker = gsn.effect_candidates(situation, th.cat([tried, received[None]]), response, 0)
            index = picker[:candidates].argmax(dim=0)
            claimed = th.gather(picker[:candidates], 0, index[None])[0] - picker[candidates]
            best_messages = th.gather(tried, 0, index[None, ..., None].expand(1, batch, agents, size))[0]
            # E_2 judges the picked candidate against the sent message (only these two rows)
            judge = gsn.effect_candidates(situation, th.stack([best_messages, received]), response, 1)
            gain = judge[0] - judge[1]
            # confirmed: the judge's gain is above the models' own error and their disagreement
            error = (1.0 - gsn.effect_r2).clamp(min=0.0).sqrt()  # RMS residual, in reward std
            floor = th.clamp(error, min=GSNMAX.SEARCH_MARGIN)
            confirmed = gain > th.maximum((claimed - gain).abs(), floor)
            pulled = confirmed & (dones < 0.5)
            targets = th.where(pulled[..., None], best_messages, received)
        return targets.flip(1), pulled.flip(1).to(sent.dtype), gain.flip(1)

    @staticmethod
    def head_gradient(
        policy: TeamPolicy, sent: th.Tensor, next_obs: th.Tensor, dones: th.Tensor
    ) -> tuple[th.Tensor, dict[str, th.Tensor]]:
        """The head design's gradient at the sent messages ``m = M(o) + H(o)``, which trains ``H``:
        the maximising signal ``d_m`` alone, through the inverting gradients of the message's bounds.

        :param policy: the team's policy (its actor and critic give the signal).
        :param sent: ``(B, 2, n)`` the messages sent (detached).
        :param next_obs: ``(B, 2, obs_dim)`` next observations.
        :param dones: ``(B, 1)`` terminal flags.
        :return: the gradient ``(B, 2, n)`` and its root-mean-square, for the log.
        """
        sent = sent.detach()
        maximising = GSNMAX._maximising(policy, sent, next_obs, dones)
        stats = {"gsn/maximising_grad_rms": maximising.pow(2).mean().sqrt()}
        return -inverting_gradients(-maximising, sent), stats


METHODS = ("NONE", "RIAL", "TCG", "GSN", "GSN-MAX")
"""Communication methods: no channel, reinforced, teammate gradients, grounded semantic network,
and (beyond the paper) the grounded semantic network that also maximises."""

PAPER_METHODS = ("NONE", "RIAL", "TCG", "GSN")
"""The paper's four methods: its claims compare these (GSN-MAX is judged by the report's
"beyond the paper" claims instead)."""

COMM_METHODS: dict[str, type[CommMethod]] = {method.name: method for method in (NONE, RIAL, TCG, GSN, GSNMAX)}
"""Method name -> its class."""
