"""CommDDPG: hybrid-action DDPG with NONE, RIAL, TCG and GSN communication."""

from sb3_comm.comm_ddpg.buffers import JointReplayBuffer
from sb3_comm.comm_ddpg.comm_ddpg import METHODS, CommDDPG, HybridDDPG
from sb3_comm.comm_ddpg.gsn import GroundedSemanticNetwork, GSNTrainingCallback
from sb3_comm.comm_ddpg.policies import CommPolicy, GSNPolicy, NonePolicy, RIALPolicy, TCGPolicy

__all__ = [
    "METHODS",
    "CommDDPG",
    "CommPolicy",
    "GSNPolicy",
    "GSNTrainingCallback",
    "GroundedSemanticNetwork",
    "HybridDDPG",
    "JointReplayBuffer",
    "NonePolicy",
    "RIALPolicy",
    "TCGPolicy",
]
