"""CommDDPG's constructor defaults: the discount (0.95 since session 19) and the batch size (128
since session 23): what a new model uses, what the replay's Monte-Carlo returns and GSN's
regression use, and that a file saved with other settings keeps them."""

from __future__ import annotations

import pytest
from stable_baselines3.common.env_util import make_vec_env

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


def test_a_file_saved_with_sb3s_0_99_and_batches_of_64_loads_with_them(tmp_path) -> None:
    """The defaults change what a new model uses, not what a saved model was trained with."""
    CommDDPG("GSN", _env(), gamma=0.99, batch_size=64, buffer_size=1000, device="cpu").save(
        tmp_path / "old.zip"
    )
    loaded = CommDDPG.load(tmp_path / "old.zip", env=_env(), device="cpu")
    assert loaded.gamma == pytest.approx(0.99)
    assert loaded.replay_buffer.gamma == pytest.approx(0.99)
    assert loaded.batch_size == 64
