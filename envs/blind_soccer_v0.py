"""Blind Soccer, PettingZoo style: ``from envs import blind_soccer_v0``.

``parallel_env()`` is the one-game PettingZoo ``ParallelEnv`` (agents ``"sighted"`` and
``"blind"``), ``batched_env(n_games=...)`` the vectorised core with the same rules
(:class:`~envs.tasks.blind_soccer.BlindSoccerTask`). See ``envs/tasks/blind_soccer.py``.
"""

from __future__ import annotations

from typing import Any

from envs.tasks.blind_soccer import BlindSoccerTask
from envs.tasks.parallel import CommParallelEnv

__all__ = ["batched_env", "parallel_env", "raw_env"]


def parallel_env(render_mode: str | None = None, **kwargs: Any) -> CommParallelEnv:
    """One game of Blind Soccer as a PettingZoo ``ParallelEnv``.

    :param render_mode: ``None`` or ``"rgb_array"``.
    :param kwargs: ``seed``, ``params``, ``noise``, ``max_steps``, ``channel_size``,
        ``rules`` (``"paper"`` or ``"dqn-hfo"``), ``time_feature``.
    """
    return CommParallelEnv(BlindSoccerTask, render_mode=render_mode, **kwargs)


raw_env = parallel_env
"""Alias of :func:`parallel_env` (there is no AEC version)."""


def batched_env(n_games: int = 1, **kwargs: Any) -> BlindSoccerTask:
    """``n_games`` games of Blind Soccer stepped at once (see :class:`BatchedTask`)."""
    return BlindSoccerTask(n_games=n_games, **kwargs)
