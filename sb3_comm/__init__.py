"""sb3-comm: Stable-Baselines3 agents that learn to communicate (GSN, RIAL, TCG).

Reproduces Hausknecht & Stone, "Grounded Semantic Networks for Learning Shared Communication
Protocols" (NIPS 2016 Deep RL workshop) on a vectorised half-field soccer simulator.

>>> from sb3_comm import CommDDPG
>>> model = CommDDPG("GSN", "BlindSoccer-v0")  # doctest: +SKIP
>>> model.learn(10_000)  # doctest: +SKIP

The package, from the bottom up: :mod:`~sb3_comm.hybrid_ddpg` (``HybridDDPG``, the single-agent
ICLR 2016 DDPG, a TD3 subclass), :mod:`~sb3_comm.comm_ddpg` (``CommDDPG(HybridDDPG)``, the team,
with one object per communication method), :mod:`~sb3_comm.wrappers` (two-agent environments),
:mod:`~sb3_comm.config` (``RunConfig``: a run's checked configuration), :mod:`~sb3_comm.training`
(``train_run``: the one run path), :mod:`~sb3_comm.results` (``RunResult``, the run's record),
and on top :mod:`~sb3_comm.experiments`, :mod:`~sb3_comm.analysis`, :mod:`~sb3_comm.zoo` and the
``sb3-comm`` command (:mod:`~sb3_comm.cli`). The tasks come from ``envs.registry``.
"""

from sb3_comm.comm_ddpg import (
    AVERAGED_ACTOR,
    GSN_REWARD_SEES_TEAMMATE,
    METHODS,
    OWN_REWARD_METHODS,
    CommDDPG,
    CommPolicy,
    GroundedSemanticNetwork,
    HybridDDPG,
)
from sb3_comm.common.layout import CommLayout, HybridActionLayout
from sb3_comm.config import RunConfig
from sb3_comm.registration import TASK_IDS, make_comm_vec_env, register_envs
from sb3_comm.results import RunResult
from sb3_comm.training import build_model, train_run
from sb3_comm.wrappers import BatchedTwoAgentVecEnv, TwoAgentEnv

register_envs()

__version__ = "0.2.0"

__all__ = [
    "AVERAGED_ACTOR",
    "GSN_REWARD_SEES_TEAMMATE",
    "METHODS",
    "OWN_REWARD_METHODS",
    "TASK_IDS",
    "BatchedTwoAgentVecEnv",
    "CommDDPG",
    "CommLayout",
    "CommPolicy",
    "GroundedSemanticNetwork",
    "HybridActionLayout",
    "HybridDDPG",
    "RunConfig",
    "RunResult",
    "TwoAgentEnv",
    "build_model",
    "make_comm_vec_env",
    "register_envs",
    "train_run",
]
