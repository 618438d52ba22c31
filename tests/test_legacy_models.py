"""Model files saved by sb3-comm 0.1.0 still load and act the same (tests/data/models_v0.1.0)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from stable_baselines3.common.env_util import make_vec_env

import envs  # noqa: F401  (registers the HFO ids)
from sb3_comm import CommDDPG, HybridDDPG, make_comm_vec_env
from sb3_comm.comm_ddpg.policies import GSNPolicy, TCGPolicy
from sb3_comm.hybrid_ddpg import HybridPolicy

DATA = Path(__file__).parent / "data" / "models_v0.1.0"
PREDICTIONS = np.load(DATA / "predictions_v0.1.0.npz")


@pytest.mark.parametrize(("method", "policy_class"), [("GSN", GSNPolicy), ("TCG", TCGPolicy)])
def test_commddpg_file_of_0_1_0_loads_and_predicts_the_same(method: str, policy_class: type) -> None:
    model = CommDDPG.load(DATA / f"commddpg_{method.lower()}_v0.1.0.zip", device="cpu")
    assert type(model.policy) is policy_class and model.method == method
    assert model.shared_reward is False  # trained on each agent's own reward, it keeps learning so
    actions, _ = model.predict(PREDICTIONS[f"{method}_obs"], deterministic=True)
    # the same to float precision: matrix products round differently on other CPUs (AVX2, AVX-512)
    np.testing.assert_allclose(actions, PREDICTIONS[f"{method}_actions"], rtol=1e-5, atol=1e-4)
    # and it trains on, with its optimizer states
    assert model.actor.optimizer.state_dict()["state"]
    model.set_env(make_comm_vec_env("GuessMyNumber-v0", n_envs=2, seed=1))
    model.learn(30, reset_num_timesteps=False)
    if method == "GSN":
        assert model.gsn_callback is not None and model.gsn_callback.n_updates > 0


def test_hybrid_ddpg_file_of_0_1_0_loads_and_predicts_the_same() -> None:
    model = HybridDDPG.load(DATA / "hybrid_ddpg_v0.1.0.zip", device="cpu")
    assert type(model.policy) is HybridPolicy and model.policy.hybrid
    actions, _ = model.predict(PREDICTIONS["hybrid_obs"], deterministic=True)
    # the same to float precision: matrix products round differently on other CPUs (AVX2, AVX-512)
    np.testing.assert_allclose(actions, PREDICTIONS["hybrid_actions"], rtol=1e-5, atol=1e-4)
    model.set_env(make_vec_env("HFOMoveToBall-v0", n_envs=2, seed=1))
    model.learn(30, reset_num_timesteps=False)
    # saved again, it is a file of the new layout
    assert "comm_layout" not in model.policy_kwargs
