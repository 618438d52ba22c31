"""Values as written in hyperparameter files and on the command line.

YAML 1.1 reads ``1e-3`` (no dot) as a string; such strings are numbers. A learning rate may be
written ``lin_1e-3`` (rl-zoo3's notation): a linear decay from 1e-3 to 0 over training.
"""

from __future__ import annotations

from typing import Any

from stable_baselines3.common.utils import LinearSchedule

__all__ = ["coerce_number", "coerce_value", "to_yaml_value"]


def coerce_number(value: Any) -> Any:
    """A string that parses as a float becomes that float; anything else is returned unchanged."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def coerce_value(key: str, value: Any) -> Any:
    """:func:`coerce_number`, and ``lin_<start>`` for ``*learning_rate`` keys as a linear schedule."""
    if key.endswith("learning_rate") and isinstance(value, str) and value.startswith("lin_"):
        start = coerce_number(value[len("lin_") :])
        if not isinstance(start, float):
            raise ValueError(f"{key}: {value!r} is not a linear schedule 'lin_<number>'")
        return LinearSchedule(start, 0.0, 1.0)
    return coerce_number(value)


def to_yaml_value(value: Any) -> Any:
    """The inverse of :func:`coerce_value` for writing a run's ``config.yml``."""
    if isinstance(value, LinearSchedule) and value.end == 0.0 and value.end_fraction == 1.0:
        return f"lin_{value.start}"
    return repr(value) if callable(value) else value
