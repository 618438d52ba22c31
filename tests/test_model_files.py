"""Model files: weights shared without pickles (save_weights / load_weights), and replay buffers
checked before they replace the model's (load_replay_buffer)."""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.buffers import ReplayBuffer
from stable_baselines3.common.save_util import save_to_pkl

from sb3_comm import CommDDPG, HybridDDPG
from sb3_comm.registration import make_comm_vec_env

TINY = {"learning_starts": 20, "batch_size": 8, "buffer_size": 500, "policy_kwargs": {"net_arch": [8]}}


def _trained(method: str = "GSN", n_envs: int = 2, task: str = "GuessMyNumber-v0", **kwargs) -> CommDDPG:
    env = make_comm_vec_env(task, n_envs=n_envs, seed=0)
    model = CommDDPG(method, env, device="cpu", seed=0, **{**TINY, **kwargs})
    return model.learn(60)


@pytest.mark.parametrize("target", ["weights.zip", "weights_folder"])
def test_save_weights_then_load_weights_predicts_the_same(tmp_path: Path, target: str) -> None:
    policy_kwargs = {"net_arch": [8], "activation_fn": th.nn.Tanh}
    model = _trained("GSN", share_parameters=False, policy_kwargs=policy_kwargs)
    path = model.save_weights(tmp_path / target)
    loaded = CommDDPG.load_weights(path, make_comm_vec_env("GuessMyNumber-v0", n_envs=2), device="cpu")
    assert loaded.method == "GSN" and loaded.share_parameters is False
    assert loaded.policy_kwargs["activation_fn"] is th.nn.Tanh and loaded.batch_size == 8
    obs = make_comm_vec_env("GuessMyNumber-v0", n_envs=2, seed=5).reset()
    for deterministic in (True,):
        expected, _ = model.predict(obs, deterministic=deterministic)
        actual, _ = loaded.predict(obs, deterministic=deterministic)
        np.testing.assert_array_equal(actual, expected)
    # A single agent's HybridDDPG has the same path.
    single = HybridDDPG("MlpPolicy", "Pendulum-v1", device="cpu", seed=0, **TINY)
    back = HybridDDPG.load_weights(single.save_weights(tmp_path / "single.zip"), "Pendulum-v1", device="cpu")
    observation = np.zeros((1, 3), dtype=np.float32)
    np.testing.assert_array_equal(back.predict(observation)[0], single.predict(observation)[0])


class _Payload:
    """What a crafted model file carries: unpickling it calls os.mkdir."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple:
        return os.mkdir, (str(self.marker),)


def test_a_pickle_payload_in_the_weights_is_refused_without_running(tmp_path: Path) -> None:
    model = _trained("TCG")
    path = model.save_weights(tmp_path / "weights.zip")
    marker = tmp_path / "code_ran"
    with zipfile.ZipFile(path) as archive:
        config = archive.read("config.json")
    crafted = tmp_path / "crafted.zip"
    with zipfile.ZipFile(crafted, "w") as archive:
        archive.writestr("config.json", config)
        with archive.open("policy.pth", "w") as handle:
            th.save({**model.policy.state_dict(), "evil": _Payload(marker)}, handle)
    with pytest.raises(ValueError, match=r"policy.pth was refused: it is not a plain file of tensors"):
        CommDDPG.load_weights(crafted, "GuessMyNumber-v0", device="cpu")
    assert not marker.exists()  # the payload never ran


def test_load_weights_names_a_wrong_environment_or_file(tmp_path: Path) -> None:
    path = _trained("RIAL").save_weights(tmp_path / "w.zip")
    with pytest.raises(ValueError, match="was trained on an environment of layout"):
        CommDDPG.load_weights(path, "BlindSoccer-v0", device="cpu")
    with pytest.raises(ValueError, match="holds a CommDDPG model"):
        HybridDDPG.load_weights(path, "Pendulum-v1", device="cpu")
    (tmp_path / "bad.zip").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match=r"bad.zip is not a weights file"):
        CommDDPG.load_weights(tmp_path / "bad.zip", "GuessMyNumber-v0")
    with pytest.raises(FileNotFoundError, match="No model weights at"):
        CommDDPG.load_weights(tmp_path / "missing.zip", "GuessMyNumber-v0")


def test_load_replay_buffer_checks_before_replacing(tmp_path: Path) -> None:
    source = _trained("GSN", n_envs=2)
    source.save_replay_buffer(tmp_path / "buffer.pkl")
    # It fits a model of the same kind: replaced, with its transitions.
    same = CommDDPG("GSN", make_comm_vec_env("GuessMyNumber-v0", n_envs=2), device="cpu", **TINY)
    same.load_replay_buffer(tmp_path / "buffer.pkl")
    assert same.replay_buffer.pos == source.replay_buffer.pos > 0
    np.testing.assert_array_equal(same.replay_buffer.observations, source.replay_buffer.observations)

    # Another number of games and another task: refused, naming both, the buffer untouched.
    other = CommDDPG("GSN", make_comm_vec_env("BlindSoccer-v0", n_envs=3), device="cpu", **TINY)
    before = other.replay_buffer
    with pytest.raises(ValueError, match=r"n_envs 2 \(model: 3\).*unchanged") as error:
        other.load_replay_buffer(tmp_path / "buffer.pkl")
    assert "observation shape" in str(error.value)
    assert other.replay_buffer is before
    # SB3's plain buffer (what TD3 saves) is not a JointReplayBuffer.
    plain = ReplayBuffer(100, source.observation_space, source.action_space, n_envs=2)
    save_to_pkl(tmp_path / "plain.pkl", plain)
    with pytest.raises(ValueError, match="it is a ReplayBuffer, not a JointReplayBuffer"):
        other.load_replay_buffer(tmp_path / "plain.pkl")
    (tmp_path / "cut.pkl").write_bytes(b"\x80\x04truncated")
    with pytest.raises(ValueError, match=r"cut\.pkl is not a readable replay buffer"):
        other.load_replay_buffer(tmp_path / "cut.pkl")
    assert other.replay_buffer is before
