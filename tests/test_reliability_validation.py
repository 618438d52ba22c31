"""Bad input is refused at the boundary with a message that names the parameter, the value and what
is accepted (issue 10, part A): the algorithms' constructors, run configurations, the command line
(one line, exit 2) and non-finite observations. Nothing here trains beyond a few dozen steps."""

from __future__ import annotations

import json
import math
import re
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.utils import LinearSchedule
from stable_baselines3.common.vec_env import DummyVecEnv
from toy_envs import CoinParallelEnv, coin_env

from sb3_comm import CommDDPG, HybridDDPG
from sb3_comm.cli import main
from sb3_comm.common.validation import check_observation
from sb3_comm.config import RunConfig
from sb3_comm.wrappers import TwoAgentEnv

TINY = {"buffer_size": 1000, "policy_kwargs": {"net_arch": [8]}}


def _coin_vec(n_envs: int = 1):
    return make_vec_env(coin_env, n_envs=n_envs, seed=0)


# ----------------------------------------------------------------------- the constructor --
BAD_ARGUMENTS = [
    ({"gamma": 1.5}, ValueError, r"gamma must be a number in \[0, 1\], got 1.5"),
    ({"gamma": -0.1}, ValueError, r"gamma .* got -0.1"),
    ({"tau": 5}, ValueError, r"tau must be a number in \(0, 1\], got 5"),
    ({"tau": 0.0}, ValueError, r"tau .* got 0.0"),
    ({"learning_rate": -1e-3}, ValueError, r"learning_rate must be a number > 0, got -0.001"),
    ({"actor_learning_rate": 0}, ValueError, r"actor_learning_rate must be a number > 0, got 0"),
    ({"gsn_learning_rate": -1.0}, ValueError, r"gsn_learning_rate must be a number > 0, got -1.0"),
    ({"learning_rate": math.nan}, ValueError, r"learning_rate .* got nan"),
    ({"learning_rate": LinearSchedule(-1e-3, 0, 1)}, ValueError, r"learning_rate: the schedule's value"),
    (
        {"learning_rate": "lin_1e-4"},
        TypeError,
        r"learning_rate must be a float or a callable schedule .* > 0, got 'lin_1e-4'",
    ),
    ({"buffer_size": 0}, ValueError, r"buffer_size must be a whole number ≥ 1, got 0"),
    ({"buffer_size": 1e5}, TypeError, r"buffer_size must be a whole number ≥ 1, got 100000.0 \(float\)"),
    ({"batch_size": 0}, ValueError, r"batch_size must be a whole number ≥ 1, got 0"),
    ({"batch_size": "abc"}, TypeError, r"batch_size .* got 'abc' \(str\)"),
    ({"learning_starts": -1}, ValueError, r"learning_starts must be a whole number ≥ 0, got -1"),
    ({"train_freq": 0}, ValueError, r"train_freq must be a whole number ≥ 1, got 0"),
    ({"train_freq": (1, "game")}, ValueError, r"train_freq\[1\] must be 'step' or 'episode'"),
    ({"gradient_steps": 0}, ValueError, r"gradient_steps must be a whole number ≥ 1 or -1"),
    ({"policy_delay": 0}, ValueError, r"policy_delay must be a whole number ≥ 1, got 0"),
    ({"max_grad_norm": -1}, ValueError, r"max_grad_norm must be a number > 0 or None \(None disables"),
    ({"max_grad_norm": 0}, ValueError, r"max_grad_norm .* or None"),
    ({"exploration_initial_eps": -3}, ValueError, r"exploration_initial_eps must be a number in \[0, 1\]"),
    ({"exploration_final_eps": 2}, ValueError, r"exploration_final_eps .* got 2"),
    ({"exploration_fraction": 1.5}, ValueError, r"exploration_fraction .* got 1.5"),
    ({"exploration": "boltzmann"}, ValueError, r"exploration must be .*'epsilon\+gaussian'"),
    ({"gaussian_noise_std": -0.1}, ValueError, r"gaussian_noise_std must be a number ≥ 0"),
    ({"mc_mixing": 1.5}, ValueError, r"mc_mixing must be a number in \[0, 1\]"),
    ({"mc_mixing": "lin_0.5"}, TypeError, r"mc_mixing must be .* or a callable schedule, got 'lin_0.5'"),
    ({"mc_mixing": lambda progress: 2.0 * progress - 1.0}, ValueError, r"mc_mixing: .* progress 0.0 .* -1.0"),
    ({"tcg_gain": math.nan}, ValueError, r"tcg_gain must be a finite number, got nan"),
    ({"tcg_gain": math.inf}, ValueError, r"tcg_gain .* got inf"),
    ({"target_policy_noise": -1}, ValueError, r"target_policy_noise must be a number ≥ 0"),
    ({"stats_window_size": 0}, ValueError, r"stats_window_size must be a whole number ≥ 1"),
    ({"channel_size": -2}, ValueError, r"channel_size must be a whole number ≥ 0 or None"),
    (
        {"policy_kwargs": {"n_critics": 0}},
        ValueError,
        r"policy_kwargs\['n_critics'\] must be a whole number ≥ 1",
    ),
    ({"policy_kwargs": {"net_arch": [-5]}}, ValueError, r"policy_kwargs\['net_arch'\] .* got \[-5\]"),
    ({"policy_kwargs": {"net_arch": [8, 0]}}, ValueError, r"net_arch.* each a whole number ≥ 1"),
    ({"policy_kwargs": {"net_arch": {"pi": [8], "qf": [-1]}}}, ValueError, r"net_arch'\]\['qf'\]"),
    ({"policy_kwargs": {"net_arch": "big"}}, TypeError, r"net_arch'\] must be a list of layer widths"),
    ({"policy_kwargs": {"gsn_net_arch": [0]}}, ValueError, r"gsn_net_arch"),
    ({"policy_kwargs": {"gsn_reward_net_arch": [-3]}}, ValueError, r"gsn_reward_net_arch"),
    ({"policy_kwargs": "abc"}, TypeError, r"policy_kwargs must be a mapping"),
]


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    BAD_ARGUMENTS,
    ids=lambda v: re.sub(r" at 0x[0-9a-fA-F]+", "", str(v))[:40],  # the same ids in every xdist worker
)
def test_constructor_refuses_bad_values(kwargs, error, match) -> None:
    with pytest.raises(error, match=match):
        CommDDPG("GSN", _coin_vec(), **{**TINY, **kwargs})


def test_single_agent_constructor_checks_too() -> None:
    with pytest.raises(ValueError, match=r"max_grad_norm .* or None"):
        HybridDDPG("MlpPolicy", "Pendulum-v1", max_grad_norm=-1, **TINY)


def test_boundary_values_are_accepted() -> None:
    model = CommDDPG(
        "TCG", _coin_vec(), gamma=1.0, tau=1.0, learning_starts=0, gradient_steps=-1,
        exploration_initial_eps=1.0, exploration_final_eps=0.0, exploration_fraction=0.0,
        gaussian_noise_std=0.0, max_grad_norm=None, train_freq=(1, "episode"), tcg_gain=-2.0,
        learning_rate=LinearSchedule(1e-3, 0.0, 1.0), buffer_size=1000, batch_size=np.int64(4),
        policy_kwargs={"net_arch": {"pi": [8], "qf": [8]}, "n_critics": 2},
    )  # fmt: skip
    model.learn(12)
    assert model.num_timesteps == 12


@pytest.mark.parametrize("steps", [0, -100])
def test_learn_needs_at_least_one_step(steps: int) -> None:
    model = CommDDPG("NONE", _coin_vec(), **TINY)
    with pytest.raises(ValueError, match=rf"total_timesteps must be a number ≥ 1, got {steps}"):
        model.learn(steps)


def test_a_vec_env_that_mixes_tasks_is_refused() -> None:
    mixed = DummyVecEnv([lambda: gym.make("BlindSoccer-v0"), lambda: gym.make("GuessMyNumber-v0")])
    with pytest.raises(ValueError, match=r"The VecEnv mixes tasks: its environments \[1\]"):
        CommDDPG("NONE", mixed, **TINY)


# ------------------------------------------------------------------- run configurations --
@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        ({"batch_size": "abc"}, r"batch_size must be a whole number ≥ 1, got 'abc'"),
        ({"learning_rate": "abc"}, r"learning_rate must be a float or a callable .*'lin_<number>'"),
        ({"gamma": 1.5}, r"gamma must be a number in \[0, 1\]"),
        ({"max_grad_norm": -1}, r"max_grad_norm must be a number > 0 or None"),
        ({"policy_kwargs": {"net_arch": [-5]}}, r"policy_kwargs\['net_arch'\] .* got \[-5\]"),
        ({"train_freq": [1, "episode"]}, r"train_freq must be a whole number ≥ 1 or a tuple"),
    ],
)
def test_run_config_checks_values_once(overrides, match) -> None:
    with pytest.raises(ValueError, match=r"'GuessMyNumber-v0': " + match):
        RunConfig.load("NONE", "GuessMyNumber-v0", overrides=overrides)


def test_packaged_configs_pass_the_checks() -> None:
    for method in ("NONE", "RIAL", "TCG", "GSN"):
        for task in ("BlindSoccer-v0", "GuessMyNumber-v0"):
            RunConfig.load(method, task)


# ------------------------------------------------------------------------- command line --
def _error_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("sb3-comm: error: ")
    return lines[0]


def _train_args(tmp_path: Path, *extra: str) -> list[str]:
    return ["train", "--env", "GuessMyNumber-v0", "--method", "NONE", "-f", str(tmp_path / "runs"), *extra]


@pytest.mark.parametrize(
    ("params", "needle"),
    [
        (["learning_rate=abc"], "learning_rate must be a float or a callable schedule"),
        (["net_arch=[1,"], "'[1,' is not valid YAML"),
        (["policy_kwargs=abc"], "write policy_kwargs as a YAML mapping"),
        (["batch_size=abc"], "batch_size must be a whole number ≥ 1, got 'abc'"),
        (["batch_size=0"], "batch_size must be a whole number ≥ 1, got 0"),
        (["policy_delay=0"], "policy_delay must be a whole number ≥ 1, got 0"),
        (["policy_kwargs={n_critics: 0}"], "policy_kwargs['n_critics'] must be a whole number ≥ 1"),
        (["policy_kwargs={net_arch: [-5]}"], "got [-5]"),
        (["max_grad_norm=-1"], "or None (None disables gradient clipping), got -1"),
        (["gamma=1.5"], "gamma must be a number in [0, 1], got 1.5"),
        (["tau=5"], "tau must be a number in (0, 1], got 5"),
        (["buffer_size=0"], "buffer_size must be a whole number ≥ 1, got 0"),
        (["exploration_initial_eps=-3"], "exploration_initial_eps must be a number in [0, 1]"),
        (["gsn_learning_rate=-1"], "gsn_learning_rate must be a number > 0"),
        (["tcg_gain=.nan"], "tcg_gain must be a finite number, got nan"),
    ],
)
def test_cli_bad_overrides_are_one_line_and_leave_no_folder(tmp_path, capsys, params, needle) -> None:
    assert main([*_train_args(tmp_path), "-params", *params]) == 2
    assert needle in _error_line(capsys)
    assert not (tmp_path / "runs").exists()


def test_cli_wrongly_typed_conf_file(tmp_path, capsys) -> None:
    conf = tmp_path / "conf.yml"
    conf.write_text("GuessMyNumber-v0:\n  policy: NONE\n  batch_size: [64]\n")
    assert main([*_train_args(tmp_path), "--conf", str(conf)]) == 2
    line = _error_line(capsys)
    assert str(conf) in line and "batch_size must be a whole number ≥ 1, got [64] (list)" in line
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["--timesteps", "0"],
        ["--timesteps", "-5"],
        ["--timesteps", "ten"],
        ["--eval-freq", "0"],
        ["--eval-episodes", "0"],
        ["--save-freq", "-1"],
        ["--n-envs", "0"],
    ],
)
def test_cli_counts_are_checked_by_argparse(tmp_path, capsys, argv) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([*_train_args(tmp_path), *argv])
    assert exit_info.value.code == 2
    assert f"argument {argv[0]}" in capsys.readouterr().err
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize("command", ["evaluate", "record-video"])
def test_cli_episodes_must_be_positive(tmp_path, capsys, command) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([command, str(tmp_path / "model.zip"), "--episodes", "0"])
    assert exit_info.value.code == 2
    assert "argument --episodes: must be ≥ 1, got 0" in capsys.readouterr().err


def test_cli_output_folder_that_is_a_file(tmp_path, capsys) -> None:
    blocker = tmp_path / "runs"
    blocker.write_text("not a folder")
    assert main(_train_args(tmp_path)) == 2
    line = _error_line(capsys)
    assert "--log-folder: cannot create the run folder" in line and str(blocker) in line


def test_cli_output_folder_not_writable(tmp_path, capsys, monkeypatch) -> None:
    # (as root a read-only folder is writable, so the refusal is simulated)
    def refuse(self, *args, **kwargs):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "mkdir", refuse)
    assert main(_train_args(tmp_path)) == 2
    assert "cannot create the run folder" in _error_line(capsys)


def test_cli_failed_start_leaves_no_run_folder(tmp_path, capsys, monkeypatch) -> None:
    import sb3_comm.training

    def broken(*args, **kwargs):
        raise ValueError("the model cannot be built")

    monkeypatch.setattr(sb3_comm.training, "build_model", broken)
    assert main([*_train_args(tmp_path), "--no-progress-bar"]) == 2
    assert "the model cannot be built" in _error_line(capsys)
    assert not list((tmp_path / "runs").rglob("*_seed0"))


def test_cli_verbose_prints_the_traceback(tmp_path, capsys) -> None:
    assert main(["-v", "evaluate", str(tmp_path / "nothing.zip"), "--env", "GuessMyNumber-v0"]) == 2
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err
    assert err.strip().splitlines()[-1].startswith("sb3-comm: error: Model file")


@pytest.fixture(scope="module")
def model_files(tmp_path_factory) -> dict[str, Path]:
    """A team model (never trained), and broken or foreign files next to it."""
    from stable_baselines3 import TD3

    from sb3_comm import make_comm_vec_env

    folder = tmp_path_factory.mktemp("models")
    team = folder / "model.zip"
    CommDDPG("NONE", make_comm_vec_env("GuessMyNumber-v0", n_envs=2), **TINY).save(team)
    files = {"team": team, "folder": folder / "run"}
    files["folder"].mkdir()
    files["no_data"] = folder / "no_data.zip"
    with zipfile.ZipFile(files["no_data"], "w") as archive:
        archive.writestr("policy.pth", b"")
    files["truncated"] = folder / "truncated.zip"
    files["truncated"].write_bytes(team.read_bytes()[:400])
    files["bad_policy"] = folder / "bad_policy.zip"
    with zipfile.ZipFile(team) as source, zipfile.ZipFile(files["bad_policy"], "w") as target:
        for name in source.namelist():
            target.writestr(name, b"garbage" if name == "policy.pth" else source.read(name))
    files["td3"] = folder / "td3.zip"
    TD3("MlpPolicy", "Pendulum-v1", buffer_size=10, policy_kwargs={"net_arch": [8]}).save(files["td3"])
    return files


@pytest.mark.parametrize(
    ("name", "needle"),
    [
        ("folder", "is a folder, not a model file"),
        ("no_data", "the archive has no 'data' entry"),
        ("truncated", "not a zip archive (truncated or corrupted?)"),
        ("bad_policy", "cannot be loaded as a CommDDPG model: corrupted or incompatible contents"),
        ("td3", "is not a CommDDPG team model (its policy comes from stable_baselines3.td3.policies)"),
    ],
)
@pytest.mark.parametrize("command", ["evaluate", "record-video"])
def test_cli_bad_model_files_are_named(model_files, capsys, command, name, needle) -> None:
    path = model_files[name]
    assert main([command, str(path), "--env", "GuessMyNumber-v0", "--episodes", "1"]) == 2
    line = _error_line(capsys)
    assert str(path) in line and needle in line


def test_cli_missing_model_keeps_its_name(tmp_path, capsys) -> None:
    missing = tmp_path / "model.zip"
    assert main(["evaluate", str(missing), "--env", "GuessMyNumber-v0"]) == 2
    line = _error_line(capsys)
    assert f"Model file {missing} does not exist" in line and ".zip.zip" not in line


def test_cli_unknown_env(model_files, capsys) -> None:
    assert main(["evaluate", str(model_files["team"]), "--env", "Nope-v0"]) == 2
    assert "Unknown environment 'Nope-v0'" in _error_line(capsys)


def test_cli_model_without_suffix_and_good_model_still_work(model_files, capsys) -> None:
    stem = str(model_files["team"])[: -len(".zip")]
    assert main(["evaluate", stem, "--env", "GuessMyNumber-v0", "--episodes", "2"]) == 0
    assert json.loads(capsys.readouterr().out)["n_episodes"] == 2


def test_cli_video_output_folder_must_exist(model_files, capsys, tmp_path) -> None:
    out = tmp_path / "nowhere" / "v.gif"
    assert main(["record-video", str(model_files["team"]), "--env", "GuessMyNumber-v0", "-o", str(out)]) == 2
    assert "the folder" in _error_line(capsys)


# --------------------------------------------------------------------------------- NaN --
class _NaNCoin(CoinParallelEnv):
    """The coin game whose speaker sees NaN at feature 1 from the second step on."""

    def _obs(self) -> dict[str, np.ndarray]:
        obs = super()._obs()
        if self.t >= 2:
            obs["speaker"] = obs["speaker"].copy()
            obs["speaker"][1] = np.nan
        return obs


def test_check_observation_names_agents_features_and_games() -> None:
    rows = np.zeros((3, 2, 5), dtype=np.float32)
    check_observation(rows, ("blind", "sighted"))
    rows[1, 0, 3] = np.nan
    rows[2, 0, 4] = np.inf
    rows[2, 1, 0] = -np.inf
    with pytest.raises(ValueError) as error:
        check_observation(rows, ("blind", "sighted"), batch_name="games")
    assert str(error.value) == (
        "observation of agent 'blind' has non-finite values at features [3, 4]; "
        "observation of agent 'sighted' has non-finite values at features [0] (in games [1, 2])"
    )


def test_predict_refuses_nan_observations() -> None:
    model = CommDDPG("RIAL", _coin_vec(), **TINY)
    obs = np.zeros(model.observation_space.shape, dtype=np.float32)
    model.predict(obs)
    obs[1, 4] = np.nan
    with pytest.raises(
        ValueError, match=r"observation of agent 'listener' has non-finite values at features \[4\]"
    ):
        model.predict(obs)


def test_single_agent_predict_refuses_nan_observations() -> None:
    model = HybridDDPG("MlpPolicy", "Pendulum-v1", **TINY)
    with pytest.raises(ValueError, match=r"^observation has non-finite values at features \[1\]"):
        model.predict(np.array([0.0, np.nan, 0.0], dtype=np.float32))


def test_wrapper_blames_the_observation_not_the_action() -> None:
    env = TwoAgentEnv(_NaNCoin(), channel_size=2)
    env.reset(seed=0)
    env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    with pytest.raises(
        ValueError, match=r"observation of agent 'speaker' has non-finite values at features \[1\]"
    ):
        env.step(np.zeros(env.action_space.shape, dtype=np.float32))


def test_training_on_a_nan_environment_blames_the_observation() -> None:
    vec = make_vec_env(lambda: TwoAgentEnv(_NaNCoin(), channel_size=2), n_envs=2, seed=0)
    model = CommDDPG("TCG", vec, learning_starts=4, batch_size=4, **TINY)
    with pytest.raises(ValueError, match=r"observation of agent 'speaker'"):
        model.learn(40)


def test_batched_vec_env_blames_the_task(monkeypatch) -> None:
    from sb3_comm import make_comm_vec_env

    vec = make_comm_vec_env("GuessMyNumber-v0", n_envs=3, seed=0)
    vec.reset()
    step = vec.task.step

    def nan_step(actions):
        obs, *rest = step(actions)
        obs = obs.copy()
        obs[2, 1, 0] = np.nan
        return (obs, *rest)

    monkeypatch.setattr(vec.task, "step", nan_step)
    vec.step_async(np.zeros((3, *vec.action_space.shape), dtype=np.float32))
    with pytest.raises(
        ValueError, match=rf"observation of agent '{vec.agent_names[1]}' .* \(in games \[2\]\)"
    ):
        vec.step_wait()
