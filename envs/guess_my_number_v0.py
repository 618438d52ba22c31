"""Guess My Number, PettingZoo style: ``from envs import guess_my_number_v0``.

``parallel_env()`` is the one-game PettingZoo ``ParallelEnv`` (agents ``"agent_0"`` and
``"agent_1"``), ``batched_env(n_games=...)`` the vectorised core with the same rules
(:class:`~envs.tasks.guess_my_number.GuessMyNumberTask`). See ``envs/tasks/guess_my_number.py``.
"""

from __future__ import annotations

from typing import Any

from envs.tasks.guess_my_number import GuessMyNumberTask
from envs.tasks.parallel import CommParallelEnv

__all__ = ["batched_env", "parallel_env", "raw_env"]


def parallel_env(render_mode: str | None = None, **kwargs: Any) -> CommParallelEnv:
    """One game of Guess My Number as a PettingZoo ``ParallelEnv``.

    :param render_mode: ``None`` or ``"rgb_array"``.
    :param kwargs: ``seed``, ``params``, ``noise``, ``max_steps``, ``channel_size``,
        ``rules`` (``"paper"`` or ``"dqn-hfo"``),
        ``hidden_numbers``, ``time_feature``.
    """
    return CommParallelEnv(GuessMyNumberTask, render_mode=render_mode, **kwargs)


raw_env = parallel_env
"""Alias of :func:`parallel_env` (there is no AEC version)."""


def batched_env(n_games: int = 1, **kwargs: Any) -> GuessMyNumberTask:
    """``n_games`` games of Guess My Number stepped at once (see :class:`BatchedTask`)."""
    return GuessMyNumberTask(n_games=n_games, **kwargs)
