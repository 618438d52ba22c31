"""``policy_kwargs={"averaged_actor": True}``: the policy's own actions (``predict``, evaluations, a
saved model's play) come from the target actor, the actor's Polyak average; training, exploration
included, is that of the plain learner, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th

from sb3_comm import CommDDPG, HybridDDPG, make_comm_vec_env
from sb3_comm.evaluation import evaluate_team
from sb3_comm.hybrid_ddpg.policies import auto_actor_average_rate

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


@pytest.mark.parametrize("bad", [0.0, -0.1, 1.5, "0.01", "Auto", "fast"])
def test_a_bad_actor_average_tau_is_a_clear_error(bad) -> None:
    with pytest.raises((TypeError, ValueError), match=r"actor_average_tau"):
        HybridDDPG("MlpPolicy", "HFOMoveToBall-v0", policy_kwargs={"actor_average_tau": bad}, device="cpu")


# ----------------------------------------------------------------- actor_average_tau="auto" --
@pytest.mark.parametrize(
    ("updates", "rate"),
    [(50_000, 0.0002), (18_750, 0.00053), (37_500, 0.00027), (100, 0.1), (10, 1.0), (0, 1.0)],
)
def test_the_auto_rate_is_a_tenth_of_the_run_to_two_figures(updates: float, rate: float) -> None:
    """10 / updates, rounded to two significant figures: the rates measured by hand on Blind Soccer,
    Guess My Number and simple_reference; a run of 10 updates or fewer plays its actor."""
    assert auto_actor_average_rate(updates) == rate


@pytest.mark.parametrize(
    ("settings", "n_envs", "budget", "updates"),
    [
        ({}, 16, 800_000, 50_000),  # Blind Soccer: 16 games, one update per step of them
        ({}, 16, 300_000, 18_750),  # Guess My Number
        ({}, 8, 300_000, 37_500),  # simple_reference (8 games)
        ({"train_freq": 4, "gradient_steps": 2}, 2, 800, 200),
        ({"train_freq": 4, "gradient_steps": -1}, 2, 800, 800),  # as many updates as steps
        ({"policy_delay": 2}, 2, 800, 200),  # the actor moves every other critic update
    ],
)
def test_planned_actor_updates_count_the_whole_budget(settings, n_envs, budget, updates) -> None:
    env = make_comm_vec_env("GuessMyNumber-v0", n_envs=n_envs, seed=0)
    model = CommDDPG("TCG", env, device="cpu", policy_kwargs=SMALL, **settings)
    model._total_timesteps = budget  # what learn(budget) sets
    assert model.planned_actor_updates() == updates


def test_auto_trains_as_the_rate_it_chooses_and_a_continued_run_plans_its_whole_budget() -> None:
    """learn(200) on 2 games plans 100 updates: rate 0.1, the same average as the fixed rate 0.1
    bit for bit; learn(200) again, continuing, plans 200 updates from the run's start: 0.05."""
    auto = _team(True, "TCG", actor_average_tau="auto")
    assert auto.policy.actor_average is not None and auto.policy.actor_average_rate is None
    auto.learn(200)
    assert auto.policy.actor_average_tau == "auto" and auto.policy.actor_average_rate == 0.1
    fixed = _team(True, "TCG", actor_average_tau=0.1)
    fixed.learn(200)
    state = fixed.policy.state_dict()
    for key, value in auto.policy.state_dict().items():
        assert th.equal(value, state[key]), key

    before = [p.clone() for p in auto.policy.actor_average.parameters()]
    auto.learn(200, reset_num_timesteps=False)
    assert auto.num_timesteps == 400 and auto.policy.actor_average_rate == 0.05
    assert not all(
        th.equal(a, b) for a, b in zip(before, auto.policy.actor_average.parameters(), strict=True)
    )


def test_auto_with_train_freq_in_episodes_plans_from_the_rollouts_it_collects() -> None:
    model = HybridDDPG(
        "MlpPolicy", "HFOMoveToBall-v0", learning_starts=50, train_freq=(1, "episode"), gradient_steps=3,
        seed=0, device="cpu", policy_kwargs={**SMALL, "averaged_actor": True, "actor_average_tau": "auto"},
    )  # fmt: skip
    seen: list[tuple[int, float | None]] = []
    train = model.train

    def spy(gradient_steps: int, batch_size: int = 100) -> None:
        train(gradient_steps, batch_size)
        seen.append((model._rollout_steps, model.policy.actor_average_rate))

    model.train = spy  # type: ignore[method-assign]
    model.learn(600)
    assert seen, "no update in 600 steps"
    for steps, rate in seen:  # 3 updates per episode of `steps` steps, over 600 steps
        assert steps > 0 and rate == auto_actor_average_rate(600 * 3 / steps)


def test_auto_is_saved_as_auto_and_logged_as_the_rate(tmp_path) -> None:
    from stable_baselines3.common.logger import configure

    model = _team(True, "GSN", actor_average_tau="auto")
    model.set_logger(configure(str(tmp_path / "log"), ["csv"]))
    model.learn(200, log_interval=100)
    with open(tmp_path / "log" / "progress.csv") as file:
        header, *rows = [line.strip().split(",") for line in file]
    column = header.index("train/actor_average_rate")
    assert [float(row[column]) for row in rows if row[column]] == pytest.approx([0.1, 0.1])

    model.save(tmp_path / "model.zip")
    loaded = CommDDPG.load(tmp_path / "model.zip", device="cpu")
    assert loaded.policy.actor_average_tau == "auto" and loaded.policy.actor_average_rate is None
    for a, b in zip(
        loaded.policy.actor_average.parameters(), model.policy.actor_average.parameters(), strict=True
    ):
        assert th.equal(a, b)
    with pytest.raises(RuntimeError, match=r"actor_average_tau='auto' has no rate yet"):
        loaded.policy.update_actor_average()
    loaded.set_env(make_comm_vec_env("BlindSoccer-v0", n_envs=2, seed=1))
    loaded.learn(100)  # a new budget: 50 updates
    assert loaded.policy.actor_average_rate == 0.2
