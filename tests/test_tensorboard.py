"""TensorBoard: dense training points, every evaluation, histograms, hparams, projector, video,
read back from the event files of short real runs."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.logger import Logger
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
from tensorboard.plugins.hparams import plugin_data_pb2

from sb3_comm import CommDDPG
from sb3_comm.common.train_log import TrainLog, dump_only
from sb3_comm.config import RunConfig
from sb3_comm.registration import make_comm_vec_env
from sb3_comm.tensorboard import PROJECTOR_HEADER, event_logger
from sb3_comm.training import EvalSettings, train_run

TINY = {
    "learning_starts": 40,
    "batch_size": 8,
    "buffer_size": 2000,
    "policy_kwargs": {"net_arch": [8]},
    "n_envs": 4,
    "n_timesteps": 400,
}


def _events(folder: Path) -> EventAccumulator:
    accumulator = EventAccumulator(str(folder), size_guidance={"scalars": 0, "histograms": 0, "images": 0})
    accumulator.Reload()
    return accumulator


def _steps(events: EventAccumulator, tag: str) -> list[int]:
    return [event.step for event in events.Scalars(tag)]


@pytest.fixture(scope="module")
def gsn_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    """A 400-step GSN run on Blind Soccer: a point every 40 steps, an evaluation every 100, a
    video every 2nd evaluation, 3 projector games."""
    run_dir = tmp_path_factory.mktemp("tb") / "run"
    config = RunConfig.load("GSN", "BlindSoccer-v0", overrides=TINY)
    evaluation = EvalSettings(freq=100, episodes=3, video_every=2, projector_episodes=3)
    train_run(config, run_dir, evaluation=evaluation, save_freq=0, log_interval=40)
    return run_dir, json.loads((run_dir / "result.json").read_text())


def test_training_points_follow_the_interval(gsn_run) -> None:
    run_dir, _ = gsn_run
    events = _events(run_dir / "tb")
    tags = ("train/critic_loss", "train/q_mean", "gsn/loss", "gsn/prediction_rmse", "time/agent_update_ms")
    for tag in tags:
        steps = _steps(events, tag)
        # one point per 40 steps once updates have begun (learning_starts 40): 80, 120, ... 400
        assert steps == list(range(80, 401, 40)), tag
    assert _steps(events, "rollout/exploration_rate") == list(range(40, 401, 40))


def test_every_evaluation_is_written_at_its_step(gsn_run) -> None:
    run_dir, _ = gsn_run
    events = _events(run_dir / "tb")
    curve = json.loads((run_dir / "evaluations.json").read_text())
    assert (
        _steps(events, "eval/mean_return") == [point["timesteps"] for point in curve] == [100, 200, 300, 400]
    )
    values = [event.value for event in events.Scalars("eval/mean_return")]
    np.testing.assert_allclose(values, [point["mean_return"] for point in curve], rtol=1e-6)
    assert _steps(events, "eval/return_blind") == [100, 200, 300, 400]
    # an evaluation adds no training point: those stay on their grid
    assert 100 not in _steps(events, "train/critic_loss")


def test_histograms_hparams_video_and_projector_are_written(gsn_run) -> None:
    run_dir, result = gsn_run
    events = _events(run_dir / "tb")
    tags = events.Tags()
    histograms = {f"messages/{agent}/{i}" for agent in ("sighted", "blind") for i in range(4)}
    assert histograms <= set(tags["histograms"])
    assert len(events.Histograms("messages/sighted/0")) == 10
    assert {"_hparams_/experiment", "_hparams_/session_start_info"} <= set(
        events.PluginTagToContent("hparams")
    )
    final = events.Scalars("final/mean_return")
    assert len(final) == 1 and final[0].value == pytest.approx(result["final"]["none"]["mean_return"])
    videos = events.Images("eval/video")
    assert [video.step for video in videos] == [200, 400]  # every 2nd evaluation
    assert videos[0].encoded_image_string[:6] == b"GIF89a"
    config = (run_dir / "tb" / "projector_config.pbtxt").read_text()
    assert 'tensor_name: "messages:00400"' in config
    metadata = (run_dir / "tb" / "00400" / "messages" / "metadata.tsv").read_text().splitlines()
    assert metadata[0].split("\t") == list(PROJECTOR_HEADER)
    vectors = np.loadtxt(run_dir / "tb" / "00400" / "messages" / "tensors.tsv", ndmin=2)
    assert vectors.shape == (len(metadata) - 1, 4)
    assert {row.split("\t")[1] for row in metadata[1:]} <= {"dash", "turn", "kick"}


def _hparams(folder: Path) -> dict[str, Any]:
    """The run's values in TensorBoard's HPARAMS view."""
    content = _events(folder).PluginTagToContent("hparams")["_hparams_/session_start_info"]
    values = plugin_data_pb2.HParamsPluginData.FromString(content).session_start_info.hparams
    return {key: getattr(value, value.WhichOneof("kind")) for key, value in values.items()}


@pytest.mark.parametrize(
    ("method", "shared", "sees_teammate"), [("TCG", False, None), ("GSN", True, True), ("NONE", True, None)]
)
def test_hparams_show_what_a_default_chose_by_method(method, shared, sees_teammate, tmp_path: Path) -> None:
    """A run with the constructor's defaults: the reward (TCG: each agent's own), GSN's reward
    model and the team that plays (the actor's average, at the rate set from the budget), which no
    configuration names, are in the HPARAMS view."""
    tiny = {"learning_starts": 40, "batch_size": 8, "buffer_size": 500, "n_envs": 4, "n_timesteps": 80}
    config = RunConfig.constructor_defaults(method, "GuessMyNumber-v0").with_overrides(tiny)
    assert "shared_reward" not in config.hyperparams
    train_run(config, tmp_path / "run", evaluation=EvalSettings(freq=80, episodes=2), save_freq=0)
    hparams = _hparams(tmp_path / "run" / "tb")
    assert hparams["method"] == method
    assert hparams["shared_reward"] == shared  # a bool is written as a number (1.0 / 0.0)
    if sees_teammate is None:
        assert "gsn_reward_sees_teammate" not in hparams
    else:
        assert hparams["gsn_reward_sees_teammate"] == sees_teammate
    assert hparams["averaged_actor"] == 1.0  # 80 steps of 4 games: 20 updates planned, rate 10 / 20
    assert hparams["actor_average_rate"] == pytest.approx(0.5)
    assert hparams["precision"] == "float32"  # the default, which no configuration names


def test_plain_learn_logs_every_log_interval_steps(tmp_path: Path) -> None:
    """The API (and rl-zoo3, which calls learn): log_interval counts environment steps."""
    env = make_comm_vec_env("GuessMyNumber-v0", n_envs=4, seed=0)
    model = CommDDPG("TCG", env, learning_starts=20, batch_size=8, policy_kwargs={"net_arch": [8]}, seed=0)
    model.set_logger(event_logger(tmp_path))
    model.learn(240, log_interval=48)
    model.logger.close()
    events = _events(tmp_path)
    assert _steps(events, "rollout/exploration_rate") == [48, 96, 144, 192, 240]
    assert _steps(events, "tcg/grad_norm") == [48, 96, 144, 192, 240]
    assert "time/agent_update_ms" in events.Tags()["scalars"]


@pytest.mark.parametrize("bad", [-1, 2.5, "10", True])
def test_log_interval_must_be_a_count_of_steps(bad) -> None:
    env = make_comm_vec_env("GuessMyNumber-v0", n_envs=2, seed=0)
    model = CommDDPG("NONE", env, policy_kwargs={"net_arch": [8]})
    with pytest.raises(ValueError, match="log_interval must be a whole number of environment steps"):
        model.learn(10, log_interval=bad)


def test_train_log_averages_without_syncing_and_dump_only_keeps_the_rest(tmp_path: Path) -> None:
    log = TrainLog()
    log.add("a", th.tensor(1.0))
    log.add("a", th.tensor(3.0))
    log.add("t", 12.0, count=4)
    assert isinstance(log._sums["a"], th.Tensor)  # still a tensor: no .item() per update
    assert log.pop_means() == {"a": 2.0, "t": 3.0}
    assert log.pop_means() == {}
    logger = Logger(str(tmp_path), [])
    logger.record("train/loss", 5.0)
    dump_only(logger, {"eval/mean_return": 1.0}, step=7)
    assert logger.name_to_value == {"train/loss": 5.0}  # the pending training value survives


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _get(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=5) as response:
        return json.loads(response.read())


def test_a_real_tensorboard_serves_the_scalars_and_the_projector(gsn_run) -> None:
    run_dir, _ = gsn_run
    port = _free_port()
    command = [sys.executable, "-m", "tensorboard.main", "--logdir", str(run_dir), "--host", "127.0.0.1"]
    server = subprocess.Popen(
        [*command, "--port", str(port), "--load_fast", "false"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        tags = None
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and server.poll() is None:
            try:
                tags = _get(f"http://127.0.0.1:{port}/data/plugin/scalars/tags")
                if tags.get("tb"):
                    break
            except OSError:
                pass
            time.sleep(0.5)
        if server.poll() is not None or tags is None:
            pytest.skip(f"TensorBoard did not start here: {server.stderr.read().decode()[-300:]}")
        assert {"eval/mean_return", "train/critic_loss", "gsn/loss"} <= set(tags["tb"])
        runs = _get(f"http://127.0.0.1:{port}/data/plugin/projector/runs")
        assert runs == ["tb"]
        config = _get(f"http://127.0.0.1:{port}/data/plugin/projector/info?run=tb")
        assert [e["tensorName"] for e in config["embeddings"]] == ["messages:00400"]
    finally:
        server.terminate()
        server.wait(timeout=10)
