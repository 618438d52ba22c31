"""CommDDPG: hybrid-action DDPG with NONE, RIAL, TCG, GSN and GSN-MAX communication.

``comm_ddpg.py`` holds the algorithm (a :class:`~sb3_comm.HybridDDPG` subclass), ``methods.py``
one object per communication method, ``policies.py`` the networks, ``gsn.py`` the grounded
semantic network and the callback that trains it, ``buffers.py`` the joint replay buffer. Imports
run one way: ``gsn`` <- ``methods`` <- ``policies`` <- ``comm_ddpg``.
"""

from sb3_comm.comm_ddpg.buffers import JointReplayBuffer
from sb3_comm.comm_ddpg.comm_ddpg import (
    AVERAGED_ACTOR,
    GSN_REWARD_SEES_TEAMMATE,
    OWN_REWARD_METHODS,
    CommDDPG,
)
from sb3_comm.comm_ddpg.gsn import GroundedSemanticNetwork, GSNTrainingCallback
from sb3_comm.comm_ddpg.methods import COMM_METHODS, METHODS, CommMethod
from sb3_comm.comm_ddpg.policies import CommPolicy, GSNMAXPolicy, GSNPolicy, NonePolicy, RIALPolicy, TCGPolicy
from sb3_comm.hybrid_ddpg import HybridDDPG, HybridPolicy

__all__ = [
    "AVERAGED_ACTOR",
    "COMM_METHODS",
    "GSN_REWARD_SEES_TEAMMATE",
    "METHODS",
    "OWN_REWARD_METHODS",
    "CommDDPG",
    "CommMethod",
    "CommPolicy",
    "GSNMAXPolicy",
    "GSNPolicy",
    "GSNTrainingCallback",
    "GroundedSemanticNetwork",
    "HybridDDPG",
    "HybridPolicy",
    "JointReplayBuffer",
    "NonePolicy",
    "RIALPolicy",
    "TCGPolicy",
]
