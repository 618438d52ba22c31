"""Hyperparameter values as written in configuration files, and the Python values they stand for.

A value is converted in one direction only, once:

* :func:`canonical_value` puts what a user wrote (in a YAML file or a ``key=value`` override)
  into the *text form* that run configurations keep, write to ``config.yml`` and fingerprint:
  YAML 1.1 reads ``1e-3`` (no dot) as a string, which becomes the number 0.001; a learning rate
  written ``lin_1e-3`` (rl-zoo3's notation for a linear decay from 1e-3 to 0 over training)
  becomes ``lin_0.001``; so does the Monte-Carlo mixing β (``mc_mixing: lin_0.5``).
* :func:`python_value` turns the text form into what an algorithm takes: a ``lin_`` string
  becomes a :class:`~stable_baselines3.common.utils.LinearSchedule`. Algorithms themselves take
  plain Python values only, as every SB3 algorithm does.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from stable_baselines3.common.utils import LinearSchedule

__all__ = ["SCHEDULED_KEYS", "algorithm_kwargs", "canonical_value", "coerce_number", "python_value"]

_SCHEDULE_PREFIX = "lin_"


def coerce_number(value: Any) -> Any:
    """A string that parses as a float becomes that float; anything else is returned unchanged."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


SCHEDULED_KEYS = ("mc_mixing",)
"""Hyperparameters besides the learning rates (``*learning_rate``) that may be written ``lin_<start>``."""


def _is_schedule(key: str, value: Any) -> bool:
    scheduled = key.endswith("learning_rate") or key in SCHEDULED_KEYS
    return scheduled and isinstance(value, str) and value.startswith(_SCHEDULE_PREFIX)


def _schedule_start(key: str, value: str) -> float:
    start = coerce_number(value[len(_SCHEDULE_PREFIX) :])
    if not isinstance(start, float):
        raise ValueError(f"{key}: {value!r} is not a linear schedule 'lin_<number>' (e.g. 'lin_1e-3')")
    return start


def canonical_value(key: str, value: Any) -> Any:
    """The text form of ``value`` for hyperparameter ``key`` (see the module docstring).

    :raises ValueError: a ``lin_`` learning rate whose start is not a number.
    """
    if _is_schedule(key, value):
        return f"{_SCHEDULE_PREFIX}{_schedule_start(key, value)}"
    return coerce_number(value)


def python_value(key: str, value: Any) -> Any:
    """The Python value of a text-form hyperparameter: ``lin_<start>`` learning rates (and
    ``mc_mixing``) become ``LinearSchedule(start, 0, 1)``; everything else is returned as it is."""
    if _is_schedule(key, value):
        return LinearSchedule(_schedule_start(key, value), 0.0, 1.0)
    return value


def algorithm_kwargs(settings: Mapping[str, Any]) -> dict[str, Any]:
    """Keyword arguments of an algorithm from text-form settings (:func:`python_value` of each)."""
    return {key: python_value(key, canonical_value(key, value)) for key, value in settings.items()}
