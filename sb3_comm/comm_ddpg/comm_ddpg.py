"""CommDDPG: parameterised-action DDPG for two agents that learn to communicate.

Paper: Hausknecht & Stone, "Grounded Semantic Networks for Learning Shared Communication
Protocols" (NIPS 2016 Deep RL workshop); the agents follow "Deep Reinforcement Learning in
Parameterized Action Space" (ICLR 2016). Original code: github.com/mhauskn/dqn-hfo (branches
``scenario`` and ``dial``), C++/Caffe.

The four methods (``policy`` argument, SPEC §1):

* ``"NONE"``: the channel carries zeros (baseline).
* ``"RIAL"``: messages are extra actor outputs trained by the sender's own critic.
* ``"TCG"``: messages are extra actor outputs trained by the *receiver's* critic: the gradient of
  ``Q_receiver(o'_receiver, a'_receiver)`` with respect to the message slot of the receiver's next
  observation replaces the sender's own critic gradient (paper §5), see :meth:`CommDDPG.train`.
* ``"GSN"``: messages are the hidden layer of a grounded semantic network trained to predict the
  teammate's reward; a callback trains it once per agent update (paper §3).
"""

from __future__ import annotations

from collections import deque
from typing import Any, ClassVar, TypeVar

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import TD3
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.noise import ActionNoise
from stable_baselines3.common.policies import BasePolicy
from stable_baselines3.common.type_aliases import GymEnv, MaybeCallback, Schedule
from stable_baselines3.common.utils import FloatSchedule, LinearSchedule, obs_as_tensor, polyak_update
from torch.nn import functional as F

from sb3_comm.comm_ddpg.buffers import JointReplayBuffer
from sb3_comm.comm_ddpg.gsn import GSNTrainingCallback
from sb3_comm.comm_ddpg.policies import METHODS, CommPolicy, GSNPolicy, NonePolicy, RIALPolicy, TCGPolicy
from sb3_comm.common.layout import CommLayout, HybridActionLayout
from sb3_comm.common.networks import inverting_gradients

__all__ = ["METHODS", "CommDDPG", "HybridDDPG"]

SelfCommDDPG = TypeVar("SelfCommDDPG", bound="CommDDPG")


class CommDDPG(TD3):
    """Hybrid-action DDPG (a TD3 subclass) with a learned message channel between two agents.

    :param policy: the communication method, ``"NONE"``, ``"RIAL"``, ``"TCG"`` or ``"GSN"``
        (or a :class:`CommPolicy` subclass).
    :param env: a two-agent environment: a registered id (``"BlindSoccer-v0"``,
        ``"GuessMyNumber-v0"``), a :class:`~sb3_comm.wrappers.TwoAgentEnv`, or a VecEnv of them
        (:func:`sb3_comm.make_comm_vec_env` steps many games at once).
    :param learning_rate: critic learning rate (or schedule).
    :param actor_learning_rate: actor learning rate or schedule (reference code: 1e-5).
    :param gsn_learning_rate: GSN learning rate or schedule of the remaining progress, e.g.
        ``LinearSchedule(1e-3, 0, 1)`` (paper: a constant 1e-6).
    :param buffer_size: replay size in joint transitions.
    :param learning_starts: transitions collected with full exploration before learning.
    :param batch_size: joint transitions per update.
    :param tau: soft target update rate.
    :param gamma: discount factor.
    :param train_freq: update the model every ``train_freq`` steps.
    :param gradient_steps: updates after each rollout (-1: as many as steps collected).
    :param exploration: ``"epsilon"`` (ICLR 2016: with probability ε an agent takes uniformly
        random action scores and parameters) or ``"gaussian"`` (Gaussian noise on every output).
    :param exploration_initial_eps: ε at the start.
    :param exploration_final_eps: ε after annealing.
    :param exploration_fraction: fraction of training over which ε is annealed linearly.
    :param gaussian_noise_std: standard deviation of the Gaussian exploration (scaled units).
    :param mc_mixing: β of the critic target ``y = β·G_t + (1 − β)·(r + γ Q'(s', μ'(s')))``
        (reference code and default: 0.5; on Blind Soccer it is what made learning stable).
    :param tcg_gain: scale of the teammate's gradient that trains TCG messages.
    :param channel_size: expected message size; must match the environment's (None: take it).
    :param share_parameters: one set of networks for both agents (role one-hot in the observation)
        or one per agent, as in the paper.
    :param max_grad_norm: gradient clipping of actor, critic and GSN (reference: 10).
    :param action_noise: optional SB3 action noise added on top of the exploration.
    :param replay_buffer_kwargs: extra arguments of :class:`JointReplayBuffer`.
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

    policy_aliases: ClassVar[dict[str, type[BasePolicy]]] = {
        "NONE": NonePolicy,
        "RIAL": RIALPolicy,
        "TCG": TCGPolicy,
        "GSN": GSNPolicy,
    }
    n_agents_accepted: ClassVar[tuple[int, ...]] = (2,)
    policy: CommPolicy

    def __init__(
        self,
        policy: str | type[CommPolicy],
        env: GymEnv | str,
        learning_rate: float | Schedule = 1e-3,
        actor_learning_rate: float | Schedule = 1e-4,
        gsn_learning_rate: float | Schedule = 1e-3,
        buffer_size: int = 200_000,
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
        mc_mixing: float = 0.5,
        tcg_gain: float = 1.0,
        channel_size: int | None = None,
        share_parameters: bool = True,
        max_grad_norm: float = 10.0,
        action_noise: ActionNoise | None = None,
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
        if exploration not in ("epsilon", "gaussian"):
            raise ValueError(f"exploration must be 'epsilon' or 'gaussian', got {exploration!r}")
        if not 0.0 <= mc_mixing <= 1.0:
            raise ValueError(f"mc_mixing (β) must lie in [0, 1], got {mc_mixing}")
        self.actor_learning_rate = actor_learning_rate
        self.gsn_learning_rate = gsn_learning_rate
        self.exploration = exploration
        self.exploration_initial_eps = exploration_initial_eps
        self.exploration_final_eps = exploration_final_eps
        self.exploration_fraction = exploration_fraction
        self.gaussian_noise_std = gaussian_noise_std
        self.mc_mixing = mc_mixing
        self.tcg_gain = tcg_gain
        self.channel_size = channel_size
        self.share_parameters = share_parameters
        self.max_grad_norm = max_grad_norm
        self.exploration_rate = exploration_initial_eps
        self._gsn_updates = 0
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
            replay_buffer_class=JointReplayBuffer,
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
        raise ValueError(
            f"Unknown communication method {policy_name!r}; accepted: {sorted(self.policy_aliases)}"
        )

    def _read_layout(self) -> CommLayout:
        """The environment's :class:`CommLayout` (or the saved one when loading without env)."""
        saved = self.policy_kwargs.get("comm_layout")
        if self.env is None:
            if saved is None:
                raise ValueError("CommDDPG needs an environment to learn its layout")
            return saved
        try:
            layout = self.env.get_attr("comm_layout", indices=[0])[0]
        except AttributeError:
            layout = self._layout_without_channel()
        if saved is not None and saved != layout:
            raise ValueError(f"The environment's layout {layout} differs from the model's {saved}")
        return layout

    def _layout_without_channel(self) -> CommLayout:
        raise ValueError(
            f"{type(self).__name__} needs a two-agent environment with a message channel: a registered id "
            "('BlindSoccer-v0', 'GuessMyNumber-v0'), sb3_comm.wrappers.TwoAgentEnv(parallel_env) or "
            f"sb3_comm.make_comm_vec_env(...); got an environment with observation space "
            f"{self.observation_space} and no 'comm_layout'"
        )

    def _setup_model(self) -> None:
        layout = self._read_layout()
        if layout.n_agents not in self.n_agents_accepted:
            raise ValueError(
                f"{type(self).__name__} accepts environments with {self.n_agents_accepted} agents; "
                f"this one has {layout.n_agents}"
            )
        if self.channel_size is not None and self.channel_size != layout.channel_size:
            raise ValueError(
                f"channel_size={self.channel_size} does not match the environment's message channel of "
                f"size {layout.channel_size}; pass channel_size={layout.channel_size} or None"
            )
        # Copies: the caller's dicts must not learn this environment's layout.
        self.policy_kwargs = {
            **self.policy_kwargs,
            "comm_layout": layout,
            "share_parameters": self.share_parameters,
        }
        self.replay_buffer_kwargs = {
            **self.replay_buffer_kwargs,
            "n_agents": layout.n_agents,
            "gamma": self.gamma,
            "store_mc_returns": self.mc_mixing > 0,
        }
        super()._setup_model()
        self.comm_layout = layout
        self.actor_lr_schedule = FloatSchedule(self.actor_learning_rate)
        self.gsn_lr_schedule = FloatSchedule(self.gsn_learning_rate)
        self.actor.optimizer.param_groups[0]["lr"] = self.actor_lr_schedule(1.0)
        self.gsn = self.policy.gsn
        if self.gsn is not None:
            self.gsn.optimizer.param_groups[0]["lr"] = self.gsn_lr_schedule(1.0)
        self.exploration_schedule = LinearSchedule(
            self.exploration_initial_eps, self.exploration_final_eps, self.exploration_fraction
        )
        # Which entries of an action row exploration may randomise: the environment action, and
        # the message only where it is an action (RIAL, TCG). GSN and NONE messages are not actions.
        explorable = np.ones(layout.action_dim, dtype=bool)
        if not self.policy.has_comm_actions:
            explorable[layout.action_message_slice] = False
        self._explorable = explorable
        self._agent_returns: deque[np.ndarray] = deque(maxlen=self._stats_window_size)

    @property
    def n_updates(self) -> int:
        """Gradient updates of the agents so far."""
        return self._n_updates

    @property
    def method(self) -> str:
        """The communication method: ``"NONE"``, ``"RIAL"``, ``"TCG"`` or ``"GSN"``."""
        return self.policy.method

    def _init_callback(self, callback: MaybeCallback, progress_bar: bool = False) -> BaseCallback:
        callback = super()._init_callback(callback, progress_bar)
        if self.gsn is not None:
            gsn_callback = GSNTrainingCallback()
            callback = CallbackList([gsn_callback, callback])
            callback.init_callback(self)
        return callback

    # ------------------------------------------------------------------------ exploration --
    def _on_step(self) -> None:
        self.exploration_rate = self.exploration_schedule(self._current_progress_remaining)
        self.logger.record("rollout/exploration_rate", self.exploration_rate)

    def _sample_action(
        self, learning_starts: int, action_noise: ActionNoise | None = None, n_envs: int = 1
    ) -> tuple[np.ndarray, np.ndarray]:
        """Policy action plus exploration, in the environment's units and SB3's scaled units.

        ε-greedy (ICLR 2016): with probability ε an agent's action scores and parameters (and
        RIAL/TCG messages) are drawn uniformly; otherwise the policy's. Before ``learning_starts``
        ε = 1. GSN messages always come from the GSN and NONE messages are always zero.
        """
        layout = self.comm_layout
        obs = obs_as_tensor(self._last_obs, self.device)  # type: ignore[arg-type]
        with th.no_grad():
            scaled = self.policy._predict(obs).cpu().numpy()
        rows = scaled.reshape(n_envs, layout.n_agents, layout.action_dim)
        warmup = self.num_timesteps < learning_starts
        if self.exploration == "epsilon" or warmup:
            epsilon = 1.0 if warmup else self.exploration_rate
            pick = np.random.random((n_envs, layout.n_agents, 1)) < epsilon
            random_rows = np.random.uniform(-1.0, 1.0, size=rows.shape).astype(np.float32)
            rows = np.where(pick & self._explorable, random_rows, rows)
        else:
            noise = np.random.normal(0.0, self.gaussian_noise_std, size=rows.shape).astype(np.float32)
            rows = np.clip(rows + noise * self._explorable, -1.0, 1.0)
        if action_noise is not None:
            extra = np.asarray(action_noise()).reshape(-1, layout.n_agents, layout.action_dim)
            rows = np.clip(rows + extra * self._explorable, -1.0, 1.0)
        buffer_action = rows.reshape(scaled.shape)
        return self.policy.unscale_action(buffer_action), buffer_action

    # ------------------------------------------------------------------------------ train --
    def train(self, gradient_steps: int, batch_size: int = 100) -> None:
        """Critic and actor updates; TCG swaps in the receiver's message gradients.

        One update: (1) critic regression to ``y = r + γ(1 − d) Q'(s', μ'(s'))`` (mixed with the
        Monte-Carlo return when β > 0); (2) actor update by the critic's action gradient, with
        inverting gradients on bounded hybrid outputs, where the message part of the gradient
        comes from the sender's own critic (RIAL), the receiver's critic (TCG), or nowhere (GSN
        and NONE have no message outputs); (3) soft target updates.
        """
        self.policy.set_training_mode(True)
        self._update_learning_rate([self.critic.optimizer])
        for group in self.actor.optimizer.param_groups:
            group["lr"] = self.actor_lr_schedule(self._current_progress_remaining)
        policy, layout = self.policy, self.comm_layout
        env_dim = policy.env_action_dim
        actor_losses, critic_losses, message_means, message_stds, tcg_norms = [], [], [], [], []
        for _ in range(gradient_steps):
            self._n_updates += 1
            data = self.replay_buffer.sample(batch_size)  # type: ignore[union-attr]
            obs, actions, next_obs = data.observations, data.actions, data.next_observations

            # (1) critic
            with th.no_grad():
                next_out = policy.actor_outputs(next_obs, target=True)
                if self.target_policy_noise > 0:
                    noise = th.randn_like(next_out) * self.target_policy_noise
                    next_out = next_out + noise.clamp(-self.target_noise_clip, self.target_noise_clip)
                next_out = next_out.clamp(-1.0, 1.0)
                next_q = th.stack(policy.q_values(next_obs, next_out, target=True)).min(dim=0).values
                target_q = data.rewards + (1.0 - data.dones) * self.gamma * next_q
                if self.mc_mixing > 0:
                    mixed = self.mc_mixing * data.mc_returns + (1.0 - self.mc_mixing) * target_q
                    target_q = th.where(data.mc_valid.bool(), mixed, target_q)
            critic_loss = sum(F.mse_loss(q, target_q) for q in policy.q_values(obs, actions))
            assert isinstance(critic_loss, th.Tensor)
            self._optimize(self.critic, critic_loss)
            critic_losses.append(critic_loss.item())

            if self._n_updates % self.policy_delay != 0:
                continue

            # (2) actor, driven by the ascent direction of each of its outputs
            out = policy.actor_outputs(obs)
            grad, own_q = self.actor_output_gradients(obs, out.detach(), next_obs, data.dones)
            # Surrogate whose gradient w.r.t. the actor outputs is exactly -grad (per sample).
            actor_surrogate = -(out * grad).sum(dim=-1).mean()
            self._optimize(self.actor, actor_surrogate)
            actor_losses.append(-own_q.mean().item())
            if policy.method == "TCG":
                tcg_norms.append(grad[..., env_dim:].norm(dim=-1).mean().item())
            if layout.channel_size:
                # The messages sent: actor outputs (RIAL, TCG) or what the GSN sent when acting.
                sent = actions[..., layout.action_message_slice]
                if policy.has_comm_actions:
                    sent = out[..., env_dim:]
                messages = sent.detach()
                message_means.append(messages.mean().item())
                message_stds.append(messages.std().item())

            # (3) targets
            polyak_update(self.critic.parameters(), self.critic_target.parameters(), self.tau)
            polyak_update(self.actor.parameters(), self.actor_target.parameters(), self.tau)

        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        self.logger.record("train/critic_loss", float(np.mean(critic_losses)))
        if actor_losses:
            self.logger.record("train/actor_loss", float(np.mean(actor_losses)))
            if message_means:
                self.logger.record("comm/message_mean", float(np.mean(message_means)))
                self.logger.record("comm/message_std", float(np.mean(message_stds)))
        if tcg_norms:
            self.logger.record("tcg/grad_norm", float(np.mean(tcg_norms)))

    def actor_output_gradients(
        self, obs: th.Tensor, out: th.Tensor, next_obs: th.Tensor, dones: th.Tensor
    ) -> tuple[th.Tensor, th.Tensor]:
        """Ascent direction for every actor output, and the own critic's Q.

        The environment-action part is ``dQ_own/da`` at the actor's current action. The message
        part is ``dQ_own/dm`` for RIAL, the receiver's gradient
        (:meth:`teammate_message_gradients`) for TCG, and absent for GSN and NONE. Bounded
        hybrid outputs then pass through inverting gradients.

        :param obs: ``(B, n_agents, obs_dim)``.
        :param out: ``(B, n_agents, actor_out_dim)`` bounded actor outputs (detached).
        :param next_obs: ``(B, n_agents, obs_dim)``.
        :param dones: ``(B, 1)`` terminal flags.
        :return: ``grad`` shaped like ``out`` and ``own_q`` ``(B, n_agents)``.
        """
        policy = self.policy
        env_dim = policy.env_action_dim
        current = out.detach().requires_grad_(True)
        own_q = policy.q_values(obs, current)[0]
        grad = th.autograd.grad(own_q.sum(), current)[0]
        if policy.method == "TCG":
            grad[..., env_dim:] = self.teammate_message_gradients(out, next_obs, dones)
        if policy.hybrid:
            grad = inverting_gradients(grad, out)
        return grad, own_q.detach()

    def teammate_message_gradients(self, out: th.Tensor, next_obs: th.Tensor, dones: th.Tensor) -> th.Tensor:
        """TCG (paper §5): each sender's message gradient from its receiver's critic.

        For sender ``i`` and receiver ``j``, with ``m = μ_i(o_i)`` the sender's current message put in
        the message slot of the receiver's next observation ``o'_j``::

            g_i = tcg_gain · ∂Q_j(o'_j[m], a'_j) / ∂m,    a'_j = μ_j(o'_j[m]) held fixed

        Terminal transitions give no gradient (there is no next step to hear the message).

        :param out: ``(B, 2, actor_out_dim)`` bounded actor outputs (their last ``n`` are messages).
        :param next_obs: ``(B, 2, obs_dim)`` next observations.
        :param dones: ``(B, 1)`` terminal flags.
        :return: ``(B, 2, n)`` gradient for each sender's message outputs.
        """
        policy, layout = self.policy, self.comm_layout
        start = layout.obs_message_slice.start
        received = out[..., policy.env_action_dim :].detach().flip(1).clone().requires_grad_(True)
        next_rows = th.cat([next_obs[..., :start], received], dim=-1)
        with th.no_grad():
            next_actions = policy.actor_outputs(next_rows)
        receiver_q = policy.q_values(next_rows, next_actions)[0]
        grad_received = th.autograd.grad(receiver_q.sum(), received)[0]
        return self.tcg_gain * grad_received.flip(1) * (1.0 - dones).unsqueeze(-1)

    def train_gsn(self, n_updates: int) -> None:
        """``n_updates`` GSN regressions on uniformly sampled joint tuples (paper eq. 2)."""
        if self.gsn is None or n_updates <= 0 or self.replay_buffer is None:
            return
        self.gsn.train(True)
        lr = self.gsn_lr_schedule(self._current_progress_remaining)
        for group in self.gsn.optimizer.param_groups:
            group["lr"] = lr
        self.logger.record("gsn/learning_rate", lr)
        losses = []
        for _ in range(n_updates):
            data = self.replay_buffer.sample(self.batch_size)
            loss = self.gsn.loss(data.observations, data.actions, data.rewards)
            self._optimize(self.gsn, loss)
            losses.append(loss.item())
            self._gsn_updates += 1
        self.logger.record("gsn/loss", float(np.mean(losses)))

    def _optimize(self, module: th.nn.Module, loss: th.Tensor) -> None:
        module.optimizer.zero_grad()  # type: ignore[union-attr]
        loss.backward()
        if self.max_grad_norm:
            th.nn.utils.clip_grad_norm_(module.parameters(), self.max_grad_norm)
        module.optimizer.step()  # type: ignore[union-attr]

    # ---------------------------------------------------------------------------- logging --
    def _update_info_buffer(self, infos: list[dict[str, Any]], dones: np.ndarray | None = None) -> None:
        super()._update_info_buffer(infos, dones)
        for info in infos:
            returns = info.get("agent_returns")
            if returns is not None:
                self._agent_returns.append(np.asarray(returns))

    def dump_logs(self) -> None:
        """SB3's rollout logs plus each agent's mean episode return."""
        if self._agent_returns:
            means = np.mean(np.stack(self._agent_returns), axis=0)
            for name, value in zip(self.comm_layout.agent_names, means, strict=False):
                self.logger.record(f"rollout/ep_return_{name}", float(value))
        super().dump_logs()

    # ---------------------------------------------------------------------- save / load --
    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "gsn", "comm_layout", "_explorable", "_agent_returns"]

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        state_dicts = ["policy", "actor.optimizer", "critic.optimizer"]
        if self.policy.gsn is not None:
            state_dicts.append("policy.gsn.optimizer")
        return state_dicts, []

    def learn(
        self: SelfCommDDPG,
        total_timesteps: int,
        callback: MaybeCallback = None,
        log_interval: int = 4,
        tb_log_name: str = "CommDDPG",
        reset_num_timesteps: bool = True,
        progress_bar: bool = False,
    ) -> SelfCommDDPG:
        """Train for ``total_timesteps`` environment steps (games × steps), as in SB3."""
        return super().learn(
            total_timesteps=total_timesteps,
            callback=callback,
            log_interval=log_interval,
            tb_log_name=tb_log_name,
            reset_num_timesteps=reset_num_timesteps,
            progress_bar=progress_bar,
        )


class HybridDDPG(CommDDPG):
    """The ICLR 2016 parameterised-action DDPG for a single agent (no channel).

    Accepts a plain Gymnasium environment with a 1-D ``Box`` action; a ``hybrid_layout``
    attribute (or ``metadata["hybrid_action"]``) marks the HFO-style action scores and parameters.
    The policy is ``"MlpPolicy"``.
    """

    policy_aliases: ClassVar[dict[str, type[BasePolicy]]] = {"MLPPOLICY": NonePolicy, "NONE": NonePolicy}
    n_agents_accepted: ClassVar[tuple[int, ...]] = (1,)

    def _layout_without_channel(self) -> CommLayout:
        obs_space, action_space = self.observation_space, self.action_space
        if not (
            isinstance(obs_space, spaces.Box) and len(obs_space.shape) == 1 and len(action_space.shape) == 1
        ):
            raise ValueError(
                f"HybridDDPG needs 1-D Box observation and action spaces; got {obs_space} and {action_space}"
            )
        assert self.env is not None
        try:
            hybrid = self.env.get_attr("hybrid_layout", indices=[0])[0]
        except AttributeError:
            hybrid = None
        if hybrid is None:
            metadata = self.env.get_attr("metadata", indices=[0])[0] or {}
            hybrid = metadata.get("hybrid_action")
        return CommLayout(
            n_agents=1,
            obs_dim=obs_space.shape[0],
            action_dim=action_space.shape[0],
            channel_size=0,
            agent_names=("agent",),
            hybrid=HybridActionLayout.from_dict(hybrid),
        )
