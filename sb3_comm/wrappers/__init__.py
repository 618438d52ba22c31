"""Wrappers that turn two-agent tasks into environments SB3 can drive."""

from sb3_comm.wrappers.batched_vec_env import BatchedSingleAgentVecEnv, BatchedTwoAgentVecEnv
from sb3_comm.wrappers.silence import NativeChannel, SilenceNativeChannel
from sb3_comm.wrappers.two_agent import TwoAgentEnv, make_task_env

__all__ = [
    "BatchedSingleAgentVecEnv",
    "BatchedTwoAgentVecEnv",
    "NativeChannel",
    "SilenceNativeChannel",
    "TwoAgentEnv",
    "make_task_env",
]
