"""rl-zoo3 path: train with a zoo_configs file, enjoy the result, a shared Optuna study, bad input."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import optuna
import pytest

from sb3_comm import CommDDPG
from sb3_comm.config import CONFIG_DIR, config_path, read_entry
from sb3_comm.zoo import ZOO_ALGOS, convert_commddpg_params, main, prepare_args, sample_commddpg_params

TINY = ["-params", "n_envs:2", "learning_starts:64", "buffer_size:2000", "batch_size:32"]


def test_train_then_enjoy_through_rl_zoo3(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    logs = tmp_path / "logs"
    conf = str(CONFIG_DIR / "gsn.yml")
    rc = main(
        [
            "train",
            "--env",
            "BlindSoccer-v0",
            "-conf",
            conf,
            "-n",
            "300",
            "-f",
            str(logs),
            "--seed",
            "3",
            *TINY,
        ]
    )
    assert rc == 0
    run_dir = logs / "commddpg" / "BlindSoccer-v0_1"
    model = CommDDPG.load(run_dir / "BlindSoccer-v0.zip", device="cpu")
    assert model.method == "GSN" and model.num_timesteps >= 300
    assert (run_dir / "BlindSoccer-v0" / "config.yml").exists()  # rl-zoo3 saved the hyperparameters

    capsys.readouterr()
    assert main(["enjoy", "--env", "BlindSoccer-v0", "-f", str(logs), "--exp-id", "1", "-n", "120"]) == 0
    out = capsys.readouterr().out
    assert "Episode Reward" in out  # rl-zoo3 loaded the model and played a whole episode (100 steps)


def test_two_workers_share_one_optuna_study(tmp_path: Path) -> None:
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    command = [
        sys.executable, "-m", "sb3_comm.zoo", "train", "--env", "GuessMyNumber-v0", "--method", "TCG",
        "-n", "200", "-optimize", "--n-trials", "1", "--n-evaluations", "1", "--eval-episodes", "2",
        "--storage", storage, "--study-name", "shared", "-f", str(tmp_path / "logs"), *TINY,
    ]  # fmt: skip
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    workers = [
        subprocess.Popen(command, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    ]
    workers.append(
        subprocess.Popen(command, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    )
    outputs = [w.communicate(timeout=240)[0].decode() for w in workers]
    assert all(w.returncode == 0 for w in workers), outputs
    study = optuna.load_study(study_name="shared", storage=storage)
    finished = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    assert len(finished) == 2  # one trial from each worker in the same study
    assert {"learning_rate", "gsn_learning_rate", "mc_mixing"} <= set(finished[0].params)


def test_sampler_gives_commddpg_arguments() -> None:
    trial = optuna.trial.FixedTrial(
        {
            "learning_rate": 1e-3, "actor_learning_rate": 1e-4, "gsn_learning_rate": 1e-3,
            "batch_size_pow": 6, "tau": 0.005, "one_minus_gamma": 0.01, "mc_mixing": 0.5,
            "exploration_fraction": 0.2, "exploration_final_eps": 0.1, "net_arch": "small",
        }
    )  # fmt: skip
    params = sample_commddpg_params(trial, 0, 2, {})
    assert params["batch_size"] == 64 and params["gamma"] == pytest.approx(0.99)
    assert params["policy_kwargs"] == {"net_arch": [64, 64]}
    assert convert_commddpg_params({"batch_size_pow": 5}) == {"batch_size": 32}
    model = CommDDPG("GSN", "GuessMyNumber-v0", device="cpu", **params)  # every key is accepted
    assert model.batch_size == 64


def test_packaged_config_and_lin_schedules_are_used(tmp_path: Path) -> None:
    args = prepare_args("train", ["--env", "BlindSoccer-v0", "--method", "rial"])
    assert args[args.index("-conf") + 1] == str(CONFIG_DIR / "rial.yml")
    assert args[:2] == ["--algo", "commddpg"]
    # rl-zoo3 hands the file's values over as written: the zoo's class converts them, when it
    # builds a model and when it loads one with extra settings (rl-zoo3's -i).
    zoo_class = ZOO_ALGOS["commddpg"]
    model = zoo_class("GSN", "GuessMyNumber-v0", actor_learning_rate="lin_1e-4", device="cpu")
    assert model.actor_lr_schedule(1.0) == pytest.approx(1e-4)
    assert model.actor_lr_schedule(0.5) == pytest.approx(5e-5)
    model.save(tmp_path / "model.zip")
    loaded = zoo_class.load(tmp_path / "model.zip", device="cpu", actor_learning_rate="lin_2e-4", gamma="0.9")
    assert loaded.actor_lr_schedule(1.0) == pytest.approx(2e-4) and loaded.gamma == pytest.approx(0.9)
    with pytest.raises(TypeError, match="float or a callable"):
        CommDDPG("GSN", "GuessMyNumber-v0", actor_learning_rate="lin_1e-4", device="cpu")


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["train", "--env", "BlindSoccer-v0", "--method", "DIAL"], "Unknown communication method 'DIAL'"),
        (["train", "--env", "CartPole-v1", "--method", "GSN"], "has no entry for 'CartPole-v1'"),
        (
            ["train", "--env", "BlindSoccer-v0", "-params", "learnin_rate:0.1"],
            "unknown key(s) ['learnin_rate']",
        ),
        (["fly", "--env", "BlindSoccer-v0"], "Unknown rl-zoo3 command 'fly'"),
    ],
)
def test_bad_input_fails_before_training(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    assert main([*argv, "-f", str(tmp_path / "logs")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "logs").exists()  # nothing was started


def test_unknown_key_in_yaml_file_is_named(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    conf = tmp_path / "bad.yml"
    conf.write_text("BlindSoccer-v0:\n  policy: GSN\n  n_envs: 2\n  gsn_lr: 0.001\n")
    assert main(["train", "--env", "BlindSoccer-v0", "-conf", str(conf), "-f", str(tmp_path / "logs")]) == 2
    err = capsys.readouterr().err
    assert "gsn_lr" in err and "accepted keys" in err
    assert not (tmp_path / "logs").exists()


def test_zoo_runs_get_the_dense_tensorboard_points(tmp_path: Path) -> None:
    """rl-zoo3's --log-interval counts environment steps with CommDDPG; its own evaluations are
    written at their step."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    conf = str(CONFIG_DIR / "none.yml")
    args = ["train", "--env", "GuessMyNumber-v0", "-conf", conf, "-n", "400", "-f", str(tmp_path / "logs")]
    args += [
        "-tb",
        str(tmp_path / "tb"),
        "--log-interval",
        "100",
        "--eval-freq",
        "100",
        "--eval-episodes",
        "2",
    ]
    assert main([*args, *TINY]) == 0
    (events_dir,) = {path.parent for path in (tmp_path / "tb").rglob("events.out.tfevents.*")}
    events = EventAccumulator(str(events_dir), size_guidance={"scalars": 0})
    events.Reload()
    steps = [event.step for event in events.Scalars("rollout/exploration_rate")]
    assert steps == [100, 200, 300, 400]
    assert [event.step for event in events.Scalars("eval/mean_reward")] == [100, 200, 300, 400]


@pytest.mark.parametrize("task", ["BlindSoccer-v0", "GuessMyNumber-v0"])
def test_paper_methods_share_every_agent_setting_on_a_task(task: str) -> None:
    """NONE, RIAL, TCG and GSN differ only in the channel: a setting changed for one method's
    entry and not the others' would make the paper's comparison unfair."""
    entries = {m: read_entry(config_path(m), task) for m in ("NONE", "RIAL", "TCG", "GSN")}
    reference = {k: v for k, v in entries["NONE"].items() if k != "policy"}
    gsn_only = {"gsn_learning_rate"}
    for method, entry in entries.items():
        agent = {k: v for k, v in entry.items() if k != "policy" and k not in gsn_only}
        agent["policy_kwargs"] = {k: v for k, v in agent["policy_kwargs"].items() if not k.startswith("gsn_")}
        assert agent == reference, f"{config_path(method).name} {task} differs from none.yml"
    assert entries["GSN"]["policy"] == "GSN" and entries["NONE"]["policy"] == "NONE"
