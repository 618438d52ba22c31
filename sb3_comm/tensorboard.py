"""TensorBoard for a run: its logger, hyperparameters, a video of an evaluation episode, and the
messages in the Embedding Projector.

Everything goes through SB3's logger (``HParam`` for the hyperparameters), except the projector,
which SB3 has no type for (``torch.utils.tensorboard``'s ``add_embedding``), and videos, which
SB3's ``Video`` can no longer write with moviepy 2 (:func:`log_video` writes the same GIF). The event
files of a run are written straight into its TensorBoard folder, so that
``tensorboard --logdir <experiment>/tb`` names each run by its folder (``GSN/BlindSoccer-v0/seed0``).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.logger import (
    HParam,
    HumanOutputFormat,
    Logger,
    TensorBoardOutputFormat,
)

from sb3_comm.common.train_log import NOT_SCALAR_FORMATS, dump_only

__all__ = [
    "PROJECTOR_HEADER",
    "event_logger",
    "log_video",
    "projector_rows",
    "record_hparams",
    "tensorboard_video",
    "write_projector",
]

PROJECTOR_HEADER = ("sender", "receiver_next_action", "episode", "step", "ball_bearing_deg")
"""Metadata columns of every message in the projector (``ball_bearing_deg``: Blind Soccer only,
the ball's bearing from the sender's body, degrees, positive to its right as HFO's angles)."""


def event_logger(folder: str | Path, verbose: int = 0) -> Logger:
    """An SB3 logger that writes TensorBoard event files straight into ``folder`` (and the console
    with ``verbose``), for ``model.set_logger``.

    SB3's own ``tensorboard_log`` adds a ``<tb_log_name>_<n>`` folder per ``learn`` call; one run
    folder per run reads better in a chart of many runs.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    formats: list[Any] = [TensorBoardOutputFormat(str(folder))]
    if verbose:
        formats.append(HumanOutputFormat(sys.stdout))
    return Logger(folder=str(folder), output_formats=formats)


def record_hparams(
    logger: Logger, hyperparams: Mapping[str, Any], metrics: Mapping[str, float | None], step: int
) -> None:
    """Write the run's hyperparameters and final metrics to TensorBoard's HPARAMS view.

    The metrics are written as scalars too (the view reads their last value).

    :param logger: the run's logger.
    :param hyperparams: name -> value; anything not a number, bool or string is written as text.
    :param metrics: tag -> final value (None and NaN are left out).
    :param step: the step of the metric scalars.
    """
    hparams = {
        key: value if isinstance(value, (bool, int, float, str)) else str(value)
        for key, value in hyperparams.items()
        if value is not None
    }
    finite = {k: float(v) for k, v in metrics.items() if v is not None and math.isfinite(float(v))}
    dump_only(
        logger,
        {**finite, "hparams": HParam(hparams, dict.fromkeys(finite, 0.0))},
        step,
        {"hparams": NOT_SCALAR_FORMATS},
    )


def _play_frames(
    model: BaseAlgorithm, env_id: str, max_steps: int, seed: int, env_kwargs: Mapping[str, Any] | None
) -> np.ndarray:
    """(T, H, W, 3) uint8 frames of one deterministic episode (messages drawn as bars)."""
    import gymnasium as gym

    env = gym.make(env_id, render_mode="rgb_array", **dict(env_kwargs or {}))
    try:
        obs, _ = env.reset(seed=seed)
        frames = [env.render()]
        for _ in range(max_steps):
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, truncated, _ = env.step(action)
            frames.append(env.render())
            if terminated or truncated:
                break
    finally:
        env.close()
    return np.stack([np.asarray(f, dtype=np.uint8) for f in frames])


def tensorboard_video(
    model: BaseAlgorithm,
    env_id: str,
    max_steps: int = 100,
    seed: int = 0,
    env_kwargs: Mapping[str, Any] | None = None,
) -> np.ndarray:
    """The frames of one deterministic evaluation episode, at half size: (T, H, W, 3) uint8.

    :param model: the team.
    :param env_id: its task.
    :param max_steps: the most steps played.
    :param seed: the episode's seed.
    :param env_kwargs: task options.
    """
    return _play_frames(model, env_id, max_steps, seed, env_kwargs)[:, ::2, ::2]


def log_video(logger: Logger, key: str, frames: np.ndarray, step: int, fps: float = 10) -> bool:
    """Write ``frames`` (T, H, W, 3) uint8 to TensorBoard's IMAGES tab as an animated GIF.

    This is what SB3's ``Video`` does through ``torch``'s ``add_video``, which needs
    ``moviepy.editor`` (gone in moviepy 2): the GIF is encoded with Pillow instead and written by
    the logger's own TensorBoard writer.

    :return: whether the logger had a TensorBoard output to write to.
    """
    import io

    from PIL import Image as PILImage
    from tensorboard.compat.proto.summary_pb2 import Summary

    pictures = [PILImage.fromarray(np.ascontiguousarray(frame)) for frame in frames]
    buffer = io.BytesIO()
    duration = max(1, round(1000 / fps))
    pictures[0].save(
        buffer, format="GIF", save_all=True, append_images=pictures[1:], duration=duration, loop=0
    )
    height, width = frames.shape[1:3]
    image = Summary.Image(height=height, width=width, colorspace=3, encoded_image_string=buffer.getvalue())
    summary = Summary(value=[Summary.Value(tag=key, image=image)])
    written = False
    for output in logger.output_formats:
        if isinstance(output, TensorBoardOutputFormat):
            output.writer.file_writer.add_summary(summary, step)
            output.writer.flush()
            written = True
    return written


def projector_rows(rollout: Any) -> tuple[np.ndarray, list[list[str]], list[str]]:
    """Messages of a recorded rollout, one row per message a receiver then acted on, with metadata.

    :param rollout: a :class:`~sb3_comm.analysis.rollout.Rollout`.
    :return: (messages (n, channel_size), metadata rows, sender name of each row).
    """
    from envs.soccer.features import BALL_ANGLE_COS, BALL_ANGLE_SIN
    from sb3_comm.analysis.rollout import ACTION_NAMES, communication_directions

    names = list(rollout.agent_names)
    blind_soccer = "sighted" in names and "blind" in names
    vectors, rows, senders = [], [], []
    alive = rollout.alive[:-1] & rollout.alive[1:]  # the receiver acts on a message one step later
    steps, games = np.nonzero(alive)
    for sender, receiver in communication_directions(names):
        vectors.append(rollout.messages[steps, games, sender])
        actions = rollout.action_types[steps + 1, games, receiver]
        obs = rollout.observations[steps, games, sender]
        bearing = np.degrees(np.arctan2(obs[:, BALL_ANGLE_SIN], obs[:, BALL_ANGLE_COS]))
        for k in range(steps.size):
            rows.append(
                [
                    names[sender],
                    ACTION_NAMES[int(actions[k])]
                    if int(actions[k]) < len(ACTION_NAMES)
                    else str(int(actions[k])),
                    str(int(games[k])),
                    str(int(steps[k])),
                    f"{bearing[k]:.0f}" if blind_soccer else "",
                ]
            )
            senders.append(names[sender])
    if not vectors:
        return np.zeros((0, rollout.channel_size), dtype=np.float32), [], []
    return np.concatenate(vectors).astype(np.float32), rows, senders


def write_projector(
    model: BaseAlgorithm,
    env_id: str,
    folder: str | Path,
    n_episodes: int = 20,
    seed: int = 0,
    step: int | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
) -> Path:
    """Play ``n_episodes`` deterministic episodes and write the messages sent to TensorBoard's
    Embedding Projector (the paper's Figure 3, interactive), with :data:`PROJECTOR_HEADER`
    metadata; colour by ``receiver_next_action`` or ``ball_bearing_deg`` in the projector.

    :param model: a trained team.
    :param env_id: its task.
    :param folder: the run's TensorBoard folder (``projector_config.pbtxt`` goes there).
    :param n_episodes: episodes played (one per parallel game).
    :param seed: their seed.
    :param step: the training step it belongs to (default: ``model.num_timesteps``).
    :param env_kwargs: task options.
    :return: ``folder``.
    :raises ValueError: a task without a message channel.
    """
    from torch.utils.tensorboard import SummaryWriter

    from sb3_comm.analysis.rollout import collect_rollout

    rollout = collect_rollout(
        model, env_id, n_episodes=n_episodes, seed=seed, env_kwargs=dict(env_kwargs or {})
    )
    if not rollout.channel_size:
        raise ValueError(f"{env_id} with this model has no message channel: nothing for the projector")
    vectors, rows, _ = projector_rows(rollout)
    folder = Path(folder)
    writer = SummaryWriter(str(folder))
    try:
        writer.add_embedding(
            vectors,
            metadata=rows,
            metadata_header=list(PROJECTOR_HEADER),
            global_step=int(model.num_timesteps if step is None else step),
            tag="messages",
        )
    finally:
        writer.close()
    return folder
