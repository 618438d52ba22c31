"""GSN-MAX's effect search (``gsn_max_search``, ``gsn_max_explorers`` and ``policy_kwargs``
``gsn_effect_model=True``): two centralised one-step effect models of the receiver's reward,
explorer games that send random messages for them, and a pull of each message towards the best
candidate by the messages' direct effect; where nothing is pulled the step is GSN's."""

from __future__ import annotations

import copy
from types import SimpleNamespace

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.env_util import make_vec_env
from test_gsn_max import params, sample
from toy_envs import coin_env

from sb3_comm import CommDDPG
from sb3_comm.comm_ddpg import GSNTrainingCallback
from sb3_comm.comm_ddpg.methods import GSNMAX
from sb3_comm.common.networks import MLP, gradient_step, mlp

LR = 1e-3
SMALL = {"net_arch": [32, 32], "gsn_net_arch": [16], "gsn_reward_net_arch": [16], "gsn_effect_model": True}


def search_model(n_envs: int = 4, signals: str = "both", **kwargs) -> CommDDPG:
    """A GSN-MAX model with effect models and one explorer game in four, whose replay holds 240
    joint transitions and which has made no update yet."""
    vec = make_vec_env(coin_env, n_envs=n_envs, seed=0)
    settings = {"gsn_max_search": 8, "gsn_max_explorers": 0.25, "gsn_max_explore_messages": False, **kwargs}
    model = CommDDPG(
        "GSN-MAX", vec, batch_size=16, learning_starts=10_000, gsn_learning_rate=LR, gsn_max_signals=signals,
        share_parameters=False, seed=0, device="cpu", policy_kwargs=SMALL, **settings,
    )  # fmt: skip
    model.learn(240)
    assert model.n_updates == 0 and not model.policy.gsn.optimizer.state_dict()["state"]
    return model


class Bump(th.nn.Module):
    """A stand-in effect model: a bump of height 3 at ``centre`` in input ``index`` (the heard
    message)."""

    def __init__(self, index: int, centre: float) -> None:
        super().__init__()
        self.index, self.centre = index, centre

    def forward(self, x: th.Tensor) -> th.Tensor:
        return 3.0 * th.exp(-20.0 * (x[..., self.index : self.index + 1] - self.centre) ** 2)


def test_explorer_games_send_random_messages_and_only_train_the_effect_models() -> None:
    model = search_model()
    buffer, layout = model.replay_buffer, model.comm_layout
    assert model.explorer_envs == buffer.explorer_envs == 1
    # acting: the last game's messages are uniformly random, the others' are M(o)
    model._last_obs = model.env.reset()
    model.num_timesteps = 10**6  # past the warm-up; messages are not explored otherwise
    model.exploration_rate = 0.0
    _, actions = model._sample_action(learning_starts=0, n_envs=4)
    rows = actions.reshape(4, layout.n_agents, layout.action_dim)
    sent = model.policy._predict(th.as_tensor(model._last_obs)).detach().numpy()
    sent = sent.reshape(4, layout.n_agents, layout.action_dim)
    sl = layout.action_message_slice
    np.testing.assert_allclose(rows[:3], sent[:3], atol=1e-6)
    assert not np.allclose(rows[3, :, sl], sent[3, :, sl])
    # replay: the agents' (and the grounding's) batches never hold an explorer game's transition
    stored = buffer.actions[: buffer.pos, :, :, sl]
    explorer_messages = {float(v) for v in stored[:, 3].ravel()}
    for _ in range(20):
        drawn = buffer.sample(16).actions[..., sl].numpy().ravel()
        assert not explorer_messages & {float(v) for v in drawn}
    # ... and the effect models' batches hold only those
    drawn = buffer.sample_explorers(64).actions[..., sl].numpy().ravel()
    assert {float(v) for v in drawn} <= explorer_messages


def test_without_explorer_games_the_buffer_samples_as_before() -> None:
    vec = make_vec_env(coin_env, n_envs=2, seed=0)
    model = CommDDPG(
        "GSN-MAX", vec, learning_starts=10_000, seed=0, gsn_max_explorers=0.0, policy_kwargs={**SMALL}
    )
    model.learn(40)
    assert model.explorer_envs == 0 and model.replay_buffer.explorer_envs == 0
    np.random.seed(3)
    inds = np.random.randint(0, 20, size=16), np.random.randint(0, 2, size=16)
    np.random.seed(3)
    drawn = model.replay_buffer.sample(16)
    th.testing.assert_close(
        drawn.observations, model.replay_buffer.to_torch(model.replay_buffer.observations[inds])
    )
    with pytest.raises(ValueError, match="no explorer games"):
        model.replay_buffer.sample_explorers(4)


def test_the_search_pulls_towards_the_candidate_both_effect_models_find_better() -> None:
    model = search_model()
    policy, gsn = model.policy, model.policy.gsn
    layout = model.comm_layout
    data = sample(model)
    sent = gsn.message(data.observations).detach()
    # stand-in effect models: a bump at +0.5 in the heard message (its input column comes after
    # both situations)
    column = 2 * layout.obs_message_slice.start
    for k in range(2):
        gsn.effect_model[k] = _PerAgent(th.nn.ModuleList([Bump(column, 0.5), Bump(column, 0.5)]))
    gsn.effect_r2.fill_(1.0)  # models that explain everything: the floor is SEARCH_MARGIN
    dones = th.zeros_like(data.dones)
    dones[:4] = 1.0
    th.manual_seed(11)
    targets, pulled, gain = GSNMAX.search_targets(policy, sent, data.next_observations, dones, 64)
    th.manual_seed(11)
    tried = th.rand((64, *sent.shape)) * 2.0 - 1.0  # the same draws, in heard (receiver) order
    received = sent.flip(1)
    tried[32:] = (received + GSNMAX.SEARCH_LOCAL_STD * th.randn((32, *sent.shape))).clamp(-1.0, 1.0)
    index = (-(tried[..., 0] - 0.5).pow(2)).argmax(dim=0)  # the bump reads the first entry
    best = th.gather(tried, 0, index[None, ..., None].expand(1, *sent.shape))[0]
    bump = lambda m: 3.0 * th.exp(-20.0 * (m[..., 0] - 0.5) ** 2)  # noqa: E731
    expected_gain = bump(best) - bump(received)
    th.testing.assert_close(gain, expected_gain.flip(1))
    # both models agree (no disagreement): pulled where the gain exceeds the floor
    expected_pulled = (expected_gain > GSNMAX.SEARCH_MARGIN) & (dones < 0.5)
    th.testing.assert_close(pulled, expected_pulled.flip(1).float())
    assert pulled.sum() > 0 and pulled[:4].sum() == 0  # terminal transitions are never pulled
    expected_targets = th.where(expected_pulled[..., None], best, received).flip(1)
    th.testing.assert_close(targets, expected_targets)


class _PerAgent(th.nn.Module):
    """Two stand-in networks applied per agent row, as :class:`AgentMLPs` with
    ``share_parameters=False``."""

    def __init__(self, nets: th.nn.ModuleList) -> None:
        super().__init__()
        self.nets = nets

    def forward(self, x: th.Tensor) -> th.Tensor:
        return th.stack([net(x[:, i]) for i, net in enumerate(self.nets)], dim=1)


def one_update(model: CommDDPG, sample_seed: int = 7) -> GSNTrainingCallback:
    callback = GSNTrainingCallback(
        model.gsn_learning_rate, 16, model.max_grad_norm, max_weight=model.gsn_max_weight,
        signals=model.gsn_max_signals, search=model.gsn_max_search,
    )  # fmt: skip
    callback.init_callback(model)
    np.random.seed(sample_seed)
    th.manual_seed(sample_seed)
    callback.train_gsn(1)
    return callback


def test_where_nothing_is_pulled_the_message_network_takes_gsns_step() -> None:
    """With the pull's weight at 0 (the effect models explain nothing yet: R² = 0), one update moves
    ``M`` and ``R`` exactly as GSN's regression step, and the effect models by their own loss."""
    model = search_model()
    gsn = model.policy.gsn
    reference = copy.deepcopy(gsn).train(True)
    reference.optimizer = th.optim.Adam(reference.parameters(), lr=LR)
    np.random.seed(7)
    data = model.replay_buffer.sample(16)
    explorers = model.replay_buffer.sample_explorers(16)
    loss = reference.loss(data.observations, data.actions, data.rewards)
    effect_loss = reference.effect_loss(explorers.observations, explorers.actions, explorers.rewards)
    target = reference.eval().effect_target(explorers.rewards)  # standardised, moments as updated
    r2 = (1.0 - effect_loss.detach() / target.var(unbiased=False)).clamp(0.0, 1.0)
    gradient_step(reference.optimizer, loss + effect_loss, model.max_grad_norm)

    assert float(gsn.effect_r2) == 0.0
    one_update(model)
    for mine, theirs in zip(gsn.parameters(), reference.parameters(), strict=True):
        th.testing.assert_close(mine, theirs)
    # the running R² moved by one batch's share, for the next update's pull
    th.testing.assert_close(gsn.effect_r2, GSNTrainingCallback.EFFECT_R2_RATE * r2)


def test_the_pull_is_the_gradient_of_half_the_squared_distance_before_the_tanh() -> None:
    model = search_model(signals="maximising")
    gsn = model.policy.gsn
    obs = sample(model).observations
    raw = gsn.message_extractor(obs)
    targets = th.full_like(raw, 0.5)
    pulled = th.ones(raw.shape[:-1])
    pull = 0.5 * ((raw - th.atanh(targets)).pow(2).sum(-1) * pulled).mean()
    grad = th.autograd.grad(pull, raw)[0]
    th.testing.assert_close(grad, (raw - th.atanh(targets)) / pulled.numel())


def test_save_load_keeps_the_effect_models_and_the_settings(tmp_path) -> None:
    model = search_model()
    one_update(model)
    path = tmp_path / "search.zip"
    model.save(path)
    loaded = CommDDPG.load(path, env=make_vec_env(coin_env, n_envs=4, seed=0), device="cpu")
    assert (loaded.gsn_max_search, loaded.gsn_max_explorers, loaded.explorer_envs) == (8, 0.25, 1)
    assert loaded.replay_buffer is None or loaded.replay_buffer.explorer_envs == 1
    assert loaded.policy.gsn.effect_model is not None
    for a, b in zip(
        model.policy.gsn.state_dict().values(), loaded.policy.gsn.state_dict().values(), strict=True
    ):
        th.testing.assert_close(a, b)
    loaded.learn(40)  # and it trains on


def test_bad_settings_are_a_clear_error() -> None:
    vec = make_vec_env(coin_env, n_envs=2)
    earlier = {"gsn_effect_model": False}  # GSN-MAX's earlier design: no effect models
    with pytest.raises(ValueError, match="needs policy_kwargs gsn_effect_model=True"):
        CommDDPG("GSN-MAX", vec, gsn_max_search=8, policy_kwargs=earlier)
    with pytest.raises(ValueError, match="gsn_max_search applies to GSN-MAX only"):
        CommDDPG("GSN", vec, gsn_max_search=8)
    with pytest.raises(ValueError, match="gsn_max_explorers applies to GSN-MAX only"):
        CommDDPG("TCG", vec, gsn_max_explorers=0.25)
    with pytest.raises(ValueError, match="gsn_max_search must be a whole number"):
        CommDDPG("GSN-MAX", vec, gsn_max_search=-1)
    with pytest.raises(ValueError, match="gsn_max_explorers must be a number in"):
        CommDDPG("GSN-MAX", vec, gsn_max_explorers=1.0, policy_kwargs={"gsn_effect_model": True})
    with pytest.raises(ValueError, match="leaves none to the agents"):
        CommDDPG("GSN-MAX", make_vec_env(coin_env, n_envs=1), gsn_max_explorers=0.5,
                 policy_kwargs={"gsn_effect_model": True})  # fmt: skip
    with pytest.raises(ValueError, match="explorer games feed GSN-MAX's effect model"):
        CommDDPG("GSN-MAX", vec, gsn_max_explorers=0.5, policy_kwargs=earlier)
    with pytest.raises(ValueError, match="gsn_effect_model=True applies to GSN-MAX only"):
        CommDDPG("GSN", vec, policy_kwargs={"gsn_effect_model": True})
    with pytest.raises(ValueError, match="choose one"):
        CommDDPG("GSN-MAX", vec, policy_kwargs={"gsn_effect_model": True, "gsn_maximising_head": True})
    with pytest.raises(ValueError, match=r"\['gsn_effect_paths'\] must be 'total' or 'action' or 'direct'"):
        CommDDPG("GSN-MAX", vec, policy_kwargs={"gsn_effect_model": True, "gsn_effect_paths": "both"})


@pytest.mark.parametrize("signals", ["both", "grounding", "maximising"])
def test_one_update_follows_the_grounding_and_the_pull_by_hand(
    monkeypatch: pytest.MonkeyPatch, signals: str
) -> None:
    """With R²_E ≈ 1 the step is Adam's first step on ``L_g + L_E + λ·½ mean ‖raw − atanh(m*)‖²``,
    ``λ = w / (1 − w) · R²_E`` (w = 0.5), the pull taken before the ``tanh``, on the rows the search
    pulls. ``signals="grounding"`` leaves the pull out (GSN's step); ``"maximising"`` keeps the
    regression off the message network (``R`` still learns from it) and pulls at full weight."""
    model = search_model(signals=signals)
    policy, gsn = model.policy, model.policy.gsn
    gsn.effect_r2.fill_(1.0)  # w / (1 − w) · R² = 1 at w = 0.5
    monkeypatch.setattr(GSNMAX, "SEARCH_MARGIN", 0.0)  # fresh effect models barely vary: pull on any gain
    reference = copy.deepcopy(gsn).train(True)
    np.random.seed(7)
    th.manual_seed(7)
    data = model.replay_buffer.sample(16)
    explorers = model.replay_buffer.sample_explorers(16)
    raw = reference.message_extractor(data.observations)
    messages = th.tanh(raw)
    grounded = messages.detach() if signals == "maximising" else messages
    loss = reference.loss(data.observations, data.actions, data.rewards, messages=grounded)
    effect_loss = reference.effect_loss(explorers.observations, explorers.actions, explorers.rewards)
    target = reference.eval().effect_target(explorers.rewards)
    reference.train(True)
    r2 = (1.0 - effect_loss.detach() / target.var(unbiased=False)).clamp(0.0, 1.0)
    running = 1.0 + GSNTrainingCallback.EFFECT_R2_RATE * (r2 - 1.0)  # the running R², this batch in
    reference.effect_r2.fill_(float(running))  # what the search reads (its error floor)
    weight = {"both": running, "grounding": 0.0, "maximising": 1.0}[signals]
    loss = loss + effect_loss
    reference_policy = SimpleNamespace(
        gsn=reference, comm_layout=policy.comm_layout, actor_outputs=policy.actor_outputs
    )
    targets, pulled, _ = GSNMAX.search_targets(
        reference_policy, messages.detach(), data.next_observations, data.dones, model.gsn_max_search
    )
    assert 0 < pulled.sum() < pulled.numel()  # some rows pulled, some not
    distance = (raw - th.atanh(targets.clamp(-0.995, 0.995))).pow(2).sum(-1)
    loss = loss + weight * 0.5 * (distance * pulled).mean()
    grads = th.autograd.grad(loss, list(reference.parameters()), allow_unused=True)
    alone = copy.deepcopy(gsn).train(True)  # the grounding's gradient alone, from the same state
    grounding_only = th.autograd.grad(
        alone.loss(data.observations, data.actions, data.rewards), list(alone.message_extractor.parameters())
    )

    before = params(gsn)
    one_update(model)
    for b, a, g in zip(before, gsn.parameters(), grads, strict=True):
        if g is None:
            assert th.equal(a, b)
            continue
        big = g.abs() > 1e-6
        th.testing.assert_close((a - b)[big], (-LR * g / (g.abs() + 1e-8))[big], rtol=1e-3, atol=1e-9)
    # the message network's step differs from the grounding's alone exactly where the pull is on
    extractor = [a - b for a, b in zip(gsn.message_extractor.parameters(), before, strict=False)]
    grounding_step = [-LR * g / (g.abs() + 1e-8) for g in grounding_only]
    same = all(th.allclose(x, y, atol=1e-7) for x, y in zip(extractor, grounding_step, strict=True))
    assert same is (signals == "grounding")


def test_a_gain_the_two_effect_models_disagree_about_is_not_pulled() -> None:
    """``E_1`` sees a bump of height 3 at +0.5, ``E_2`` the same bump at height ``h``: the judged
    gain ``h·Δ`` must exceed the disagreement ``(3 − h)·Δ`` (and the floor)."""
    model = search_model()
    policy, gsn = model.policy, model.policy.gsn
    data = sample(model)
    sent = gsn.message(data.observations).detach()
    column = 2 * model.comm_layout.obs_message_slice.start
    gsn.effect_r2.fill_(1.0)
    pulls = {}
    for height in (1.0, 2.0, 3.0):
        judge = Bump(column, 0.5)
        judge.forward = lambda x, judge=judge, height=height: Bump.forward(judge, x) * height / 3.0
        gsn.effect_model[0] = _PerAgent(th.nn.ModuleList([Bump(column, 0.5), Bump(column, 0.5)]))
        gsn.effect_model[1] = _PerAgent(th.nn.ModuleList([judge, judge]))
        th.manual_seed(5)
        _, pulled, gain = GSNMAX.search_targets(policy, sent, data.next_observations, data.dones, 64)
        claimed = gain * 3.0 / height
        expected = (gain > (claimed - gain).abs().clamp(min=GSNMAX.SEARCH_MARGIN)) & (data.dones < 0.5)
        th.testing.assert_close(pulled, expected.float())
        pulls[height] = int(pulled.sum())
    assert pulls[1.0] == 0  # the judge sees a third of the claimed gain: never confirmed
    assert pulls[3.0] >= pulls[2.0] > 0  # two thirds or all of it: confirmed above the floor


def test_a_gain_within_the_effect_models_error_is_not_pulled() -> None:
    """The same bump for both models: with R²_E = 0.75 (an RMS residual of 0.5 reward std) only gains
    above 0.5 are pulled; with R²_E = 0, none below 1."""
    model = search_model()
    policy, gsn = model.policy, model.policy.gsn
    data = sample(model)
    sent = gsn.message(data.observations).detach()
    column = 2 * model.comm_layout.obs_message_slice.start
    for k in range(2):
        gsn.effect_model[k] = _PerAgent(th.nn.ModuleList([Bump(column, 0.5), Bump(column, 0.5)]))
    for r2, floor in ((1.0, GSNMAX.SEARCH_MARGIN), (0.75, 0.5), (0.0, 1.0)):
        gsn.effect_r2.fill_(r2)
        th.manual_seed(5)
        _, pulled, gain = GSNMAX.search_targets(policy, sent, data.next_observations, data.dones, 64)
        expected = (gain > floor) & (data.dones < 0.5)
        th.testing.assert_close(pulled, expected.float())
        assert pulled.sum() > 0 or floor == 1.0


def test_a_new_gsn_max_is_the_effect_search_and_old_designs_keep_theirs(tmp_path) -> None:
    """``CommDDPG("GSN-MAX", env)`` with nothing set is the packaged design's method (effect models,
    16 candidates, a quarter of the games explorers, w = 0.8, no ε-random messages); the earlier
    design (no effect models, or the head) keeps its own defaults; one game leaves no explorer
    games, with a warning; what a model was trained with survives save and load."""
    model = CommDDPG("GSN-MAX", make_vec_env(coin_env, n_envs=8, seed=0), seed=0)
    assert model.policy.gsn.effect_model is not None
    assert (model.gsn_max_search, model.gsn_max_explorers, model.explorer_envs) == (16, 0.25, 2)
    assert (model.gsn_max_weight, model.gsn_max_explore_messages) == (0.8, False)
    model.save(tmp_path / "search.zip")
    loaded = CommDDPG.load(tmp_path / "search.zip", device="cpu")
    assert (loaded.gsn_max_search, loaded.gsn_max_explorers, loaded.gsn_max_weight) == (16, 0.25, 0.8)
    earlier = CommDDPG("GSN-MAX", make_vec_env(coin_env, n_envs=2), policy_kwargs={"gsn_effect_model": False})
    assert earlier.policy.gsn.effect_model is None
    assert (earlier.gsn_max_search, earlier.gsn_max_explorers, earlier.explorer_envs) == (None, 0.0, 0)
    assert (earlier.gsn_max_weight, earlier.gsn_max_explore_messages) == (0.5, True)
    head = CommDDPG("GSN-MAX", make_vec_env(coin_env, n_envs=2), policy_kwargs={"gsn_maximising_head": True})
    assert head.policy.gsn.effect_model is None and head.gsn_max_weight == 0.5
    with pytest.warns(UserWarning, match="one parallel game"):
        single = CommDDPG("GSN-MAX", make_vec_env(coin_env, n_envs=1))
    assert single.explorer_envs == 0 and single.gsn_max_search == 16
    tcg = CommDDPG("TCG", make_vec_env(coin_env, n_envs=2))
    assert (tcg.gsn_max_search, tcg.gsn_max_explorers, tcg.gsn_max_explore_messages) == (None, 0.0, True)


@pytest.mark.parametrize("precision", [None, th.bfloat16])
@pytest.mark.parametrize("layer_norm", [False, True])
def test_an_mlp_on_candidates_that_differ_in_some_columns_equals_it_on_each_assembled_input(
    precision: th.dtype | None, layer_norm: bool
) -> None:
    """``MLP.forward_candidates`` makes the first layer's product on the shared columns once; it
    gives what ``forward`` gives on every candidate's whole input (float32: to rounding; bfloat16
    hidden layers: to their precision)."""
    th.manual_seed(0)
    net = mlp(11, 3, [32, 32], th.nn.LeakyReLU, layer_norm=layer_norm)
    net.hidden_dtype = precision
    fixed, candidates = th.randn(6, 2, 8), th.randn(5, 6, 2, 3)
    columns = slice(4, 7)  # the varying columns sit inside the row
    whole = th.cat([fixed[..., :4].expand(5, 6, 2, 4), candidates, fixed[..., 4:].expand(5, 6, 2, 4)], dim=-1)
    got = net.forward_candidates(fixed, candidates, columns)
    assert got.shape == (5, 6, 2, 3) and got.dtype == th.float32
    tolerance = {"atol": 1e-5, "rtol": 1e-5} if precision is None else {"atol": 0.05, "rtol": 0.05}
    th.testing.assert_close(got, net(whole), **tolerance)
    with pytest.raises(TypeError, match="Linear first layer"):
        MLP(th.nn.Tanh(), th.nn.Linear(11, 3)).forward_candidates(fixed, candidates, columns)


@pytest.mark.parametrize("share_parameters", [True, False])
def test_the_effect_models_on_candidate_messages_equal_them_on_each_message(share_parameters: bool) -> None:
    """``effect_candidates`` (the effect search's evaluation of C heard messages) equals
    ``effect`` on each heard message, for shared and per-agent effect models."""
    vec = make_vec_env(coin_env, n_envs=4, seed=0)
    model = CommDDPG(
        "GSN-MAX", vec, learning_starts=10_000, seed=0, share_parameters=share_parameters, policy_kwargs=SMALL
    )
    model.learn(240)
    gsn = model.policy.gsn
    assert gsn.effect_model[0].share_parameters is share_parameters
    data = sample(model)
    start = model.comm_layout.obs_message_slice.start
    situation, actions = data.next_observations[..., :start], data.actions
    heard = th.rand((7, *gsn.message(data.observations).shape)) * 2.0 - 1.0
    for which in (0, 1):
        got = gsn.effect_candidates(situation, heard, actions, which)
        expected = th.stack([gsn.effect(situation, candidate, actions, which) for candidate in heard])
        th.testing.assert_close(got, expected, atol=1e-5, rtol=1e-5)
    assert not th.allclose(got[0], got[1])  # the candidates are told apart
