"""HybridDDPG (ICLR 2016 single agent): learns, saves and loads; schedules are plain values."""

from __future__ import annotations

import numpy as np
import pytest
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.utils import LinearSchedule

import envs  # noqa: F401  (registers the HFO ids)
from sb3_comm import CommDDPG, HybridDDPG, make_comm_vec_env
from sb3_comm.hybrid_ddpg import HybridPolicy


def test_learn_save_load_round_trip(tmp_path) -> None:
    env = make_vec_env("HFOMoveToBall-v0", n_envs=2, seed=0)
    model = HybridDDPG(
        "MlpPolicy", env, learning_starts=20, batch_size=8, buffer_size=200,
        actor_learning_rate=LinearSchedule(1e-4, 0.0, 1.0), policy_kwargs={"net_arch": [16]}, seed=0,
        device="cpu",
    )  # fmt: skip
    model.learn(60)
    assert isinstance(model.policy, HybridPolicy) and model.policy.hybrid
    assert model.n_updates > 0 and model.replay_buffer.sample(4).observations.shape == (4, 58)
    obs = env.reset()
    before, _ = model.predict(obs, deterministic=True)
    model.save(tmp_path / "hybrid.zip")
    loaded = HybridDDPG.load(tmp_path / "hybrid.zip", device="cpu")
    np.testing.assert_array_equal(before, loaded.predict(obs, deterministic=True)[0])
    assert loaded.n_updates == model.n_updates


def test_one_agent_and_two_agents_are_told_apart() -> None:
    with pytest.raises(ValueError, match="1-D Box"):
        HybridDDPG("MlpPolicy", make_comm_vec_env("GuessMyNumber-v0", n_envs=1))
    with pytest.raises(ValueError, match="HybridDDPG"):
        CommDDPG("GSN", make_vec_env("HFOMoveToBall-v0", n_envs=1))


@pytest.mark.parametrize("key", ["learning_rate", "actor_learning_rate", "gsn_learning_rate"])
def test_schedule_strings_belong_in_config_files(key: str) -> None:
    with pytest.raises(TypeError, match=r"float or a callable.*sb3_comm\.config"):
        CommDDPG("GSN", "GuessMyNumber-v0", device="cpu", **{key: "lin_1e-4"})
    model = CommDDPG("GSN", "GuessMyNumber-v0", device="cpu", **{key: LinearSchedule(1e-4, 0.0, 1.0)})
    assert getattr(model, key)(0.5) == pytest.approx(5e-5)
