"""GSN-MAX's head design (``policy_kwargs`` ``gsn_maximising_head=True``): the message is
``M(o) + H(o)``; ``M`` and ``R`` follow the regression alone (as GSN), the head ``H`` the receiver
critic's gradient alone, each with its own Adam; either signal can be switched off."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.env_util import make_vec_env
from test_gsn_max import LR, assert_loaded_like, inverted, params, receiver_gradient_by_hand, sample
from toy_envs import coin_env

from sb3_comm import CommDDPG
from sb3_comm.comm_ddpg import GSNTrainingCallback

HEAD_LR = 1e-4
SMALL = {"net_arch": [32, 32], "gsn_net_arch": [16], "gsn_reward_net_arch": [16]}


def head_model(signals: str = "both", **kwargs) -> CommDDPG:
    """A GSN-MAX model with a head whose replay holds 120 joint transitions and which has made no
    update yet (fresh optimizers: Adam's first step is ``-lr * sign(grad)``)."""
    vec = make_vec_env(coin_env, n_envs=2, seed=0)
    model = CommDDPG(
        "GSN-MAX", vec, batch_size=16, learning_starts=10_000, gsn_learning_rate=LR,
        actor_learning_rate=HEAD_LR, gsn_max_signals=signals, gsn_max_explore_messages=False,
        share_parameters=False, seed=0, device="cpu",
        policy_kwargs={**SMALL, "gsn_maximising_head": True, "gsn_message_activation": "linear"},
        **kwargs,
    )  # fmt: skip
    model.learn(60)
    assert model.n_updates == 0 and not model.policy.gsn.head_optimizer.state_dict()["state"]
    return model


def one_update(model: CommDDPG, sample_seed: int = 7) -> GSNTrainingCallback:
    callback = GSNTrainingCallback(
        model.gsn_learning_rate, 16, model.max_grad_norm, signals=model.gsn_max_signals,
        head_learning_rate=model.actor_learning_rate,
    )  # fmt: skip
    callback.init_callback(model)
    np.random.seed(sample_seed)
    callback.train_gsn(1)
    return callback


def adam_first_step(before: th.Tensor, after: th.Tensor, grad: th.Tensor, lr: float) -> None:
    big = grad.abs() > 1e-6
    assert big.any()
    th.testing.assert_close(
        (after - before)[big], (-lr * grad / (grad.abs() + 1e-8))[big], rtol=1e-3, atol=1e-9
    )


def output_layer_mask(head: th.nn.Module) -> list[bool]:
    """For each parameter of ``head``, whether it belongs to an output layer (the last linear
    layer of each agent's network)."""
    outputs = set()
    for net in head.nets:
        last = [layer for layer in net.modules() if isinstance(layer, th.nn.Linear)][-1]
        outputs |= {id(last.weight), id(last.bias)}
    return [id(p) in outputs for p in head.parameters()]


def test_the_head_starts_at_zero_so_the_first_messages_are_gsns() -> None:
    model = head_model()
    gsn = model.policy.gsn
    obs = sample(model).observations
    th.testing.assert_close(gsn.message(obs), gsn.grounded_message(obs))
    assert gsn.maximising_head is not None and gsn.maximising_head(obs).abs().max() == 0
    # the regression's optimizer holds M and R only, the head's the head only
    grounding = {id(p) for group in gsn.optimizer.param_groups for p in group["params"]}
    head = {id(p) for group in gsn.head_optimizer.param_groups for p in group["params"]}
    assert grounding == {id(p) for p in gsn.grounding_parameters()}
    assert head == {id(p) for p in gsn.maximising_head.parameters()} and not grounding & head


@pytest.mark.parametrize("signals", ["both", "grounding", "maximising"])
def test_one_update_trains_m_and_r_by_the_regression_and_the_head_by_the_receivers_critic(
    signals: str,
) -> None:
    model = head_model(signals)
    gsn = model.policy.gsn
    data = sample(model)
    critic_before, actor_before = params(model.policy.critic), params(model.policy.actor)
    grounding_before, head_before = (
        [p.detach().clone() for p in gsn.grounding_parameters()],
        params(gsn.maximising_head),
    )
    ref = copy.deepcopy(gsn).train(True)
    regression_grads = th.autograd.grad(
        ref.loss(data.observations, data.actions, data.rewards), ref.grounding_parameters()
    )

    one_update(model)
    grounding_after = list(gsn.grounding_parameters())
    if signals == "maximising":  # M and R stay as they were
        assert all(th.equal(a, b) for a, b in zip(grounding_before, grounding_after, strict=True))
    else:
        for before, after, grad in zip(grounding_before, grounding_after, regression_grads, strict=True):
            adam_first_step(before, after.detach(), grad, LR)
    is_output = output_layer_mask(gsn.maximising_head)
    head_after = params(gsn.maximising_head)
    # the head's output layers start at zero: its first step moves them alone
    for before, after, output in zip(head_before, head_after, is_output, strict=True):
        assert output or th.equal(before, after)
    if signals == "grounding":  # the head stays at zero: GSN
        assert all(th.equal(a, b) for a, b in zip(head_before, head_after, strict=True))
    else:
        # by hand: d = −inv(g)/B at the sent message M(o) (after the regression step; H(o) = 0),
        # g the receiver critic's gradient; the head's output layers get Jᵀd
        with th.no_grad():
            sent = gsn.grounded_message(data.observations)
        g = receiver_gradient_by_hand(model, data, sent)
        assert g.abs().sum() > 0
        d = -inverted(g, sent) / len(g)
        head = copy.deepcopy(gsn.maximising_head)
        for p, before in zip(head.parameters(), head_before, strict=True):
            p.data.copy_(before)
        grads = th.autograd.grad(head(data.observations), list(head.parameters()), grad_outputs=d)
        for before, after, grad, output in zip(head_before, head_after, grads, is_output, strict=True):
            if output:
                adam_first_step(before, after, grad, HEAD_LR)
    # the agents did not move, and no gradient was left on them
    assert all(th.equal(a, b) for a, b in zip(critic_before, model.policy.critic.parameters(), strict=True))
    assert all(th.equal(a, b) for a, b in zip(actor_before, model.policy.actor.parameters(), strict=True))
    assert all(p.grad is None for p in model.policy.critic.parameters())


def test_the_head_learns_at_the_actors_learning_rate_schedule() -> None:
    model = head_model()
    model._current_progress_remaining = 0.25
    callback = one_update(model)
    assert callback.head_lr_schedule(0.25) == pytest.approx(HEAD_LR)
    assert model.policy.gsn.head_optimizer.param_groups[0]["lr"] == pytest.approx(HEAD_LR)
    from stable_baselines3.common.utils import LinearSchedule

    model.actor_learning_rate = LinearSchedule(HEAD_LR, 0.0, 1.0)
    one_update(model)
    assert model.policy.gsn.head_optimizer.param_groups[0]["lr"] == pytest.approx(0.25 * HEAD_LR)


def test_save_load_keeps_the_head_and_its_optimizer(tmp_path) -> None:
    model = head_model()
    one_update(model)
    path = tmp_path / "gsn_max_head.zip"
    model.save(path)
    loaded = CommDDPG.load(path, device="cpu")
    assert loaded.policy.gsn_maximising_head and loaded.policy.gsn.maximising_head is not None
    assert_loaded_like(model, loaded, "head_optimizer")


def test_the_head_is_a_clear_error_where_it_would_not_be_trained() -> None:
    vec = make_vec_env(coin_env, n_envs=1)
    with pytest.raises(ValueError, match="gsn_maximising_head=True applies to GSN-MAX only"):
        CommDDPG("GSN", vec, policy_kwargs={"gsn_maximising_head": True})
    with pytest.raises(ValueError, match=r"leave gsn_max_weight at 0\.5"):
        CommDDPG("GSN-MAX", vec, gsn_max_weight=0.3, policy_kwargs={"gsn_maximising_head": True})
    with pytest.raises(TypeError, match="gsn_maximising_head"):
        CommDDPG("GSN-MAX", vec, policy_kwargs={"gsn_maximising_head": "yes"})
