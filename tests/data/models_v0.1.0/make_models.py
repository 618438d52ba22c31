"""Model files of sb3-comm 0.1.0 (before the algorithm classes were restructured).

Used by tests/test_legacy_models.py. Run with the 0.1.0 code on the path:
``PYTHONPATH=<0.1.0 checkout> python make_models.py <out dir>``.
"""

import sys

import numpy as np
import torch as th
from stable_baselines3.common.env_util import make_vec_env

import envs  # noqa: F401  (registers the HFO ids)
from sb3_comm import CommDDPG, HybridDDPG, make_comm_vec_env


def main(out_dir: str) -> None:
    """Save two CommDDPG files, one HybridDDPG file and their predictions on fixed observations."""
    th.set_num_threads(1)
    tiny = {"net_arch": [8], "gsn_net_arch": [4], "gsn_reward_net_arch": [4]}
    small = {"seed": 0, "learning_starts": 20, "batch_size": 8, "buffer_size": 100, "device": "cpu"}
    preds = {}
    for method in ("GSN", "TCG"):
        env = make_comm_vec_env("GuessMyNumber-v0", n_envs=2, seed=0)
        model = CommDDPG(method, env, policy_kwargs=tiny, **small)
        model.learn(60)
        obs = np.random.default_rng(1).uniform(-1, 1, size=(4, *model.observation_space.shape))
        preds[f"{method}_obs"] = obs.astype(np.float32)
        preds[f"{method}_actions"] = model.predict(preds[f"{method}_obs"], deterministic=True)[0]
        model.save(f"{out_dir}/commddpg_{method.lower()}_v0.1.0.zip")
    env = make_vec_env("HFOMoveToBall-v0", n_envs=2, seed=0)
    model = HybridDDPG("MlpPolicy", env, policy_kwargs={"net_arch": [8]}, **small)
    model.learn(60)
    obs = np.random.default_rng(1).uniform(-1, 1, size=(4, *model.observation_space.shape))
    preds["hybrid_obs"] = obs.astype(np.float32)
    preds["hybrid_actions"] = model.predict(preds["hybrid_obs"], deterministic=True)[0]
    model.save(f"{out_dir}/hybrid_ddpg_v0.1.0.zip")
    np.savez(f"{out_dir}/predictions_v0.1.0.npz", **preds)


if __name__ == "__main__":
    main(sys.argv[1])
