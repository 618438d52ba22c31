"""``policy_kwargs={"averaged_actor": True}``: the policy's own actions (``predict``, evaluations, a
saved model's play) come from the target actor, the actor's Polyak average; training, exploration
included, is that of the plain learner, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th

from sb3_comm import CommDDPG, HybridDDPG, make_comm_vec_env
from sb3_comm.evaluation import evaluate_team

SMALL = {"net_arch": [16, 16]}


def _team(averaged: bool, method: str = "TCG", **policy_kwargs) -> CommDDPG:
    env = make_comm_vec_env("BlindSoccer-v0", n_envs=2, seed=0)
    return CommDDPG(
        method, env, learning_starts=40, batch_size=16, seed=0, device="cpu",
        policy_kwargs={**SMALL, "averaged_actor": averaged, **policy_kwargs},
    )  # fmt: skip


def test_predict_plays_the_target_actor_and_the_plain_policy_the_actor() -> None:
    model = HybridDDPG(
        "MlpPolicy", "HFOMoveToBall-v0", learning_starts=50, seed=0, device="cpu",
        policy_kwargs={**SMALL, "averaged_actor": True},
    )  # fmt: skip
    model.learn(150)
    policy = model.policy
    obs = model.replay_buffer.sample(32).observations
    with th.no_grad():
        actor = policy.actor_outputs(obs).clamp(-1.0, 1.0)
        average = policy.actor_outputs(obs, target=True).clamp(-1.0, 1.0)
    assert not th.allclose(actor, average), "after 100 updates the average must lag the actor"
    action, _ = model.predict(obs.numpy(), deterministic=True)
    np.testing.assert_allclose(action, policy.unscale_action(average.numpy()), rtol=0, atol=1e-6)
    policy.averaged_actor = False
    action, _ = model.predict(obs.numpy(), deterministic=True)
    np.testing.assert_allclose(action, policy.unscale_action(actor.numpy()), rtol=0, atol=1e-6)


def test_a_team_plays_the_average_with_its_messages_and_keeps_it_through_save_and_load(tmp_path) -> None:
    model = _team(averaged=True)
    model.learn(120)
    policy = model.policy
    obs = model.replay_buffer.sample(8).observations.reshape(8, -1)
    with th.no_grad():
        average = policy.scaled_actions(obs, averaged=True)
        actor = policy.scaled_actions(obs, averaged=False)
        th.testing.assert_close(policy._predict(obs), average)
    message = policy.comm_layout.action_message_slice
    assert not th.allclose(average[..., message], actor[..., message]), "TCG's messages come from the average"

    model.save(tmp_path / "model.zip")
    loaded = CommDDPG.load(tmp_path / "model.zip", device="cpu")
    assert loaded.policy.averaged_actor is True
    with th.no_grad():
        th.testing.assert_close(loaded.policy._predict(obs), average)

    # an evaluation plays the average: the games of the actor differ, those of the average put in
    # the actor's place are the same
    def play() -> np.ndarray:
        return np.asarray(evaluate_team(loaded, "BlindSoccer-v0", n_episodes=4, seed=3).team_returns)

    averaged = play()
    loaded.policy.averaged_actor = False
    assert not np.array_equal(play(), averaged)
    loaded.policy.actor.load_state_dict(loaded.policy.actor_target.state_dict())
    np.testing.assert_array_equal(play(), averaged)


@pytest.mark.parametrize("method", ["TCG", "GSN"])
def test_the_option_leaves_training_and_exploration_as_they_are(method: str) -> None:
    trained = []
    for averaged in (False, True):
        model = _team(averaged, method)
        model.learn(160)
        trained.append(model.policy.state_dict())
    plain, averaged = trained
    assert plain.keys() == averaged.keys()
    for key in plain:
        assert th.equal(plain[key], averaged[key]), key


def test_a_non_boolean_averaged_actor_is_a_clear_error() -> None:
    with pytest.raises(TypeError, match=r"policy_kwargs\['averaged_actor'\] must be True or False, got 1"):
        HybridDDPG("MlpPolicy", "HFOMoveToBall-v0", policy_kwargs={"averaged_actor": 1}, device="cpu")


def test_actor_average_tau_keeps_a_separate_average_that_the_team_plays_and_saves(tmp_path) -> None:
    """``actor_average_tau``: an average of the actor of its own rate, one lerp per actor update,
    played by ``averaged_actor``; the target actor (the critic's bootstrap) stays DDPG's."""
    tau = 0.02
    model = _team(True, "TCG", actor_average_tau=tau)
    policy = model.policy
    assert policy.actor_average is not None
    expected = [p.clone() for p in policy.actor.parameters()]
    seen = [0]  # updates folded into `expected`

    def record(_locals, _globals) -> bool:  # after each step: the actor of the updates so far
        nonlocal expected
        if model._n_updates > seen[0]:  # one update per step (train_freq=1, gradient_steps=1)
            assert model._n_updates == seen[0] + 1
            expected = [e + tau * (p - e) for e, p in zip(expected, policy.actor.parameters(), strict=True)]
            seen[0] = model._n_updates
        return True

    model.learn(120, callback=record)
    record(None, None)  # the update after the last step
    assert seen[0] == model._n_updates > 0
    for average, hand in zip(policy.actor_average.parameters(), expected, strict=True):
        th.testing.assert_close(average, hand, rtol=1e-5, atol=1e-6)
    targets = list(policy.actor_target.parameters())
    assert not all(th.equal(a, t) for a, t in zip(policy.actor_average.parameters(), targets, strict=True))

    obs = model.replay_buffer.sample(8).observations.reshape(8, -1)
    with th.no_grad():
        played = policy._predict(obs)
        message = policy.comm_layout.action_message_slice
        outputs = policy.bound_outputs(policy.actor_average(obs.reshape(8, *policy.observation_space.shape)))
        th.testing.assert_close(played, policy.scaled_actions(obs, averaged=True))
        assert not th.allclose(played[..., message], policy.scaled_actions(obs)[..., message])
    assert outputs.shape[-1] == policy.actor_out_dim

    model.save(tmp_path / "model.zip")
    loaded = CommDDPG.load(tmp_path / "model.zip", device="cpu")
    assert loaded.policy.actor_average_tau == tau
    for a, b in zip(loaded.policy.actor_average.parameters(), policy.actor_average.parameters(), strict=True):
        assert th.equal(a, b)
    with th.no_grad():
        th.testing.assert_close(loaded.policy._predict(obs), played)


def test_a_separate_average_leaves_training_as_it_is() -> None:
    plain = _team(False, "GSN")  # built, then trained: the seed also sets numpy's global generator
    plain.learn(160)
    averaged = _team(False, "GSN", actor_average_tau=0.001)
    averaged.learn(160)
    state = averaged.policy.state_dict()
    for key, value in plain.policy.state_dict().items():
        assert th.equal(value, state[key]), key


@pytest.mark.parametrize("bad", [0.0, -0.1, 1.5, "0.01"])
def test_a_bad_actor_average_tau_is_a_clear_error(bad) -> None:
    with pytest.raises((TypeError, ValueError), match=r"actor_average_tau"):
        HybridDDPG("MlpPolicy", "HFOMoveToBall-v0", policy_kwargs={"actor_average_tau": bad}, device="cpu")
