"""CommDDPG's constructor default discount (0.95 since session 19): what a new model uses, what the
replay's Monte-Carlo returns use, and that a file saved with another discount keeps it."""

from __future__ import annotations

import pytest
from stable_baselines3.common.env_util import make_vec_env

from sb3_comm import CommDDPG, HybridDDPG, make_comm_vec_env


def _env():
    return make_comm_vec_env("GuessMyNumber-v0", n_envs=2, seed=0)


@pytest.mark.parametrize("method", ["NONE", "RIAL", "TCG", "GSN", "GSN-MAX"])
def test_a_new_model_and_its_replay_discount_with_0_95(method: str) -> None:
    model = CommDDPG(method, _env(), mc_mixing=0.5, buffer_size=1000, seed=0, device="cpu")
    assert model.gamma == pytest.approx(0.95)
    assert model.replay_buffer.gamma == pytest.approx(0.95)  # the Monte-Carlo returns' discount


def test_the_single_agent_learner_keeps_sb3s_0_99() -> None:
    model = HybridDDPG("MlpPolicy", make_vec_env("HFOMoveToBall-v0", n_envs=1, seed=0), device="cpu")
    assert model.gamma == pytest.approx(0.99)


def test_a_file_saved_with_sb3s_0_99_loads_with_it(tmp_path) -> None:
    """The default changes what a new model uses, not what a saved model was trained with."""
    CommDDPG("GSN", _env(), gamma=0.99, buffer_size=1000, device="cpu").save(tmp_path / "old.zip")
    loaded = CommDDPG.load(tmp_path / "old.zip", env=_env(), device="cpu")
    assert loaded.gamma == pytest.approx(0.99)
    assert loaded.replay_buffer.gamma == pytest.approx(0.99)
