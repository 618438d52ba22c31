"""Task cores (batched over games) and their PettingZoo / Gymnasium shells.

* :class:`BatchedTask` (``batched.py``): the vectorised core, N games per step.
* :class:`BlindSoccerTask`, :class:`GuessMyNumberTask`: the paper's two communication tasks.
* :class:`CommParallelEnv` (``parallel.py``): the PettingZoo ``ParallelEnv`` shell.
* ``single_agent.py``: :class:`MoveToBallEnv`, :class:`ScoreEmptyGoalEnv` (Gymnasium) and their
  batched cores.
* ``hfo_actions.py``: the 8-entry HFO action vector and :func:`decode_actions`.
"""

from envs.tasks.batched import BatchedTask
from envs.tasks.blind_soccer import BlindSoccerTask
from envs.tasks.guess_my_number import GuessMyNumberTask
from envs.tasks.hfo_actions import ACTION_HIGH, ACTION_LOW, HYBRID_LAYOUT, decode_actions
from envs.tasks.parallel import CommParallelEnv
from envs.tasks.single_agent import MoveToBallEnv, MoveToBallTask, ScoreEmptyGoalEnv, ScoreEmptyGoalTask

__all__ = [
    "ACTION_HIGH",
    "ACTION_LOW",
    "HYBRID_LAYOUT",
    "BatchedTask",
    "BlindSoccerTask",
    "CommParallelEnv",
    "GuessMyNumberTask",
    "MoveToBallEnv",
    "MoveToBallTask",
    "ScoreEmptyGoalEnv",
    "ScoreEmptyGoalTask",
    "decode_actions",
]
