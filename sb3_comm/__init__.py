"""sb3-comm: Stable-Baselines3 agents that learn to communicate (GSN, RIAL, TCG).

Reproduces Hausknecht & Stone, "Grounded Semantic Networks for Learning Shared Communication
Protocols" (NIPS 2016 Deep RL workshop) on a vectorised half-field soccer simulator.

>>> from sb3_comm import CommDDPG
>>> model = CommDDPG("GSN", "BlindSoccer-v0")  # doctest: +SKIP
>>> model.learn(10_000)  # doctest: +SKIP
"""

from sb3_comm.comm_ddpg import METHODS, CommDDPG, CommPolicy, GroundedSemanticNetwork, HybridDDPG
from sb3_comm.common.layout import CommLayout, HybridActionLayout
from sb3_comm.registration import TASK_IDS, make_comm_vec_env, register_envs
from sb3_comm.wrappers import BatchedTwoAgentVecEnv, TwoAgentEnv

register_envs()

__version__ = "0.1.0"

__all__ = [
    "METHODS",
    "TASK_IDS",
    "BatchedTwoAgentVecEnv",
    "CommDDPG",
    "CommLayout",
    "CommPolicy",
    "GroundedSemanticNetwork",
    "HybridActionLayout",
    "HybridDDPG",
    "TwoAgentEnv",
    "make_comm_vec_env",
    "register_envs",
]
