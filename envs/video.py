"""Record an episode of a policy as a GIF or MP4 (frames from ``render()``, messages as bars)."""

from __future__ import annotations

import pathlib
from collections.abc import Callable
from typing import Any

import numpy as np

from envs.soccer import render

__all__ = ["record_episode"]


def _frame(env: Any) -> np.ndarray:
    if getattr(env, "render_mode", None) == "rgb_array":
        return env.render()
    task = getattr(env, "task", None)
    if task is None:
        raise ValueError("The environment must have render_mode='rgb_array' (or a batched core .task).")
    return task.render(0)


def record_episode(
    env: Any,
    policy: Callable[[Any], Any],
    path: str | pathlib.Path,
    fps: int = 10,
    max_steps: int | None = None,
    seed: int | None = None,
) -> pathlib.Path:
    """Play one episode and save its frames with :func:`envs.soccer.render.save_video`.

    :param env: a PettingZoo ``ParallelEnv`` of this project (policy: obs dict -> action dict),
        or one of its Gymnasium environments (policy: obs -> action). Best created with
        ``render_mode="rgb_array"``; otherwise its batched core renders the frames.
    :param policy: maps the current observation(s) to the action(s).
    :param path: output file; the suffix (``.gif`` or ``.mp4``) picks the format.
    :param fps: frames per second.
    :param max_steps: stop after this many steps even if the episode goes on.
    :param seed: seed of the episode's reset.
    :return: the path written.
    """
    multi_agent = hasattr(env, "possible_agents")
    obs, _ = env.reset(seed=seed)
    frames = [_frame(env)]
    steps = 0
    while max_steps is None or steps < max_steps:
        obs, _, terminated, truncated, _ = env.step(policy(obs))
        over = not env.agents if multi_agent else (terminated or truncated)
        frames.append(_frame(env))
        steps += 1
        if over:
            break
    return render.save_video(frames, path, fps=fps)
