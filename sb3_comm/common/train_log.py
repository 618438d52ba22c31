"""Training values between two logged points: averaged, without a host sync per update.

The learners add a value per update (a loss, a Q statistic, a time); :class:`TrainLog` keeps
running sums (tensors stay on their device: no ``.item()`` per update) and hands the means over
once per logged point. :func:`dump_only` writes a few values at a given step without flushing
anything else the logger holds (an evaluation between two training points).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import torch as th
from stable_baselines3.common.logger import Logger

__all__ = ["NOT_SCALAR_FORMATS", "TrainLog", "dump_only"]

NOT_SCALAR_FORMATS = ("stdout", "log", "json", "csv")
"""Output formats a histogram, an image, a video or hyperparameters are excluded from (only
TensorBoard takes them)."""


class TrainLog:
    """Sums and counts per key, averaged and cleared by :meth:`pop_means`.

    Example::

        log = TrainLog()
        log.add("train/critic_loss", loss.detach())  # a 0-d tensor: no sync
        log.add("time/agent_update_ms", 12.0, count=4)  # 4 updates took 12 ms in all
        log.pop_means()  # {"train/critic_loss": ..., "time/agent_update_ms": 3.0}
    """

    def __init__(self) -> None:
        self._sums: dict[str, Any] = {}
        self._counts: dict[str, int] = {}

    def add(self, key: str, value: float | th.Tensor, count: int = 1) -> None:
        """Add ``value`` (the sum of ``count`` observations) to ``key``.

        :param key: the logger key (``train/critic_loss``).
        :param value: a number or a 0-d tensor (detached; it stays on its device until
            :meth:`pop_means`).
        :param count: how many observations ``value`` sums.
        """
        if isinstance(value, th.Tensor):
            value = value.detach()
        if key in self._sums:
            self._sums[key] = self._sums[key] + value
            self._counts[key] += count
        else:
            self._sums[key] = value
            self._counts[key] = count

    def __contains__(self, key: str) -> bool:
        return key in self._sums

    def pop_means(self) -> dict[str, float]:
        """The mean of every key since the last call (one host transfer per key), then clear."""
        means = {}
        for key, total in self._sums.items():
            value = total.item() if isinstance(total, th.Tensor) else float(total)
            means[key] = value / max(self._counts[key], 1)
        self._sums.clear()
        self._counts.clear()
        return means


def dump_only(
    logger: Logger,
    values: Mapping[str, Any],
    step: int,
    exclude: Mapping[str, Iterable[str] | str | None] | None = None,
) -> None:
    """Write ``values`` at ``step`` as one logger dump, keeping what the logger already held.

    SB3's ``Logger.dump`` writes (and clears) every recorded value; an evaluation made between two
    training points must not write, or drop, the training values gathered so far.

    :param logger: the SB3 logger.
    :param values: key -> value (scalars, arrays for histograms, SB3 ``Video``/``Image``/``HParam``).
    :param step: the x-axis value (environment steps).
    :param exclude: per key, output formats it is kept out of.
    """
    held = (dict(logger.name_to_value), dict(logger.name_to_count), dict(logger.name_to_excluded))
    logger.name_to_value.clear()
    logger.name_to_count.clear()
    logger.name_to_excluded.clear()
    try:
        for key, value in values.items():
            logger.record(key, value, exclude=(exclude or {}).get(key))
        logger.dump(step)
    finally:
        logger.name_to_value.update(held[0])
        logger.name_to_count.update(held[1])
        logger.name_to_excluded.update(held[2])
