"""Interrupting and resuming a run: Ctrl-C and SIGTERM save a checkpoint, --resume finishes the run
with its curve continued; rl-zoo3's -i continues from a zoo model and its replay buffer."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch as th
from stable_baselines3.common.callbacks import BaseCallback

from sb3_comm import CommDDPG
from sb3_comm.cli import main
from sb3_comm.config import RunConfig
from sb3_comm.results import RunResult
from sb3_comm.training import EvalSettings, TrainingInterrupted, resume_run, train_run
from sb3_comm.zoo import main as zoo_main

ROOT = Path(__file__).resolve().parents[1]
TINY = {
    "learning_starts": 40,
    "batch_size": 8,
    "buffer_size": 1000,
    "policy_kwargs": {"net_arch": [8]},
    "n_envs": 2,
    "n_timesteps": 200,
}
SETTINGS = EvalSettings(freq=100, episodes=2, ablations=("none",))


class _SignalAt(BaseCallback):
    """Sends ``signum`` to this process once the model reaches ``steps`` (a user's Ctrl-C)."""

    def __init__(self, steps: int, signum: int = signal.SIGINT) -> None:
        super().__init__()
        self.steps, self.signum, self.sent = steps, signum, False

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.steps and not self.sent:
            self.sent = True
            os.kill(os.getpid(), self.signum)
        return True


class _Crash(BaseCallback):
    def _on_step(self) -> bool:
        raise RuntimeError("crash")


class _GSNCount(BaseCallback):
    """Records the agent and GSN updates of one learn() call."""

    def _on_training_start(self) -> None:
        self.agent_updates_at_start = self.model.n_updates

    def _on_training_end(self) -> None:
        self.agent_updates = self.model.n_updates - self.agent_updates_at_start
        self.gsn_updates = self.model.gsn_callback.n_updates

    def _on_step(self) -> bool:
        return True


def _interrupted_run(run: Path) -> TrainingInterrupted:
    config = RunConfig.load("GSN", "GuessMyNumber-v0", seed=2, overrides=TINY)
    with pytest.raises(TrainingInterrupted) as stopped:
        train_run(config, run, SETTINGS, save_freq=100, callbacks=[_SignalAt(100)], save_replay_buffer=True)
    return stopped.value


def test_ctrl_c_saves_a_checkpoint_and_resume_finishes_the_run(tmp_path: Path) -> None:
    run = tmp_path / "run"
    stopped = _interrupted_run(run)
    assert stopped.exit_code == 130 and "resume with: sb3-comm train --resume" in str(stopped)
    steps = stopped.timesteps
    assert 100 <= steps < 200 and stopped.checkpoint == run / "checkpoints" / f"model_{steps}_steps.zip"
    assert (run / "checkpoints" / f"model_replay_buffer_{steps}_steps.pkl").exists()
    assert CommDDPG.load(run / "model.zip").num_timesteps == steps
    assert not (run / "result.json").exists()
    config_before = (run / "config.yml").read_text()
    again = tmp_path / "again"
    shutil.copytree(run, again)

    count = _GSNCount()
    result = resume_run(run, callbacks=[count])
    assert result.timesteps == result.budget == 200
    # The curve continues: one point per evaluation step, none repeated.
    assert [p["timesteps"] for p in result.curve] == [100, 200]
    seconds = [p["seconds"] for p in result.curve]
    assert seconds == sorted(seconds)
    assert (run / "config.yml").read_text() == config_before
    # GSN: one update per agent update in the resumed session too.
    assert count.agent_updates > 0 and count.gsn_updates == count.agent_updates
    with pytest.raises(ValueError, match="is a finished run"):
        resume_run(run)

    # Resuming the same checkpoint again gives the same run (the resume reseeds).
    twin = resume_run(again)
    assert [p["mean_return"] for p in twin.curve] == [p["mean_return"] for p in result.curve]
    first, second = CommDDPG.load(run / "model.zip"), CommDDPG.load(again / "model.zip")
    for a, b in zip(first.policy.parameters(), second.policy.parameters(), strict=True):
        assert th.equal(a, b)


def test_resume_refuses_what_it_cannot_continue(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(ValueError, match="is not a run folder to resume"):
        resume_run(tmp_path)
    config = RunConfig.load("NONE", "GuessMyNumber-v0", overrides={**TINY, "n_timesteps": 40})
    with pytest.raises(RuntimeError, match="crash"):  # a run that died before its first checkpoint
        train_run(config, tmp_path / "early", SETTINGS, save_freq=0, callbacks=[_Crash()])
    with pytest.raises(ValueError, match="no checkpoint to resume from"):
        resume_run(tmp_path / "early")
    # The CLI: one line, exit 2; a resume takes no new settings.
    assert main(["train", "--resume", str(tmp_path / "early"), "--seed", "3", "--eval-freq", "5"]) == 2
    assert "drop --seed, --eval-freq" in capsys.readouterr().err
    assert main(["train", "--env", "GuessMyNumber-v0"]) == 2
    assert "train needs --env and --method (or --resume RUN_DIR)" in capsys.readouterr().err


def test_sigterm_saves_a_checkpoint_then_resume_finishes(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    command = [
        sys.executable, "-m", "sb3_comm.cli", "train", "--env", "GuessMyNumber-v0", "--method", "TCG",
        "-n", "300", "--n-envs", "2", "--params", "learning_starts=40", "batch_size=8", "buffer_size=1000",
        "policy_kwargs={net_arch: [8]}", "--eval-freq", "100", "--eval-episodes", "2", "--save-freq", "50",
        "--save-replay-buffer", "--no-progress-bar", "-f", str(tmp_path / "runs"),
    ]  # fmt: skip
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    run = tmp_path / "runs" / "GuessMyNumber-v0" / "TCG_seed0"
    deadline = time.monotonic() + 180
    while not list((run / "checkpoints").glob("model_*_steps.zip")) and time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()
        time.sleep(0.1)
    process.send_signal(signal.SIGTERM)
    out, err = process.communicate(timeout=120)
    assert process.returncode == 143, (out, err)
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert last.startswith("sb3-comm: interrupted by SIGTERM at ") and f"--resume {run}" in last
    steps = int(last.split(" at ")[1].split()[0])
    assert steps < 300 and (run / "checkpoints" / f"model_{steps}_steps.zip").exists()
    assert (run / "checkpoints" / f"model_replay_buffer_{steps}_steps.pkl").exists()
    assert (run / "model.zip").exists() and not (run / "result.json").exists()

    assert main(["train", "--resume", str(run), "--no-progress-bar"]) == 0
    assert "Resuming" in capsys.readouterr().out
    result = RunResult.load(run / "result.json")
    assert result.timesteps == 300 and [p["timesteps"] for p in result.curve] == [100, 200, 300]


def test_rl_zoo3_continues_training_with_i(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    common = ["--env", "GuessMyNumber-v0", "--method", "TCG", "-n", "60", "-f", str(logs), "--seed", "1"]
    params = ["-params", "n_envs:2", "learning_starts:20", "buffer_size:1000", "batch_size:8"]
    assert zoo_main(["train", *common, "--save-replay-buffer", *params]) == 0
    first = logs / "commddpg" / "GuessMyNumber-v0_1"
    assert (first / "replay_buffer.pkl").exists()
    # -i: the string hyperparameters (lin_1e-3) are converted, the replay buffer is checked and loaded.
    assert zoo_main(["train", *common, "-i", str(first / "GuessMyNumber-v0.zip"), *params]) == 0
    second = CommDDPG.load(logs / "commddpg" / "GuessMyNumber-v0_2" / "GuessMyNumber-v0.zip", device="cpu")
    assert second.method == "TCG" and second.num_timesteps >= 60
