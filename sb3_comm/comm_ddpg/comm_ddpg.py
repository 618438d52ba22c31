"""CommDDPG: parameterised-action DDPG for two agents that learn to communicate.

Paper: Hausknecht & Stone, "Grounded Semantic Networks for Learning Shared Communication
Protocols" (NIPS 2016 Deep RL workshop); the agents are the ICLR 2016 agents of
:class:`~sb3_comm.HybridDDPG`, which this class extends. Original code: github.com/mhauskn/dqn-hfo
(branches ``scenario`` and ``dial``), C++/Caffe.

What a team adds to the single agent: a :class:`~sb3_comm.comm_ddpg.buffers.JointReplayBuffer`
that keeps both agents of a game together, the message channel, and the communication method
(``policy`` argument, SPEC §1). Each method is one object,
:class:`~sb3_comm.comm_ddpg.methods.CommMethod`, held by the policy:

* ``"NONE"``: the channel carries zeros (baseline).
* ``"RIAL"``: messages are extra actor outputs trained by the sender's own critic.
* ``"TCG"``: messages are extra actor outputs trained by the *receiver's* critic: the gradient of
  ``Q_receiver(o'_receiver, a'_receiver)`` with respect to the message slot of the receiver's next
  observation replaces the sender's own critic gradient (paper §5), a hook in the actor step of
  :meth:`~sb3_comm.HybridDDPG.train` (:meth:`CommDDPG.actor_output_gradients`).
* ``"GSN"``: messages are the hidden layer of a grounded semantic network trained to predict the
  teammate's reward; :class:`~sb3_comm.comm_ddpg.gsn.GSNTrainingCallback` trains it once per agent
  update (paper §3).
* ``"GSN-MAX"`` (beyond the paper): GSN's messages, whose extractor the same callback moves along
  a normalised mix of the regression's gradient and the receiver critic's (TCG's signal)
  (:class:`~sb3_comm.comm_ddpg.methods.GSNMAX`).
"""

from __future__ import annotations

import warnings
from collections import deque
from typing import Any, ClassVar, TypeVar

import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.noise import ActionNoise
from stable_baselines3.common.policies import BasePolicy
from stable_baselines3.common.type_aliases import GymEnv, MaybeCallback, Schedule
from stable_baselines3.common.utils import LinearSchedule

from sb3_comm.comm_ddpg.buffers import JointReplayBuffer, JointReplayBufferSamples
from sb3_comm.comm_ddpg.gsn import GSNTrainingCallback
from sb3_comm.comm_ddpg.methods import GSNMAX, METHODS, TCG
from sb3_comm.comm_ddpg.policies import (
    CommPolicy,
    GSNMAXPolicy,
    GSNPolicy,
    NonePolicy,
    RIALPolicy,
    TCGPolicy,
)
from sb3_comm.common.layout import CommLayout
from sb3_comm.common.train_log import NOT_SCALAR_FORMATS
from sb3_comm.common.validation import check_hyperparameters
from sb3_comm.hybrid_ddpg.hybrid_ddpg import HybridDDPG

__all__ = [
    "AVERAGED_ACTOR",
    "DEFAULT_ACTOR_LEARNING_RATE",
    "GSN_REWARD_SEES_TEAMMATE",
    "METHODS",
    "OWN_REWARD_METHODS",
    "CommDDPG",
    "HybridDDPG",
]

OWN_REWARD_METHODS = ("TCG",)
"""Methods whose agents learn from their own rewards when ``shared_reward`` is not given (the
others learn from the team's). TCG trains a sender's message by its receiver's critic, ``∂Q_j/∂m_i``
for the message ``m_i`` that the receiver ``j`` hears; with the team's reward that critic's target
also holds the reward caused by ``j``'s own previous message, which is neither in its observation
nor in its action, so it is noise to that critic. On Guess My Number, with the constructor's other
defaults, TCG passed on each of 10 seeds with its own reward (0.92–1.00 of the maximum), against
1 of 5 with the team's (0.23–0.99); on mpe2 simple_reference, where TCG's messages carry nothing
either way, it closed −0.09 of the communication gap against −0.03 (README, "TCG's default reward")."""

GSN_REWARD_SEES_TEAMMATE = True
"""GSN's default of ``policy_kwargs["gsn_reward_sees_teammate"]`` for a new ``CommDDPG("GSN", env)``:
the reward model also sees the teammate's own observation, ``R(M(o_i), a_j, o_j)``. With the
constructor's other defaults it learned more on Blind Soccer (0.79 of the oracle against 0.44, 5
seeds) and on mpe2 simple_reference (0.58 of the communication gap against 0.29) than the paper's
``R(M(o_i), a_j)``, which the packaged configurations pin (README, "Defaults")."""

DEFAULT_ACTOR_LEARNING_RATE = LinearSchedule(1e-4, 0.0, 1.0)
"""``actor_learning_rate`` of a new ``CommDDPG(method, env)``: 1e-4 decaying linearly to 0 over the
``total_timesteps`` of ``learn`` (rl-zoo3's ``lin_1e-4``); the critic's and GSN's rates stay
constant (1e-3). With it the defaults passed 9 of 10 Blind Soccer seeds (GSN, seeds 0–9; 4 of
10 with a constant 1e-4) and 16 of 20 over seeds 0–19, and closed 0.68 of mpe2 simple_reference's
communication gap in 300,000 steps (0.70 with the constant rate; decaying all three rates: 0.57)
(README, "An actor rate that decays as the default")."""

AVERAGED_ACTOR: dict[str, Any] = {"averaged_actor": True, "actor_average_tau": "auto"}
"""What a new ``CommDDPG(method, env)`` plays where ``policy_kwargs`` leaves ``averaged_actor``
unset: a Polyak average of its actor whose rate is set from the budget given to ``learn``, about 10
/ the run's actor updates, so that it spans the last tenth of any run (``actor_average_tau="auto"``,
see :class:`~sb3_comm.hybrid_ddpg.policies.HybridPolicy`). Training is the same bit for bit: only
what plays (``predict``, every evaluation, a saved model) changes. On Blind Soccer the actor's
latest iterate dips for an evaluation or two mid-run, and the average does not follow it: with the
constructor's other defaults 20 of 20 seeds pass the stability bar played by the average, 16 played
by the actor (the 16 seeds the rate was not chosen on: 16 against 15). Guess My Number, 5 of 5 either
way, the average at the bar 50,000–75,000 steps later (125,000 of 300,000); mpe2
simple_reference, 0.68 of the communication gap either way (README, "The actor's average as the
default"). ``policy_kwargs={"averaged_actor": False}`` plays the actor, as the packaged
configurations pin (their results were measured so) and as :class:`HybridDDPG`, the ICLR 2016
agent, does; a model saved before this default plays what it was saved with."""


GSN_MAX_EFFECT_SEARCH: dict[str, Any] = {
    "gsn_max_weight": 0.8,
    "gsn_max_search": 16,
    "gsn_max_explorers": 0.25,
    "gsn_max_explore_messages": False,
}
"""What a new ``CommDDPG("GSN-MAX", env)`` uses where an argument is left at None: its effect
search (``policy_kwargs`` ``gsn_effect_model=True``, also the default for a new GSN-MAX model),
the design of the packaged ``zoo_configs/gsn-max.yml``, which solves Blind Soccer and Guess My
Number with one configuration (README, "Beyond the paper"). With one parallel game there is none to
spare for explorer games: ``gsn_max_explorers`` then defaults to 0, with a warning."""

GSN_MAX_EARLIER = {"gsn_max_weight": 0.5, "gsn_max_explore_messages": True}
"""The same defaults for GSN-MAX's earlier designs (no effect model: the receiver critic's
signal; ``gsn_maximising_head``), and for models saved before the effect search."""


def _method_name(policy: str | type[BasePolicy], policy_kwargs: dict[str, Any] | None) -> str | None:
    """The communication method a constructor call asks for (an alias, a policy class, or
    ``policy_kwargs["method"]``), or None where it cannot be told (an unknown alias: the policy
    lookup raises its own error)."""
    named = policy_kwargs.get("method") if isinstance(policy_kwargs, dict) else None
    if isinstance(named, str):
        return named.upper()
    if isinstance(policy, str):
        return policy.upper()
    method_class = getattr(policy, "method_class", None)
    return getattr(method_class, "name", None)


SelfCommDDPG = TypeVar("SelfCommDDPG", bound="CommDDPG")


class CommDDPG(HybridDDPG):
    """Hybrid-action DDPG (:class:`~sb3_comm.HybridDDPG`) with a learned message channel between two agents.

    :param policy: the communication method, ``"NONE"``, ``"RIAL"``, ``"TCG"``, ``"GSN"`` or
        ``"GSN-MAX"`` (or a :class:`CommPolicy` subclass).
    :param env: a two-agent environment: a registered id (``"BlindSoccer-v0"``,
        ``"GuessMyNumber-v0"``), a :class:`~sb3_comm.wrappers.TwoAgentEnv`, or a VecEnv of them
        (:func:`sb3_comm.make_comm_vec_env` steps many games at once).
    :param learning_rate: critic learning rate: a number, or a schedule of the remaining progress
        (1 -> 0). The default is a constant 1e-3.
    :param actor_learning_rate: actor learning rate or schedule (reference code: 1e-5). The default
        decays linearly from 1e-4 to 0 over the ``total_timesteps`` of ``learn`` (rl-zoo3's
        ``lin_1e-4``), as in the packaged configurations, while the critic's and GSN's rates stay
        constant: the actor settles where the team got, and the critic and the message network
        keep learning (since session 25; a constant 1e-4 before; README, "An actor rate that
        decays as the default"). ``1e-4`` gives the earlier constant rate.
    :param gsn_learning_rate: GSN learning rate or schedule of the remaining progress, e.g.
        ``LinearSchedule(1e-3, 0, 1)`` (paper: a constant 1e-6); GSN-MAX: its grounding step.
    :param gsn_max_weight: GSN-MAX only: the share ``w`` of the maximising signal. Effect search:
        the pull's weight is ``w / (1 − w)`` times the effect models' R²; earlier designs: the share
        of the receiver critic's gradient in the unit-RMS mix (not used by the head design,
        ``policy_kwargs`` ``gsn_maximising_head=True``, whose head is trained at
        ``actor_learning_rate``). None: 0.8 with the effect search, 0.5 otherwise.
    :param gsn_max_signals: GSN-MAX only: ``"both"``, or ``"grounding"`` / ``"maximising"`` alone
        (the method's ablations).
    :param gsn_max_explore_messages: GSN-MAX only: explore messages like actions (with probability
        ε a uniformly random message is sent), so that the receiver's critic sees messages other
        than the current ones; False sends ``M(o)`` always, as GSN. None: False with the effect
        search (its explorer games explore instead), True otherwise.
    :param gsn_max_warmup: GSN-MAX only: the fraction of training over which the maximising share
        rises linearly from 0 to ``gsn_max_weight`` (0: the full share from the start), so that the
        receiver first learns to read grounded messages.
    :param gsn_max_centred: GSN-MAX only: subtract from the maximising signal its mean over the
        batch (per sender and message entry) before the mix, keeping its scale: only the part that
        differs between states moves the messages, so a critic that does not read the messages yet
        (whose gradient pushes every message the same way) adds next to nothing.
    :param gsn_max_gain: GSN-MAX only: None (the default) scales each signal to unit RMS before the
        mix; a number κ > 0 mixes them as they are, ``d = (1 − w)·d_g + w·κ·d_m``, so that a
        maximising signal that is small (a receiver critic that barely depends on the message) stays
        small instead of being scaled up to the grounding's size.
    :param gsn_max_sgd: GSN-MAX only: None (the default) mixes the signals in one Adam step; a number
        c > 0 gives the grounding its own Adam step and the maximising signal a plain gradient step
        of rate ``c`` × the GSN's learning rate, so that its step follows its size (Adam would turn a
        small signal into full-size steps).
    :param gsn_max_search: GSN-MAX only, with ``policy_kwargs`` ``gsn_effect_model=True`` (the
        default for a new GSN-MAX model): a number K searches K candidate messages for one whose
        direct effect on the receiver's reward, by the effect models, beats the sent message's, and
        pulls the message towards it (the *effect search*, :class:`~sb3_comm.comm_ddpg.methods.GSNMAX`);
        0 follows the effect model's gradient instead (tried, not packaged). None: 16.
    :param gsn_max_explorers: GSN-MAX only: the fraction of the parallel games (at least one when
        > 0) whose agents send uniformly random messages, so that the effect models see what a
        message does apart from what it says; their transitions train the effect models only, never
        the agents or the grounding (0: no explorer games). None: 0.25 with the effect models and
        at least two parallel games, else 0.
    :param buffer_size: replay size in joint transitions.
    :param learning_starts: transitions collected with full exploration before learning.
    :param batch_size: joint transitions per update (agents and GSN). The default is 128 (until
        session 23 it was 64, the default of :class:`~sb3_comm.HybridDDPG`): with it the defaults
        learn Blind Soccer further, on the mean and on the worst seed, and simple_reference and
        Guess My Number as well as before, at about 35 % more time per step (README, "Batches of
        128 as the default"). The packaged configurations pin their own.
    :param tau: soft target update rate.
    :param gamma: discount factor. The default is 0.95 (until session 19 it was 0.99, the default
        of SB3 and of :class:`~sb3_comm.HybridDDPG`): with it the defaults learn mpe2
        ``simple_reference`` and Blind Soccer further, in the mean and on the worst seed (README,
        "A discount of 0.95 as the default"). The packaged configurations pin their own.
    :param train_freq: update the model every ``train_freq`` steps.
    :param gradient_steps: updates after each rollout (-1: as many as steps collected).
    :param exploration: ``"epsilon"`` (ICLR 2016: with probability ε an agent takes uniformly
        random action scores and parameters), ``"gaussian"`` (Gaussian noise on every output) or
        ``"epsilon+gaussian"`` (both: ε-random rows, Gaussian noise on the others).
    :param exploration_initial_eps: ε at the start.
    :param exploration_final_eps: ε after annealing.
    :param exploration_fraction: fraction of training over which ε is annealed linearly.
    :param gaussian_noise_std: standard deviation of the Gaussian exploration (scaled units).
    :param mc_mixing: β of the critic target ``y = β·G_t + (1 − β)·(r + γ Q'(s', μ'(s')))``
        (reference code: 0.5, on Blind Soccer what made learning stable, and what its packaged
        configuration uses; default: 0, the TD target: the Monte-Carlo return of an episode cut by
        a time limit is summed as if the episode had ended, which biases the critic on tasks whose
        episodes are mostly truncated, see ``benchmarks/results/simple_reference_beta0.5.md``;
        ``replay_buffer_kwargs={"mc_truncated": "bootstrap"}`` completes it at the cut instead,
        which removes that bias, but β = 0.5 still cost TCG most of Guess My Number, see
        ``benchmarks/results/stability_pilot_defaults_gmn_tcg_beta0.5_bootstrap.md``). A
        callable is a schedule of the remaining progress (1 -> 0), as the learning rates
        (``"lin_0.5"`` in a configuration: β decays linearly to 0).
    :param tcg_gain: scale of the teammate's gradient that trains TCG messages.
    :param relabel_messages: GSN only: replace the heard messages of every replayed transition by
        what the current message network sends for the stored observations (the previous step's
        sender rows for the observation, the transition's own rows for the next observation),
        instead of the messages of the GSN as it was when the transition was stored
        (:class:`~sb3_comm.comm_ddpg.buffers.JointReplayBuffer`).
    :param shared_reward: every agent learns from the team's reward, the mean of the agents'
        rewards (the cooperative objective; MPE's ``shared_reward`` for its collaborative tasks),
        instead of its own reward in ``info["agent_rewards"]`` (False: the paper's setting, what
        the packaged configurations use; on Blind Soccer both agents' rewards are equal anyway).
        None (default): True, except for TCG (:data:`OWN_REWARD_METHODS`), which learns from each
        agent's own reward, and for a model loaded from a file saved before this option existed,
        which keeps learning from its own rewards as it did. On a task whose agents' rewards
        differ, the agent's own reward may hang mostly on what its teammate does
        (simple_reference: ¾ of it), which its movement cannot change, so its critic learns
        from noise: there, with the defaults, GSN closed 0.29 of the communication gap with the
        team's reward and none with its own (``benchmarks/results/simple_reference_shared_reward_300k.md``,
        ``simple_reference_own_reward_300k.md``). TCG's messages follow the receiver's critic,
        whose team reward would include the reward caused by the receiver's own previous
        message, which is not among that critic's inputs (README, "TCG's default reward").
    :param channel_size: expected message size; must match the environment's (None: take it).
    :param share_parameters: one set of networks for both agents (role one-hot in the observation)
        or one per agent, as in the paper.
    :param max_grad_norm: gradient clipping of actor, critic and GSN (reference: 10; None: no clipping).
    :param action_noise: optional SB3 action noise added on top of the exploration.
    :param replay_buffer_kwargs: extra arguments of :class:`JointReplayBuffer`.
    :param policy_delay: actor update every ``policy_delay`` critic updates (1: DDPG).
    :param target_policy_noise: TD3 target smoothing noise (0: DDPG).
    :param target_noise_clip: TD3 clip of that noise.
    :param stats_window_size: episodes averaged in the rollout logs.
    :param tensorboard_log: TensorBoard log folder.
    :param policy_kwargs: extra arguments of the policy (``net_arch``, ``n_critics``, ...). For
        GSN, ``gsn_reward_sees_teammate`` defaults to :data:`GSN_REWARD_SEES_TEAMMATE` (True: the
        reward model also sees the teammate's observation); pass False for the paper's GSN, as the
        packaged configurations do. Where ``averaged_actor`` is not given, the team plays a Polyak
        average of its actor over the last tenth of the run (:data:`AVERAGED_ACTOR`); pass
        ``averaged_actor=False`` to play the actor itself.
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
        "GSN-MAX": GSNMAXPolicy,
    }
    policy: CommPolicy
    replay_buffer: JointReplayBuffer

    def __init__(
        self,
        policy: str | type[CommPolicy],
        env: GymEnv | str,
        learning_rate: float | Schedule = 1e-3,
        actor_learning_rate: float | Schedule = DEFAULT_ACTOR_LEARNING_RATE,
        gsn_learning_rate: float | Schedule = 1e-3,
        gsn_max_weight: float | None = None,
        gsn_max_signals: str = "both",
        gsn_max_explore_messages: bool | None = None,
        gsn_max_warmup: float = 0.0,
        gsn_max_centred: bool = False,
        gsn_max_gain: float | None = None,
        gsn_max_sgd: float | None = None,
        gsn_max_search: int | None = None,
        gsn_max_explorers: float | None = None,
        buffer_size: int = 1_000_000,
        learning_starts: int = 1_000,
        batch_size: int = 128,
        tau: float = 0.005,
        gamma: float = 0.95,
        train_freq: int | tuple[int, str] = 1,
        gradient_steps: int = 1,
        exploration: str = "epsilon",
        exploration_initial_eps: float = 1.0,
        exploration_final_eps: float = 0.1,
        exploration_fraction: float = 0.2,
        gaussian_noise_std: float = 0.1,
        mc_mixing: float | Schedule = 0.0,
        tcg_gain: float = 1.0,
        relabel_messages: bool = False,
        shared_reward: bool | None = None,
        channel_size: int | None = None,
        share_parameters: bool = True,
        max_grad_norm: float | None = 10.0,
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
        check_hyperparameters(
            {
                "gsn_learning_rate": gsn_learning_rate,
                "gsn_max_weight": gsn_max_weight,
                "gsn_max_signals": gsn_max_signals,
                "gsn_max_explore_messages": gsn_max_explore_messages,
                "gsn_max_warmup": gsn_max_warmup,
                "gsn_max_centred": gsn_max_centred,
                "gsn_max_gain": gsn_max_gain,
                "gsn_max_sgd": gsn_max_sgd,
                "gsn_max_search": gsn_max_search,
                "gsn_max_explorers": gsn_max_explorers,
                "tcg_gain": tcg_gain,
                "relabel_messages": relabel_messages,
                "shared_reward": shared_reward,
                "channel_size": channel_size,
                "share_parameters": share_parameters,
            }
        )  # the shared arguments are checked by HybridDDPG
        self.gsn_learning_rate = gsn_learning_rate
        self.gsn_max_weight = gsn_max_weight
        self.gsn_max_signals = gsn_max_signals
        self.gsn_max_explore_messages = gsn_max_explore_messages
        self.gsn_max_warmup = gsn_max_warmup
        self.gsn_max_centred = gsn_max_centred
        self.gsn_max_gain = gsn_max_gain
        self.gsn_max_sgd = gsn_max_sgd
        self.gsn_max_search = gsn_max_search
        self.gsn_max_explorers = gsn_max_explorers
        self._gsn_max_given = {
            name
            for name, value in (
                ("gsn_max_weight", gsn_max_weight),
                ("gsn_max_explore_messages", gsn_max_explore_messages),
                ("gsn_max_search", gsn_max_search),
                ("gsn_max_explorers", gsn_max_explorers),
            )
            if value is not None
        }
        self.tcg_gain = tcg_gain
        self.relabel_messages = relabel_messages
        # SB3's load builds the model with _init_setup_model=False, then sets the saved attributes:
        # a file from before this option has none, and it learned from its own rewards.
        method = _method_name(policy, policy_kwargs)
        if shared_reward is None:  # TCG: each agent's own reward (OWN_REWARD_METHODS)
            shared_reward = _init_setup_model and method not in OWN_REWARD_METHODS
        self.shared_reward = bool(shared_reward)
        self.channel_size = channel_size
        self.share_parameters = share_parameters
        new_gsn = _init_setup_model and method == "GSN"
        if new_gsn and (policy_kwargs is None or isinstance(policy_kwargs, dict)):  # else: refused below
            # a new GSN model: the reward model sees the teammate unless told otherwise (a saved
            # model keeps the policy_kwargs it was saved with, which SB3's load sets after this)
            policy_kwargs = {"gsn_reward_sees_teammate": GSN_REWARD_SEES_TEAMMATE, **(policy_kwargs or {})}
        new_gsn_max = _init_setup_model and method == "GSN-MAX"
        if new_gsn_max and (policy_kwargs is None or isinstance(policy_kwargs, dict)):
            # a new GSN-MAX model: the effect search, unless another design is asked for
            head = bool((policy_kwargs or {}).get("gsn_maximising_head", False))
            policy_kwargs = {"gsn_effect_model": not head, **(policy_kwargs or {})}
        if _init_setup_model and (policy_kwargs is None or isinstance(policy_kwargs, dict)):
            if "averaged_actor" not in (policy_kwargs or {}):
                # a new team plays its actor's average over the run's last tenth (a saved model
                # keeps the policy_kwargs it was saved with: one saved before this default plays
                # what it played then)
                policy_kwargs = {**AVERAGED_ACTOR, **(policy_kwargs or {})}
        self.gsn_callback: GSNTrainingCallback | None = None
        self._in_learn = False
        self._drawn_batches: deque[JointReplayBufferSamples] | None = None
        super().__init__(
            policy,
            env,
            learning_rate=learning_rate,
            actor_learning_rate=actor_learning_rate,
            buffer_size=buffer_size,
            learning_starts=learning_starts,
            batch_size=batch_size,
            tau=tau,
            gamma=gamma,
            train_freq=train_freq,
            gradient_steps=gradient_steps,
            exploration=exploration,
            exploration_initial_eps=exploration_initial_eps,
            exploration_final_eps=exploration_final_eps,
            exploration_fraction=exploration_fraction,
            gaussian_noise_std=gaussian_noise_std,
            mc_mixing=mc_mixing,
            max_grad_norm=max_grad_norm,
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
            _init_setup_model=_init_setup_model,
        )

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
                raise ValueError(
                    "CommDDPG found no team layout ('comm_layout') in the saved settings: the file was not "
                    "saved by sb3_comm.CommDDPG (a one-agent HybridDDPG or another algorithm's model?)"
                )
            return saved
        try:
            layouts = self.env.get_attr("comm_layout")
        except AttributeError:
            raise ValueError(
                "CommDDPG needs a two-agent environment with a message channel: a registered id "
                "('BlindSoccer-v0', 'GuessMyNumber-v0'), sb3_comm.wrappers.TwoAgentEnv(parallel_env) or "
                f"sb3_comm.make_comm_vec_env(...); got an environment with observation space "
                f"{self.observation_space} and no 'comm_layout' (one agent: sb3_comm.HybridDDPG)"
            ) from None
        layout = layouts[0]
        mixed = [i for i, other in enumerate(layouts) if other != layout]
        if mixed:
            raise ValueError(
                f"The VecEnv mixes tasks: its environments {mixed} have another layout than environment 0 "
                f"(agents {list(layouts[mixed[0]].agent_names)} vs {list(layout.agent_names)}); "
                "one CommDDPG trains on one task"
            )
        if saved is not None and saved != layout:
            raise ValueError(f"The environment's layout {layout} differs from the model's {saved}")
        return layout

    def _environment_policy_kwargs(self) -> dict[str, Any]:
        """What the policy learns from the environment: the team's :class:`CommLayout`."""
        layout = self._read_layout()
        if layout.n_agents != 2:
            raise ValueError(f"CommDDPG accepts environments with 2 agents; this one has {layout.n_agents}")
        if self.channel_size is not None and self.channel_size != layout.channel_size:
            raise ValueError(
                f"channel_size={self.channel_size} does not match the environment's message channel of "
                f"size {layout.channel_size}; pass channel_size={layout.channel_size} or None"
            )
        self.comm_layout = layout
        self.replay_buffer_kwargs = {
            **self.replay_buffer_kwargs,
            "n_agents": layout.n_agents,
            "shared_reward": self.shared_reward,
        }
        explorers = self.explorer_envs
        if explorers and explorers >= self.n_envs:
            raise ValueError(
                f"gsn_max_explorers={self.gsn_max_explorers!r} of {self.n_envs} parallel game(s) leaves "
                "none to the agents: use more games (n_envs) or a smaller fraction"
            )
        if explorers:
            self.replay_buffer_kwargs["explorer_envs"] = explorers
        return {"comm_layout": layout, "share_parameters": self.share_parameters}

    @property
    def explorer_envs(self) -> int:
        """GSN-MAX's explorer games: how many of the parallel games (the last ones) send random
        messages for the effect model (``gsn_max_explorers`` of ``n_envs``, at least one when > 0)."""
        fraction = getattr(self, "gsn_max_explorers", 0.0)  # models saved before the option
        if not fraction:
            return 0
        return max(1, round(fraction * self.n_envs))

    def _sample_action(
        self, learning_starts: int, action_noise: ActionNoise | None = None, n_envs: int = 1
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`HybridDDPG._sample_action <sb3_comm.HybridDDPG._sample_action>`; in GSN-MAX's
        explorer games every agent sends a uniformly random message."""
        action, buffer_action = super()._sample_action(learning_starts, action_noise, n_envs)
        explorers = self.explorer_envs
        if not explorers:
            return action, buffer_action
        layout = self.comm_layout
        rows = buffer_action.reshape(n_envs, layout.n_agents, layout.action_dim).copy()
        shape = (explorers, layout.n_agents, layout.channel_size)
        rows[n_envs - explorers :, :, layout.action_message_slice] = np.random.uniform(-1.0, 1.0, size=shape)
        buffer_action = rows.reshape(buffer_action.shape)
        return self.policy.unscale_action(buffer_action), buffer_action

    def _explorable_entries(self) -> np.ndarray:
        """The environment action, and the message where it is an action (RIAL, TCG) or explored
        (GSN-MAX)."""
        explorable = np.ones(self.comm_layout.action_dim, dtype=bool)
        method = self.policy.comm_method
        explored = method.comm_actions or (method.explore_messages and self.gsn_max_explore_messages)
        if not explored:
            explorable[self.comm_layout.action_message_slice] = False
        return explorable

    def _resolve_gsn_max_defaults(self) -> None:
        """Give the GSN-MAX settings left at None their values: the effect search's
        (:data:`GSN_MAX_EFFECT_SEARCH`) where the policy has effect models, the earlier designs'
        (:data:`GSN_MAX_EARLIER`; no search, no explorer games) otherwise, as for every other method
        and for models saved before the effect search."""
        kwargs = self.policy_kwargs if isinstance(self.policy_kwargs, dict) else {}
        method = _method_name(self.policy_class, kwargs)
        effect = method == "GSN-MAX" and bool(kwargs.get("gsn_effect_model", False))
        defaults = (
            GSN_MAX_EFFECT_SEARCH
            if effect
            else {**GSN_MAX_EARLIER, "gsn_max_search": None, "gsn_max_explorers": 0.0}
        )
        for name, value in defaults.items():
            if getattr(self, name, None) is None:
                setattr(self, name, value)
        if effect and self.gsn_max_explorers and self.n_envs < 2:
            if "gsn_max_explorers" in self._gsn_max_given:
                return  # refused with the reason in _environment_policy_kwargs
            warnings.warn(
                "GSN-MAX trains on one parallel game: none is left to spare for the explorer games that "
                "show its effect models what a message does apart from what it says (gsn_max_explorers), "
                "so they learn from the agents' own games. Use n_envs >= 2 (the packaged configuration "
                "uses 16, 4 of them explorers), or set gsn_max_explorers=0 to silence this.",
                stacklevel=5,
            )
            self.gsn_max_explorers = 0.0

    def _setup_model(self) -> None:
        self._resolve_gsn_max_defaults()
        super()._setup_model()
        if not isinstance(self.policy.comm_method, GSNMAX):
            if self.gsn_max_signals != "both":
                raise ValueError(
                    f"gsn_max_signals applies to GSN-MAX only (it switches one of its two signals off); "
                    f"method {self.method} got gsn_max_signals={self.gsn_max_signals!r}: leave it at 'both'"
                )
            # (option, its value when off, how that value is written); getattr: models saved before an option
            for name, off, shown in (
                ("gsn_max_explore_messages", True, "True"),
                ("gsn_max_warmup", 0.0, "0"),
                ("gsn_max_sgd", None, "None"),
                ("gsn_max_gain", None, "None"),
                ("gsn_max_centred", False, "False"),
                ("gsn_max_search", None, "None"),
                ("gsn_max_explorers", 0.0, "0"),
            ):
                value = getattr(self, name, off)
                if (value is not off) if isinstance(off, bool) or off is None else (value != off):
                    raise ValueError(
                        f"{name} applies to GSN-MAX only; method {self.method} got {name}={value!r}: "
                        f"leave it at {shown}"
                    )
        self.gsn = self.policy.gsn
        if self.gsn is not None and self.gsn.maximising_head is not None and self.gsn_max_weight != 0.5:
            raise ValueError(
                f"gsn_max_weight mixes the two signals of GSN-MAX's one-extractor design; with "
                f"policy_kwargs gsn_maximising_head=True each signal trains its own network, so there is "
                f"nothing to weigh: leave gsn_max_weight at 0.5 (got {self.gsn_max_weight!r})"
            )
        head = self.gsn is not None and self.gsn.maximising_head is not None
        sgd = getattr(self, "gsn_max_sgd", None)
        gain = getattr(self, "gsn_max_gain", None)
        if sgd is not None and (gain is not None or self.gsn_max_signals != "both"):
            raise ValueError(
                "gsn_max_sgd steps the two signals apart (Adam for the grounding, a plain gradient step for "
                "the maximising signal): it takes both signals (gsn_max_signals='both') and no "
                f"gsn_max_gain (got gsn_max_signals={self.gsn_max_signals!r}, "
                f"gsn_max_gain={gain!r})"
            )
        if head and (getattr(self, "gsn_max_centred", False) or gain is not None or sgd is not None):
            raise ValueError(
                "gsn_max_centred, gsn_max_gain and gsn_max_sgd shape the maximising signal of GSN-MAX's "
                "one-extractor mix; with policy_kwargs gsn_maximising_head=True the head is trained by the "
                "signal alone: leave them at False, None and None"
            )
        search = getattr(self, "gsn_max_search", None)
        effect = self.gsn is not None and self.gsn.effect_model is not None
        if search and not effect:
            raise ValueError(
                f"gsn_max_search={search!r} searches messages by GSN-MAX's effect model: it needs "
                "policy_kwargs gsn_effect_model=True"
            )
        if search is not None and (
            getattr(self, "gsn_max_centred", False) or gain is not None or sgd is not None
        ):
            raise ValueError(
                "gsn_max_search pulls messages towards the effect model's best candidate: it takes no "
                "gsn_max_centred, gsn_max_gain or gsn_max_sgd (leave them at False, None and None)"
            )
        if self.explorer_envs and not effect:
            raise ValueError(
                f"gsn_max_explorers={self.gsn_max_explorers!r}: explorer games feed GSN-MAX's effect model; "
                "set policy_kwargs gsn_effect_model=True (or leave gsn_max_explorers at 0)"
            )
        self._attach_relabeler()
        self._agent_returns: deque[np.ndarray] = deque(maxlen=self._stats_window_size)

    def _attach_relabeler(self) -> None:
        """Give the replay buffer :meth:`relabel_heard_messages` where ``relabel_messages`` asks."""
        if not self.relabel_messages:
            return
        explored = self._explorable[self.comm_layout.action_message_slice].any()
        if self.gsn is None or explored:
            raise ValueError(
                f"relabel_messages=True needs messages that are a function of the sender's observation, "
                f"m = M(o) (method GSN, or GSN-MAX with gsn_max_explore_messages=False); method "
                f"{self.method} {'explores its messages' if explored else 'has no message network'}"
            )
        self.replay_buffer.message_relabeler = self.relabel_heard_messages

    def relabel_heard_messages(
        self, obs: th.Tensor, next_obs: th.Tensor, previous: th.Tensor, has_previous: th.Tensor
    ) -> tuple[th.Tensor, th.Tensor]:
        """The heard messages of replayed transitions, as the current GSN would send them.

        The message heard at step ``t`` was sent at ``t − 1``: ``M(o_{t−1}^{teammate})``, from the
        previous step's rows (kept as stored where the transition begins an episode: the zeros of a
        reset). The message heard at ``t + 1`` is ``M(o_t^{teammate})`` of the relabelled rows.
        Messages are clipped to the channel's [-1, 1].

        :param obs: ``(B, 2, obs_dim)`` observations.
        :param next_obs: ``(B, 2, obs_dim)`` next observations.
        :param previous: ``(B, 2, obs_dim)`` observations of the previous step of the same game.
        :param has_previous: ``(B,)`` 1 where ``previous`` is valid.
        :return: ``obs`` and ``next_obs`` with their heard messages replaced (new tensors).
        """
        assert self.gsn is not None
        heard = self.comm_layout.obs_message_slice
        with th.no_grad():
            # Row i hears its teammate's message: flip the agent axis (two agents).
            sent_before = self.gsn.message(previous).clamp(-1.0, 1.0).flip(1)
            obs = obs.clone()
            keep = has_previous.view(-1, 1, 1) > 0
            obs[..., heard] = th.where(keep, sent_before, obs[..., heard])
            next_obs = next_obs.clone()
            next_obs[..., heard] = self.gsn.message(obs).clamp(-1.0, 1.0).flip(1)
        return obs, next_obs

    def load_replay_buffer(self, path: Any, truncate_last_traj: bool = True) -> None:
        """:meth:`HybridDDPG.load_replay_buffer <sb3_comm.HybridDDPG.load_replay_buffer>`, with the
        message relabelling attached again (it is not saved with the buffer)."""
        super().load_replay_buffer(path, truncate_last_traj)
        self.replay_buffer.shared_reward = self.shared_reward  # the model's setting, not the file's
        self._attach_relabeler()

    @property
    def method(self) -> str:
        """The communication method: ``"NONE"``, ``"RIAL"``, ``"TCG"``, ``"GSN"`` or ``"GSN-MAX"``."""
        return self.policy.comm_method.name

    def _init_callback(self, callback: MaybeCallback, progress_bar: bool = False) -> BaseCallback:
        callback = super()._init_callback(callback, progress_bar)
        if self.gsn_callback is not None:  # the last learn call's (its worker, if train() started one)
            self.gsn_callback.close()
        self.gsn_callback = None
        if self.gsn is not None:
            self.gsn_callback = GSNTrainingCallback(
                self.gsn_learning_rate,
                self.batch_size,
                self.max_grad_norm,
                max_weight=self.gsn_max_weight,
                max_warmup=getattr(self, "gsn_max_warmup", 0.0),  # models saved before the option
                signals=self.gsn_max_signals,
                centred=getattr(self, "gsn_max_centred", False),  # models saved before the option
                gain=getattr(self, "gsn_max_gain", None),
                sgd=getattr(self, "gsn_max_sgd", None),
                head_learning_rate=self.actor_learning_rate,
                search=getattr(self, "gsn_max_search", None) or None,  # 0: the effect gradient
            )
            callback = CallbackList([self.gsn_callback, callback])
            callback.init_callback(self)
        return callback

    # ------------------------------------------------------------------------------ train --
    def train(self, gradient_steps: int, batch_size: int = 100) -> None:
        """The agents' updates (:meth:`HybridDDPG.train <sb3_comm.HybridDDPG.train>`); inside
        ``learn``, the GSN's matching updates too, beside them where a core is spare
        (:meth:`GSNTrainingCallback.begin_updates`)."""
        callback = self.gsn_callback if self._in_learn else None
        if callback is None or gradient_steps <= 0:
            super().train(gradient_steps, batch_size)
            return
        # The agents' batches are drawn first, then the GSN's: the order of the random draws of a
        # GSN that trains after the agents, whether it now trains beside them or after them.
        self._drawn_batches = deque(self.replay_buffer.sample(batch_size) for _ in range(gradient_steps))
        callback.begin_updates(gradient_steps)
        try:
            super().train(gradient_steps, batch_size)
        finally:
            self._drawn_batches = None
            callback.end_updates()

    def _next_batch(self, batch_size: int) -> JointReplayBufferSamples:
        """A batch drawn before the GSN's (:meth:`train`), or a fresh sample."""
        if self._drawn_batches:
            return self._drawn_batches.popleft()
        return super()._next_batch(batch_size)

    def actor_output_gradients(
        self, obs: th.Tensor, out: th.Tensor, next_obs: th.Tensor, dones: th.Tensor
    ) -> tuple[th.Tensor, th.Tensor]:
        """Ascent direction for every actor output, and the own critic's Q.

        The environment-action part is ``dQ_own/da`` at the actor's current action. The message
        part is what the method says (:meth:`CommMethod.actor_gradient`): ``dQ_own/dm`` for RIAL,
        the receiver's gradient (:meth:`teammate_message_gradients`) for TCG, and absent for GSN and
        NONE (no message outputs). Bounded hybrid outputs then pass through inverting gradients.

        :param obs: ``(B, n_agents, obs_dim)``.
        :param out: ``(B, n_agents, actor_out_dim)`` bounded actor outputs (detached).
        :param next_obs: ``(B, n_agents, obs_dim)``.
        :param dones: ``(B, 1)`` terminal flags.
        :return: ``grad`` shaped like ``out`` and ``own_q`` ``(B, n_agents)``.
        """
        grad, own_q = self.policy.comm_method.actor_gradients(
            self.policy, obs, out, next_obs, dones, self.tcg_gain
        )
        return self.invert_bounded_gradients(grad, out), own_q

    def teammate_message_gradients(self, out: th.Tensor, next_obs: th.Tensor, dones: th.Tensor) -> th.Tensor:
        """TCG (paper §5): each sender's message gradient from its receiver's critic.

        See :meth:`~sb3_comm.comm_ddpg.methods.TCG.teammate_message_gradients`; scaled by ``tcg_gain``.

        :param out: ``(B, 2, actor_out_dim)`` bounded actor outputs (their last ``n`` are messages).
        :param next_obs: ``(B, 2, obs_dim)`` next observations.
        :param dones: ``(B, 1)`` terminal flags.
        :return: ``(B, 2, n)`` gradient for each sender's message outputs.
        """
        return TCG.teammate_message_gradients(self.policy, out, next_obs, dones, self.tcg_gain)

    def _actor_step_stats(
        self, data: JointReplayBufferSamples, out: th.Tensor, grad: th.Tensor
    ) -> dict[str, th.Tensor]:
        """Messages sent (mean, std) and, for TCG, the size of the receiver's gradient."""
        policy, layout = self.policy, self.comm_layout
        stats: dict[str, th.Tensor] = {}
        if layout.channel_size:
            # The messages sent: actor outputs (RIAL, TCG) or what the GSN sent when acting.
            sent = data.actions[..., layout.action_message_slice]
            if policy.comm_method.comm_actions:
                sent = out[..., policy.env_action_dim :]
            messages = sent.detach()
            stats["comm/message_mean"] = messages.mean()
            stats["comm/message_std"] = messages.std()
        if isinstance(policy.comm_method, TCG):
            stats["tcg/grad_norm"] = grad[..., policy.env_action_dim :].norm(dim=-1).mean()
        return stats

    # ---------------------------------------------------------------------------- logging --
    def _update_info_buffer(self, infos: list[dict[str, Any]], dones: np.ndarray | None = None) -> None:
        super()._update_info_buffer(infos, dones)
        for info in infos:
            returns = info.get("agent_returns")
            if returns is not None:
                self._agent_returns.append(np.asarray(returns))

    MESSAGE_HISTOGRAM_ROWS = 4096
    """Most recent transitions whose messages make the histograms of a logged point."""

    def _record_training_point(self) -> None:
        """The training means, each agent's mean episode return, and histograms of the messages
        sent (``messages/<agent>/<entry>``, from the most recent transitions in the replay)."""
        super()._record_training_point()
        if self._agent_returns:
            means = np.mean(np.stack(self._agent_returns), axis=0)
            for name, value in zip(self.comm_layout.agent_names, means, strict=False):
                self.logger.record(f"rollout/ep_return_{name}", float(value))
        sent = self._recent_messages()
        if sent is not None:
            for a, name in enumerate(self.comm_layout.agent_names):
                for i in range(sent.shape[-1]):
                    self.logger.record(f"messages/{name}/{i}", sent[:, a, i], exclude=NOT_SCALAR_FORMATS)

    def _recent_messages(self) -> np.ndarray | None:
        """``(n, n_agents, channel_size)`` messages of the most recent transitions, or None."""
        buffer, layout = self.replay_buffer, self.comm_layout
        if buffer is None or not layout.channel_size or (buffer.pos == 0 and not buffer.full):
            return None
        rows = max(1, self.MESSAGE_HISTOGRAM_ROWS // buffer.n_envs)
        end = buffer.pos if buffer.pos > 0 else buffer.buffer_size
        actions = buffer.actions[max(0, end - rows) : end]
        actions = actions.reshape(-1, layout.n_agents, layout.action_dim)
        return actions[..., layout.action_message_slice]

    # ---------------------------------------------------------------------- save / load --
    def _excluded_save_params(self) -> list[str]:
        excluded = [
            "gsn",
            "gsn_callback",
            "comm_layout",
            "_agent_returns",
            "_in_learn",
            "_drawn_batches",
            "_gsn_max_given",
        ]
        return [*super()._excluded_save_params(), *excluded]

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        state_dicts, variables = super()._get_torch_save_params()
        if self.policy.gsn is not None:
            state_dicts = [*state_dicts, "policy.gsn.optimizer"]
            if self.policy.gsn.head_optimizer is not None:
                state_dicts = [*state_dicts, "policy.gsn.head_optimizer"]
        return state_dicts, variables

    def learn(
        self: SelfCommDDPG,
        total_timesteps: int,
        callback: MaybeCallback = None,
        log_interval: int | None = None,
        tb_log_name: str = "CommDDPG",
        reset_num_timesteps: bool = True,
        progress_bar: bool = False,
    ) -> SelfCommDDPG:
        """Train for ``total_timesteps`` environment steps (games × steps), as in SB3."""
        self._in_learn = True
        try:
            return super().learn(
                total_timesteps=total_timesteps,
                callback=callback,
                log_interval=log_interval,
                tb_log_name=tb_log_name,
                reset_num_timesteps=reset_num_timesteps,
                progress_bar=progress_bar,
            )
        finally:
            self._in_learn = False
            if self.gsn_callback is not None:  # its worker process, if any, ends with learn
                self.gsn_callback.close()
