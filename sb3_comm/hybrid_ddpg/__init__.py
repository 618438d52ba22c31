"""HybridDDPG: the parameterised-action DDPG of Hausknecht & Stone (ICLR 2016) for one agent."""

from sb3_comm.hybrid_ddpg.hybrid_ddpg import HybridDDPG
from sb3_comm.hybrid_ddpg.policies import HybridPolicy

__all__ = ["HybridDDPG", "HybridPolicy"]
