"""CommDDPG's constructor defaults: the discount (0.95 since session 19), the batch size (128
since session 23), an actor learning rate that decays linearly to 0 (since session 25) and the
actor's average over the run's last tenth playing (since session 31): what a new model uses, what
the replay's Monte-Carlo returns and GSN's regression use, and that a file saved with other
settings keeps them."""

from __future__ import annotations

import pytest
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.utils import FloatSchedule

from sb3_comm import CommDDPG, HybridDDPG, make_comm_vec_env


def _env():
    return make_comm_vec_env("GuessMyNumber-v0", n_envs=2, seed=0)


@pytest.mark.parametrize("method", ["NONE", "RIAL", "TCG", "GSN", "GSN-MAX"])
def test_a_new_model_discounts_with_0_95_and_draws_batches_of_128(method: str) -> None:
    model = CommDDPG(method, _env(), mc_mixing=0.5, buffer_size=1000, learning_starts=0, seed=0, device="cpu")
    assert model.gamma == pytest.approx(0.95)
    assert model.replay_buffer.gamma == pytest.approx(0.95)  # the Monte-Carlo returns' discount
    assert model.batch_size == 128
    if model.gsn is not None:  # GSN's regression draws the agents' batch size
        model.learn(4)
        assert model.gsn_callback is not None and model.gsn_callback.batch_size == 128


def test_the_single_agent_learner_keeps_sb3s_0_99_and_batches_of_64() -> None:
    model = HybridDDPG("MlpPolicy", make_vec_env("HFOMoveToBall-v0", n_envs=1, seed=0), device="cpu")
    assert model.gamma == pytest.approx(0.99)
    assert model.batch_size == 64


def test_a_file_saved_with_the_earlier_defaults_loads_with_them(tmp_path) -> None:
    """The defaults change what a new model uses, not what a saved model was trained with: SB3's
    0.99, batches of 64 and a constant actor rate."""
    old = CommDDPG(
        "GSN", _env(), gamma=0.99, batch_size=64, actor_learning_rate=1e-4, buffer_size=1000, device="cpu"
    )
    old.save(tmp_path / "old.zip")
    loaded = CommDDPG.load(tmp_path / "old.zip", env=_env(), device="cpu")
    assert loaded.gamma == pytest.approx(0.99)
    assert loaded.replay_buffer.gamma == pytest.approx(0.99)
    assert loaded.batch_size == 64
    assert loaded.actor_lr_schedule(0.0) == pytest.approx(1e-4)


@pytest.mark.parametrize("method", ["NONE", "TCG", "GSN"])
def test_a_new_model_decays_its_actor_rate_to_zero_and_keeps_the_others_constant(method: str) -> None:
    """The actor's rate is 1e-4 at the start of training, half of that halfway and 0 at the end;
    the critic's (1e-3) and GSN's (1e-3) stay; checked on what the optimizers get in a real
    ``learn``."""
    model = CommDDPG(method, _env(), buffer_size=1000, learning_starts=0, seed=0, device="cpu")
    for progress in (1.0, 0.5, 0.0):
        assert model.actor_lr_schedule(progress) == pytest.approx(1e-4 * progress)
        assert model.lr_schedule(progress) == pytest.approx(1e-3)
    rates: list[tuple[float, float, float]] = []

    class Record(BaseCallback):
        def _on_step(self) -> bool:
            critic = self.model.critic.optimizer.param_groups[0]["lr"]
            actor = self.model.actor.optimizer.param_groups[0]["lr"]
            rates.append((self.model._current_progress_remaining, critic, actor))
            return True

    model.learn(64, callback=Record())  # 32 VecEnv steps of 2 games, an update after each
    # SB3 moves the progress after the callback: the first entry is the start, at 1, before any
    # update; each later one holds the rates of the update made at the progress reached then
    assert [progress for progress, _, _ in rates] == pytest.approx([1 - k / 32 for k in range(32)])
    for progress, critic, actor in rates[1:]:
        assert critic == pytest.approx(1e-3) and actor == pytest.approx(1e-4 * progress)
    assert model.actor.optimizer.param_groups[0]["lr"] == 0.0
    assert model.critic.optimizer.param_groups[0]["lr"] == pytest.approx(1e-3)
    if model.gsn_callback is not None:  # GSN: the message network's own rate stays constant
        assert model.gsn_callback.lr_schedule(0.0) == pytest.approx(1e-3)


@pytest.mark.parametrize("method", ["NONE", "RIAL", "TCG", "GSN", "GSN-MAX"])
def test_a_new_team_plays_its_actors_average_over_the_runs_last_tenth(method: str) -> None:
    """The default of session 31: the separate average at the rate ``"auto"``, set by ``learn``."""
    model = CommDDPG(method, _env(), buffer_size=1000, learning_starts=20, batch_size=8, seed=0, device="cpu")
    policy = model.policy
    assert policy.averaged_actor is True and policy.actor_average_tau == "auto"
    assert policy.actor_average is not None
    model.learn(400)  # 2 games: 200 planned updates
    assert policy.actor_average_rate == 0.05


def test_told_otherwise_a_team_plays_what_it_is_told() -> None:
    actor = CommDDPG("TCG", _env(), buffer_size=1000, policy_kwargs={"averaged_actor": False}, device="cpu")
    assert actor.policy.averaged_actor is False and actor.policy.actor_average is None
    target = CommDDPG(
        "TCG",
        _env(),
        buffer_size=1000,
        policy_kwargs={"averaged_actor": True, "actor_average_tau": None},
        device="cpu",
    )
    assert target.policy.averaged_actor is True and target.policy.actor_average is None  # the target actor
    fixed = CommDDPG(
        "TCG", _env(), buffer_size=1000, policy_kwargs={"actor_average_tau": 0.001}, device="cpu"
    )
    assert fixed.policy.averaged_actor is True and fixed.policy.actor_average_rate == 0.001


def test_the_single_agent_learner_plays_its_actor() -> None:
    model = HybridDDPG("MlpPolicy", make_vec_env("HFOMoveToBall-v0", n_envs=1, seed=0), device="cpu")
    assert model.policy.averaged_actor is False and model.policy.actor_average is None


def test_a_file_saved_before_the_average_was_the_default_plays_its_actor(tmp_path) -> None:
    """A model saved before the default existed has no such key in its policy_kwargs: it plays its
    actor, as it did when it was measured."""
    old = CommDDPG("GSN", _env(), buffer_size=1000, policy_kwargs={"averaged_actor": False}, device="cpu")
    del old.policy_kwargs["averaged_actor"]  # what a file of an earlier version holds
    old.save(tmp_path / "old.zip")
    loaded = CommDDPG.load(tmp_path / "old.zip", env=_env(), device="cpu")
    assert loaded.policy.averaged_actor is False and loaded.policy.actor_average is None
    new = CommDDPG("GSN", _env(), buffer_size=1000, device="cpu")
    new.save(tmp_path / "new.zip")
    loaded = CommDDPG.load(tmp_path / "new.zip", env=_env(), device="cpu")
    assert loaded.policy.averaged_actor is True and loaded.policy.actor_average_tau == "auto"


PAPER_METHODS = ("NONE", "RIAL", "TCG", "GSN")


def test_every_packaged_configuration_pins_the_actor_it_was_measured_with() -> None:
    """Each packaged result was measured with a player the file names, never the constructor's
    default unnoticed: on Blind Soccer, since session 37, the paper's methods play the actor's
    average at the automatic rate; everywhere else the actor plays."""
    from sb3_comm.config import RunConfig

    for method in (*PAPER_METHODS, "GSN-MAX"):
        for env_id in ("BlindSoccer-v0", "GuessMyNumber-v0"):
            kwargs = RunConfig.load(method, env_id).algorithm_kwargs()["policy_kwargs"]
            averaged = method in PAPER_METHODS and env_id == "BlindSoccer-v0"
            assert kwargs["averaged_actor"] is averaged, (method, env_id)
            if averaged:
                assert kwargs["actor_average_tau"] == "auto", (method, env_id)


def _learner_settings(model: CommDDPG) -> dict:
    """What a model learns with: every hyperparameter and schedule (sampled over the run), less
    ``shared_reward``."""
    progress = (1.0, 0.5, 0.01)
    return {
        "scalars": (model.gamma, model.tau, model.batch_size, model.learning_starts, model.buffer_size,
                    model.train_freq, model.gradient_steps, model.exploration_fraction,
                    model.exploration_final_eps, model.exploration_initial_eps, model.max_grad_norm,
                    model.n_envs),
        "rates": [(model.lr_schedule(p), model.actor_lr_schedule(p), model.mc_mixing_schedule(p))
                  for p in progress],
        "gsn_rates": [FloatSchedule(model.gsn_learning_rate)(p) for p in progress],
        "policy_kwargs": {k: v for k, v in model.policy_kwargs.items() if k != "net_arch"},
        "net_arch": model.policy_kwargs.get("net_arch") or [256, 256],
    }  # fmt: skip


@pytest.mark.parametrize("method", PAPER_METHODS)
def test_packaged_blind_soccer_is_the_constructors_learner(method: str) -> None:
    """Since session 37 the packaged Blind Soccer entries of the paper's methods are
    ``CommDDPG(method, env)`` with only the paper's own rewards set. Both agents of Blind Soccer get
    the same reward, so the team's reward (the constructor's default for NONE, RIAL and GSN) is the
    same number: the same settings, and the same model after a few updates, bit for bit, as the
    constructor with nothing set (whose 20 Blind Soccer GSN seeds are measured in the README)."""
    import torch as th

    from sb3_comm.config import RunConfig
    from sb3_comm.training import build_model

    packaged = RunConfig.load(method, "BlindSoccer-v0")
    entry = {"n_envs": packaged.n_envs, "n_timesteps": packaged.n_timesteps}
    plain = RunConfig.from_entry(entry, method, "BlindSoccer-v0")
    short = {"n_envs": 2, "learning_starts": 40, "buffer_size": 2000}  # the same on both sides
    models = []
    for config in (packaged, plain):
        settings = _learner_settings(build_model(config, device="cpu"))
        model = build_model(config.with_overrides(short), device="cpu")
        model.learn(120)
        models.append((settings, model))
    (settings_a, a), (settings_b, b) = models
    assert a.shared_reward is False and b.shared_reward is (method != "TCG")
    assert settings_a == settings_b
    for (name, x), (_, y) in zip(a.policy.state_dict().items(), b.policy.state_dict().items(), strict=True):
        assert th.equal(x, y), name
