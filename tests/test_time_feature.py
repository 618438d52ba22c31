"""The tasks' ``time_feature`` option (time awareness, Pardo et al. 2018) and the ``env_kwargs`` that
carry a task's options through a run: config file, ``--env-kwargs``, training and evaluation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from envs.soccer import referee
from envs.tasks import BlindSoccerTask, GuessMyNumberTask
from sb3_comm.cli import main, parse_env_kwargs
from sb3_comm.config import RunConfig, task_options
from sb3_comm.registration import make_comm_vec_env
from sb3_comm.training import EvalSettings, build_model, train_run
from sb3_comm.zoo import prepare_args


def _actions(task: BlindSoccerTask | GuessMyNumberTask, rng: np.random.Generator) -> np.ndarray:
    """Random actions in the action box (messages included)."""
    return rng.uniform(
        task.action_low, task.action_high, size=(task.n_games, task.n_players, task.action_size)
    )


def _both(values: np.ndarray) -> np.ndarray:
    """(k,) per-game values as (k, 2): one per agent."""
    return np.repeat(np.asarray(values, dtype=np.float64)[:, None], 2, axis=1)


def test_remaining_time_is_observed_and_the_limit_terminates() -> None:
    task = BlindSoccerTask(n_games=4, seed=0, max_steps=4, time_feature=True, rules="dqn-hfo")
    plain = BlindSoccerTask(n_games=4, seed=0, max_steps=4, rules="dqn-hfo")
    assert task.observation_size == plain.observation_size + 1 == 71 and task.n_extra == 1
    np.testing.assert_array_equal(task.obs[..., 66], 1.0)  # both agents, the blind one too
    rng = np.random.default_rng(1)
    for step in range(1, 9):
        actions = _actions(task, rng)
        obs, rewards, terminated, truncated, info = task.step(actions)
        ref_obs, ref_rewards, ref_terminated, ref_truncated, ref_info = plain.step(actions)
        # the same games: features, messages, rewards and outcomes do not depend on the option
        np.testing.assert_array_equal(obs[..., :66], ref_obs[..., :66])
        np.testing.assert_array_equal(obs[..., 67:], ref_obs[..., 66:])
        np.testing.assert_array_equal(rewards, ref_rewards)
        np.testing.assert_array_equal(info["outcome"], ref_info["outcome"])
        # a time limit truncates the plain task and terminates the time-aware one
        np.testing.assert_array_equal(terminated, ref_terminated | ref_truncated)
        assert not truncated.any()
        ended = info["done"]
        np.testing.assert_array_equal(ended, ref_info["done"])
        timed_out = ended & ~ref_terminated
        assert (info["outcome"][timed_out] == referee.OUT_OF_TIME).all()
        # the last observation of an episode reads 1 - length / max_steps (0 at the limit);
        # the first observation of the next one reads 1
        length = info["episode_length"]
        np.testing.assert_allclose(info["final_observation"][ended, :, 66], _both(1 - length[ended] / 4))
        np.testing.assert_array_equal(obs[ended, :, 66], 1.0)
        np.testing.assert_allclose(obs[~ended, :, 66], _both(1 - task.episode_steps[~ended] / 4))
        if step == 4:
            assert timed_out.any()  # at least one game ran to the limit
    # the full-information state holds the time too
    state = task.global_state().reshape(4, 2, -1)
    np.testing.assert_allclose(state[:, :, 66], _both(1 - task.episode_steps / 4))


def test_time_feature_follows_the_task_entries_and_precedes_the_message() -> None:
    task = GuessMyNumberTask(n_games=2, seed=0, time_feature=True, hidden_numbers=(-0.3, 0.6))
    assert task.observation_size == 66 + 1 + 1 + 1
    np.testing.assert_allclose(task.obs[:, :, 66], [[-0.3, 0.6]] * 2)  # the hidden numbers
    np.testing.assert_array_equal(task.obs[:, :, 67], 1.0)
    actions = np.zeros((2, 2, task.action_size))
    actions[..., 8] = [0.25, -0.5]
    obs, *_ = task.step(actions)
    np.testing.assert_allclose(obs[:, :, 67], 0.99)
    np.testing.assert_allclose(obs[:, :, 68], [[-0.5, 0.25]] * 2)  # the teammate's message, last


def test_time_feature_must_be_a_bool() -> None:
    with pytest.raises(TypeError, match="time_feature must be True or False, got 'yes'"):
        BlindSoccerTask(time_feature="yes")


def test_hfo_untouched_ball_rule_still_truncates_with_the_time_feature() -> None:
    from envs.tasks.single_agent import ScoreEmptyGoalTask

    task = ScoreEmptyGoalTask(n_games=2, seed=0, time_feature=True)
    actions = np.zeros((2, 1, task.action_size))
    actions[..., :3] = [-1.0, 1.0, -1.0]  # turn by 0: nobody touches the ball
    for _ in range(task.untouched_cycles + 5):
        _, _, terminated, truncated, info = task.step(actions)
        if info["done"].any():
            break
    assert (info["episode_length"] < task.max_steps).all()  # ended by the untouched-ball rule
    assert truncated.all() and not terminated.any()  # the agents cannot see that clock
    assert (info["outcome"] == referee.OUT_OF_TIME).all()


def test_env_kwargs_in_a_config_reach_training_and_evaluation(tmp_path: Path) -> None:
    tiny = {
        "learning_starts": 40,
        "batch_size": 8,
        "buffer_size": 1000,
        "policy_kwargs": {"net_arch": [8]},
        "n_envs": 2,
        "n_timesteps": 80,
        "env_kwargs": {"time_feature": True, "max_steps": 20},
    }
    config = RunConfig.load("GSN", "BlindSoccer-v0", overrides=tiny)
    assert config.env_kwargs == {"time_feature": True, "max_steps": 20}
    assert "env_kwargs" not in config.algorithm_kwargs()
    model = build_model(config)
    plain = make_comm_vec_env("BlindSoccer-v0", n_envs=2, seed=0)
    assert model.observation_space.shape[-1] == plain.observation_space.shape[-1] + 1
    run = tmp_path / "run"
    result = train_run(config, run, evaluation=EvalSettings(freq=40, episodes=2), save_freq=0)
    # evaluated on the task it learned (a 70-entry observation would not fit the model)
    assert result.final["none"]["n_episodes"] == 2 and len(result.curve) == 2
    assert result.hyperparams["env_kwargs"] == {"time_feature": True, "max_steps": 20}  # in the record
    written = yaml.safe_load((run / "config.yml").read_text())["BlindSoccer-v0"]
    assert written["env_kwargs"] == {"time_feature": True, "max_steps": 20}
    again = RunConfig.load("GSN", "BlindSoccer-v0", path=run / "config.yml")
    assert again.env_kwargs == config.env_kwargs and again.hyperparams == config.hyperparams
    # a config without task options writes none (config.yml and its fingerprint stay as they were)
    assert "env_kwargs" not in RunConfig.load("GSN", "BlindSoccer-v0").to_entry()


@pytest.mark.parametrize(
    ("env_kwargs", "message"),
    [
        (
            {"time_feture": True},
            r"unknown option\(s\) \['time_feture'\]; BlindSoccer-v0 accepts: \[.*'time_feature'",
        ),
        ({"seed": 3}, r"unknown option\(s\) \['seed'\]"),  # the run's seed decides
        ("time_feature", "write env_kwargs as a YAML mapping"),
    ],
)
def test_bad_env_kwargs_are_refused_before_anything_is_built(env_kwargs: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        RunConfig.load("GSN", "BlindSoccer-v0", overrides={"env_kwargs": env_kwargs})


def test_task_options_of_each_kind_of_task() -> None:
    assert "time_feature" in task_options("GuessMyNumber-v0") and "hidden_numbers" in task_options(
        "GuessMyNumber-v0"
    )
    assert "n_games" not in task_options("BlindSoccer-v0")
    assert "time_feature" in task_options("HFOScoreEmptyGoal-v0")
    assert task_options("Pendulum-v1") is None  # built by Gymnasium: its options are its own


def test_cli_env_kwargs_train_and_evaluate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert parse_env_kwargs(["time_feature:true", "max_steps: 30"]) == {"time_feature": True, "max_steps": 30}
    with pytest.raises(ValueError, match="must look like key:value"):
        parse_env_kwargs(["time_feature=true"])
    args = [
        "train", "--env", "GuessMyNumber-v0", "--method", "TCG", "--timesteps", "80", "--n-envs", "2",
        "-f", str(tmp_path), "--eval-freq", "80", "--eval-episodes", "2", "--no-progress-bar",
        "-params", "learning_starts=40", "batch_size=8", "policy_kwargs={net_arch: [8]}",
        "--env-kwargs", "time_feature:true",
    ]  # fmt: skip
    assert main(args) == 0
    run = tmp_path / "GuessMyNumber-v0" / "TCG_seed0"
    assert yaml.safe_load((run / "config.yml").read_text())["GuessMyNumber-v0"]["env_kwargs"] == {
        "time_feature": True
    }
    capsys.readouterr()
    # evaluate reads the task options from the run's config.yml
    assert main(["evaluate", str(run / "model.zip"), "--episodes", "2"]) == 0
    assert json.loads(capsys.readouterr().out)["n_episodes"] == 2
    # a bad option stops before the run folder exists
    assert main([*args[:-1], "time_feture:true"]) == 2
    assert "unknown option(s) ['time_feture']" in capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "GuessMyNumber-v0").iterdir()) == ["TCG_seed0"]


def test_rl_zoo_evaluates_on_the_task_options_of_the_file(tmp_path: Path) -> None:
    conf = tmp_path / "gsn.yml"
    entry = {"policy": "GSN", "env_kwargs": {"time_feature": True}}
    conf.write_text(yaml.safe_dump({"BlindSoccer-v0": entry}))
    args = prepare_args("train", ["--env", "BlindSoccer-v0", "-conf", str(conf)])
    assert args[args.index("--eval-env-kwargs") + 1] == "time_feature:True"  # rl-zoo3 reads literals
    command_line = ["--env", "BlindSoccer-v0", "-conf", str(conf), "--env-kwargs", "max_steps:50"]
    given = prepare_args("train", command_line)
    assert "--eval-env-kwargs" not in given  # rl-zoo3 then evaluates with the command line's


def test_time_feature_reaches_the_vec_env() -> None:
    vec_env = make_comm_vec_env("BlindSoccer-v0", n_envs=3, seed=0, env_kwargs={"time_feature": True})
    obs = vec_env.reset()
    assert obs.shape[-1] == vec_env.observation_space.shape[-1]
    plain = make_comm_vec_env("BlindSoccer-v0", n_envs=3, seed=0)
    assert vec_env.observation_space.shape[-1] == plain.observation_space.shape[-1] + 1


def test_simple_reference_time_feature_same_games_limit_terminates() -> None:
    from sb3_comm.foreign.batched_simple_reference import N_FEATURES, SimpleReferenceTask

    task = SimpleReferenceTask(n_games=3, seed=2, max_cycles=5, time_feature=True)
    plain = SimpleReferenceTask(n_games=3, seed=2, max_cycles=5)
    assert task.observation_size == plain.observation_size + 1
    assert (task.observation_low[N_FEATURES], task.observation_high[N_FEATURES]) == (0.0, 1.0)
    np.testing.assert_array_equal(task.obs[..., N_FEATURES], 1.0)
    rng = np.random.default_rng(0)
    for step in range(1, 7):
        actions = rng.uniform(task.action_low, task.action_high, size=(3, 2, task.action_size))
        obs, rewards, terminated, truncated, info = task.step(actions)
        ref_obs, ref_rewards, ref_terminated, ref_truncated, _ = plain.step(actions)
        np.testing.assert_array_equal(obs[..., :N_FEATURES], ref_obs[..., :N_FEATURES])
        np.testing.assert_array_equal(obs[..., N_FEATURES + 1 :], ref_obs[..., N_FEATURES:])
        np.testing.assert_array_equal(rewards, ref_rewards)
        assert not truncated.any() and not ref_terminated.any()
        np.testing.assert_array_equal(terminated, ref_truncated)
        taken = (step - 1) % 5 + 1  # steps of the current episode (the sixth starts a new one)
        assert terminated.all() == (taken == 5)
        expected = 1 - taken / 5
        np.testing.assert_allclose(info["final_observation"][..., N_FEATURES], expected, atol=1e-7)
        np.testing.assert_allclose(obs[..., N_FEATURES], 1.0 if taken == 5 else expected, atol=1e-7)
