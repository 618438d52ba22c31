"""``policy_kwargs={"precision": "bfloat16"}``: the hidden layers of every network compute in
bfloat16, while parameters, gradients, optimizer state, outputs and losses stay float32; the
default (``"float32"``) computes as before."""

from __future__ import annotations

import re

import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3.common.env_util import make_vec_env
from toy_envs import coin_env

from sb3_comm import CommDDPG
from sb3_comm.comm_ddpg import gsn as gsn_module
from sb3_comm.comm_ddpg.gsn_worker import can_fork
from sb3_comm.common.networks import MLP, mlp, set_precision
from sb3_comm.hybrid_ddpg.policies import HybridPolicy

BF16 = {"precision": "bfloat16"}


def _output_dtypes(net: MLP, x: th.Tensor) -> list[th.dtype]:
    """The dtype each ``Linear`` of ``net`` returns on ``x``, in order."""
    seen: list[th.dtype] = []
    hooks = [
        layer.register_forward_hook(lambda _m, _i, out: seen.append(out.dtype))
        for layer in net
        if isinstance(layer, th.nn.Linear)
    ]
    try:
        net(x)
    finally:
        for hook in hooks:
            hook.remove()
    return seen


def test_bfloat16_hidden_layers_and_float32_output_parameters_and_gradients() -> None:
    th.manual_seed(0)
    net = mlp(6, 3, [32, 32], th.nn.LeakyReLU)
    x = th.randn(64, 6)
    exact = net(x)
    assert _output_dtypes(net, x) == [th.float32] * 3
    set_precision(net, "bfloat16")
    assert _output_dtypes(net, x) == [th.bfloat16, th.bfloat16, th.float32]
    out = net(x)
    assert out.dtype == th.float32
    # the same function to bfloat16's precision (8 bits of mantissa), not the same numbers
    th.testing.assert_close(out, exact, rtol=0.05, atol=0.02)
    assert not th.equal(out, exact)
    out.square().sum().backward()
    for name, param in net.named_parameters():
        assert param.dtype == th.float32 and param.grad is not None and param.grad.dtype == th.float32, name
        assert param.grad.abs().sum() > 0, name
    set_precision(net, "float32")
    assert th.equal(net(x), exact)  # back to the plain network, to the bit


def test_a_bad_precision_is_a_clear_error() -> None:
    said = r"precision must be one of \['float32', 'bfloat16'\] \(the arithmetic of the networks' hidden "
    said += r"layers\)"
    with pytest.raises(ValueError, match=said + ", got 'float16'"):
        set_precision(mlp(2, 1, [4], th.nn.ReLU), "float16")
    env = make_vec_env(coin_env, n_envs=1, seed=0)
    with pytest.raises(ValueError, match=r"policy_kwargs\['precision'\] must be 'float32' or 'bfloat16'"):
        CommDDPG("GSN", env, policy_kwargs={"precision": "half"})
    box = spaces.Box(-1.0, 1.0, (3,))
    with pytest.raises(ValueError, match=said + ", got 'bf16'"):  # the policy built directly
        HybridPolicy(box, box, lambda _: 1e-3, precision="bf16")


def _mlps(model: CommDDPG) -> dict[str, MLP]:
    return {name: m for name, m in model.policy.named_modules() if isinstance(m, MLP)}


@pytest.mark.parametrize("method", ["GSN", "TCG", "GSN-MAX"])
def test_every_network_of_a_team_trains_in_bfloat16_and_saves_the_setting(method: str, tmp_path) -> None:
    env = make_vec_env(coin_env, n_envs=2, seed=0)
    model = CommDDPG(
        method, env, batch_size=16, learning_starts=20, seed=0, policy_kwargs={"net_arch": [16], **BF16}
    )
    networks = _mlps(model)
    # actor, its target and average, critic and target, and GSN's extractor and reward model
    expected = {"actor", "actor_target", "actor_average", "critic", "critic_target"}
    if method != "TCG":
        expected |= {"gsn.message_extractor", "gsn.reward_model"}
    if method == "GSN-MAX":  # and the effect search's two effect models
        expected |= {"gsn.effect_model"}
    assert {re.sub(r"\.\d+$", "", name.rsplit(".nets.", 1)[0]) for name in networks} == expected
    assert all(net.hidden_dtype is th.bfloat16 for net in networks.values())
    before = {name: p.detach().clone() for name, p in model.policy.named_parameters()}
    model.learn(200)
    for name, param in model.policy.named_parameters():
        assert param.dtype == th.float32 and th.isfinite(param).all(), name
    trained = ("actor.", "critic.") if method == "TCG" else ("actor.", "critic.", "gsn.")
    moved = {name for name, p in model.policy.named_parameters() if not th.equal(p, before[name])}
    assert all(any(name.startswith(prefix) for name in moved) for prefix in trained)

    model.save(tmp_path / "team.zip")
    loaded = CommDDPG.load(tmp_path / "team.zip")
    assert loaded.policy.precision == "bfloat16"
    assert all(net.hidden_dtype is th.bfloat16 for net in _mlps(loaded).values())
    obs = env.reset()
    assert (model.predict(obs, deterministic=True)[0] == loaded.predict(obs, deterministic=True)[0]).all()


def test_float32_is_the_default_and_computes_as_before() -> None:
    env = make_vec_env(coin_env, n_envs=2, seed=0)
    model = CommDDPG("GSN", env, seed=0, policy_kwargs={"net_arch": [16]})
    assert model.policy.precision == "float32"
    assert all(net.hidden_dtype is None for net in _mlps(model).values())
    obs = th.randn(5, 2, model.policy.obs_dim)
    actor = model.policy.actor.nets[0]
    plain = th.nn.Sequential(*actor)  # the same layers as a plain Sequential
    assert th.equal(actor(obs[:, 0]), plain(obs[:, 0]))


@pytest.mark.skipif(not can_fork(), reason="the GSN's worker is forked: Linux only")
def test_the_gsn_worker_trains_in_bfloat16_too(monkeypatch: pytest.MonkeyPatch) -> None:
    """The GSN's worker process inherits the setting: with and without it, the same parameters."""
    states = []
    for beside in (True, False):
        monkeypatch.setattr(gsn_module, "spare_core", lambda beside=beside: beside)
        env = make_vec_env(coin_env, n_envs=2, seed=0)
        model = CommDDPG(
            "GSN", env, batch_size=16, learning_starts=20, seed=0, policy_kwargs={"net_arch": [16], **BF16}
        )
        model.learn(200)
        assert model.gsn_callback.n_updates > 0 and model.gsn_callback.uses_worker() is beside
        states.append(model.policy.state_dict())
    for name, tensor in states[0].items():
        assert th.equal(tensor, states[1][name]), name
