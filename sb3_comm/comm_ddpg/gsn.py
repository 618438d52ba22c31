"""The Grounded Semantic Network (paper §3) and the callback that trains it.

A GSN predicts the teammate's one-step reward from the agent's own observation and the teammate's
action, ``r̂ = R(M(o_sender; θm), a_teammate; θr)`` (eq. 1); the hidden layer ``m = M(o_sender)``
is the message. It is trained by regression on joint replay tuples
``(o_sender, a_teammate, r_teammate)`` (eq. 2), one update per agent update, with Adam and a small
learning rate (the paper used 1e-6).

Design: the GSN is trained apart from the agents, by :class:`GSNTrainingCallback` (SB3's order of
extension: a callback before a new algorithm). The callback owns the GSN's update and learning-rate
schedule; the algorithm only builds the network (through the GSN method object), adds the
callback, and, inside ``learn``, tells it when an agent update begins and ends
(:meth:`GSNTrainingCallback.begin_updates`, :meth:`~GSNTrainingCallback.end_updates`).

Speed: a GSN update reads only the GSN and its own batch, and an agent update never reads the GSN,
so on a machine with a core to spare the GSN's updates run in a second process *beside* the agents'
updates of the same ``train`` call (:class:`~sb3_comm.comm_ddpg.gsn_worker.GSNWorker`; a thread
gained nothing: two threads of small torch operations mostly wait for each other's GIL). Every
batch is drawn first, in the trainer, the agents' and then the GSN's, in the order in which the GSN
trained after the agents before: a run is the same, to the bit, with the worker or without it.
GSN-MAX's update reads the agents' critic, so it runs after theirs, in the trainer.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any, NamedTuple

import torch as th
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.type_aliases import Schedule
from stable_baselines3.common.utils import FloatSchedule
from torch import nn
from torch.nn import functional as F

from sb3_comm.comm_ddpg.gsn_worker import GSN_BATCH_FIELDS, GSNWorker, can_fork, optimizer_state_complete
from sb3_comm.common.networks import MLP, AgentMLPs, adam_step, clip_gradients, gradient_step

__all__ = ["BESIDE_AGENTS", "GSNTrainingCallback", "GroundedSemanticNetwork", "spare_core"]

BESIDE_AGENTS = True
"""Let GSN updates run in a second process beside the agents' updates where a core is spare
(:func:`spare_core`). The experiment runner turns it off in processes that share the cores with
other runs."""


def spare_core() -> bool:
    """Whether this process may use a core that torch's intra-op threads leave free."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    return cores > th.get_num_threads()


class GroundedSemanticNetwork(nn.Module):
    """Message extractor ``M`` and teammate reward model ``R`` for every agent.

    :param n_agents: number of agents (2).
    :param obs_dim: length of a sender's observation row.
    :param teammate_action_dim: length of the teammate's action fed to ``R`` (its own action,
        without its message).
    :param channel_size: message size ``n``.
    :param message_net_arch: hidden widths of ``M``.
    :param reward_net_arch: hidden widths of ``R``.
    :param activation_fn: hidden activation class.
    :param share_parameters: one GSN for both agents (role one-hot tells them apart) or one each.
    :param message_activation: ``"tanh"`` bounds messages to [-1, 1] inside the network;
        ``"linear"`` leaves them raw (the channel clips them), as the authors' "NoTanh" runs.
    :param heard_dim: 0 (GSN, the paper), or the message size ``n``: ``R`` also sees the message the
        teammate heard at that step (the sender's previous message, the last ``n`` entries of the
        teammate's observation row), so that a reward the sender's own earlier message caused is
        explained by that input and not asked of the new message (GSN-MAX's option
        ``gsn_reward_hears``).
    :param teammate_obs_dim: 0 (GSN, the paper), or the length of an observation row without its
        received message: ``R`` also sees the teammate's own observation (``R(M(o_i), a_j, o_j)``,
        without the message ``o_j`` heard), so that the message need only carry what the teammate
        lacks to explain its reward (option ``gsn_reward_sees_teammate``). ``R`` is used in training
        only; a message still depends on the sender's observation alone.
    :param maximising_head: GSN-MAX's head design: a second network ``H`` of the sender's
        observation (the shape of ``M``, its output layer zero, so that training starts as GSN) whose
        output is added to the grounded message, ``m = M(o) + H(o)``. ``M`` and ``R`` are trained by
        the regression alone, on ``M(o)``; ``H`` by the receiver critic's gradient alone, with its own
        optimizer (:attr:`head_optimizer`).
    :param effect_obs_dim: 0 (no effect model), or the length of an observation row without its
        received message: GSN-MAX's *effect model* ``E(o_j, o_i, m, a_j)``, a centralised one-step
        model of an agent's own reward from both agents' situations (without the messages heard),
        the message it heard and its own action (option ``gsn_effect_model``; see
        :class:`~sb3_comm.comm_ddpg.methods.GSNMAX`). Trained by regression beside ``R``; it only
        gives GSN-MAX's maximising signal and never shapes a message directly.
    :param normalize_rewards: regress on teammate rewards standardised by their running mean and
        standard deviation. Soccer rewards are tiny (a variance of about 1e-5 on Blind Soccer), and
        without this the regression barely moves from its initial guess, so the messages carry no
        information; the paper's loss is recovered with ``False``.
    """

    def __init__(
        self,
        n_agents: int,
        obs_dim: int,
        teammate_action_dim: int,
        channel_size: int,
        message_net_arch: list[int],
        reward_net_arch: list[int],
        activation_fn: type[nn.Module],
        share_parameters: bool = True,
        message_activation: str = "tanh",
        normalize_rewards: bool = True,
        heard_dim: int = 0,
        maximising_head: bool = False,
        teammate_obs_dim: int = 0,
        effect_obs_dim: int = 0,
    ) -> None:
        super().__init__()
        self.heard_dim = heard_dim
        self.teammate_obs_dim = teammate_obs_dim
        if message_activation not in ("tanh", "linear"):
            raise ValueError(f"message_activation must be 'tanh' or 'linear', got {message_activation!r}")
        self.teammate_action_dim = teammate_action_dim
        self.message_activation = message_activation
        self.normalize_rewards = normalize_rewards
        # Running moments of the teammate reward (saved with the model).
        self.register_buffer("reward_mean", th.zeros(()))
        self.register_buffer("reward_var", th.ones(()))
        self.register_buffer("reward_count", th.zeros(()))
        self.optimizer: th.optim.Optimizer | None = None
        """Optimizer of ``M`` and ``R`` (set by the policy)."""
        self.head_optimizer: th.optim.Optimizer | None = None
        """Optimizer of the maximising head ``H``, if any (set by the policy)."""
        self.message_extractor = AgentMLPs(
            n_agents, obs_dim, channel_size, message_net_arch, activation_fn, share_parameters
        )
        self.reward_model = AgentMLPs(
            n_agents,
            channel_size + teammate_action_dim + heard_dim + teammate_obs_dim,
            1,
            reward_net_arch,
            activation_fn,
            share_parameters,
        )
        self.maximising_head: AgentMLPs | None = None
        """GSN-MAX's ``H`` (``maximising_head=True``), or None."""
        self.effect_obs_dim = effect_obs_dim
        self.effect_model: nn.ModuleList | None = None
        """GSN-MAX's effect models ``E_1``, ``E_2`` (``effect_obs_dim`` > 0), or None."""
        if effect_obs_dim:
            # how much of the reward the effect model explains (an average over updates, R²)
            self.register_buffer("effect_r2", th.zeros(()))
            # running moments of the rewards the effect model learns (its own data: explorer games)
            self.register_buffer("effect_reward_mean", th.zeros(()))
            self.register_buffer("effect_reward_var", th.ones(()))
            self.register_buffer("effect_reward_count", th.zeros(()))
            # two models of the same data, initialised apart: one picks a candidate, the other
            # judges it (as double Q-learning), so that one model's error is not mistaken for an effect
            self.effect_model = nn.ModuleList(
                AgentMLPs(
                    n_agents,
                    2 * effect_obs_dim + channel_size + teammate_action_dim,
                    1,
                    reward_net_arch,
                    activation_fn,
                    share_parameters,
                )
                for _ in range(2)
            )
        if maximising_head:
            self.maximising_head = AgentMLPs(
                n_agents, obs_dim, channel_size, message_net_arch, activation_fn, share_parameters
            )
            with th.no_grad():
                for net in self.maximising_head.nets:
                    last = [layer for layer in net.modules() if isinstance(layer, nn.Linear)][-1]
                    nn.init.zeros_(last.weight)
                    nn.init.zeros_(last.bias)

    def grounded_message(self, obs: th.Tensor) -> th.Tensor:
        """``M(o_sender)``, the hidden layer of the reward prediction (paper eq. 1), for every row."""
        raw = self.message_extractor(obs)
        return th.tanh(raw) if self.message_activation == "tanh" else raw

    def message(self, obs: th.Tensor) -> th.Tensor:
        """The message sent for every agent row, ``(B, n_agents, obs_dim) -> (B, n_agents, n)``:
        ``M(o_sender)``, plus ``H(o_sender)`` where there is a maximising head."""
        grounded = self.grounded_message(obs)
        if self.maximising_head is None:
            return grounded
        return grounded + self.maximising_head(obs)

    def grounding_parameters(self) -> list[nn.Parameter]:
        """The parameters the regression trains: ``M``'s and ``R``'s (not the head's)."""
        return [*self.message_extractor.parameters(), *self.reward_model.parameters()]

    def _raw_prediction(
        self, obs: th.Tensor, teammate_actions: th.Tensor, messages: th.Tensor | None = None
    ) -> th.Tensor:
        messages = self.grounded_message(obs) if messages is None else messages
        parts = [messages, teammate_actions[..., : self.teammate_action_dim]]
        if self.heard_dim:  # what each row's teammate heard: the end of the teammate's row
            parts.append(obs.flip(-2)[..., -self.heard_dim :])
        if self.teammate_obs_dim:  # the teammate's own observation, without what it heard
            parts.append(obs.flip(-2)[..., : self.teammate_obs_dim])
        features = th.cat(parts, dim=-1)
        return self.reward_model(features).squeeze(-1)

    def effect(self, situation: th.Tensor, heard: th.Tensor, actions: th.Tensor, which: int = 0) -> th.Tensor:
        """``E(o_j, o_i, m_j, a_j)``, each agent's own one-step reward by effect model ``which``
        (standardised by the effect models' running reward moments), ``(B, n_agents)``.

        :param situation: ``(B, n_agents, effect_obs_dim)`` each row's observation without the
            message it heard (row ``i``'s teammate is the other row).
        :param heard: ``(B, n_agents, n)`` the message each row heard.
        :param actions: ``(B, n_agents, ≥ teammate_action_dim)`` each row's own action (the
            environment action comes first; the rest is ignored).
        :param which: 0 or 1, the effect model.
        """
        assert self.effect_model is not None
        features = th.cat(
            [situation, situation.flip(-2), heard, actions[..., : self.teammate_action_dim]], dim=-1
        )
        return self.effect_model[which](features).squeeze(-1)

    def effect_candidates(
        self, situation: th.Tensor, heard: th.Tensor, actions: th.Tensor, which: int = 0
    ) -> th.Tensor:
        """:meth:`effect` for ``C`` heard messages in the same situations, ``(C, B, n_agents)``:
        ``heard`` ``(C, B, n_agents, n)``, ``situation`` and ``actions`` as in :meth:`effect`, held
        for every candidate. The same values to float rounding, but the first layer's product on
        the situations and actions is made once, not once per candidate
        (:meth:`~sb3_comm.common.networks.MLP.forward_candidates`).
        """
        assert self.effect_model is not None
        model = self.effect_model[which]
        if not (isinstance(model, AgentMLPs) and all(isinstance(net, MLP) for net in model.nets)):
            # another network (a stand-in): every candidate's input assembled
            count, batch = heard.shape[:2]
            rows = count * batch
            values = self.effect(
                situation.expand(count, *situation.shape).reshape(rows, *situation.shape[1:]),
                heard.reshape(rows, *heard.shape[2:]),
                actions.expand(count, *actions.shape).reshape(rows, *actions.shape[1:]),
                which,
            )
            return values.reshape(count, batch, -1)
        fixed = th.cat([situation, situation.flip(-2), actions[..., : self.teammate_action_dim]], dim=-1)
        start = 2 * situation.shape[-1]
        columns = slice(start, start + heard.shape[-1])
        if model.share_parameters:
            return model.nets[0].forward_candidates(fixed, heard, columns).squeeze(-1)
        return th.stack(
            [
                net.forward_candidates(fixed[:, i], heard[:, :, i], columns).squeeze(-1)
                for i, net in enumerate(model.nets)
            ],
            dim=2,
        )

    def effect_loss(self, obs: th.Tensor, actions: th.Tensor, rewards: th.Tensor) -> th.Tensor:
        """The effect models' regression on replayed transitions (the mean of their two losses):
        each row's own reward from both rows' situations, the message the row heard and its action
        (standardised by :meth:`effect_target`).

        :param obs: ``(B, 2, obs_dim)`` observations (the heard message is their last ``n`` entries).
        :param actions: ``(B, 2, action_dim)`` actions.
        :param rewards: ``(B, 2)`` rewards.
        """
        return self.effect_regression(obs, actions, self.effect_target(rewards))

    def effect_regression(self, obs: th.Tensor, actions: th.Tensor, target: th.Tensor) -> th.Tensor:
        """:meth:`effect_loss` against a target already made by :meth:`effect_target` ``(B, 2)``."""
        start = self.effect_obs_dim
        situation, heard = obs[..., :start], obs[..., start:]
        return sum(F.mse_loss(self.effect(situation, heard, actions, k), target) for k in range(2)) / 2.0

    def effect_target(self, rewards: th.Tensor) -> th.Tensor:
        """The effect model's regression target: ``rewards`` standardised by the running moments of
        the rewards it learns from (updated first, in training mode), where ``normalize_rewards``."""
        if not self.normalize_rewards:
            return rewards
        if self.training:
            with th.no_grad():
                _merge_moments(
                    self.effect_reward_mean, self.effect_reward_var, self.effect_reward_count, rewards
                )
        return (rewards - self.effect_reward_mean) / self.effect_reward_var.sqrt().clamp_min(1e-8)

    @property
    def reward_std(self) -> th.Tensor:
        """Running standard deviation of the teammate reward."""
        return self.reward_var.sqrt().clamp_min(1e-8)

    def predict_teammate_reward(self, obs: th.Tensor, teammate_actions: th.Tensor) -> th.Tensor:
        """``r̂ = R(M(o_sender), a_teammate)`` (paper eq. 1) in reward units, shape ``(B, n_agents)``."""
        raw = self._raw_prediction(obs, teammate_actions)
        return raw * self.reward_std + self.reward_mean if self.normalize_rewards else raw

    def update_reward_statistics(self, rewards: th.Tensor) -> None:
        """Merge a batch into the running mean and variance (parallel-moments formula)."""
        _merge_moments(self.reward_mean, self.reward_var, self.reward_count, rewards)

    def loss(
        self, obs: th.Tensor, actions: th.Tensor, rewards: th.Tensor, messages: th.Tensor | None = None
    ) -> th.Tensor:
        """Paper eq. 2 on joint tuples: each agent predicts the other's reward from the other's action.

        In training mode the running reward moments are updated first; with
        ``normalize_rewards`` the regression target is the standardised teammate reward.

        :param obs: ``(B, 2, obs_dim)`` the senders' observations.
        :param actions: ``(B, 2, action_dim)`` both agents' actions (row ``j`` is agent ``j``'s).
        :param rewards: ``(B, 2)`` both agents' rewards.
        :param messages: ``(B, 2, n)`` the grounded messages ``M(obs)`` when already computed
            (GSN-MAX differentiates the loss with respect to them).
        """
        teammate_actions = actions.flip(1)
        target = rewards.flip(1)
        if self.normalize_rewards:
            if self.training:
                with th.no_grad():
                    self.update_reward_statistics(target)
            target = (target - self.reward_mean) / self.reward_std
        return F.mse_loss(self._raw_prediction(obs, teammate_actions, messages), target)


def _merge_moments(mean: th.Tensor, var: th.Tensor, count: th.Tensor, batch: th.Tensor) -> None:
    """Merge ``batch`` into the running ``mean``, ``var`` and ``count`` (in place; parallel-moments
    formula)."""
    batch_mean, batch_var, n = batch.mean(), batch.var(unbiased=False), batch.numel()
    total = count + n
    delta = batch_mean - mean
    m2 = var * count + batch_var * n + delta**2 * count * n / total
    mean += delta * n / total
    var.copy_(m2 / total)
    count.copy_(total)


class GSNTrainingCallback(BaseCallback):
    """Trains the model's GSN with one update per agent update (paper §3, "Training").

    :class:`~sb3_comm.CommDDPG` adds this callback itself when its method is ``"GSN"`` or
    ``"GSN-MAX"``. Inside ``learn``, every ``train()`` call of the model brackets its agent updates
    with :meth:`begin_updates` and :meth:`end_updates`: the callback draws as many batches of joint
    tuples ``(o_sender, a_teammate, r_teammate)`` as the agents will make updates, and performs a
    GSN update on each, beside the agents' updates in a second process where a core is spare
    (GSN), or after them (GSN-MAX, whose update reads their critic; or no core spare). Agent updates
    made otherwise (``model.train()`` called outside ``learn``) are caught up at the start of the
    next rollout and at the end of training. It reads only the model's public ``policy.gsn``,
    ``replay_buffer``, ``n_updates``, ``progress_remaining`` and ``train_log``.

    For ``GSN-MAX`` (:class:`~sb3_comm.comm_ddpg.methods.GSNMAX`) each update gives the message
    extractor the normalised mix of the grounding regression's and the receivers' critic
    gradients at the messages (:meth:`GSNMAX.message_gradient
    <sb3_comm.comm_ddpg.methods.GSNMAX.message_gradient>`); the reward model gets the regression's.

    :param learning_rate: GSN learning rate, or a schedule of the remaining progress (1 -> 0).
    :param batch_size: joint tuples per update.
    :param max_grad_norm: gradient clipping (0 or None: none).
    :param max_weight: GSN-MAX's weight ``w`` of the maximising signal (other methods: unused).
    :param max_warmup: GSN-MAX's warm-up: the fraction of training over which the maximising share
        rises linearly from 0 to ``max_weight`` (0: ``max_weight`` from the start).
    :param signals: GSN-MAX's signals, one of ``GSN_MAX_SIGNALS`` (``"both"``, ``"grounding"``,
        ``"maximising"``); GSN always uses only the grounding.
    :param centred: GSN-MAX's centred maximising signal (its batch mean removed,
        :meth:`GSNMAX.message_gradient <sb3_comm.comm_ddpg.methods.GSNMAX.message_gradient>`).
    :param gain: GSN-MAX's raw mix gain κ (None: each signal scaled to unit RMS).
    :param sgd: GSN-MAX's plain-gradient rate of the maximising signal, a multiple of the GSN's
        learning rate (None: one Adam step on the mix).
    :param beside_agents: run GSN updates in a second process beside the agents' (None: where
        :data:`BESIDE_AGENTS` allows it, a core is spare (:func:`spare_core`) and the update does
        not read the agents' networks). The result is the same either way; only the time differs.
    :param verbose: 0 silent, 1 info.
    :param head_learning_rate: learning rate (or schedule) of GSN-MAX's maximising head, where the
        GSN has one (the model passes its actor's: the head is trained like TCG's message outputs).
    :param search: GSN-MAX's effect search: candidates per message (None: not this design; see
        :meth:`GSNMAX.search_targets <sb3_comm.comm_ddpg.methods.GSNMAX.search_targets>`).
    """

    def __init__(
        self,
        learning_rate: float | Schedule = 1e-3,
        batch_size: int = 64,
        max_grad_norm: float | None = 10.0,
        max_weight: float = 0.5,
        signals: str = "both",
        beside_agents: bool | None = None,
        verbose: int = 0,
        head_learning_rate: float | Schedule = 1e-4,
        max_warmup: float = 0.0,
        centred: bool = False,
        gain: float | None = None,
        sgd: float | None = None,
        search: int | None = None,
    ) -> None:
        super().__init__(verbose)
        self.search = search
        self.learning_rate = learning_rate
        self.lr_schedule = FloatSchedule(learning_rate)
        self.head_lr_schedule = FloatSchedule(head_learning_rate)
        self.max_weight = max_weight
        self.max_warmup = max_warmup
        self.batch_size = batch_size
        self.max_grad_norm = max_grad_norm
        self.signals = signals
        self.centred = centred
        self.gain = gain
        self.sgd = sgd
        self.beside_agents = beside_agents
        self.n_updates = 0
        """GSN updates performed by this callback."""
        self.agent_updates_matched = 0
        """The model's agent-update count that the GSN updates have caught up with."""
        self._worker: GSNWorker | None = None
        self._submitted = 0
        self._deferred: Callable[[], list[tuple[str, Any, int]]] | None = None
        self._weight_now = max_weight

    def _init_callback(self) -> None:
        # Agent updates made before this callback joined (an earlier learn() call, a loaded
        # model) were matched then.
        self.agent_updates_matched = self.model.n_updates  # type: ignore[attr-defined]

    def _on_rollout_start(self) -> None:
        pending = self.model.n_updates - self.agent_updates_matched  # type: ignore[attr-defined]
        self.train_gsn(pending)

    def _on_training_end(self) -> None:
        self.end_updates()
        self._on_rollout_start()
        self.close()

    def _on_step(self) -> bool:
        return True

    # ------------------------------------------------------------------------- updates --
    def uses_worker(self) -> bool:
        """Whether :meth:`begin_updates` runs the GSN's updates in a second process
        (:class:`~sb3_comm.comm_ddpg.gsn_worker.GSNWorker`): a GSN (GSN-MAX's update reads the
        agents' critic) on the CPU, on Linux, where a core is spare or ``beside_agents`` asks."""
        policy = self.model.policy  # type: ignore[union-attr]
        reads_agents = getattr(policy.comm_method, "message_gradient", None) is not None  # GSN-MAX
        on_cpu = policy.gsn is not None and policy.gsn.reward_mean.device.type == "cpu"
        if reads_agents or not on_cpu or not can_fork():
            return False
        if self.beside_agents is not None:
            return self.beside_agents
        return BESIDE_AGENTS and spare_core()

    def begin_updates(self, n_updates: int) -> None:
        """Start the GSN updates that match ``n_updates`` agent updates about to be made.

        Draws the batches now (so the random stream does not depend on where the updates run),
        then sends them to the worker process (:meth:`uses_worker`) or keeps them for
        :meth:`end_updates`. The first update of a ``learn`` call runs in the trainer when the
        optimizer has no state yet (the worker shares the state the trainer holds).

        :param n_updates: agent updates the model is about to make.
        """
        self.end_updates()  # an earlier begin without end (an exception in train)
        batches = self._prepare(n_updates)
        if not batches:
            return
        self.agent_updates_matched += n_updates
        gsn = self.model.policy.gsn  # type: ignore[union-attr]
        if self._worker is not None or (self.uses_worker() and optimizer_state_complete(gsn.optimizer)):
            if self._worker is None:
                self._worker = GSNWorker(self, batches[0], capacity=len(batches))
            self._worker.submit(gsn.optimizer.param_groups[0]["lr"], batches)
            self._submitted = len(batches)
        else:
            self._deferred = lambda: self._updates(batches)

    def end_updates(self) -> None:
        """Finish the updates started by :meth:`begin_updates` (wait for the worker, or run them)."""
        if self._submitted:
            count, self._submitted = self._submitted, 0
            assert self._worker is not None
            self._record(self._worker.result())  # re-raises an error of the worker here
            self.n_updates += count
        if self._deferred is not None:
            deferred, self._deferred = self._deferred, None
            self._record(deferred())

    def close(self) -> None:
        """Stop the worker process, if any (the end of ``learn``; a later call forks a new one)."""
        self._submitted = 0
        if self._worker is not None:
            worker, self._worker = self._worker, None
            worker.close()

    def train_gsn(self, n_updates: int) -> None:
        """``n_updates`` GSN regressions on uniformly sampled joint tuples (paper eq. 2), now.

        :param n_updates: number of gradient steps.
        """
        batches = self._prepare(n_updates)
        if batches:
            self._record(self._updates(batches))
            self.agent_updates_matched += n_updates

    def _prepare(self, n_updates: int) -> list[Any]:
        """Set the learning rate and draw the batches of ``n_updates`` updates (none: nothing to do)."""
        gsn: GroundedSemanticNetwork | None = self.model.policy.gsn  # type: ignore[union-attr]
        replay_buffer = self.model.replay_buffer  # type: ignore[attr-defined]
        if gsn is None or n_updates <= 0 or replay_buffer is None:
            return []
        self._training_mode(gsn)
        lr = self.lr_schedule(self.model.progress_remaining)  # type: ignore[attr-defined]
        for group in gsn.optimizer.param_groups:  # type: ignore[union-attr]
            group["lr"] = lr
        self.model.train_log.add("gsn/learning_rate", lr)  # type: ignore[attr-defined]
        mixes = getattr(self.model.policy.comm_method, "message_gradient", None) is not None  # GSN-MAX
        if mixes and gsn.maximising_head is None and self.signals == "both":  # the mix's share w
            self._weight_now = self.current_max_weight(self.model.progress_remaining)  # type: ignore[attr-defined]
            self.model.train_log.add("gsn/maximising_weight", self._weight_now)  # type: ignore[attr-defined]
        if gsn.head_optimizer is not None:
            head_lr = self.head_lr_schedule(self.model.progress_remaining)  # type: ignore[attr-defined]
            for group in gsn.head_optimizer.param_groups:
                group["lr"] = head_lr
        if not mixes:  # a GSN's regression reads only these fields of its batches
            return [replay_buffer.sample_fields(self.batch_size, GSN_BATCH_FIELDS) for _ in range(n_updates)]
        batches = [replay_buffer.sample(self.batch_size) for _ in range(n_updates)]
        if gsn.effect_model is not None and getattr(replay_buffer, "explorer_envs", 0):
            # the effect model learns from the explorer games (drawn after the GSN's batches)
            explorers = [replay_buffer.sample_explorers(self.batch_size) for _ in range(n_updates)]
            return [_WithExplorers(data, extra) for data, extra in zip(batches, explorers, strict=True)]
        return batches

    def _training_mode(self, gsn: GroundedSemanticNetwork) -> None:
        """``gsn.train(True)`` (its mode decides whether it updates its reward statistics), with the
        modules listed once: ``nn.Module.train`` walks the module tree at every call."""
        listed = self.__dict__.get("_gsn_modules")
        if listed is None or listed[0] is not gsn:
            listed = self.__dict__["_gsn_modules"] = (gsn, list(gsn.modules()))
        for module in listed[1]:
            module.__dict__["training"] = True

    def current_max_weight(self, progress_remaining: float) -> float:
        """GSN-MAX's maximising share ``w`` at this point of training: ``max_weight``, reached
        linearly over the first ``max_warmup`` of training.

        :param progress_remaining: SB3's remaining progress (1 at the start, 0 at the end).
        """
        progress = 1.0 - progress_remaining
        if self.max_warmup <= 0.0 or progress >= self.max_warmup:
            return self.max_weight
        return self.max_weight * max(progress, 0.0) / self.max_warmup

    def _record(self, values: list[tuple[str, Any, int]]) -> None:
        log = self.model.train_log  # type: ignore[attr-defined]
        for key, value, count in values:
            log.add(key, value, count=count)

    def _updates(self, batches: list[Any]) -> list[tuple[str, Any, int]]:
        """One GSN update per batch; returns the values to log (the model's log is not touched
        here: this may run in the worker process)."""
        began = time.perf_counter()
        policy = self.model.policy  # type: ignore[union-attr]
        gsn: GroundedSemanticNetwork = policy.gsn
        mixing = getattr(policy.comm_method, "message_gradient", None)  # GSN-MAX
        extractor = list(gsn.message_extractor.parameters())
        reward_model = list(gsn.reward_model.parameters())
        values: list[tuple[str, Any, int]] = []
        head = gsn.maximising_head
        for data in batches:
            explorers = None
            if isinstance(data, _WithExplorers):
                data, explorers = data.data, data.explorers
            if mixing is None:  # GSN: the regression alone (paper eq. 2)
                loss = gsn.loss(data.observations, data.actions, data.rewards)
                gradient_step(gsn.optimizer, loss, self.max_grad_norm)  # type: ignore[arg-type]
            elif self.search is not None:  # GSN-MAX, effect search
                loss, stats = self._effect_search_update(policy, gsn, data, explorers)
                values += stats
            elif head is not None:  # GSN-MAX, head design: each signal trains its own network
                loss, stats = self._head_design_update(policy, gsn, head, data)
                values += stats
            else:
                messages = gsn.message(data.observations)
                sent = messages.detach().requires_grad_(True)
                loss = gsn.loss(data.observations, data.actions, data.rewards, messages=sent)
                *reward_grads, grounding = th.autograd.grad(loss, [*reward_model, sent])
                signals = "grounding" if self.sgd is not None else self.signals
                gradient, stats = mixing(
                    policy, sent.detach(), grounding, data.next_observations, data.dones,
                    self._weight_now, signals, self.centred, self.gain,
                )  # fmt: skip
                plain_step = None
                if self.sgd is not None:  # the maximising signal's own, plain gradient step
                    ascent, max_stats = policy.comm_method.head_gradient(
                        policy, sent.detach(), data.next_observations, data.dones
                    )
                    stats.update(max_stats)
                    plain_step = th.autograd.grad(messages, extractor, grad_outputs=ascent, retain_graph=True)
                extractor_grads = th.autograd.grad(messages, extractor, grad_outputs=gradient)
                trained = [*reward_model, *extractor]
                grads = [*reward_grads, *extractor_grads]
                if gsn.effect_model is not None:  # the effect model's own regression
                    effect_params = list(gsn.effect_model.parameters())
                    effect_data = data if explorers is None else explorers
                    effect_loss = gsn.effect_loss(
                        effect_data.observations, effect_data.actions, effect_data.rewards
                    )
                    trained += effect_params
                    grads += th.autograd.grad(effect_loss, effect_params)
                    stats["gsn/effect_loss"] = effect_loss.detach()
                for param, grad in zip(trained, grads, strict=True):
                    param.grad = grad
                if self.max_grad_norm:
                    clip_gradients(trained, self.max_grad_norm)
                adam_step(gsn.optimizer)  # type: ignore[arg-type]
                if plain_step is not None:
                    rate = self.sgd * gsn.optimizer.param_groups[0]["lr"]  # type: ignore[union-attr, operator]
                    with th.no_grad():
                        th._foreach_add_(extractor, list(plain_step), alpha=-rate)
                values += [(key, value, 1) for key, value in stats.items()]
            loss = loss.detach()
            values.append(("gsn/loss", loss, 1))
            # the prediction error in reward units (the loss is standardised when normalising)
            scale = gsn.reward_std.detach() if gsn.normalize_rewards else 1.0
            values.append(("gsn/prediction_rmse", loss.sqrt() * scale, 1))
            self.n_updates += 1
        values.append(("time/gsn_update_ms", 1000.0 * (time.perf_counter() - began), len(batches)))
        return values

    PULL_BOUND = 0.995
    """A ``tanh`` message is pulled before its ``tanh``, towards ``atanh`` of its target clipped to
    this bound."""

    EFFECT_R2_RATE = 0.01
    """Weight of one batch in the running R² of the effect model (about the last 100 updates)."""

    def _effect_search_update(
        self, policy: Any, gsn: GroundedSemanticNetwork, data: Any, explorers: Any | None
    ) -> tuple[th.Tensor, list[tuple[str, Any, int]]]:
        """GSN-MAX's effect search on one batch: one Adam step of the GSN on

            L = L_g(M(o)) + L_E + λ · ½ mean ‖M(o) − m*‖²,    λ = w / (1 − w) · R²_E,

        the grounding regression (paper eq. 2, GSN's loss on ``M`` and ``R``), the effect models'
        regression on the explorer games' transitions (where there are any), and a pull of each
        message (before its ``tanh``, where it has one) towards the best candidate ``m*`` that the
        effect models find
        (:meth:`GSNMAX.search_targets <sb3_comm.comm_ddpg.methods.GSNMAX.search_targets>`; rows with
        no better candidate are not pulled). ``R²_E``, the share of the reward's variance the effect
        model explains (a running average), keeps the pull out while the model knows nothing. Where
        nothing is pulled, the step is GSN's. ``signals`` switches either part off (the ablations).
        Returns the regression loss and the values to log."""
        obs = data.observations
        raw = gsn.message_extractor(obs)
        messages = th.tanh(raw) if gsn.message_activation == "tanh" else raw
        grounded = messages if self.signals != "maximising" else messages.detach()  # R still learns
        loss = gsn.loss(obs, data.actions, data.rewards, messages=grounded)
        effect_data = data if explorers is None else explorers
        target = gsn.effect_target(effect_data.rewards)
        effect_loss = gsn.effect_regression(effect_data.observations, effect_data.actions, target)
        with th.no_grad():
            r2 = (1.0 - effect_loss / target.var(unbiased=False).clamp_min(1e-12)).clamp(0.0, 1.0)
            gsn.effect_r2.lerp_(r2, self.EFFECT_R2_RATE)
        total = loss + effect_loss
        values: list[tuple[str, Any, int]] = [
            ("gsn/effect_loss", effect_loss.detach(), 1),
            ("gsn/effect_r2", gsn.effect_r2.clone(), 1),
        ]
        if self.signals != "grounding":
            assert self.search is not None
            targets, pulled, gain = policy.comm_method.search_targets(
                policy, messages.detach(), data.next_observations, data.dones, self.search
            )
            weight = self._weight_now / max(1.0 - self._weight_now, 1e-6) * gsn.effect_r2
            if self.signals == "maximising":
                weight = th.ones_like(weight)
            if gsn.message_activation == "tanh":  # pulled before the tanh: a saturated message still moves
                targets = th.atanh(targets.clamp(-self.PULL_BOUND, self.PULL_BOUND))
            pull = 0.5 * ((raw - targets).pow(2).sum(-1) * pulled).mean()
            total = total + weight * pull
            values += [
                ("gsn/search_pulled", pulled.mean(), 1),
                ("gsn/search_gain", (gain * pulled).sum() / pulled.sum().clamp_min(1.0), 1),
                ("gsn/pull_loss", pull.detach(), 1),
                ("gsn/pull_weight", weight.clone(), 1),
            ]
        gradient_step(gsn.optimizer, total, self.max_grad_norm)  # type: ignore[arg-type]
        return loss, values

    def _head_design_update(
        self, policy: Any, gsn: GroundedSemanticNetwork, head: nn.Module, data: Any
    ) -> tuple[th.Tensor, list[tuple[str, Any, int]]]:
        """GSN-MAX's head design on one batch: the regression step of ``M`` and ``R`` (paper eq. 2,
        as GSN), then the step of ``H`` along the receiver critic's gradient at ``m = M(o) + H(o)``;
        either is left out where :attr:`signals` switches it off. Returns the regression loss and
        the maximising signal's statistics to log."""
        obs = data.observations
        if self.signals != "maximising":
            loss = gsn.loss(obs, data.actions, data.rewards)
            gradient_step(gsn.optimizer, loss, self.max_grad_norm)  # type: ignore[arg-type]
        else:  # M and R stay as initialised; the loss is only logged
            with th.no_grad():
                loss = gsn.loss(obs, data.actions, data.rewards)
        values: list[tuple[str, Any, int]] = []
        if self.signals != "grounding":
            with th.no_grad():
                grounded = gsn.grounded_message(obs)
            offset = head(obs)
            gradient, stats = policy.comm_method.head_gradient(
                policy, grounded + offset.detach(), data.next_observations, data.dones
            )
            params = list(head.parameters())
            for param, grad in zip(
                params, th.autograd.grad(offset, params, grad_outputs=gradient), strict=True
            ):
                param.grad = grad
            if self.max_grad_norm:
                clip_gradients(params, self.max_grad_norm)
            adam_step(gsn.head_optimizer)  # type: ignore[arg-type]
            values += [(key, value, 1) for key, value in stats.items()]
        return loss, values


class _WithExplorers(NamedTuple):
    """A GSN batch and the explorer games' batch drawn with it (GSN-MAX's effect model)."""

    data: Any
    explorers: Any
