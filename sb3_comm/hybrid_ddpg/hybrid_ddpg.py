"""HybridDDPG: DDPG in a parameterised action space, for one agent.

Paper: Hausknecht & Stone, "Deep Reinforcement Learning in Parameterized Action Space" (ICLR
2016). Original code: github.com/mhauskn/dqn-hfo, C++/Caffe.

A TD3 subclass (with TD3's twin critics, delay and target smoothing off by default, it is DDPG)
with what the ICLR agent added:

* hybrid heads: the actor outputs action scores and their parameters; bounded outputs are kept in
  range by **inverting gradients** (:func:`~sb3_comm.common.networks.inverting_gradients`);
* **ε-exploration**: with probability ε the action scores and parameters are drawn uniformly;
* **Monte-Carlo mixing** of the critic target, ``y = β·G_t + (1 − β)·(r + γ Q'(s', μ'(s')))``,
  with the returns kept by :class:`~sb3_comm.common.buffers.MonteCarloReplayBuffer`;
* a separate actor learning rate (or schedule) and gradient clipping.

:class:`~sb3_comm.CommDDPG` extends it to two agents that learn to communicate.
"""

from __future__ import annotations

import dataclasses
import inspect
import io
import json
import pathlib
import pickle
import time
import zipfile
from typing import Any, ClassVar, TypeVar

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import TD3
from stable_baselines3.common.noise import ActionNoise
from stable_baselines3.common.policies import BasePolicy
from stable_baselines3.common.save_util import load_from_pkl
from stable_baselines3.common.type_aliases import (
    GymEnv,
    MaybeCallback,
    RolloutReturn,
    Schedule,
    TrainFreq,
    TrainFrequencyUnit,
)
from stable_baselines3.common.utils import (
    FloatSchedule,
    LinearSchedule,
    obs_as_tensor,
    update_learning_rate,
)
from torch.nn import functional as F

from sb3_comm.common.buffers import MonteCarloReplayBuffer, MonteCarloReplayBufferSamples
from sb3_comm.common.layout import HybridActionLayout
from sb3_comm.common.networks import gradient_step, inverting_gradients
from sb3_comm.common.train_log import TrainLog
from sb3_comm.common.validation import HYPERPARAMETERS, Range, check_hyperparameters
from sb3_comm.hybrid_ddpg.policies import ACTOR_AVERAGE_AUTO, HybridPolicy, auto_actor_average_rate

__all__ = [
    "LOG_POINTS",
    "NOT_HYPERPARAMETERS",
    "WEIGHTS_FORMAT",
    "HybridDDPG",
    "check_schedule",
    "default_log_interval",
]

LOG_POINTS = 200
"""Logged training points per ``learn`` call when no ``log_interval`` is given."""

SelfHybridDDPG = TypeVar("SelfHybridDDPG", bound="HybridDDPG")

WEIGHTS_FORMAT = 1
"""Version of the ``config.json`` written by :meth:`HybridDDPG.save_weights`."""

NOT_HYPERPARAMETERS = frozenset(
    {"self", "policy", "env", "tensorboard_log", "verbose", "seed", "device", "_init_setup_model"}
)
"""Constructor arguments that are not hyperparameters (what a run or the caller supplies)."""

# Constructor arguments that are not settings of the model (or are stored apart, as policy_kwargs).
_NOT_WEIGHTS_SETTINGS = NOT_HYPERPARAMETERS | {
    "policy_kwargs",
    "action_noise",
    "replay_buffer_class",
    "replay_buffer_kwargs",
}


def check_schedule(name: str, value: Any) -> float | Schedule:
    """A learning rate as SB3 takes it: a number > 0, or a callable of the remaining progress whose
    value at progress 1.0 is finite and > 0 (:class:`~sb3_comm.common.validation.LearningRate`).

    :param name: the parameter's name (for the error message).
    :param value: the value given.
    :raises TypeError: for anything else, e.g. the string ``"lin_1e-4"`` of a config file.
    :raises ValueError: a rate (or a schedule's first value) that is not finite and > 0.
    """
    HYPERPARAMETERS["learning_rate"](name, value)
    return value


class HybridDDPG(TD3):
    """The ICLR 2016 parameterised-action DDPG for a single agent (a TD3 subclass).

    Accepts a Gymnasium environment with 1-D ``Box`` observations and actions; a ``hybrid_layout``
    attribute (or ``metadata["hybrid_action"]``) marks the HFO-style action scores and parameters.

    :param policy: ``"MlpPolicy"`` (or a :class:`HybridPolicy` subclass).
    :param env: the environment (an id, an env, or a VecEnv).
    :param learning_rate: critic learning rate (or schedule).
    :param actor_learning_rate: actor learning rate or schedule (reference code: 1e-5).
    :param buffer_size: replay size in transitions.
    :param learning_starts: transitions collected with full exploration before learning.
    :param batch_size: transitions per update.
    :param tau: soft target update rate.
    :param gamma: discount factor.
    :param train_freq: update the model every ``train_freq`` steps.
    :param gradient_steps: updates after each rollout (-1: as many as steps collected).
    :param exploration: ``"epsilon"`` (ICLR 2016: with probability ε take uniformly random action
        scores and parameters), ``"gaussian"`` (Gaussian noise on every output) or
        ``"epsilon+gaussian"`` (both: ε-random rows, Gaussian noise on the others, so that the
        critic also sees actions near the actor's own, where its action gradient is read).
    :param exploration_initial_eps: ε at the start.
    :param exploration_final_eps: ε after annealing.
    :param exploration_fraction: fraction of training over which ε is annealed linearly.
    :param gaussian_noise_std: standard deviation of the Gaussian exploration (scaled units).
    :param mc_mixing: β of the critic target ``y = β·G_t + (1 − β)·(r + γ Q'(s', μ'(s')))``
        (reference code: 0.5, what the packaged configurations use; default: 0, the TD target:
        the Monte-Carlo return of an episode cut by a time limit is summed as if the episode had
        ended, which biases the critic on tasks whose episodes are mostly truncated, see
        ``benchmarks/results/simple_reference_beta0.5.md``; the replay's ``mc_truncated="bootstrap"``
        completes it at the cut by the target critics' value). A callable is a schedule of the
        remaining progress (1 -> 0), as the learning rates (``"lin_0.5"`` in a configuration: β decays
        linearly to 0; on Blind Soccer this made the final team worse,
        ``benchmarks/results/stability_pilot_bs_gsn_beta_lin.md``).
    :param max_grad_norm: gradient clipping of actor and critic (reference: 10; None: no clipping).
    :param action_noise: optional SB3 action noise added on top of the exploration.
    :param replay_buffer_class: a :class:`MonteCarloReplayBuffer` subclass (None: that class).
    :param replay_buffer_kwargs: extra arguments of the replay buffer.
    :param policy_delay: actor update every ``policy_delay`` critic updates (1: DDPG).
    :param target_policy_noise: TD3 target smoothing noise (0: DDPG).
    :param target_noise_clip: TD3 clip of that noise.
    :param stats_window_size: episodes averaged in the rollout logs.
    :param tensorboard_log: TensorBoard log folder.
    :param policy_kwargs: extra arguments of the policy (``net_arch``, ``n_critics``, ...).
    :param verbose: 0 silent, 1 info, 2 debug.
    :param seed: random seed.
    :param device: torch device.
    :param _init_setup_model: build the networks now.
    """

    policy_aliases: ClassVar[dict[str, type[BasePolicy]]] = {"MLPPOLICY": HybridPolicy, "NONE": HybridPolicy}
    policy: HybridPolicy
    replay_buffer: MonteCarloReplayBuffer

    def __init__(
        self,
        policy: str | type[HybridPolicy],
        env: GymEnv | str,
        learning_rate: float | Schedule = 1e-3,
        actor_learning_rate: float | Schedule = 1e-4,
        buffer_size: int = 1_000_000,
        learning_starts: int = 1_000,
        batch_size: int = 64,
        tau: float = 0.005,
        gamma: float = 0.99,
        train_freq: int | tuple[int, str] = 1,
        gradient_steps: int = 1,
        exploration: str = "epsilon",
        exploration_initial_eps: float = 1.0,
        exploration_final_eps: float = 0.1,
        exploration_fraction: float = 0.2,
        gaussian_noise_std: float = 0.1,
        mc_mixing: float | Schedule = 0.0,
        max_grad_norm: float | None = 10.0,
        action_noise: ActionNoise | None = None,
        replay_buffer_class: type[MonteCarloReplayBuffer] | None = None,
        replay_buffer_kwargs: dict[str, Any] | None = None,
        policy_delay: int = 1,
        target_policy_noise: float = 0.0,
        target_noise_clip: float = 0.5,
        stats_window_size: int = 100,
        tensorboard_log: str | None = None,
        policy_kwargs: dict[str, Any] | None = None,
        verbose: int = 0,
        seed: int | None = None,
        device: th.device | str = "auto",
        _init_setup_model: bool = True,
    ) -> None:
        # Every argument is checked here, once (sb3_comm.common.validation holds what each accepts).
        check_hyperparameters(locals())
        self.actor_learning_rate = actor_learning_rate
        self.exploration = exploration
        self.exploration_initial_eps = exploration_initial_eps
        self.exploration_final_eps = exploration_final_eps
        self.exploration_fraction = exploration_fraction
        self.gaussian_noise_std = gaussian_noise_std
        self.mc_mixing = mc_mixing
        self.max_grad_norm = max_grad_norm
        self.exploration_rate = exploration_initial_eps
        super().__init__(
            policy,
            env,
            learning_rate=learning_rate,
            buffer_size=buffer_size,
            learning_starts=learning_starts,
            batch_size=batch_size,
            tau=tau,
            gamma=gamma,
            train_freq=train_freq,
            gradient_steps=gradient_steps,
            action_noise=action_noise,
            replay_buffer_class=replay_buffer_class or MonteCarloReplayBuffer,
            replay_buffer_kwargs=replay_buffer_kwargs,
            policy_delay=policy_delay,
            target_policy_noise=target_policy_noise,
            target_noise_clip=target_noise_clip,
            stats_window_size=stats_window_size,
            tensorboard_log=tensorboard_log,
            policy_kwargs=policy_kwargs,
            verbose=verbose,
            seed=seed,
            device=device,
            _init_setup_model=False,
        )
        if _init_setup_model:
            self._setup_model()

    # ----------------------------------------------------------------------------- set-up --
    def _get_policy_from_name(self, policy_name: str) -> type[BasePolicy]:
        if policy_name.upper() in self.policy_aliases:
            return self.policy_aliases[policy_name.upper()]
        raise ValueError(f"Unknown policy {policy_name!r}; accepted: {sorted(self.policy_aliases)}")

    def _environment_policy_kwargs(self) -> dict[str, Any]:
        """What the policy learns from the environment: the hybrid action layout."""
        if self.env is None:
            return {"hybrid_layout": self.policy_kwargs.get("hybrid_layout")}
        obs_space, action_space = self.observation_space, self.action_space
        if not (
            isinstance(obs_space, spaces.Box)
            and len(obs_space.shape) == 1
            and isinstance(action_space, spaces.Box)
            and len(action_space.shape) == 1
        ):
            raise ValueError(
                f"HybridDDPG needs 1-D Box observation and action spaces; got {obs_space} and {action_space}"
            )
        try:
            hybrid = self.env.get_attr("hybrid_layout", indices=[0])[0]
        except AttributeError:
            hybrid = None
        if hybrid is None:
            metadata = self.env.get_attr("metadata", indices=[0])[0] or {}
            hybrid = metadata.get("hybrid_action")
        return {"hybrid_layout": HybridActionLayout.from_dict(hybrid)}

    def _explorable_entries(self) -> np.ndarray:
        """Which entries of an action exploration may randomise (all of them)."""
        return np.ones(self.action_space.shape[-1], dtype=bool)  # type: ignore[index]

    def _upgrade_file_of_0_1_0(self) -> None:
        """Settings loaded from a file of sb3-comm 0.1.0, when HybridDDPG was a one-agent CommDDPG."""
        layout = self.policy_kwargs.get("comm_layout")
        if layout is None or layout.n_agents != 1:  # a new file, or a team's (CommDDPG)
            return
        policy_kwargs = {**self.policy_kwargs}
        del policy_kwargs["comm_layout"]
        policy_kwargs.pop("share_parameters", None)
        self.policy_kwargs = {**policy_kwargs, "hybrid_layout": layout.hybrid}
        self.policy_class = HybridPolicy
        self.replay_buffer_class = MonteCarloReplayBuffer
        self.replay_buffer_kwargs = {k: v for k, v in self.replay_buffer_kwargs.items() if k != "n_agents"}

    def _setup_model(self) -> None:
        self._upgrade_file_of_0_1_0()
        # Copies: the caller's dicts must not learn this environment's layout.
        from_env = self._environment_policy_kwargs()
        self.policy_kwargs = {**self.policy_kwargs, **from_env}
        self.replay_buffer_kwargs = {
            **self.replay_buffer_kwargs,
            "gamma": self.gamma,
            "store_mc_returns": self.uses_mc_returns,
        }
        super()._setup_model()
        self.mc_mixing_schedule = FloatSchedule(self.mc_mixing)
        self.actor_lr_schedule = FloatSchedule(self.actor_learning_rate)
        self.actor.optimizer.param_groups[0]["lr"] = self.actor_lr_schedule(1.0)
        self.exploration_schedule = LinearSchedule(
            self.exploration_initial_eps, self.exploration_final_eps, self.exploration_fraction
        )
        self._explorable = self._explorable_entries()
        self.train_log = TrainLog()
        """Values of the updates since the last logged point (averaged there)."""
        self.log_interval_steps = 0
        """Environment steps between two logged training points (0: none); set by ``learn``."""
        self._next_log_step = 0
        self._rollout_steps = 0
        """Environment steps of the last rollout (all games together)."""

    # ------------------------------------------------------------------- public counters --
    @property
    def n_updates(self) -> int:
        """Agent (critic) updates so far, over all ``learn`` calls."""
        return self._n_updates

    @property
    def uses_mc_returns(self) -> bool:
        """Whether the critic target mixes in Monte-Carlo returns (``mc_mixing`` > 0 at the start or
        the end of training), so that the replay buffer must store them."""
        beta = self.mc_mixing
        if callable(beta):
            return beta(1.0) > 0 or beta(0.0) > 0
        return beta > 0

    @property
    def progress_remaining(self) -> float:
        """Remaining progress of the current ``learn`` call, 1 -> 0 (the argument of schedules)."""
        return self._current_progress_remaining

    # ------------------------------------------------------------------------ exploration --
    def _on_step(self) -> None:
        self.exploration_rate = self.exploration_schedule(self._current_progress_remaining)
        if self.log_interval_steps and self.num_timesteps >= self._next_log_step:
            self._next_log_step = (
                self.num_timesteps // self.log_interval_steps + 1
            ) * self.log_interval_steps
            self.dump_logs()

    # ---------------------------------------------------------------------------- logging --
    def _update_learning_rate(self, optimizers: list[th.optim.Optimizer] | th.optim.Optimizer) -> None:
        """SB3's, with the rate logged at the next point (not recorded at every update)."""
        rate = self.lr_schedule(self._current_progress_remaining)
        for optimizer in optimizers if isinstance(optimizers, list) else [optimizers]:
            update_learning_rate(optimizer, rate)
        self.train_log.add("train/learning_rate", rate)

    def _record_training_point(self) -> None:
        """Record what a logged training point holds besides SB3's rollout values: the means of
        :attr:`train_log` and the exploration rate. Subclasses add theirs."""
        for key, value in self.train_log.pop_means().items():
            self.logger.record(key, value)
        self.logger.record("rollout/exploration_rate", self.exploration_rate)
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")

    def dump_logs(self) -> None:
        """Write one logged point at ``num_timesteps``: training means, then SB3's rollout values."""
        self._record_training_point()
        super().dump_logs()

    def _sample_action(
        self, learning_starts: int, action_noise: ActionNoise | None = None, n_envs: int = 1
    ) -> tuple[np.ndarray, np.ndarray]:
        """Policy action plus exploration, in the environment's units and SB3's scaled units.

        ε-greedy (ICLR 2016): with probability ε an action's scores and parameters are drawn
        uniformly (per agent row, and only the explorable entries); otherwise the policy's, plus
        Gaussian noise with ``exploration="epsilon+gaussian"``. Before ``learning_starts`` ε = 1.
        """
        obs = obs_as_tensor(self._last_obs, self.device)  # type: ignore[arg-type]
        with th.no_grad():
            scaled = self.policy.scaled_actions(obs).cpu().numpy()  # the actor, never its average
        # One action row per agent: (n_envs, action_dim) or (n_envs, n_agents, action_dim).
        rows = scaled.reshape(n_envs, *self.action_space.shape)  # type: ignore[misc]
        warmup = self.num_timesteps < learning_starts
        if self.exploration != "gaussian" or warmup:
            epsilon = 1.0 if warmup else self.exploration_rate
            pick = np.random.random((*rows.shape[:-1], 1)) < epsilon
            random_rows = np.random.uniform(-1.0, 1.0, size=rows.shape).astype(np.float32)
            if self.exploration == "epsilon+gaussian" and not warmup:
                noise = np.random.normal(0.0, self.gaussian_noise_std, size=rows.shape).astype(np.float32)
                rows = np.clip(rows + noise * self._explorable, -1.0, 1.0)
            rows = np.where(pick & self._explorable, random_rows, rows)
        else:
            noise = np.random.normal(0.0, self.gaussian_noise_std, size=rows.shape).astype(np.float32)
            rows = np.clip(rows + noise * self._explorable, -1.0, 1.0)
        if action_noise is not None:
            extra = np.asarray(action_noise()).reshape(-1, *self.action_space.shape)  # type: ignore[misc]
            rows = np.clip(rows + extra * self._explorable, -1.0, 1.0)
        buffer_action = rows.reshape(scaled.shape)
        return self.policy.unscale_action(buffer_action), buffer_action

    # ------------------------------------------------------------------------------ train --
    def collect_rollouts(self, *args: Any, **kwargs: Any) -> RolloutReturn:
        """SB3's, remembering how many environment steps the rollout took (see
        :meth:`planned_actor_updates`)."""
        rollout = super().collect_rollouts(*args, **kwargs)
        self._rollout_steps = rollout.episode_timesteps
        return rollout

    def planned_actor_updates(self, gradient_steps: int | None = None) -> float:
        """The actor updates a run of this ``learn`` budget makes, counted from its first step: the
        budget (``total_timesteps``, and the steps before it where ``reset_num_timesteps=False``
        continues a run, so that a resumed run plans as the uninterrupted one) times the updates
        per environment step, ``gradient_steps / (train_freq × n_envs) / policy_delay``.

        :param gradient_steps: the updates after the last rollout, which count where ``train_freq``
            counts episodes: the updates per step are then those of the last rollout.
        """
        frequency = self.train_freq
        assert isinstance(frequency, TrainFreq)
        if frequency.unit == TrainFrequencyUnit.STEP:
            collected = frequency.frequency * self.n_envs
            updates = self.gradient_steps if self.gradient_steps >= 0 else collected
        else:
            collected = max(self._rollout_steps, 1)
            updates = self.gradient_steps if gradient_steps is None else gradient_steps
            if updates < 0:
                updates = collected
        return self._total_timesteps * updates / collected / self.policy_delay

    def train(self, gradient_steps: int, batch_size: int = 100) -> None:
        """Critic and actor updates, as in the ICLR 2016 agent (plus the team's message hooks).

        One update: sample; critic target ``y = r + γ(1 − d) Q'(s', μ'(s'))`` (mixed with the
        Monte-Carlo return where β > 0); critic loss; actor loss, by the critic's action gradient
        passed through :meth:`actor_output_gradients`; soft target updates.
        """
        began = time.perf_counter()
        self.policy.set_training_mode(True)
        self._update_learning_rate([self.critic.optimizer])
        actor_rate = self.actor_lr_schedule(self._current_progress_remaining)
        for group in self.actor.optimizer.param_groups:
            group["lr"] = actor_rate
        log = self.train_log
        log.add("train/actor_learning_rate", actor_rate)
        mc_mixing = self.mc_mixing_schedule(self._current_progress_remaining)
        if self.uses_mc_returns:
            log.add("train/mc_mixing", mc_mixing)
        policy = self.policy
        if policy.actor_average_tau == ACTOR_AVERAGE_AUTO:
            policy.actor_average_rate = auto_actor_average_rate(self.planned_actor_updates(gradient_steps))
            log.add("train/actor_average_rate", policy.actor_average_rate)
        sources, targets = self._soft_update_pairs()
        for _ in range(gradient_steps):
            self._n_updates += 1
            # sample
            data = self._next_batch(batch_size)
            obs, actions, next_obs = data.observations, data.actions, data.next_observations

            # critic target
            with th.no_grad():
                tail = data.mc_tail_observations if mc_mixing > 0 else None
                if tail is None:
                    next_q = self._target_values(next_obs)
                else:  # the states at the time limits' cuts in the same pass (mc_truncated="bootstrap")
                    next_q, tail_q = self._target_values(th.cat([next_obs, tail])).chunk(2)
                target_q = data.rewards + (1.0 - data.dones) * self.gamma * next_q
                if mc_mixing > 0:
                    mc_returns = data.mc_returns
                    if tail is not None:
                        mc_returns = mc_returns + data.mc_tail_discount * tail_q
                    mixed = mc_mixing * mc_returns + (1.0 - mc_mixing) * target_q
                    target_q = th.where(data.mc_valid.bool(), mixed, target_q)

            # critic loss
            q_values = policy.q_values(obs, actions)
            critic_loss = sum(F.mse_loss(q, target_q) for q in q_values)
            assert isinstance(critic_loss, th.Tensor)
            self._optimize(self.critic, critic_loss)
            log.add("train/critic_loss", critic_loss)
            q = q_values[0].detach()
            log.add("train/q_mean", q.mean())
            log.add("train/q_max", q.max())
            log.add("train/q_min", q.min())
            log.add("train/target_q_mean", target_q.mean())

            if self._n_updates % self.policy_delay != 0:
                continue

            # actor loss: a surrogate whose gradient w.r.t. the actor outputs is exactly -grad
            out = policy.actor_outputs(obs)
            grad, own_q = self.actor_output_gradients(obs, out.detach(), next_obs, data.dones)
            actor_surrogate = -(out * grad).sum(dim=-1).mean()
            self._optimize(self.actor, actor_surrogate)
            log.add("train/actor_loss", -own_q.mean())
            for key, value in self._actor_step_stats(data, out, grad).items():
                log.add(key, value)
            if policy.actor_guard:
                log.add("train/actor_guarded", policy.guarded_fraction)

            # soft update, θ' ← θ' + τ (θ − θ'), all tensors at once
            th._foreach_lerp_(targets, sources, self.tau)
            policy.update_actor_average()

        if gradient_steps > 0:  # the agent's own update, without the method's extra networks
            log.add("time/agent_update_ms", 1000.0 * (time.perf_counter() - began), count=gradient_steps)

    def _target_values(self, next_obs: th.Tensor) -> th.Tensor:
        """``min_k Q'_k(s', μ'(s') + ε)``: the target critics' value of the target actor's outputs
        (TD3's clipped noise ε where ``target_policy_noise`` > 0), the bootstrap of a critic target."""
        policy = self.policy
        next_out = policy.actor_outputs(next_obs, target=True)
        if self.target_policy_noise > 0:
            noise = th.randn_like(next_out) * self.target_policy_noise
            next_out = next_out + noise.clamp(-self.target_noise_clip, self.target_noise_clip)
        next_out = next_out.clamp(-1.0, 1.0)
        return th.stack(policy.q_values(next_obs, next_out, target=True)).min(dim=0).values

    def _next_batch(self, batch_size: int) -> MonteCarloReplayBufferSamples:
        """The batch of the next update: a uniform sample of the replay buffer."""
        return self.replay_buffer.sample(batch_size)  # type: ignore[union-attr]

    def _soft_update_pairs(self) -> tuple[list[th.Tensor], list[th.Tensor]]:
        """The trained parameters and their targets, listed once per policy."""
        policy = self.policy
        pairs = policy.__dict__.get("_soft_update_pairs")
        if pairs is None:
            sources = [*policy.critic.parameters(), *policy.actor.parameters()]
            targets = [*policy.critic_target.parameters(), *policy.actor_target.parameters()]
            pairs = policy.__dict__["_soft_update_pairs"] = (sources, targets)
        return pairs

    def critic_action_gradients(self, obs: th.Tensor, out: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """``dQ/d out`` of the (first) critic at the actor's outputs, and that critic's ``Q``
        (the policy's :meth:`~sb3_comm.hybrid_ddpg.HybridPolicy.critic_action_gradients`).

        :param obs: observations.
        :param out: bounded actor outputs (detached).
        :return: ``grad`` shaped like ``out`` and ``Q`` (detached).
        """
        return self.policy.critic_action_gradients(obs, out)

    def invert_bounded_gradients(self, grad: th.Tensor, out: th.Tensor) -> th.Tensor:
        """Inverting gradients on hybrid heads (ICLR 2016, eq. 11); ``tanh`` heads need none."""
        return inverting_gradients(grad, out) if self.policy.hybrid else grad

    def actor_output_gradients(
        self, obs: th.Tensor, out: th.Tensor, next_obs: th.Tensor, dones: th.Tensor
    ) -> tuple[th.Tensor, th.Tensor]:
        """Ascent direction for every actor output, and the critic's Q.

        ``dQ/da`` at the actor's current action, through inverting gradients on bounded hybrid
        outputs.

        :param obs: observations ``(B, obs_dim)``.
        :param out: bounded actor outputs (detached).
        :param next_obs: next observations (unused here; a team's messages need them).
        :param dones: ``(B, 1)`` terminal flags (unused here).
        :return: ``grad`` shaped like ``out`` and ``own_q``.
        """
        grad, own_q = self.critic_action_gradients(obs, out)
        return self.invert_bounded_gradients(grad, out), own_q

    def _actor_step_stats(
        self, data: MonteCarloReplayBufferSamples, out: th.Tensor, grad: th.Tensor
    ) -> dict[str, th.Tensor]:
        """Extra values logged (as means, 0-d tensors) after each actor update; none for one agent."""
        return {}

    def _optimize(self, module: th.nn.Module, loss: th.Tensor) -> None:
        gradient_step(module.optimizer, loss, self.max_grad_norm)  # type: ignore[arg-type]

    # ---------------------------------------------------------------------- save / load --
    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_explorable", "train_log"]

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        return ["policy", "actor.optimizer", "critic.optimizer"], []

    def load_replay_buffer(
        self, path: str | pathlib.Path | io.BufferedIOBase, truncate_last_traj: bool = True
    ) -> None:
        """Load a replay buffer written by :meth:`save_replay_buffer`, checked before it replaces the model's.

        The loaded buffer must be of this model's kind: its class (a :class:`MonteCarloReplayBuffer`,
        a :class:`~sb3_comm.comm_ddpg.buffers.JointReplayBuffer` for a team), observation and action
        shapes, parallel games, agents and Monte-Carlo returns (with the same γ and the same
        ``mc_truncated``: what an episode cut by a time limit gets). Otherwise a
        ``ValueError`` names every difference and the model keeps its buffer. Episodes that were
        still running when the buffer was saved are closed without a Monte-Carlo return (the
        environment restarts; their transitions keep the TD target).

        The file is a pickle, as in SB3: load only files you trust.

        :param path: the file (SB3 adds ``.pkl`` when missing).
        :param truncate_last_traj: SB3's argument for HER buffers; unused here.
        """
        try:
            buffer = load_from_pkl(path, self.verbose)
        except FileNotFoundError:
            raise
        except Exception as error:  # a truncated or foreign file: name it, keep the model's buffer
            raise ValueError(
                f"{path} is not a readable replay buffer ({type(error).__name__}: {error})"
            ) from error
        problems = self.replay_buffer_mismatch(buffer)
        if problems:
            raise ValueError(
                f"The replay buffer in {path} does not fit this model: {'; '.join(problems)} "
                "(the model's replay buffer is unchanged)"
            )
        buffer.device = self.device
        buffer.close_open_episodes()
        self.replay_buffer = buffer

    def replay_buffer_mismatch(self, buffer: Any) -> list[str]:
        """How ``buffer`` differs from a replay buffer of this model (empty: it fits).

        :param buffer: a loaded replay buffer (any object).
        :return: one description per difference, e.g. ``"n_envs 4 (model: 2)"``.
        """
        expected_class = self.replay_buffer_class or MonteCarloReplayBuffer
        if not isinstance(buffer, expected_class):
            return [f"it is a {type(buffer).__name__}, not a {expected_class.__name__}"]
        reference = self.replay_buffer
        wanted = {
            "observation shape": tuple(self.observation_space.shape),  # type: ignore[arg-type]
            "action shape": tuple(self.action_space.shape),  # type: ignore[arg-type]
            "n_envs": self.n_envs,
            "n_agents": getattr(reference, "n_agents", 1),
            "Monte-Carlo returns": self.uses_mc_returns,
        }
        found = {
            "observation shape": tuple(buffer.observation_space.shape),
            "action shape": tuple(buffer.action_space.shape),
            "n_envs": buffer.n_envs,
            "n_agents": getattr(buffer, "n_agents", 1),
            "Monte-Carlo returns": bool(buffer.store_mc_returns),
        }
        problems = [
            f"{key} {found[key]!r} (model: {wanted[key]!r})" for key in wanted if found[key] != wanted[key]
        ]
        if buffer.store_mc_returns and buffer.gamma != self.gamma:
            problems.append(f"Monte-Carlo returns discounted with gamma {buffer.gamma} (model: {self.gamma})")
        wanted_cut = getattr(reference, "mc_truncated", "sum")
        if buffer.store_mc_returns and self.uses_mc_returns and buffer.mc_truncated != wanted_cut:
            problems.append(f"mc_truncated {buffer.mc_truncated!r} (model: {wanted_cut!r})")
        return problems

    # ------------------------------------------------------------- weights without pickle --
    @classmethod
    def _weights_algorithm(cls) -> type[HybridDDPG]:
        """The package class this class builds (a subclass such as rl-zoo3's counts as its base)."""
        for klass in cls.__mro__:
            if "__init__" in vars(klass) and "learning_rate" in inspect.signature(klass.__init__).parameters:
                return klass
        return HybridDDPG

    def _layout_description(self) -> dict[str, Any] | None:
        layout = getattr(self, "comm_layout", None) or self.policy_kwargs.get("hybrid_layout")
        return json.loads(json.dumps(dataclasses.asdict(layout))) if layout is not None else None

    def weights_config(self) -> dict[str, Any]:
        """The JSON configuration written next to the weights by :meth:`save_weights`.

        ``algorithm``, ``method``, the environment ``layout`` (checked against the environment on
        loading), ``policy_kwargs`` (classes such as ``activation_fn`` by their ``torch.nn`` or
        ``torch.optim`` name) and the constructor's plain ``hyperparameters``; settings that are
        not plain values (schedules given as callables) are listed under ``not_stored``.
        """
        algorithm = self._weights_algorithm()
        params = inspect.signature(algorithm.__init__).parameters
        hyperparameters: dict[str, Any] = {}
        not_stored: list[str] = []
        for name in params:
            if name in _NOT_WEIGHTS_SETTINGS:
                continue
            # SB3 keeps some arguments with a leading underscore (stats_window_size).
            value = getattr(self, name) if hasattr(self, name) else getattr(self, f"_{name}", None)
            if isinstance(value, TrainFreq):
                value = [value.frequency, value.unit.value]
            if value is None or isinstance(value, bool | int | float | str | list):
                hyperparameters[name] = value
            else:
                not_stored.append(name)
        policy_kwargs = {}
        for key, value in self.policy_kwargs.items():
            if key in ("comm_layout", "hybrid_layout", "share_parameters"):
                continue  # from the environment, or a hyperparameter
            policy_kwargs[key] = _class_name(key, value)
        return {
            "format": WEIGHTS_FORMAT,
            "algorithm": algorithm.__name__,
            "method": getattr(self, "method", None),
            "layout": self._layout_description(),
            "policy_kwargs": policy_kwargs,
            "hyperparameters": hyperparameters,
            "not_stored": not_stored,
        }

    def save_weights(self, path: str | pathlib.Path) -> pathlib.Path:
        """Save the networks' weights and a JSON configuration: a model file to share without pickles.

        Writes ``policy.pth`` (``torch.save`` of the policy's ``state_dict``: tensors only) and
        ``config.json`` (:meth:`weights_config`), into the folder ``path``, or into one archive when
        ``path`` ends in ``.zip``. :meth:`load_weights` reads them back without unpickling anything.
        The optimizers, the replay buffer and the counters are not saved: this is for using and
        sharing a trained model; continue training from :meth:`save`'s file.

        :param path: a folder, or a ``.zip`` file.
        :return: the path written.
        """
        config = json.dumps(self.weights_config(), indent=2)
        weights = io.BytesIO()
        th.save(self.policy.state_dict(), weights)
        path = pathlib.Path(path)
        if path.suffix == ".zip":
            path.parent.mkdir(parents=True, exist_ok=True)
            with zipfile.ZipFile(path, "w") as archive:
                archive.writestr("config.json", config)
                archive.writestr("policy.pth", weights.getvalue())
        else:
            path.mkdir(parents=True, exist_ok=True)
            (path / "config.json").write_text(config)
            (path / "policy.pth").write_bytes(weights.getvalue())
        return path

    @classmethod
    def load_weights(
        cls: type[SelfHybridDDPG],
        path: str | pathlib.Path,
        env: GymEnv | str,
        device: th.device | str = "auto",
        **kwargs: Any,
    ) -> SelfHybridDDPG:
        """A model built from :meth:`save_weights`' files, with nothing unpickled.

        The configuration is JSON and the weights are read with ``torch.load(..., weights_only=True)``,
        which accepts tensors and refuses any other object: a crafted file cannot run code here
        (unlike :meth:`load`, which unpickles, as SB3 does).

        :param path: the folder or ``.zip`` written by :meth:`save_weights`.
        :param env: the environment (an id or an environment), whose layout must match the saved one.
        :param device: torch device.
        :param kwargs: settings that replace the saved hyperparameters (e.g. ``buffer_size``).
        :raises ValueError: a file that is not such a model, a weights file holding anything but
            tensors, a model of another algorithm, or an environment of another layout.
        """
        path = pathlib.Path(path)
        config, state = _read_weights(path, device)
        algorithm = cls._weights_algorithm()
        if config.get("algorithm") != algorithm.__name__:
            raise ValueError(f"{path} holds a {config.get('algorithm')} model; load it with that class")
        settings = dict(config.get("hyperparameters", {}))
        if isinstance(settings.get("train_freq"), list):
            settings["train_freq"] = tuple(settings["train_freq"])
        policy_kwargs = {key: _class_of(key, value) for key, value in config.get("policy_kwargs", {}).items()}
        model = cls(
            config.get("method") or "MlpPolicy",
            env,
            policy_kwargs=policy_kwargs,
            device=device,
            **{**settings, **kwargs},
        )
        if model._layout_description() != config.get("layout"):
            raise ValueError(
                f"{path} was trained on an environment of layout {config.get('layout')}; "
                f"this one has {model._layout_description()}"
            )
        try:
            model.policy.load_state_dict(state)
        except RuntimeError as error:
            raise ValueError(f"{path}: the weights do not fit the configured networks: {error}") from error
        return model

    def learn(
        self: SelfHybridDDPG,
        total_timesteps: int,
        callback: MaybeCallback = None,
        log_interval: int | None = None,
        tb_log_name: str = "HybridDDPG",
        reset_num_timesteps: bool = True,
        progress_bar: bool = False,
    ) -> SelfHybridDDPG:
        """Train for ``total_timesteps`` environment steps (≥ 1), as in SB3.

        :param log_interval: **environment steps** between two logged training points (SB3's
            off-policy algorithms count episodes, which means little with hundreds of parallel
            games). Each point holds the means of every training value since the previous one.
            None: about :data:`LOG_POINTS` points over this call; 0: no training points.
        """
        Range(1.0)("total_timesteps", total_timesteps)
        self.log_interval_steps = interval = _log_interval(log_interval, total_timesteps, self.n_envs)
        start = 0 if reset_num_timesteps else self.num_timesteps
        self._next_log_step = (start // interval + 1) * interval if interval else 0
        return super().learn(
            total_timesteps=total_timesteps,
            callback=callback,
            log_interval=None,  # the points come from _on_step, every log_interval_steps
            tb_log_name=tb_log_name,
            reset_num_timesteps=reset_num_timesteps,
            progress_bar=progress_bar,
        )


def default_log_interval(total_timesteps: int, n_envs: int) -> int:
    """About :data:`LOG_POINTS` logged points over ``total_timesteps``, on the grid of ``n_envs``
    environment steps (one vectorised step)."""
    per_point = max(total_timesteps // LOG_POINTS, 1)
    return max(n_envs, per_point // n_envs * n_envs)


def _log_interval(log_interval: int | None, total_timesteps: int, n_envs: int) -> int:
    """Environment steps between logged points: the given number, or the default."""
    if log_interval is None:
        return default_log_interval(total_timesteps, n_envs)
    if isinstance(log_interval, bool) or not isinstance(log_interval, (int, np.integer)) or log_interval < 0:
        raise ValueError(
            f"log_interval must be a whole number of environment steps ≥ 0 (0: no training points) "
            f"or None (about {LOG_POINTS} points), got {log_interval!r}"
        )
    return int(log_interval)


_CLASS_MODULES = {"activation_fn": (th.nn, th.nn.Module), "optimizer_class": (th.optim, th.optim.Optimizer)}


def _class_name(key: str, value: Any) -> Any:
    """A policy setting as JSON: a ``torch.nn`` / ``torch.optim`` class by its dotted name."""
    if key in _CLASS_MODULES and isinstance(value, type):
        module, _ = _CLASS_MODULES[key]
        if getattr(module, value.__name__, None) is value:
            return f"{module.__name__}.{value.__name__}"
    try:
        json.dumps(value)
    except TypeError:
        raise ValueError(
            f"policy_kwargs[{key!r}] = {value!r} cannot be written as JSON; save_weights stores plain "
            "values and torch.nn / torch.optim classes (use save() for this model)"
        ) from None
    return value


def _class_of(key: str, value: Any) -> Any:
    """The inverse of :func:`_class_name`: only classes of ``torch.nn`` / ``torch.optim`` are looked up."""
    if key not in _CLASS_MODULES or not isinstance(value, str):
        return value
    module, base = _CLASS_MODULES[key]
    prefix = f"{module.__name__}."
    found = getattr(module, value[len(prefix) :], None) if value.startswith(prefix) else None
    if not (isinstance(found, type) and issubclass(found, base)):
        raise ValueError(f"policy_kwargs[{key!r}] = {value!r} is not a class of {module.__name__}")
    return found


def _read_weights(path: pathlib.Path, device: th.device | str) -> tuple[dict[str, Any], dict[str, th.Tensor]]:
    """``config.json`` and ``policy.pth`` of a folder or ``.zip``, read without unpickling."""
    try:
        if path.is_dir():
            config_text, weights = (path / "config.json").read_text(), (path / "policy.pth").read_bytes()
        else:
            with zipfile.ZipFile(path) as archive:
                config_text = archive.read("config.json").decode()
                weights = archive.read("policy.pth")
    except FileNotFoundError:
        raise FileNotFoundError(
            f"No model weights at {path} (a folder or .zip with config.json and policy.pth)"
        ) from None
    except (KeyError, zipfile.BadZipFile) as error:
        raise ValueError(f"{path} is not a weights file of save_weights ({error})") from error
    try:
        config = json.loads(config_text)
    except json.JSONDecodeError as error:
        raise ValueError(f"{path}: config.json is not valid JSON: {error}") from error
    if not isinstance(config, dict) or config.get("format") != WEIGHTS_FORMAT:
        raise ValueError(f"{path}: config.json is not a weights configuration of format {WEIGHTS_FORMAT}")
    map_location = "cpu" if device == "auto" else device
    try:
        state = th.load(io.BytesIO(weights), map_location=map_location, weights_only=True)
    except (pickle.UnpicklingError, RuntimeError, EOFError) as error:
        raise ValueError(
            f"{path}: policy.pth was refused: it is not a plain file of tensors (torch.load with "
            f"weights_only=True; nothing in it was run): {error}"
        ) from error
    if not isinstance(state, dict) or not all(isinstance(v, th.Tensor) for v in state.values()):
        raise ValueError(f"{path}: policy.pth must hold a state dict of tensors")
    return config, state
