"""The GSN's reward model seeing the teammate's own observation (``gsn_reward_sees_teammate``)."""

from __future__ import annotations

import pytest
import torch as th
from stable_baselines3.common.env_util import make_vec_env
from toy_envs import coin_env

from sb3_comm import CommDDPG


def _gsn_model(**policy_kwargs) -> CommDDPG:
    vec = make_vec_env(coin_env, n_envs=2, seed=0)
    kwargs = {"net_arch": [16], "gsn_net_arch": [16], "gsn_reward_net_arch": [16], **policy_kwargs}
    return CommDDPG("GSN", vec, policy_kwargs=kwargs, seed=0, device="cpu")


def test_the_reward_model_sees_the_teammates_observation_but_not_what_it_heard(tmp_path) -> None:
    model = _gsn_model(gsn_reward_sees_teammate=True)
    gsn, layout = model.policy.gsn, model.comm_layout
    n, obs_dim = layout.channel_size, layout.obs_dim
    own = obs_dim - n  # the observation without the received message
    assert gsn.teammate_obs_dim == own
    assert gsn.reward_model.nets[0][0].in_features == n + gsn.teammate_action_dim + own
    th.manual_seed(0)
    obs = th.randn(5, 2, obs_dim)
    actions = th.randn(5, 2, layout.action_dim)
    with th.no_grad():
        messages = gsn.message(obs)
        base = gsn._raw_prediction(obs, actions.flip(1), messages)
        # agent 1's own observation changes: row 0's prediction of r_1 moves, row 1's does not
        seen = obs.clone()
        seen[:, 1, :own] += 0.5
        moved = gsn._raw_prediction(seen, actions.flip(1), messages)
        # what agent 1 heard changes: no prediction moves (with the messages held fixed)
        heard = obs.clone()
        heard[:, 1, own:] += 0.5
        unmoved = gsn._raw_prediction(heard, actions.flip(1), messages)
        # the message itself still depends on the sender's observation alone
        assert th.equal(gsn.message(seen)[:, 0], messages[:, 0])
    assert not th.allclose(moved[:, 0], base[:, 0])
    th.testing.assert_close(moved[:, 1], base[:, 1])
    th.testing.assert_close(unmoved, base)

    # the regression's gradient reaches the extractor M through the message
    loss = gsn.loss(obs, actions, th.randn(5, 2))
    loss.backward()
    assert all(p.grad is not None and p.grad.abs().sum() > 0 for p in gsn.message_extractor.parameters())

    model.save(tmp_path / "sees.zip")
    loaded = CommDDPG.load(tmp_path / "sees.zip", device="cpu")
    assert loaded.policy.gsn.teammate_obs_dim == own
    assert loaded.policy.gsn_reward_sees_teammate is True


def test_off_in_the_policy_as_in_the_paper() -> None:
    """The policy's own default is the paper's ``R(M(o_i), a_j)`` (CommDDPG sets True for a new GSN
    model; see the test below), which ``gsn_reward_sees_teammate=False`` asks for."""
    gsn = _gsn_model(gsn_reward_sees_teammate=False).policy.gsn
    assert gsn.teammate_obs_dim == 0
    assert gsn.reward_model.nets[0][0].in_features == gsn.message_extractor.nets[0][-1].out_features + (
        gsn.teammate_action_dim
    )


def test_a_non_boolean_value_is_a_clear_error() -> None:
    with pytest.raises(TypeError, match=r"gsn_reward_sees_teammate'\] must be True or False, got 'yes'"):
        _gsn_model(gsn_reward_sees_teammate="yes")


def test_a_new_gsn_sees_the_teammate_by_default_and_old_files_keep_the_papers_model(tmp_path) -> None:
    """``CommDDPG("GSN", env)`` sets ``gsn_reward_sees_teammate=True`` unless told otherwise (and
    saves it explicitly); GSN-MAX and the other methods keep the policy's default; a model built for
    loading (``_init_setup_model=False``) gets nothing added, so a file saved before the default
    changed rebuilds the paper's ``R(M(o_i), a_j)`` it was trained with."""
    from sb3_comm import GSN_REWARD_SEES_TEAMMATE
    from sb3_comm.comm_ddpg.policies import CommPolicy, GSNPolicy

    assert GSN_REWARD_SEES_TEAMMATE is True
    env = make_vec_env(coin_env, n_envs=1)
    for policy, kwargs in (
        ("GSN", None),
        ("gsn", {"net_arch": [16]}),
        (GSNPolicy, None),
        (CommPolicy, {"method": "GSN"}),
    ):
        model = CommDDPG(policy, env, policy_kwargs=kwargs)
        assert model.policy.gsn_reward_sees_teammate is True, policy
        assert model.policy.gsn.teammate_obs_dim > 0
    paper = CommDDPG("GSN", env, policy_kwargs={"gsn_reward_sees_teammate": False})
    assert paper.policy.gsn.teammate_obs_dim == 0
    assert CommDDPG("GSN-MAX", env).policy.gsn.teammate_obs_dim == 0
    assert "gsn_reward_sees_teammate" not in CommDDPG("TCG", env).policy_kwargs
    assert "gsn_reward_sees_teammate" not in CommDDPG("GSN", env, _init_setup_model=False).policy_kwargs
    model = CommDDPG("GSN", env)
    model.save(tmp_path / "default.zip")
    assert CommDDPG.load(tmp_path / "default.zip", device="cpu").policy.gsn.teammate_obs_dim > 0
