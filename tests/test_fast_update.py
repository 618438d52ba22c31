"""The fast update path (fused Adam, one foreach soft update, foreach clipping, cached module
lists) against a straightforward reference implementation of the same DDPG update."""

from __future__ import annotations

import copy
import inspect
import os

import pytest
import torch as th
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.utils import LinearSchedule
from torch.nn import functional as F
from toy_envs import coin_env

from sb3_comm import CommDDPG


def _plain_adam(module: th.nn.Module, fast: th.optim.Optimizer) -> th.optim.Optimizer:
    """A for-loop Adam over ``module``'s parameters, in the fast optimizer's state."""
    plain = th.optim.Adam(module.parameters(), lr=1.0, foreach=False, fused=False)
    plain.load_state_dict(copy.deepcopy(fast.state_dict()))
    for group in plain.param_groups:
        group["fused"], group["foreach"] = False, False
    return plain


def _reference_update(model: CommDDPG, ref, data, max_grad_norm: float, beta: float | None = None) -> None:
    """One DDPG update written out: TD target mixed with the Monte-Carlo return (weight ``beta``,
    default the model's ``mc_mixing``), critic step, actor step on -Q(s, mu(s)), soft updates
    parameter by parameter (and of the actor's average the team plays, where it keeps one)."""
    beta = model.mc_mixing if beta is None else beta
    critic_opt = _plain_adam(ref.critic, model.policy.critic.optimizer)
    actor_opt = _plain_adam(ref.actor, model.policy.actor.optimizer)
    obs, actions, next_obs = data.observations, data.actions, data.next_observations
    with th.no_grad():
        next_out = ref.actor_outputs(next_obs, target=True).clamp(-1.0, 1.0)
        target = (
            data.rewards + (1.0 - data.dones) * model.gamma * ref.q_values(next_obs, next_out, target=True)[0]
        )
        mc_returns = data.mc_returns
        if data.mc_tail_observations is not None:  # mc_truncated="bootstrap": the value at the cut
            tail = data.mc_tail_observations
            tail_out = ref.actor_outputs(tail, target=True).clamp(-1.0, 1.0)
            mc_returns = mc_returns + data.mc_tail_discount * ref.q_values(tail, tail_out, target=True)[0]
        mixed = beta * mc_returns + (1.0 - beta) * target
        target = th.where(data.mc_valid.bool(), mixed, target)
    critic_loss = F.mse_loss(ref.q_values(obs, actions)[0], target)
    critic_opt.zero_grad()
    critic_loss.backward()
    th.nn.utils.clip_grad_norm_(list(ref.critic.parameters()), max_grad_norm, foreach=False)
    critic_opt.step()
    actor_loss = -ref.q_values(obs, ref.actor_outputs(obs))[0].mean()
    actor_opt.zero_grad()
    actor_loss.backward()
    th.nn.utils.clip_grad_norm_(list(ref.actor.parameters()), max_grad_norm, foreach=False)
    actor_opt.step()
    with th.no_grad():
        for net, target_net in ((ref.critic, ref.critic_target), (ref.actor, ref.actor_target)):
            for p, p_target in zip(net.parameters(), target_net.parameters(), strict=True):
                p_target.mul_(1.0 - model.tau).add_(p, alpha=model.tau)
        if ref.actor_average is not None:  # the average the team plays (the default), at its rate
            rate = ref.actor_average_rate
            for p, p_average in zip(ref.actor.parameters(), ref.actor_average.parameters(), strict=True):
                p_average.mul_(1.0 - rate).add_(p, alpha=rate)


@pytest.mark.parametrize(
    ("method", "mc_truncated"), [("NONE", "sum"), ("RIAL", "sum"), ("NONE", "bootstrap")]
)
def test_one_fast_update_equals_the_reference(method: str, mc_truncated: str) -> None:
    env = make_vec_env(coin_env, n_envs=2, seed=0)
    model = CommDDPG(
        method, env, batch_size=16, learning_starts=20, seed=0, tau=0.05, max_grad_norm=0.5, mc_mixing=0.5,
        policy_kwargs={"net_arch": [16, 16]}, replay_buffer_kwargs={"mc_truncated": mc_truncated},
    )  # fmt: skip
    model.learn(60)
    assert model.policy.critic.optimizer.param_groups[0]["fused"] is True
    data = model.replay_buffer.sample(16)
    if mc_truncated == "bootstrap":  # the coin game is cut by its time limit: every return has a tail
        assert bool((data.mc_tail_discount[data.mc_valid.bool()] > 0).all()) and bool(data.mc_valid.any())
    model.replay_buffer.sample = lambda *args, **kwargs: data  # the same batch for both
    ref = copy.deepcopy(model.policy)
    _reference_update(model, ref, data, max_grad_norm=0.5)
    model.train(gradient_steps=1, batch_size=16)
    moved = 0
    for (name, fast), slow in zip(model.policy.state_dict().items(), ref.state_dict().values(), strict=True):
        th.testing.assert_close(fast, slow, rtol=1e-5, atol=1e-6, msg=lambda m, n=name: f"{n}: {m}")
        moved += 1
    assert moved > 8


def test_a_scheduled_mc_mixing_uses_beta_at_the_current_progress() -> None:
    """``mc_mixing=LinearSchedule(0.5, 0, 1)`` halfway through training mixes with β = 0.25."""
    env = make_vec_env(coin_env, n_envs=2, seed=0)
    model = CommDDPG(
        "NONE", env, batch_size=16, learning_starts=20, seed=0, tau=0.05, max_grad_norm=0.5,
        mc_mixing=LinearSchedule(0.5, 0.0, 1.0), policy_kwargs={"net_arch": [16, 16]},
        actor_learning_rate=1e-4,  # the reference's constant rate
    )  # fmt: skip
    model.learn(60)
    assert model.replay_buffer.store_mc_returns
    model._current_progress_remaining = 0.5
    model.train_log.pop_means()  # the values logged during learn
    data = model.replay_buffer.sample(16)
    assert bool(data.mc_valid.bool().any())
    model.replay_buffer.sample = lambda *args, **kwargs: data
    ref = copy.deepcopy(model.policy)
    _reference_update(model, ref, data, max_grad_norm=0.5, beta=0.25)
    model.train(gradient_steps=1, batch_size=16)
    for (name, fast), slow in zip(model.policy.state_dict().items(), ref.state_dict().values(), strict=True):
        th.testing.assert_close(fast, slow, rtol=1e-5, atol=1e-6, msg=lambda m, n=name: f"{n}: {m}")
    assert model.train_log.pop_means()["train/mc_mixing"] == pytest.approx(0.25)


def test_one_gsn_update_beside_the_agents_equals_the_reference(monkeypatch: pytest.MonkeyPatch) -> None:
    """A GSN update run in the worker process, beside the agents' update, is the plain regression
    step of paper eq. 2: MSE on the standardised teammate reward, clipping, Adam."""
    from sb3_comm.comm_ddpg import gsn as gsn_module

    monkeypatch.setattr(gsn_module, "spare_core", lambda: True)
    env = make_vec_env(coin_env, n_envs=2, seed=0)
    model = CommDDPG(
        "GSN", env, batch_size=16, learning_starts=20, seed=0, max_grad_norm=0.5, gsn_learning_rate=1e-3,
        policy_kwargs={"net_arch": [16, 16], "gsn_net_arch": [8], "gsn_reward_net_arch": [8],
                       "gsn_reward_sees_teammate": False},  # the paper's R(M(o_i), a_j)
    )  # fmt: skip
    model.learn(60)
    callback = model.gsn_callback
    assert callback is not None and callback.uses_worker()
    data = model.replay_buffer.sample(16)
    model.replay_buffer.sample = lambda *args, **kwargs: data  # the same batch for GSN and agents
    model.replay_buffer.sample_fields = lambda batch_size, fields: data
    ref = copy.deepcopy(model.policy.gsn)
    optimizer = _plain_adam(ref, model.policy.gsn.optimizer)
    for group in optimizer.param_groups:
        group["lr"] = callback.lr_schedule(model.progress_remaining)
    ref.train()
    teammate_reward = data.rewards.flip(1)
    batch_var, batch_mean = teammate_reward.var(unbiased=False), teammate_reward.mean()
    count = ref.reward_count + teammate_reward.numel()
    mean = ref.reward_mean + (batch_mean - ref.reward_mean) * teammate_reward.numel() / count
    delta = batch_mean - ref.reward_mean
    var = (
        ref.reward_var * ref.reward_count
        + batch_var * teammate_reward.numel()
        + delta**2 * ref.reward_count * teammate_reward.numel() / count
    ) / count
    target = (teammate_reward - mean) / var.sqrt()
    ref.reward_mean.copy_(mean), ref.reward_var.copy_(var), ref.reward_count.copy_(count)
    messages = th.tanh(ref.message_extractor(data.observations))
    features = th.cat([messages, data.actions.flip(1)[..., : ref.teammate_action_dim]], dim=-1)
    loss = F.mse_loss(ref.reward_model(features).squeeze(-1), target)
    optimizer.zero_grad()
    loss.backward()
    th.nn.utils.clip_grad_norm_(list(ref.parameters()), 0.5, foreach=False)
    optimizer.step()

    pids = []
    updates = callback._updates
    monkeypatch.setattr(callback, "_updates", lambda b: (pids.append(os.getpid()), updates(b))[1])
    model._in_learn = True  # as inside learn(): train() brackets the agents' update with the GSN's
    model.train(gradient_steps=1, batch_size=16)
    worker = callback._worker
    assert worker is not None and worker.alive  # the update ran in the worker process ...
    assert pids == []  # ... not in this one
    assert callback.n_updates == model.n_updates
    callback.close()
    assert not worker.alive
    for (name, fast), slow in zip(
        model.policy.gsn.state_dict().items(), ref.state_dict().values(), strict=True
    ):
        th.testing.assert_close(fast, slow, rtol=1e-5, atol=1e-6, msg=lambda m, n=name: f"{n}: {m}")


def test_gsn_beside_the_agents_trains_the_same_model_as_after_them(monkeypatch: pytest.MonkeyPatch) -> None:
    """The worker process changes the time only: the same seed gives the same parameters (GSN,
    its optimizer's state, the agents), bit for bit."""
    from sb3_comm.comm_ddpg import gsn as gsn_module

    started = []

    class CountedWorker(gsn_module.GSNWorker):
        def __init__(self, callback, *args, **kwargs) -> None:
            started.append(callback)
            super().__init__(callback, *args, **kwargs)

    monkeypatch.setattr(gsn_module, "GSNWorker", CountedWorker)
    states = {}
    for beside in (True, False):
        monkeypatch.setattr(gsn_module, "spare_core", lambda beside=beside: beside)
        env = make_vec_env(coin_env, n_envs=2, seed=0)
        model = CommDDPG(
            "GSN", env, batch_size=16, learning_starts=20, seed=0, policy_kwargs={"net_arch": [16]}
        )
        model.learn(200)
        model.learn(100, reset_num_timesteps=False)  # a second learn call forks a new worker
        assert model.gsn_callback.agent_updates_matched == model.n_updates  # every update matched
        assert model.gsn_callback.n_updates > 0
        assert model.gsn_callback._worker is None  # stopped at the end of learn
        gsn_optimizer = model.policy.gsn.optimizer.state_dict()["state"]
        states[beside] = {
            **model.policy.state_dict(),
            **{f"gsn_adam.{i}.{k}": v for i, s in gsn_optimizer.items() for k, v in s.items()},
        }
    assert len(started) == 2  # one worker per learn call with a spare core, none without
    assert len(states[True]) == len(states[False])
    for name, tensor in states[True].items():
        assert th.equal(tensor, states[False][name]), name


@pytest.mark.parametrize("scale", [1e-3, 1e3])  # below and above the bound
def test_clip_gradients_gives_torchs_clipped_gradients(scale: float) -> None:
    from sb3_comm.common.networks import clip_gradients

    th.manual_seed(0)
    ours = [th.nn.Parameter(th.randn(5, 3)), th.nn.Parameter(th.randn(3)), th.nn.Parameter(th.randn(2))]
    theirs = [th.nn.Parameter(p.detach().clone()) for p in ours]
    for a, b in zip(ours, theirs, strict=True):
        a.grad = th.randn_like(a) * scale
        b.grad = a.grad.clone()
    ours[2].grad = theirs[2].grad = None  # a parameter without a gradient is left alone
    clip_gradients(ours, 1.0)
    th.nn.utils.clip_grad_norm_(theirs, 1.0, foreach=False)
    for a, b in zip(ours[:2], theirs[:2], strict=True):
        assert th.equal(a.grad, b.grad)
    assert ours[2].grad is None
    norm = th.linalg.vector_norm(th.stack([p.grad.norm() for p in ours[:2]]))
    assert norm <= 1.0 + 1e-5 if scale > 1 else norm < 0.1


@pytest.mark.parametrize(
    "optimizer_class, kwargs",
    [
        (th.optim.Adam, {"lr": 1e-3}),
        (th.optim.Adam, {"lr": 3e-4, "weight_decay": 0.1, "maximize": True}),
        (th.optim.AdamW, {"lr": 1e-3, "betas": (0.8, 0.99), "eps": 1e-6}),
    ],
)
def test_adam_step_equals_the_optimizers_step_to_the_bit(optimizer_class, kwargs) -> None:
    """The fused kernel called directly gives the parameters and the state of ``step()``, bit for bit,
    over steps of changing gradients, two parameter groups and a changed learning rate."""
    from sb3_comm.common.networks import adam_step

    th.manual_seed(0)
    ours = [th.nn.Parameter(th.randn(7, 5)), th.nn.Parameter(th.randn(5)), th.nn.Parameter(th.randn(3))]
    theirs = [th.nn.Parameter(p.detach().clone()) for p in ours]
    optimizers = [
        optimizer_class([{"params": params[:2]}, {"params": params[2:], "lr": 0.5}], fused=True, **kwargs)
        for params in (ours, theirs)
    ]
    for k in range(6):
        if k == 3:
            for optimizer in optimizers:
                optimizer.param_groups[0]["lr"] = 0.01
        for a, b in zip(ours, theirs, strict=True):
            a.grad = th.randn_like(a) * 10.0 ** (k - 2)
            b.grad = a.grad.clone()
        adam_step(optimizers[0])
        optimizers[1].step()
        for a, b in zip(ours, theirs, strict=True):
            assert th.equal(a, b)
            for key, value in optimizers[1].state[b].items():
                assert th.equal(optimizers[0].state[a][key], value), key


def test_adam_step_leaves_other_optimizers_to_their_step() -> None:
    """Not a fused Adam, a parameter without a gradient, or a step hook: ``step()`` itself."""
    from sb3_comm.common.networks import adam_step

    called = []
    params = [th.nn.Parameter(th.ones(3)), th.nn.Parameter(th.ones(2))]
    for optimizer in (
        th.optim.Adam(params, lr=0.1, foreach=False),  # not fused
        th.optim.SGD(params, lr=0.1),
        th.optim.Adam(params, lr=0.1, fused=True),
    ):
        name = type(optimizer).__name__
        optimizer.register_step_post_hook(lambda *_, name=name: called.append(name))
        params[0].grad, params[1].grad = th.ones(3), None
        adam_step(optimizer)  # the first step of the fused Adam: no state yet
        params[1].grad = th.ones(2)
        adam_step(optimizer)
    assert called == ["Adam", "Adam", "SGD", "SGD", "Adam", "Adam"]
    # each stepped the second parameter once (its first step: Adam by lr, SGD by lr × gradient)
    assert th.allclose(params[1], th.full((2,), 0.7))


def test_adam_step_leaves_a_scheduled_optimizer_to_its_wrapped_step() -> None:
    """A learning-rate scheduler wraps ``optimizer.step`` on the object to count its calls; that
    optimizer takes its own ``step`` (no "scheduler stepped before the optimizer" warning)."""
    import warnings

    from sb3_comm.common.networks import adam_step

    param = th.nn.Parameter(th.ones(3))
    optimizer = th.optim.Adam([param], lr=0.1, fused=True)
    param.grad = th.ones(3)
    optimizer.step()  # the state exists: without the check, adam_step would call the kernel
    scheduler = th.optim.lr_scheduler.StepLR(optimizer, step_size=1, gamma=0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for _ in range(2):
            param.grad = th.ones(3)
            adam_step(optimizer)
            scheduler.step()
    assert optimizer.param_groups[0]["lr"] == 0.025
    assert th.allclose(param, th.full((3,), 1.0 - 0.1 - 0.1 - 0.05), atol=1e-6)


def test_the_agents_batches_are_drawn_before_the_gsns() -> None:
    """The order of the random draws of a GSN trained after the agents (as before the thread):
    per train() call, the agents' batches, then the GSN's, then the next rollout's exploration."""
    env = make_vec_env(coin_env, n_envs=2, seed=0)
    model = CommDDPG(
        "GSN",
        env,
        batch_size=8,
        learning_starts=20,
        gradient_steps=2,
        seed=0,
        policy_kwargs={"net_arch": [8]},
    )
    model.learn(24)  # the buffer, and the callback
    draws: list[str] = []
    sample = model.replay_buffer.sample

    def recorded(*args, **kwargs):
        callers = {frame.function for frame in inspect.stack()[1:5]}
        draws.append("gsn" if "_prepare" in callers else "agents")
        return sample(*args, **kwargs)

    sample_fields = model.replay_buffer.sample_fields

    def recorded_fields(*args, **kwargs):  # the GSN's light sample
        draws.append("gsn" if "_prepare" in {frame.function for frame in inspect.stack()[1:3]} else "?")
        return sample_fields(*args, **kwargs)

    model.replay_buffer.sample = recorded
    model.replay_buffer.sample_fields = recorded_fields
    model.learn(4, reset_num_timesteps=False)  # two rollouts of 2 steps, two train() calls
    assert draws == ["agents", "agents", "gsn", "gsn"] * 2
