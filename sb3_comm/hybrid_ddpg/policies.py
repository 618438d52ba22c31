"""Actor-critic policy of the parameterised-action DDPG (Hausknecht & Stone, ICLR 2016).

The actor outputs the whole action vector (for HFO: 3 action scores and 5 parameters); the
environment executes the argmax score with its parameters. The critic sees the observation and
*all* actor outputs. Bounded hybrid outputs are linear and kept in range with inverting gradients
during training; a plain ``Box`` action uses ``tanh`` heads as SB3's TD3 does. Everything works in
SB3's scaled action space [-1, 1]; ``predict`` rescales to the environment's bounds.

Tensors keep SB3's shapes: observations ``(B, obs_dim)``, Q-values ``(B, 1)``. The operations
act on the last axis only, so :class:`~sb3_comm.comm_ddpg.policies.CommPolicy` reuses them on the
agent rows ``(B, n_agents, width)`` of a team.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.policies import BasePolicy
from stable_baselines3.common.type_aliases import PyTorchObs, Schedule
from torch import nn

from sb3_comm.common.layout import HybridActionLayout
from sb3_comm.common.networks import check_precision, mlp, set_precision
from sb3_comm.common.validation import SCORE_GRADIENTS, check_observation

__all__ = [
    "ACTOR_AVERAGE_AUTO",
    "ACTOR_AVERAGE_SPAN",
    "SCORE_GRADIENTS",
    "SWITCH_MARGIN",
    "HybridPolicy",
    "auto_actor_average_rate",
]

SWITCH_MARGIN = 0.05
"""How far above the other scores an alternative's score is put when the critic rates it."""

ACTOR_AVERAGE_AUTO = "auto"
"""``actor_average_tau="auto"``: the rate of the actor's average is set from the run's budget."""

ACTOR_AVERAGE_SPAN = 10.0
"""With ``actor_average_tau="auto"`` the rate is ``ACTOR_AVERAGE_SPAN / U`` for a run of ``U``
actor updates: the average's mean age, ``1/τ̄`` updates, is a tenth of the run."""


def auto_actor_average_rate(actor_updates: float) -> float:
    """The rate ``actor_average_tau="auto"`` gives a run of ``actor_updates`` actor updates:
    ``ACTOR_AVERAGE_SPAN / actor_updates`` to two significant figures, at most 1 (the actor itself).

    Two figures make the rate a plain number in the logs, the same for runs whose budgets differ by
    a few steps, and equal to the rates measured by hand: 0.0002 for Blind Soccer's 50,000 updates
    (800,000 steps of 16 games), 0.00053 for Guess My Number's 18,750 and 0.00027 for
    simple_reference's 37,500 (README, "Every seed, every evaluation").

    >>> auto_actor_average_rate(50_000), auto_actor_average_rate(18_750), auto_actor_average_rate(5)
    (0.0002, 0.00053, 1.0)
    """
    if not actor_updates > ACTOR_AVERAGE_SPAN:  # also NaN: no budget to spread over
        return 1.0
    return float(f"{ACTOR_AVERAGE_SPAN / actor_updates:.2g}")


class HybridPolicy(BasePolicy):
    """Actor, critic(s) and their targets for one agent with a (possibly parameterised) action.

    :param observation_space: ``Box(obs_dim)``.
    :param action_space: ``Box(action_dim)``.
    :param lr_schedule: critic learning-rate schedule (the algorithm sets the actor's).
    :param hybrid_layout: the parameterised-action layout (action scores, then parameters), or
        None for a plain ``Box`` action (``tanh`` heads).
    :param net_arch: hidden widths of actor and critic, or a dict with keys ``pi`` and ``qf``.
    :param activation_fn: hidden activation (leaky ReLU, slope 0.01, as the reference code).
    :param n_critics: 1 for DDPG, 2 for TD3's clipped double Q.
    :param score_gradient: what moves the action scores of a hybrid action: ``"critic"`` (the
        ICLR 2016 agent: the critic's gradient ``dQ/ds`` at the actor's scores) or
        ``"alternatives"`` (each score by the critic's advantage of executing its discrete action
        with the actor's current parameters, ``Q_k − mean_j Q_j``; see
        :meth:`critic_action_gradients`).
    :param critic_layer_norm: a ``LayerNorm`` after each hidden layer of the critics (off: the
        ICLR 2016 agent). It keeps the critic's features on one scale while its targets move.
    :param actor_guard: on the rows of an actor update where the (first) critic rates the target
        actor's outputs above the actor's own, the actor is moved towards the target actor's
        outputs instead of along the critic's local gradient, with that gradient's length (off: the
        ICLR 2016 agent; see :meth:`guarded_gradients`). On Blind Soccer with the constructor's
        defaults it made the dips after the bar rarer (11 of 12 seeds pass, 8 without) but the
        teams end lower, 0.88 against 0.90 of the oracle on 1,000 games
        (``benchmarks/results/stability_summary_defaults_bs_gsn_actor_guard_12seeds.md``).
    :param averaged_actor: the policy's own actions (:meth:`predict`, every evaluation, a saved
        model's play) come from the target actor, the Polyak average of the actor that DDPG keeps
        for its critic targets (rate ``tau``), instead of the actor's latest iterate. Training is
        unchanged: exploration and every update use the actor (see :meth:`scaled_actions`). Off:
        the ICLR 2016 agent. On Blind Soccer with the constructor's defaults the target actor has
        none of the actor's deepest dips after learning and plays the same final team, and passes
        17 of 20 seeds against the actor's 16
        (``benchmarks/results/checkpoint_level_defaults_bs_gsn_20seeds_averaged_actor.md``); the
        slower average of ``actor_average_tau="auto"`` passes 20 of 20 and is what a new
        :class:`~sb3_comm.comm_ddpg.CommDDPG` plays (``sb3_comm.AVERAGED_ACTOR``).
    :param actor_average_tau: the rate of the average that ``averaged_actor`` plays. None: the
        target actor (rate ``tau``). A number in (0, 1]: a separate average of the actor,
        ``actor_average``, kept at that rate after every actor update (saved with the model;
        training is unchanged, the average is only played). ``"auto"``: that separate average,
        with the rate set by the algorithm as it trains from the run's budget, about 10 / (the run's actor
        updates; see :func:`auto_actor_average_rate`), so that the average spans a tenth of any
        run. A fixed rate counts updates, not steps: 0.0002 spans about the last 5,000 updates, a
        tenth of a Blind Soccer run with 16 games, where it removes the actor's dips; on a run of
        fewer updates it lags the actor for most of the run (Guess My Number's 18,750 updates: the
        bar at 275,000 of 300,000 steps, the actor's at 50,000–75,000; at the rate ``"auto"`` gives,
        0.00053, at 125,000; README, "Every seed, every evaluation").
    :param precision: the arithmetic of every network's hidden layers (actor, critics, their
        targets and average, and a team's GSN): ``"float32"`` (default) or ``"bfloat16"``, mixed
        precision where the hidden layers' matrix products run in bfloat16 and the output layers,
        parameters, gradients, optimizer state and losses stay float32
        (:class:`~sb3_comm.common.networks.MLP`).
        Faster where the processor has bfloat16 arithmetic (AVX-512 BF16, AMX, recent GPUs); it
        changes the numbers a network computes, so its learning results are measured apart (README,
        "Training in bfloat16").
    :param optimizer_class: optimizer of actor and critic.
    :param optimizer_kwargs: extra optimizer arguments (the reference used Adam betas (0.95, 0.999)).
    """

    actor: nn.Module
    actor_target: nn.Module
    critic: nn.ModuleList
    critic_target: nn.ModuleList

    def __init__(
        self,
        observation_space: spaces.Box,
        action_space: spaces.Box,
        lr_schedule: Schedule,
        hybrid_layout: HybridActionLayout | None = None,
        net_arch: list[int] | dict[str, list[int]] | None = None,
        activation_fn: type[nn.Module] = nn.LeakyReLU,
        n_critics: int = 1,
        score_gradient: str = "critic",
        critic_layer_norm: bool = False,
        actor_guard: bool = False,
        averaged_actor: bool = False,
        actor_average_tau: float | str | None = None,
        precision: str = "float32",
        optimizer_class: type[th.optim.Optimizer] = th.optim.Adam,
        optimizer_kwargs: dict[str, Any] | None = None,
    ) -> None:
        check_precision(precision)
        self.precision = precision
        auto = isinstance(actor_average_tau, str) and actor_average_tau == ACTOR_AVERAGE_AUTO
        if not (
            actor_average_tau is None
            or auto
            or (not isinstance(actor_average_tau, str) and 0.0 < float(actor_average_tau) <= 1.0)
        ):
            raise ValueError(
                f"actor_average_tau must be None (the target actor), {ACTOR_AVERAGE_AUTO!r} (set from the "
                f"run's budget) or a number in (0, 1]; got {actor_average_tau!r}"
            )
        self.actor_average_tau: float | str | None = (
            actor_average_tau if actor_average_tau is None or auto else float(actor_average_tau)
        )
        """The setting: None, ``"auto"`` or a fixed rate."""
        self.actor_average_rate: float | None = None if auto else self.actor_average_tau  # type: ignore[assignment]
        """The rate :meth:`update_actor_average` uses (``"auto"``: set by the algorithm as it trains)."""
        if score_gradient not in SCORE_GRADIENTS:
            raise ValueError(f"score_gradient must be one of {list(SCORE_GRADIENTS)}, got {score_gradient!r}")
        self.score_gradient = score_gradient
        self.critic_layer_norm = bool(critic_layer_norm)
        self.actor_guard = bool(actor_guard)
        self.guarded_fraction: th.Tensor | None = None
        """The share of the rows of the last actor update that ``actor_guard`` redirected."""
        self.averaged_actor = bool(averaged_actor)
        super().__init__(
            observation_space,
            action_space,
            optimizer_class=optimizer_class,
            optimizer_kwargs=optimizer_kwargs,
            squash_output=True,
        )
        if net_arch is None:
            net_arch = [256, 256]
        self.net_arch = net_arch
        self.actor_arch, self.critic_arch = (
            (net_arch["pi"], net_arch["qf"]) if isinstance(net_arch, dict) else (net_arch, net_arch)
        )
        self.activation_fn = activation_fn
        self.n_critics = n_critics
        self.hybrid_layout = hybrid_layout
        self.hybrid = hybrid_layout is not None
        self.obs_dim = observation_space.shape[-1]
        self.env_action_dim = self._env_action_dim()
        self.actor_out_dim = self._actor_out_dim()
        self._build(lr_schedule)
        set_precision(self, precision)

    # ------------------------------------------------------------------------------ build --
    def _env_action_dim(self) -> int:
        """Length of the part of an action that acts on the environment."""
        return self.action_space.shape[-1]  # type: ignore[index]

    def _actor_out_dim(self) -> int:
        """Number of actor outputs (the critic sees all of them)."""
        return self.env_action_dim

    def make_actor(self) -> nn.Module:
        """``obs -> actor outputs`` (raw, see :meth:`bound_outputs`)."""
        return mlp(self.obs_dim, self.actor_out_dim, self.actor_arch, self.activation_fn)

    def make_critic(self) -> nn.Module:
        """``[obs | actor outputs] -> Q``."""
        in_dim = self.obs_dim + self.actor_out_dim
        return mlp(in_dim, 1, self.critic_arch, self.activation_fn, self.critic_layer_norm)

    def _build(self, lr_schedule: Schedule) -> None:
        """Actor, critics, their targets and the optimizers (in this order: it fixes the seeding)."""
        self.actor, self.actor_target = self.make_actor(), self.make_actor()
        self.critic = nn.ModuleList(self.make_critic() for _ in range(self.n_critics))
        self.critic_target = nn.ModuleList(self.make_critic() for _ in range(self.n_critics))
        self.actor_target.load_state_dict(self.actor.state_dict())
        self.critic_target.load_state_dict(self.critic.state_dict())
        self.actor_target.requires_grad_(False)
        self.critic_target.requires_grad_(False)
        self.actor_average: nn.Module | None = None
        if self.actor_average_tau is not None:  # built without drawing: the seeding stays as it was
            with th.random.fork_rng(devices=[]):
                self.actor_average = self.make_actor()
            self.actor_average.load_state_dict(self.actor.state_dict())
            self.actor_average.requires_grad_(False)
        self.actor.optimizer = self.make_optimizer(self.actor, lr_schedule(1))  # type: ignore[assignment]
        self.critic.optimizer = self.make_optimizer(self.critic, lr_schedule(1))  # type: ignore[assignment]

    def make_optimizer(self, module: nn.Module, lr: float) -> th.optim.Optimizer:
        """The optimizer of one trained network: ``optimizer_class(params, lr, **optimizer_kwargs)``.

        Adam and AdamW run fused (one kernel over all parameters instead of a Python loop over
        them: the same update, several times faster for these small networks) unless
        ``optimizer_kwargs`` chooses ``fused`` or ``foreach`` itself.
        """
        kwargs = dict(self.optimizer_kwargs)
        if (
            self.optimizer_class in (th.optim.Adam, th.optim.AdamW)
            and not {"fused", "foreach"} & kwargs.keys()
        ):
            kwargs["fused"] = True
        return self.optimizer_class(module.parameters(), lr=lr, **kwargs)

    # ---------------------------------------------------------------------------- helpers --
    def bound_outputs(self, out: th.Tensor) -> th.Tensor:
        """Raw actor outputs to actions in [-1, 1]: ``tanh`` for plain Box heads, identity otherwise.

        Hybrid heads are linear: inverting gradients keep them in range during training, and
        :meth:`_predict` clips what is executed.
        """
        return out if self.hybrid else th.tanh(out)

    def actor_outputs(self, obs: th.Tensor, target: bool = False) -> th.Tensor:
        """Bounded actor outputs ``(..., actor_out_dim)``."""
        actor = self.actor_target if target else self.actor
        return self.bound_outputs(actor(obs))

    def played_outputs(self, obs: th.Tensor, averaged: bool = False) -> th.Tensor:
        """Bounded outputs of the actor, or (``averaged``) of the average the policy plays: the
        separate ``actor_average`` where ``actor_average_tau`` is set, else the target actor."""
        if not averaged:
            return self.actor_outputs(obs)
        average = self.actor_target if self.actor_average is None else self.actor_average
        return self.bound_outputs(average(obs))

    def update_actor_average(self) -> None:
        """``θ̄ ← θ̄ + τ̄ (θ − θ̄)``: the separate average one step towards the actor at the rate
        :attr:`actor_average_rate` (no-op without ``actor_average_tau``); the algorithm calls it
        after every actor update."""
        if self.actor_average is None:
            return
        if self.actor_average_rate is None:
            raise RuntimeError(
                "actor_average_tau='auto' has no rate yet: the algorithm sets actor_average_rate from the "
                "run's budget when it trains (learn); set it before updating the average by hand"
            )
        pairs = self.__dict__.get("_average_pairs")
        if pairs is None:
            pairs = self.__dict__["_average_pairs"] = (
                list(self.actor_average.parameters()),
                list(self.actor.parameters()),
            )
        with th.no_grad():
            th._foreach_lerp_(pairs[0], pairs[1], self.actor_average_rate)

    def critic_value(self, critic: nn.Module, x: th.Tensor) -> th.Tensor:
        """One critic's output on ``[obs | actions]`` rows: ``(B, 1)`` as in SB3."""
        return critic(x)

    def q_values(self, obs: th.Tensor, actions: th.Tensor, target: bool = False) -> list[th.Tensor]:
        """Each critic's ``Q(o, a)``.

        :param obs: observations ``(B, obs_dim)``.
        :param actions: bounded actor outputs, or actions as stored in the replay buffer (entries
            past ``actor_out_dim`` are not seen by the critic).
        :param target: use the target critics.
        """
        critics = self.critic_target if target else self.critic
        x = th.cat([obs, actions[..., : self.actor_out_dim]], dim=-1)
        return [self.critic_value(critic, x) for critic in critics]

    def critic_action_gradients(self, obs: th.Tensor, out: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """``dQ/d out`` of the (first) critic at the actor's outputs, and that critic's ``Q``.

        :param obs: observations.
        :param out: bounded actor outputs (detached).
        :return: ``grad`` shaped like ``out`` and ``Q`` (detached).
        """
        current = out.detach().requires_grad_(True)
        own_q = self.q_values(obs, current)[0]
        grad = th.autograd.grad(own_q.sum(), current)[0]
        if self.score_gradient == "alternatives" and self.hybrid_layout is not None:
            n = self.hybrid_layout.n_actions
            grad[..., :n] = self.alternative_advantages(obs, out.detach()).reshape(grad[..., :n].shape)
        own_q = own_q.detach()
        if self.actor_guard:
            grad = self.guarded_gradients(obs, out.detach(), grad, own_q)
        return grad, own_q

    def guarded_gradients(
        self, obs: th.Tensor, out: th.Tensor, grad: th.Tensor, own_q: th.Tensor
    ) -> th.Tensor:
        """``actor_guard``: back towards the target actor where the critic prefers its outputs.

        The target actor trails the actor (soft updates), so it is where the actor was recently.
        Where the critic values the target actor's outputs above the actor's, ``Q(o, μ'(o)) >
        Q(o, μ(o))``, the actor has moved somewhere its own critic rates worse: the row's ascent
        direction becomes ``μ'(o) − μ(o)``, scaled to the length of the critic's gradient on that row
        (so the step size, and the scale of rewards, stay those of the critic's gradient). Other
        rows keep the critic's gradient. A Q-filter (Nair et al., 2018) whose demonstrator is the
        target actor; seen before Blind Soccer's collapses: every critic rated the earlier actor's
        actions above the current one's
        (``benchmarks/results/collapse_anatomy_blind_soccer_gsn_relabel_seed7.md``).

        :param obs: observations.
        :param out: bounded actor outputs (detached).
        :param grad: the critic's ascent direction, shaped like ``out``.
        :param own_q: the first critic's ``Q`` at ``out`` (detached).
        :return: the ascent direction, shaped like ``out``.
        """
        with th.no_grad():
            anchor = self.actor_outputs(obs, target=True)
            anchor_q = self.q_values(obs, anchor)[0]
            worse = anchor_q > own_q  # (B, 1) for one agent, (B, n_agents) for a team
            if worse.dim() < grad.dim():
                worse = worse.unsqueeze(-1)
            pull = anchor - out
            length = grad.norm(dim=-1, keepdim=True) / pull.norm(dim=-1, keepdim=True).clamp_min(1e-12)
            self.guarded_fraction = worse.float().mean()
            return th.where(worse, pull * length, grad)

    def alternative_advantages(self, obs: th.Tensor, out: th.Tensor) -> th.Tensor:
        """The critic's advantage of executing each discrete action with the actor's parameters.

        For action ``k``, its score is put :data:`SWITCH_MARGIN` above the highest score (at most
        1) and every other score at least that margin below it, everything else as the actor
        outputs it: ``Q_k`` is the first critic's value of switching to ``k`` (for the argmax
        action, about the actor's own value). The scores' ascent direction is ``Q_k − mean_j Q_j``:
        with ``"critic"``, the scores of actions that are not taken get only the critic's gradient
        at the actor's scores, which fades where the critic sees those actions rarely, and they
        drift until one overtakes the chosen action (seen before Blind Soccer's collapses,
        ``benchmarks/results/collapse_anatomy_blind_soccer_gsn_relabel_seed7.md``; this option
        alone did not prevent them, ``benchmarks/results/blind_soccer_gsn_variants.md``).

        :param obs: observations.
        :param out: bounded actor outputs (detached).
        :return: ``(..., n_actions)`` advantages, in the shape of ``Q`` with the actions last.
        """
        assert self.hybrid_layout is not None
        n = self.hybrid_layout.n_actions
        scores = out[..., :n]
        switched = (scores.max(dim=-1, keepdim=True).values + SWITCH_MARGIN).clamp(max=1.0)
        values = []
        with th.no_grad():
            for k in range(n):
                alternative = out.clone()
                alternative[..., :n] = th.minimum(scores, switched - SWITCH_MARGIN)
                alternative[..., k : k + 1] = switched
                values.append(self.q_values(obs, alternative)[0])
        q = th.stack(values, dim=-1)
        return q - q.mean(dim=-1, keepdim=True)

    # ---------------------------------------------------------------------------- SB3 API --
    def forward(self, obs: th.Tensor, deterministic: bool = True) -> th.Tensor:
        """Deterministic scaled actions (same as :meth:`_predict`)."""
        return self._predict(obs, deterministic)

    def _predict(self, observation: PyTorchObs, deterministic: bool = True) -> th.Tensor:
        """The policy's actions: the target actor's with ``averaged_actor``, else the actor's."""
        return self.scaled_actions(observation, averaged=self.averaged_actor)  # type: ignore[arg-type]

    def scaled_actions(self, observation: th.Tensor, averaged: bool = False) -> th.Tensor:
        """Actions in SB3's scaled units ``[-1, 1]`` of the actor, or of its Polyak average (the
        target actor, or ``actor_average``; see :meth:`played_outputs`) where ``averaged``.
        Exploration during training acts on the actor's.

        :param observation: a batch of observations.
        :param averaged: use the average.
        """
        return self.played_outputs(observation, averaged).clamp(-1.0, 1.0)

    def observation_agents(self) -> tuple[str, ...] | None:
        """Names of the agent rows of an observation, for error messages (None: one agent)."""
        return None

    def predict(
        self,
        observation: np.ndarray | dict[str, np.ndarray],
        state: tuple[np.ndarray, ...] | None = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = False,
    ) -> tuple[np.ndarray, tuple[np.ndarray, ...] | None]:
        """SB3's ``predict``, refusing observations with NaN or inf (a NaN in gives NaN actions out).

        :raises ValueError: naming the agent and the feature indices that are not finite.
        """
        check_observation(observation, self.observation_agents())
        return super().predict(observation, state, episode_start, deterministic)

    def set_training_mode(self, mode: bool) -> None:
        """Train/eval mode of the trained networks (targets stay in eval mode).

        SB3 switches modes twice per environment step; ``nn.Module.train`` walks the module tree
        each time, so the trained modules are listed once and set directly.
        """
        modules = self.__dict__.get("_trained_modules")
        if modules is None:
            modules = self.__dict__["_trained_modules"] = self._trained_submodules()
        for module in modules:
            module.__dict__["training"] = mode  # a plain attribute: skip nn.Module.__setattr__
        self.training = mode

    def _trained_submodules(self) -> list[nn.Module]:
        """Every module whose mode follows :meth:`set_training_mode`."""
        return [*self.actor.modules(), *self.critic.modules()]

    def load_state_dict(
        self, state_dict: Mapping[str, Any], strict: bool = True, assign: bool = False
    ) -> Any:
        """``nn.Module.load_state_dict``, also reading files of sb3-comm 0.1.0.

        Up to 0.1.0 the single-agent networks were per-agent wrappers (keys ``actor.nets.0.*``);
        they are the plain networks (``actor.*``) now.
        """
        own = self.state_dict()
        renamed = {}
        for key, value in state_dict.items():
            legacy = re.sub(r"\.nets\.0\.", ".", key, count=1)
            renamed[legacy if key not in own and legacy in own else key] = value
        return super().load_state_dict(renamed, strict=strict, assign=assign)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data.update(
            hybrid_layout=self.hybrid_layout,
            net_arch=self.net_arch,
            activation_fn=self.activation_fn,
            n_critics=self.n_critics,
            score_gradient=self.score_gradient,
            critic_layer_norm=self.critic_layer_norm,
            actor_guard=self.actor_guard,
            averaged_actor=self.averaged_actor,
            actor_average_tau=self.actor_average_tau,
            precision=self.precision,
            lr_schedule=self._dummy_schedule,
            optimizer_class=self.optimizer_class,
            optimizer_kwargs=self.optimizer_kwargs,
        )
        return data

    @staticmethod
    def _dummy_schedule(_: float) -> float:
        return 0.0
