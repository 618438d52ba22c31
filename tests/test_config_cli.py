"""Hyperparameter files and the ``sb3-comm`` command line."""

from __future__ import annotations

import itertools
import json

import pytest

from sb3_comm import CommDDPG
from sb3_comm.cli import main, parse_overrides
from sb3_comm.config import CONFIG_DIR, RunConfig


@pytest.mark.parametrize("method", ["NONE", "RIAL", "TCG", "GSN"])
@pytest.mark.parametrize("env_id", ["BlindSoccer-v0", "GuessMyNumber-v0"])
def test_packaged_configs_load(method: str, env_id: str) -> None:
    config = RunConfig.load(method, env_id)
    assert config.method == method
    assert config.n_envs >= 1 and config.n_timesteps > 0
    settings = config.algorithm_kwargs()
    # Blind Soccer (since session 37): the constructor's learner, a constant critic rate, gamma 0.95
    # and beta 0; Guess My Number: rates decaying from 1e-3, gamma 0.9 and beta 0 (explore_gmn_tcg_*).
    rate = settings["learning_rate"]
    if env_id == "BlindSoccer-v0":
        assert rate == pytest.approx(1e-3)
    else:
        assert callable(rate) and rate(1.0) == pytest.approx(1e-3) and rate(0.5) == pytest.approx(5e-4)
    expected = {"BlindSoccer-v0": (0.95, 0.0), "GuessMyNumber-v0": (0.9, 0.0)}[env_id]
    assert (settings["gamma"], settings["mc_mixing"]) == expected


def test_every_packaged_configuration_pins_its_beta() -> None:
    """The constructor's default beta changed (0.5 -> 0); no packaged run may follow it unnoticed."""
    import yaml

    for path in sorted(CONFIG_DIR.glob("*.yml")):
        for env_id, entry in yaml.safe_load(path.read_text()).items():
            assert "mc_mixing" in entry, f"{path.name}: {env_id} does not set mc_mixing"


def test_gsn_max_has_one_configuration_for_both_tasks() -> None:
    """GSN-MAX's tasks differ only in gamma and the budget (issue: one configuration solves both)."""
    soccer = RunConfig.load("GSN-MAX", "BlindSoccer-v0")
    number = RunConfig.load("GSN-MAX", "GuessMyNumber-v0")
    differ = {k for k in soccer.hyperparams.keys() | number.hyperparams.keys()
              if soccer.hyperparams.get(k) != number.hyperparams.get(k)}  # fmt: skip
    assert differ == {"gamma"}
    # the effect search (README, "Beyond the paper"): effect models, 16 candidates, explorer games
    assert soccer.hyperparams["gsn_max_weight"] == 0.8
    assert (soccer.hyperparams["gsn_max_search"], soccer.hyperparams["gsn_max_explorers"]) == (16, 0.25)
    assert soccer.hyperparams["policy_kwargs"]["gsn_effect_model"] is True


def test_config_errors_name_the_problem(tmp_path) -> None:
    bad_key = tmp_path / "bad.yml"
    bad_key.write_text("BlindSoccer-v0:\n  policy: GSN\n  learning_rat: 0.001\n")
    with pytest.raises(ValueError, match=r"unknown key\(s\) \['learning_rat'\].*accepted keys"):
        RunConfig.load("GSN", "BlindSoccer-v0", path=bad_key)
    with pytest.raises(ValueError, match=r"no entry for 'GuessMyNumber-v0'.*BlindSoccer-v0"):
        RunConfig.load("GSN", "GuessMyNumber-v0", path=bad_key)
    other = tmp_path / "other.yml"
    other.write_text("BlindSoccer-v0:\n  policy: TCG\n")
    with pytest.raises(ValueError, match="configured for method TCG"):
        RunConfig.load("GSN", "BlindSoccer-v0", path=other)
    broken = tmp_path / "broken.yml"
    broken.write_text("BlindSoccer-v0: [unclosed\n")
    with pytest.raises(ValueError, match="not valid YAML"):
        RunConfig.load("GSN", "BlindSoccer-v0", path=broken)
    with pytest.raises(ValueError, match="Unknown communication method 'DIAL'"):
        RunConfig.load("DIAL", "BlindSoccer-v0")


def test_numbers_without_a_dot_are_numbers(tmp_path) -> None:
    path = tmp_path / "numbers.yml"
    path.write_text("BlindSoccer-v0:\n  policy: GSN\n  gsn_learning_rate: 1e-6\n")
    assert RunConfig.load("GSN", "BlindSoccer-v0", path=path).hyperparams[
        "gsn_learning_rate"
    ] == pytest.approx(1e-6)
    assert parse_overrides(["gsn_learning_rate=1e-6", "batch_size=32"]) == {
        "gsn_learning_rate": 1e-6,
        "batch_size": 32,
    }
    with pytest.raises(ValueError, match="key=value"):
        parse_overrides(["batch_size"])


def test_config_dir_is_the_repository_folder() -> None:
    assert (CONFIG_DIR / "gsn.yml").is_file()


def test_cli_train_then_evaluate(tmp_path, capsys) -> None:
    args = [
        "train", "--env", "GuessMyNumber-v0", "--method", "gsn", "--timesteps", "240", "--n-envs", "2",
        "-f", str(tmp_path), "--eval-freq", "200", "--eval-episodes", "2", "--no-progress-bar",
        "-params", "learning_starts=100", "batch_size=16", "policy_kwargs={net_arch: [16]}",
    ]  # fmt: skip
    assert main(args) == 0
    run = tmp_path / "GuessMyNumber-v0" / "GSN_seed0"
    assert (run / "model.zip").is_file() and (run / "config.yml").is_file()
    assert list((run / "tb").rglob("events.out.tfevents.*"))
    curve = json.loads((run / "evaluations.json").read_text())
    assert len(curve) == 2 and all("mean_return" in point for point in curve)
    out = capsys.readouterr().out
    assert "tensorboard --logdir" in out and str(run) in out
    # the last periodic evaluation and the final one (other games, with the ablations) apart
    assert "Last periodic evaluation" in out and "with messages intact" in out and "zeroed" in out

    # A second run never overwrites the first.
    assert main(args) == 0
    assert (tmp_path / "GuessMyNumber-v0" / "GSN_seed0_1" / "model.zip").is_file()
    capsys.readouterr()

    assert main(["evaluate", str(run / "model.zip"), "--episodes", "2", "--ablation", "zero"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["env"] == "GuessMyNumber-v0" and report["method"] == "GSN" and report["n_episodes"] == 2
    # -params policy_kwargs=... replaces the file's policy_kwargs whole (as rl-zoo3 does), its
    # averaged_actor: false pin included: the team plays the constructor's default, the average
    assert report["averaged_actor"] is True and report["actor_average_tau"] == "auto"

    projector = tmp_path / "projector"
    assert main(["evaluate", str(run / "model.zip"), "--episodes", "2", "--projector", str(projector)]) == 0
    assert "PROJECTOR tab" in capsys.readouterr().out
    assert (projector / "projector_config.pbtxt").is_file()


def test_cli_rejects_unknown_override_before_training(tmp_path, capsys) -> None:
    code = main(
        ["train", "--env", "BlindSoccer-v0", "--method", "GSN", "-f", str(tmp_path), "-params", "lr=3"]
    )
    assert code == 2
    err = capsys.readouterr().err
    assert "unknown key(s) ['lr']" in err and "accepted keys" in err
    assert not (tmp_path / "BlindSoccer-v0").exists()


def test_linear_schedules_for_learning_rates() -> None:
    from stable_baselines3.common.utils import LinearSchedule

    from sb3_comm.common.hyperparams import canonical_value, python_value

    assert canonical_value("gsn_learning_rate", "lin_1e-3") == "lin_0.001"
    schedule = python_value("gsn_learning_rate", "lin_0.001")
    assert isinstance(schedule, LinearSchedule)
    assert schedule(1.0) == pytest.approx(1e-3) and schedule(0.5) == pytest.approx(5e-4)
    assert canonical_value("exploration", "lin_1e-3") == "lin_1e-3"  # only learning rates are schedules
    assert python_value("exploration", "lin_1e-3") == "lin_1e-3"
    with pytest.raises(ValueError, match="linear schedule"):
        canonical_value("learning_rate", "lin_fast")


def test_mc_mixing_may_be_a_linear_schedule(tmp_path) -> None:
    from stable_baselines3.common.utils import LinearSchedule

    from sb3_comm.config import RunConfig

    path = tmp_path / "gsn.yml"
    path.write_text("BlindSoccer-v0:\n  mc_mixing: lin_0.5\n  n_timesteps: 1000\n")
    config = RunConfig.load("GSN", "BlindSoccer-v0", path=path)
    assert config.hyperparams["mc_mixing"] == "lin_0.5"
    beta = config.algorithm_kwargs()["mc_mixing"]
    assert isinstance(beta, LinearSchedule)
    assert (beta(1.0), beta(0.5), beta(0.0)) == pytest.approx((0.5, 0.25, 0))
    path.write_text("BlindSoccer-v0:\n  mc_mixing: lin_2\n")
    with pytest.raises(ValueError, match=r"mc_mixing: the schedule's value at progress 1.0 .*, got 2"):
        RunConfig.load("GSN", "BlindSoccer-v0", path=path)


def test_gsn_learning_rate_schedule_is_applied() -> None:
    from stable_baselines3.common.utils import LinearSchedule

    from sb3_comm import make_comm_vec_env

    env = make_comm_vec_env("GuessMyNumber-v0", n_envs=2)
    model = CommDDPG(
        "GSN", env, gsn_learning_rate=LinearSchedule(1e-3, 0.0, 1.0),
        learning_starts=50, batch_size=8, policy_kwargs={"net_arch": [8]}, device="cpu",
    )  # fmt: skip
    seen: list[float] = []
    optimizer = model.gsn.optimizer
    model.learn(200, callback=lambda _l, _g: seen.append(optimizer.param_groups[0]["lr"]) or True)
    trained = [lr for lr in seen if lr < 1e-3]  # after the first GSN updates
    assert trained and all(a >= b for a, b in itertools.pairwise(trained))
    assert trained[-1] == pytest.approx(1e-3 * (1 - 198 / 200), abs=2e-5)


def test_cli_trains_a_registered_task_without_packaged_configuration_with_the_defaults(
    tmp_path, capsys
) -> None:
    """A registered two-agent task that no packaged file configures trains with the constructor's
    defaults (and says so); its config.yml holds no hyperparameter the user did not set."""
    args = [
        "train", "--env", "MPESimpleReference-v0", "--method", "GSN", "--timesteps", "160", "--n-envs", "2",
        "-f", str(tmp_path), "--eval-freq", "80", "--eval-episodes", "2", "--no-progress-bar",
        "-params", "learning_starts=50",
    ]  # fmt: skip
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "No packaged configuration of GSN for MPESimpleReference-v0: CommDDPG's constructor" in out
    assert "the team plays its actor's average over the run's last tenth" in out
    run = tmp_path / "MPESimpleReference-v0" / "GSN_seed0"
    assert (run / "model.zip").is_file()
    policy = CommDDPG.load(run / "model.zip", device="cpu").policy
    assert policy.averaged_actor is True and policy.actor_average_tau == "auto"
    assert main([*args[:-1], "learning_starts=50", "policy_kwargs={averaged_actor: false}"]) == 0
    assert "; the team plays its actor\n" in capsys.readouterr().out
    entry = RunConfig.load("GSN", "MPESimpleReference-v0", path=run / "config.yml")
    assert (entry.n_envs, entry.n_timesteps, entry.hyperparams) == (2, 160, {"learning_starts": 50})
    assert len(json.loads((run / "evaluations.json").read_text())) == 2


@pytest.mark.parametrize(
    ("env_id", "message"),
    [
        ("NoSuchTask-v0", "Unknown environment 'NoSuchTask-v0': not a registered id"),
        ("HFOScoreEmptyGoal-v0", "is not a two-agent task that CommDDPG can train"),
    ],
)
def test_cli_train_refuses_an_unknown_or_single_agent_task(
    tmp_path, capsys, env_id: str, message: str
) -> None:
    assert main(["train", "--env", env_id, "--method", "GSN", "-f", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def _reports_of_a_team_that_sends_one(
    model, network, flag_sets: list[list[str]], tmp_path, capsys
) -> list[dict]:
    """``sb3-comm evaluate`` reports of ``model`` saved with ``network``'s output layer always sending
    +1 (weights 0, bias 1), one report per set of flags."""
    import torch as th

    last = network.nets[0][-1]
    with th.no_grad():
        last.weight.zero_()
        last.bias.fill_(1.0)
    model.save(tmp_path / "model.zip")
    reports = []
    for flags in flag_sets:
        command = ["evaluate", str(tmp_path / "model.zip"), "--env", "GuessMyNumber-v0", "--episodes", "2"]
        assert main(command + flags) == 0
        reports.append(json.loads(capsys.readouterr().out))
    return reports


def test_cli_evaluate_plays_the_averaged_actor_when_asked(tmp_path, capsys) -> None:
    """``sb3-comm evaluate --averaged-actor`` plays the target actor: here one that always sends the
    message +1, so its games differ from the actor's."""
    from sb3_comm import make_comm_vec_env

    env = make_comm_vec_env("GuessMyNumber-v0", n_envs=2, seed=0)
    model = CommDDPG(
        "TCG", env, seed=0, device="cpu", policy_kwargs={"averaged_actor": False}
    )  # plays its actor
    reports = _reports_of_a_team_that_sends_one(
        model, model.policy.actor_target, [[], ["--averaged-actor"]], tmp_path, capsys
    )
    assert [r["averaged_actor"] for r in reports] == [False, True]
    assert reports[1]["actor_average_tau"] is None  # the target actor played, no separate average
    assert reports[0]["agent_mean_returns"] != reports[1]["agent_mean_returns"]


def test_cli_evaluate_plays_the_actor_of_a_default_team_when_asked(tmp_path, capsys) -> None:
    """A new team plays its actor's average (the default): ``sb3-comm evaluate`` plays it as saved,
    ``--no-averaged-actor`` plays the actor instead (here an average that always sends +1)."""
    from sb3_comm import make_comm_vec_env

    model = CommDDPG("TCG", make_comm_vec_env("GuessMyNumber-v0", n_envs=2, seed=0), seed=0, device="cpu")
    reports = _reports_of_a_team_that_sends_one(
        model, model.policy.actor_average, [[], ["--no-averaged-actor"]], tmp_path, capsys
    )
    assert [r["averaged_actor"] for r in reports] == [True, False]
    assert reports[0]["actor_average_tau"] == "auto"
    assert reports[0]["agent_mean_returns"] != reports[1]["agent_mean_returns"]


def test_cli_train_precision_adds_to_the_packaged_policy_kwargs(tmp_path, capsys) -> None:
    """``--precision bfloat16`` sets the networks' arithmetic and keeps the file's other
    policy_kwargs (its averaged_actor: false pin included), where ``-params policy_kwargs=`` would
    replace them; --resume refuses it."""
    args = [
        "train", "--env", "GuessMyNumber-v0", "--method", "TCG", "--timesteps", "120", "--n-envs", "2",
        "-f", str(tmp_path), "--eval-freq", "120", "--eval-episodes", "2", "--no-progress-bar",
        "--precision", "bfloat16", "-params", "learning_starts=60", "batch_size=16",
    ]  # fmt: skip
    assert main(args) == 0
    assert "2 parallel games, seed 0, hidden layers in bfloat16\n" in capsys.readouterr().out
    run = tmp_path / "GuessMyNumber-v0" / "TCG_seed0"
    kwargs = RunConfig.load("TCG", "GuessMyNumber-v0", path=run / "config.yml").hyperparams["policy_kwargs"]
    packaged = RunConfig.load("TCG", "GuessMyNumber-v0").hyperparams["policy_kwargs"]
    assert kwargs == {**packaged, "precision": "bfloat16"}
    policy = CommDDPG.load(run / "model.zip", device="cpu").policy
    assert policy.precision == "bfloat16" and policy.averaged_actor is False
    with pytest.raises(SystemExit):  # not a precision
        main(["train", "--env", "GuessMyNumber-v0", "--method", "TCG", "--precision", "float16"])
    assert main(["train", "--resume", str(run), "--precision", "float32"]) == 2
