"""GSN-MAX's earlier design (``policy_kwargs`` ``gsn_effect_model=False``): the message extractor
is trained by the grounding regression and by the receiver critic's gradient; either signal can be
switched off. The effect search, the default, is tested in ``test_gsn_max_search.py``."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.env_util import make_vec_env
from toy_envs import coin_env

from sb3_comm import CommDDPG
from sb3_comm.comm_ddpg import GSNTrainingCallback
from sb3_comm.comm_ddpg.methods import TCG

LR, WEIGHT = 1e-3, 0.3
EARLIER = {"gsn_effect_model": False}  # the receiver critic's signal, not the effect search


def replay_filled_model(signals: str = "both", **kwargs) -> CommDDPG:
    """A GSN-MAX model whose replay holds 120 joint transitions and which has made no update yet
    (a fresh optimizer: Adam's first step is ``-lr * sign(grad)``)."""
    vec = make_vec_env(coin_env, n_envs=2, seed=0)
    model = CommDDPG(
        "GSN-MAX",
        vec,
        batch_size=16,
        learning_starts=10_000,
        gsn_learning_rate=LR,
        gsn_max_weight=WEIGHT,
        gsn_max_signals=signals,
        share_parameters=False,
        policy_kwargs={**EARLIER, "net_arch": [32, 32], "gsn_net_arch": [16], "gsn_reward_net_arch": [16]},
        seed=0,
        device="cpu",
        **kwargs,
    )
    model.learn(60)
    assert model.n_updates == 0 and not model.policy.gsn.optimizer.state_dict()["state"]
    return model


def params(module: th.nn.Module) -> list[th.Tensor]:
    return [p.detach().clone() for p in module.parameters()]


def assert_adam_first_step(before, after, grads, lr: float = LR) -> None:
    """Adam's first step from an empty state is ``-lr * g / (|g| + eps)``: ``-lr * sign(g)`` where
    the gradient is not tiny, never more than ``lr`` anywhere."""
    for b, a, g in zip(before, after, grads, strict=True):
        delta = a - b
        big = g.abs() > 1e-6
        assert big.any()
        exact = -lr * g / (g.abs() + 1e-8)  # Adam's eps
        th.testing.assert_close(delta[big], exact[big], rtol=1e-3, atol=1e-9)
        assert (delta.abs() <= lr * (1 + 1e-4)).all()


def one_callback_update(model: CommDDPG, sample_seed: int = 7) -> None:
    callback = GSNTrainingCallback(
        model.gsn_learning_rate, 16, model.max_grad_norm,
        max_weight=model.gsn_max_weight, signals=model.gsn_max_signals,
    )  # fmt: skip
    callback.init_callback(model)
    np.random.seed(sample_seed)
    callback.train_gsn(1)


def sample(model: CommDDPG, sample_seed: int = 7):
    np.random.seed(sample_seed)
    return model.replay_buffer.sample(16)


def inverted(ascent: th.Tensor, m: th.Tensor) -> th.Tensor:
    """Inverting gradients for the bound [-1, 1], written out (ICLR 2016, eq. 11)."""
    return th.where(ascent > 0, ascent * (1 - m) / 2, ascent * (m + 1) / 2)


def receiver_gradient_by_hand(model: CommDDPG, data, messages: th.Tensor) -> th.Tensor:
    """``(1 − d)·∂Q_j(o'_j ⊕ m_i, a'_j)/∂m_i`` with receiver j's own critic (``nets[j]``), its action
    held fixed."""
    policy = model.policy
    m = messages.detach().requires_grad_(True)
    n, obs_dim = model.comm_layout.channel_size, model.comm_layout.obs_dim
    total = 0.0
    for sender, receiver in ((0, 1), (1, 0)):
        rows = data.next_observations.clone()
        rows[:, receiver, obs_dim - n :] = m[:, sender].detach()
        with th.no_grad():
            a_next = policy.actor_outputs(rows)[:, receiver]
        o_next = th.cat([data.next_observations[:, receiver, : obs_dim - n], m[:, sender]], dim=-1)
        q = policy.critic[0].nets[receiver](th.cat([o_next, a_next], dim=-1)).squeeze(-1)
        total = total + (q * (1 - data.dones[:, 0])).sum()
    return th.autograd.grad(total, m)[0]


def mix_inputs():
    """A fresh model's batch, its messages, a small grounding gradient at them, the arguments of
    ``message_gradient`` and the maximising signal ``d_m = −g / B`` computed by hand."""
    model = replay_filled_model()
    data = sample(model)
    messages = model.policy.gsn.message(data.observations).detach()
    grounding = 1e-3 * th.randn_like(messages)
    args = (model.policy, messages, grounding, data.next_observations, data.dones)
    d_m = -receiver_gradient_by_hand(model, data, messages) / len(messages)
    return model, data, messages, grounding, args, d_m


def expected_gradients(model: CommDDPG, data, signals: str):
    """By hand, on a copy: the reward model's regression gradient and the extractor's gradient
    ``Jᵀ d`` with ``d`` mixed as the GSNMAX docstring says."""
    ref = copy.deepcopy(model.policy.gsn).train(True)  # the callback trains in training mode
    messages = ref.message(data.observations)
    sent = messages.detach().requires_grad_(True)
    loss = ref.loss(data.observations, data.actions, data.rewards, messages=sent)
    *reward_grads, d_g = th.autograd.grad(loss, [*ref.reward_model.parameters(), sent])
    g = receiver_gradient_by_hand(model, data, messages)
    m0 = messages.detach()
    d_m = -g / len(g)
    rms = lambda x: x.pow(2).mean().sqrt()  # noqa: E731
    d = {
        "grounding": d_g,
        "maximising": d_m,
        "both": rms(d_g) * ((1 - WEIGHT) * d_g / rms(d_g) + WEIGHT * d_m / rms(d_m)),
    }[signals]
    d = -inverted(-d, m0)
    extractor_grads = th.autograd.grad(messages, list(ref.message_extractor.parameters()), grad_outputs=d)
    return reward_grads, extractor_grads, d


def test_the_maximising_gradient_is_tcgs_receiver_gradient_inverted() -> None:
    model = replay_filled_model()
    policy = model.policy
    data = sample(model)
    messages = policy.gsn.message(data.observations).detach()
    g = receiver_gradient_by_hand(model, data, messages)
    assert g.abs().sum() > 0
    # ... which is TCG's message gradient for these messages
    out = th.cat([policy.actor_outputs(data.observations).detach(), messages], dim=-1)
    th.testing.assert_close(
        TCG.teammate_message_gradients(policy, out, data.next_observations, data.dones), g
    )
    # the loss gradient −g / B through inverting gradients for the bound [-1, 1]
    grounding = th.randn_like(messages)
    d, stats = policy.comm_method.message_gradient(
        policy, messages, grounding, data.next_observations, data.dones, signals="maximising"
    )
    th.testing.assert_close(d, -inverted(g, messages) / len(g))
    th.testing.assert_close(stats["gsn/maximising_grad_rms"], (g / len(g)).pow(2).mean().sqrt())


def test_the_mix_scales_each_signal_to_unit_rms() -> None:
    model, _, messages, grounding, args, d_m = mix_inputs()
    policy = model.policy
    rms = lambda x: x.pow(2).mean().sqrt()  # noqa: E731
    for w in (0.0, 0.25, 1.0):
        d, _ = policy.comm_method.message_gradient(*args, weight=w)
        mix = rms(grounding) * ((1 - w) * grounding / rms(grounding) + w * d_m / rms(d_m))
        th.testing.assert_close(d, -inverted(-mix, messages))
    grounding_only = -inverted(-grounding, messages)
    th.testing.assert_close(policy.comm_method.message_gradient(*args, weight=0.0)[0], grounding_only)
    th.testing.assert_close(
        policy.comm_method.message_gradient(*args, signals="grounding")[0], grounding_only
    )


@pytest.mark.parametrize("signals", ["both", "grounding", "maximising"])
def test_one_update_moves_the_extractor_along_the_mix_and_the_reward_model_along_the_regression(
    signals: str,
) -> None:
    model = replay_filled_model(signals)
    gsn = model.policy.gsn
    critic_before, actor_before = params(model.policy.critic), params(model.policy.actor)
    extractor_before, reward_before = params(gsn.message_extractor), params(gsn.reward_model)
    reward_grads, extractor_grads, _ = expected_gradients(model, sample(model), signals)

    one_callback_update(model)
    assert_adam_first_step(extractor_before, params(gsn.message_extractor), extractor_grads)
    assert_adam_first_step(reward_before, params(gsn.reward_model), reward_grads)
    # the agents did not move, and no gradient was left on them
    assert all(th.equal(a, b) for a, b in zip(critic_before, model.policy.critic.parameters(), strict=True))
    assert all(th.equal(a, b) for a, b in zip(actor_before, model.policy.actor.parameters(), strict=True))
    assert all(p.grad is None for p in model.policy.critic.parameters())


def test_switching_a_signal_off_changes_the_step() -> None:
    steps = {}
    for signals in ("both", "grounding", "maximising"):
        model = replay_filled_model(signals)
        before = params(model.policy.gsn.message_extractor)
        one_callback_update(model)
        after = params(model.policy.gsn.message_extractor)
        steps[signals] = th.cat([(a - b).flatten() for a, b in zip(after, before, strict=True)])
    assert not th.allclose(steps["both"], steps["grounding"])
    assert not th.allclose(steps["both"], steps["maximising"])
    assert not th.allclose(steps["grounding"], steps["maximising"])


@pytest.mark.parametrize("explore", [True, False])
def test_gsn_max_explores_its_messages_unless_told_not_to(explore: bool) -> None:
    model = replay_filled_model(gsn_max_explore_messages=explore)
    model._last_obs = model.env.reset()
    model.num_timesteps = 0  # warm-up: epsilon = 1
    _, buffer_action = model._sample_action(learning_starts=100, n_envs=2)
    expected = model.policy._predict(th.as_tensor(model._last_obs)).detach().numpy()
    sl = model.comm_layout.action_message_slice
    assert np.allclose(buffer_action[..., sl], expected[..., sl], atol=1e-6) is not explore
    assert not np.allclose(buffer_action[..., : sl.start], expected[..., : sl.start])


def test_save_load_keeps_the_optimizer_and_the_settings(tmp_path) -> None:
    model = replay_filled_model("maximising")
    model.gsn_max_signals = "both"
    one_callback_update(model)
    path = tmp_path / "gsn_max.zip"
    model.save(path)
    loaded = CommDDPG.load(path, device="cpu")
    assert loaded.method == "GSN-MAX"
    assert (loaded.gsn_max_weight, loaded.gsn_max_signals, loaded.gsn_max_explore_messages) == (
        WEIGHT,
        "both",
        True,
    )
    assert_loaded_like(model, loaded, "optimizer")


def assert_loaded_like(model: CommDDPG, loaded: CommDDPG, optimizer: str) -> None:
    """``loaded`` has the GSN's parameters and the state of its optimizer ``optimizer`` (an
    attribute of the GSN), and acts as ``model`` does."""
    saved = getattr(model.policy.gsn, optimizer).state_dict()["state"]
    restored = getattr(loaded.policy.gsn, optimizer).state_dict()["state"]
    assert saved and saved.keys() == restored.keys()
    for k in saved:
        th.testing.assert_close(saved[k]["exp_avg"], restored[k]["exp_avg"])
    for a, b in zip(model.policy.gsn.parameters(), loaded.policy.gsn.parameters(), strict=True):
        th.testing.assert_close(a, b)
    obs = model.env.reset()
    np.testing.assert_array_equal(model.predict(obs)[0], loaded.predict(obs)[0])


def test_bad_signals_are_a_clear_error() -> None:
    vec = make_vec_env(coin_env, n_envs=1)
    with pytest.raises(ValueError, match=r"gsn_max_signals must be 'both' or 'grounding' or 'maximising'"):
        CommDDPG("GSN-MAX", vec, gsn_max_signals="max")
    with pytest.raises(ValueError, match="gsn_max_weight"):
        CommDDPG("GSN-MAX", vec, gsn_max_weight=1.5)
    with pytest.raises(ValueError, match="gsn_max_signals applies to GSN-MAX only"):
        CommDDPG("GSN", vec, gsn_max_signals="maximising")
    with pytest.raises(ValueError, match="gsn_max_explore_messages applies to GSN-MAX only"):
        CommDDPG("TCG", vec, gsn_max_explore_messages=False)
    with pytest.raises(TypeError, match="gsn_max_explore_messages"):
        CommDDPG("GSN-MAX", vec, gsn_max_explore_messages="yes")


def test_the_reward_model_can_also_hear_what_the_teammate_heard(tmp_path) -> None:
    """With ``gsn_reward_hears=True`` R sees the message the teammate heard (the end of the
    teammate's row); by default (GSN-MAX's configuration, and GSN, the paper) it does not."""
    assert replay_filled_model().policy.gsn.heard_dim == 0
    vec = make_vec_env(coin_env, n_envs=2, seed=0)
    kwargs = {**EARLIER, "net_arch": [32, 32], "gsn_net_arch": [16], "gsn_reward_hears": True}
    model = CommDDPG("GSN-MAX", vec, share_parameters=False, policy_kwargs=kwargs, seed=0, device="cpu")
    gsn = model.policy.gsn
    n, obs_dim = model.comm_layout.channel_size, model.comm_layout.obs_dim
    assert gsn.reward_model.nets[0][0].in_features == n + gsn.teammate_action_dim + n
    obs = th.randn(5, 2, obs_dim)
    actions = th.randn(5, 2, model.comm_layout.action_dim)
    changed = obs.clone()
    changed[:, 1, obs_dim - n :] += 0.5  # what agent 1 heard: only row 0's prediction of r_1 moves
    with th.no_grad():
        before = gsn.predict_teammate_reward(obs, actions.flip(1))
        after = gsn.predict_teammate_reward(changed, actions.flip(1))
        messages = gsn.message(obs)
    assert not th.allclose(before[:, 0], after[:, 0])
    # row 1's own message changes with its observation, row 1's prediction with it; with the
    # message held fixed, only the heard input matters
    with th.no_grad():
        fixed = gsn._raw_prediction(changed, actions.flip(1), messages)
        base = gsn._raw_prediction(obs, actions.flip(1), messages)
    th.testing.assert_close(fixed[:, 1], base[:, 1])

    model.save(tmp_path / "hears.zip")
    assert CommDDPG.load(tmp_path / "hears.zip", device="cpu").policy.gsn.heard_dim == n

    paper_gsn = CommDDPG(
        "GSN", make_vec_env(coin_env, n_envs=1),
        policy_kwargs={"gsn_net_arch": [16], "gsn_reward_sees_teammate": False},
    ).policy.gsn  # fmt: skip
    assert paper_gsn.heard_dim == 0
    assert paper_gsn.reward_model.nets[0][0].in_features == n + paper_gsn.teammate_action_dim


def test_the_warmup_raises_the_maximising_share_linearly_and_is_saved(tmp_path) -> None:
    """``gsn_max_warmup``: ``w`` rises from 0 to ``gsn_max_weight`` over that fraction of training;
    its first update is then the grounding's alone, and the option is saved with the model."""
    callback = GSNTrainingCallback(max_weight=0.4, max_warmup=0.25)
    assert callback.current_max_weight(1.0) == 0.0
    assert callback.current_max_weight(0.9) == pytest.approx(0.16)  # 10 % of training: 0.4 · 0.1/0.25
    assert callback.current_max_weight(0.75) == pytest.approx(0.4)
    assert callback.current_max_weight(0.1) == pytest.approx(0.4)
    assert GSNTrainingCallback(max_weight=0.4).current_max_weight(1.0) == 0.4  # no warm-up

    steps = {}
    for signals, warmup in (("both", 0.5), ("grounding", 0.0)):
        model = replay_filled_model(signals)
        model._current_progress_remaining = 1.0  # the start of training: w = 0 with the warm-up
        before = params(model.policy.gsn.message_extractor)
        callback = GSNTrainingCallback(
            model.gsn_learning_rate, 16, model.max_grad_norm,
            max_weight=model.gsn_max_weight, signals=signals, max_warmup=warmup,
        )  # fmt: skip
        callback.init_callback(model)
        np.random.seed(7)
        callback.train_gsn(1)
        after = params(model.policy.gsn.message_extractor)
        steps[signals] = th.cat([(a - b).flatten() for a, b in zip(after, before, strict=True)])
    th.testing.assert_close(steps["both"], steps["grounding"], rtol=1e-4, atol=1e-9)

    model = replay_filled_model(gsn_max_warmup=0.3)
    model.save(tmp_path / "warm.zip")
    assert CommDDPG.load(tmp_path / "warm.zip", device="cpu").gsn_max_warmup == 0.3


def test_a_bad_warmup_is_a_clear_error() -> None:
    vec = make_vec_env(coin_env, n_envs=1)
    with pytest.raises(ValueError, match=r"gsn_max_warmup must be a number in \[0, 1\), got 1.0"):
        CommDDPG("GSN-MAX", vec, gsn_max_warmup=1.0)
    with pytest.raises(ValueError, match="gsn_max_warmup applies to GSN-MAX only"):
        CommDDPG("GSN", vec, gsn_max_warmup=0.2)


def test_the_maximising_share_is_logged_for_gsn_maxs_mix_only() -> None:
    """``gsn/maximising_weight`` is GSN-MAX's (both signals); GSN has no share to log."""
    logged = {}
    for method in ("GSN-MAX", "GSN"):
        vec = make_vec_env(coin_env, n_envs=2, seed=0)
        model = CommDDPG(
            method, vec, batch_size=16, learning_starts=20, share_parameters=False, seed=0, device="cpu",
            policy_kwargs={"net_arch": [32, 32], "gsn_net_arch": [16], "gsn_reward_net_arch": [16]}
            | (EARLIER if method == "GSN-MAX" else {}),
            **({"gsn_max_weight": WEIGHT} if method == "GSN-MAX" else {}),
        )  # fmt: skip
        model.learn(60)
        logged[method] = model.train_log.pop_means()
    assert logged["GSN-MAX"]["gsn/maximising_weight"] == pytest.approx(WEIGHT)
    assert "gsn/maximising_weight" not in logged["GSN"] and "gsn/loss" in logged["GSN"]


def test_the_centred_mix_removes_the_maximising_signals_batch_mean() -> None:
    """``gsn_max_centred``: the maximising signal less its mean over the batch's non-terminal rows
    (per sender and entry), divided by the uncentred signal's RMS; a signal that is the same in
    every state then adds nothing, and the share of the state-dependent part is logged."""
    model, data, messages, grounding, args, d_m = mix_inputs()
    policy = model.policy
    live = 1 - data.dones[:, 0]
    assert live.sum() > 0
    mean = (d_m * live[:, None, None]).sum(0) / live.sum()
    centred = (d_m - mean) * live[:, None, None]
    rms = lambda x: x.pow(2).mean().sqrt()  # noqa: E731
    d, stats = policy.comm_method.message_gradient(*args, weight=WEIGHT, centred=True)
    mix = rms(grounding) * ((1 - WEIGHT) * grounding / rms(grounding) + WEIGHT * centred / rms(d_m))
    th.testing.assert_close(d, -inverted(-mix, messages))
    th.testing.assert_close(stats["gsn/maximising_state_share"], rms(centred) / rms(d_m))
    assert not th.allclose(d, policy.comm_method.message_gradient(*args, weight=WEIGHT)[0])

    # a critic whose message gradient is the same in every state: only the grounding moves messages
    from sb3_comm.comm_ddpg import methods

    same = th.tensor([[0.3, -0.2]]).expand(len(messages), 2).reshape(len(messages), 2, 1)
    same = same.expand_as(messages).clone()
    original = methods.GSNMAX._maximising
    methods.GSNMAX._maximising = staticmethod(lambda *a: same)  # type: ignore[method-assign]
    try:
        no_dones = th.zeros_like(data.dones)
        d, stats = policy.comm_method.message_gradient(
            policy, messages, grounding, data.next_observations, no_dones, weight=WEIGHT, centred=True
        )
    finally:
        methods.GSNMAX._maximising = original  # type: ignore[method-assign]
    th.testing.assert_close(d, -inverted(-(1 - WEIGHT) * grounding, messages))
    assert float(stats["gsn/maximising_state_share"]) == pytest.approx(0.0, abs=1e-6)


def test_centring_is_gsn_max_only_saved_and_checked(tmp_path) -> None:
    vec = make_vec_env(coin_env, n_envs=1)
    with pytest.raises(ValueError, match="gsn_max_centred applies to GSN-MAX only"):
        CommDDPG("GSN", vec, gsn_max_centred=True)
    with pytest.raises(TypeError, match="gsn_max_centred must be True or False, got 'yes'"):
        CommDDPG("GSN-MAX", vec, gsn_max_centred="yes")
    with pytest.raises(ValueError, match="gsn_max_sgd shape the maximising signal of"):
        CommDDPG("GSN-MAX", vec, gsn_max_centred=True, policy_kwargs={"gsn_maximising_head": True})
    with pytest.raises(ValueError, match="gsn_max_sgd shape the maximising signal"):
        CommDDPG("GSN-MAX", vec, gsn_max_sgd=1.0, policy_kwargs={"gsn_maximising_head": True})
    model = replay_filled_model(gsn_max_centred=True)
    callback = model._init_callback(None)
    assert model.gsn_callback.centred is True and callback is not None
    model.save(tmp_path / "centred.zip")
    assert CommDDPG.load(tmp_path / "centred.zip", device="cpu").gsn_max_centred is True


def test_the_raw_mix_keeps_each_signals_size() -> None:
    """``gsn_max_gain=κ``: ``d = (1 − w)·d_g + w·κ·d_m`` with neither signal rescaled, so a tiny
    maximising signal stays tiny (the unit-RMS mix would blow it up to the grounding's size)."""
    model, _, messages, grounding, args, d_m = mix_inputs()
    policy = model.policy
    for gain in (0.5, 20.0):
        d, _ = policy.comm_method.message_gradient(*args, weight=WEIGHT, gain=gain)
        th.testing.assert_close(d, -inverted(-((1 - WEIGHT) * grounding + WEIGHT * gain * d_m), messages))
    assert not th.allclose(d, policy.comm_method.message_gradient(*args, weight=WEIGHT)[0])


def test_a_bad_gain_is_a_clear_error(tmp_path) -> None:
    vec = make_vec_env(coin_env, n_envs=1)
    with pytest.raises(ValueError, match="gsn_max_gain must be a number > 0"):
        CommDDPG("GSN-MAX", vec, gsn_max_gain=0.0)
    with pytest.raises(ValueError, match="gsn_max_gain applies to GSN-MAX only"):
        CommDDPG("TCG", vec, gsn_max_gain=2.0)
    model = replay_filled_model(gsn_max_gain=5.0)
    model._init_callback(None)
    assert model.gsn_callback.gain == 5.0
    model.save(tmp_path / "gain.zip")
    assert CommDDPG.load(tmp_path / "gain.zip", device="cpu").gsn_max_gain == 5.0


def test_the_plain_maximising_step_adds_to_the_groundings_adam_step() -> None:
    """``gsn_max_sgd=c``: the extractor takes the grounding's Adam step (as ``signals="grounding"``)
    plus ``−c·lr·Jᵀ d_m``, the maximising signal's plain gradient step, so that a small signal moves
    it little; the reward model takes the regression's step alone."""
    c = 50.0
    model = replay_filled_model(gsn_max_sgd=c)
    gsn = model.policy.gsn
    data = sample(model)
    _, grounding_grads, _ = expected_gradients(model, data, "grounding")
    ref = copy.deepcopy(gsn).train(True)
    messages = ref.message(data.observations)
    d_m = -receiver_gradient_by_hand(model, data, messages) / len(messages)
    plain = th.autograd.grad(
        messages, list(ref.message_extractor.parameters()), grad_outputs=-inverted(-d_m, messages.detach())
    )
    before = params(gsn.message_extractor)
    callback = GSNTrainingCallback(LR, 16, model.max_grad_norm, sgd=c)
    callback.init_callback(model)
    np.random.seed(7)
    callback.train_gsn(1)
    after = params(gsn.message_extractor)
    adam_part = [a - b + c * LR * p for a, b, p in zip(after, before, plain, strict=True)]
    assert_adam_first_step(before, [b + d for b, d in zip(before, adam_part, strict=True)], grounding_grads)
    assert any(p.abs().max() > 1e-6 for p in plain)
    vec = make_vec_env(coin_env, n_envs=1)
    with pytest.raises(ValueError, match="gsn_max_sgd steps the two signals apart"):
        CommDDPG("GSN-MAX", vec, gsn_max_sgd=1.0, gsn_max_signals="grounding", policy_kwargs=EARLIER)
    with pytest.raises(ValueError, match="gsn_max_sgd applies to GSN-MAX only"):
        CommDDPG("GSN", vec, gsn_max_sgd=1.0)
