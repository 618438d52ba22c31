"""The device code path, tested on the CPU (issue 13, GPU item).

A run on a GPU fails where a tensor is made without the model's device: it lands on the CPU and
meets the GPU's tensors. Here torch's default device is set to ``"meta"`` (tensors without data)
while the model lives on the CPU, so a tensor made on the default device instead of the model's
fails the same way, on a machine without a GPU. And a GPU that torch cannot see is a clear error,
not SB3's silent fall-back to the CPU.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.utils import LinearSchedule

import envs  # noqa: F401  (registers the HFO ids)
from sb3_comm import METHODS, CommDDPG, HybridDDPG, make_comm_vec_env
from sb3_comm.cli import main
from sb3_comm.evaluation import evaluate_team

TINY: dict[str, Any] = {
    "learning_starts": 24,
    "batch_size": 8,
    "buffer_size": 400,
    "policy_kwargs": {"net_arch": [8]},
    "seed": 0,
    "device": "cpu",
}


@pytest.fixture
def default_device_meta() -> Iterator[None]:
    """Tensors made without a device are on ``meta`` for the test's duration."""
    th.set_default_device("meta")
    try:
        yield
    finally:
        th.set_default_device(None)


@pytest.fixture
def no_gpu(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(th.cuda, "is_available", lambda: False)
    monkeypatch.setattr(th.cuda, "device_count", lambda: 0)


def test_the_meta_default_catches_a_tensor_made_without_the_model_device(default_device_meta: None) -> None:
    on_cpu = th.ones(2, device="cpu")
    with pytest.raises((RuntimeError, NotImplementedError)):
        (on_cpu + th.ones(2)).tolist()  # what the tests below would hit


@pytest.mark.parametrize(
    ("method", "extra"),
    [(m, {}) for m in METHODS]
    + [
        ("GSN", {"relabel_messages": True, "mc_mixing": 0.5}),
        (
            "GSN-MAX",
            {
                "gsn_max_explore_messages": False,
                "policy_kwargs": {"net_arch": [8], "gsn_maximising_head": True},
                "mc_mixing": LinearSchedule(0.5, 0.0, 1.0),
            },
        ),
        (
            "TCG",
            {
                "policy_kwargs": {"net_arch": [8], "n_critics": 2},
                "target_policy_noise": 0.2,
                "policy_delay": 2,
            },
        ),
    ],
)
def test_training_and_evaluation_make_every_tensor_on_the_model_device(
    method: str, extra: dict[str, Any], default_device_meta: None
) -> None:
    th.set_default_device("cpu")  # the model is built on the CPU, then the default moves away
    model = CommDDPG(method, make_comm_vec_env("BlindSoccer-v0", n_envs=2, seed=0), **{**TINY, **extra})
    th.set_default_device("meta")
    model.learn(60)
    assert model.n_updates > 0
    assert all(p.device.type == "cpu" and th.isfinite(p).all() for p in model.policy.parameters())
    obs = model.env.reset()
    actions, _ = model.predict(obs, deterministic=True)
    assert np.isfinite(actions).all()
    assert np.isfinite(evaluate_team(model, "BlindSoccer-v0", n_episodes=1).mean)


def test_hybrid_ddpg_makes_every_tensor_on_the_model_device(default_device_meta: None) -> None:
    th.set_default_device("cpu")
    model = HybridDDPG("MlpPolicy", make_vec_env("HFOMoveToBall-v0", n_envs=2, seed=0), mc_mixing=0.5, **TINY)
    th.set_default_device("meta")
    model.learn(60)
    assert model.n_updates > 0 and all(p.device.type == "cpu" for p in model.policy.parameters())


@pytest.mark.parametrize("device", ["cuda", "cuda:0", th.device("cuda")])
def test_a_gpu_torch_cannot_see_is_an_error(device: Any, no_gpu: None, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"asks for a GPU, but torch .* sees no CUDA device here; use 'cpu'"):
        CommDDPG("GSN", "GuessMyNumber-v0", device=device)
    model = CommDDPG("NONE", "GuessMyNumber-v0", **TINY)
    model.save(tmp_path / "m.zip")
    with pytest.raises(ValueError, match="sees no CUDA device"):
        CommDDPG.load(tmp_path / "m.zip", device=device)  # not SB3's silent fall-back to the CPU


def test_a_gpu_index_beyond_those_torch_sees_is_an_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(th.cuda, "is_available", lambda: True)
    monkeypatch.setattr(th.cuda, "device_count", lambda: 1)
    with pytest.raises(ValueError, match=r"device='cuda:1': torch sees 1 CUDA device\(s\), indices 0 to 0"):
        CommDDPG("GSN", "GuessMyNumber-v0", device="cuda:1")


@pytest.mark.parametrize(
    ("device", "error", "match"),
    [("gpu", ValueError, "device must be 'auto', 'cpu', 'cuda'"), (0, TypeError, r"got 0 \(int\)")],
)
def test_a_device_torch_does_not_know_is_an_error(device: Any, error: type[Exception], match: str) -> None:
    with pytest.raises(error, match=match):
        HybridDDPG("MlpPolicy", "HFOMoveToBall-v0", device=device)


@pytest.mark.parametrize("device", ["auto", "cpu", th.device("cpu")])
def test_the_cpu_and_auto_are_accepted_without_a_gpu(device: Any, no_gpu: None) -> None:
    assert CommDDPG("GSN", "GuessMyNumber-v0", device=device).device.type == "cpu"


def test_cli_device_without_a_gpu_exits_2_before_any_folder(
    no_gpu: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["train", "--env", "GuessMyNumber-v0", "--method", "NONE", "--device", "cuda"]
    with pytest.raises(SystemExit) as exited:
        main([*argv, "--log-folder", str(tmp_path / "runs")])
    assert exited.value.code == 2
    assert "argument --device: 'cuda' asks for a GPU" in capsys.readouterr().err
    assert not (tmp_path / "runs").exists()
