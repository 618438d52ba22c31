"""What each hyperparameter accepts, in one table, and the checks of values at the boundary.

The algorithms (:class:`~sb3_comm.HybridDDPG`, :class:`~sb3_comm.CommDDPG`) check their arguments
once, in the constructor; :class:`~sb3_comm.config.RunConfig` checks a file's values with the same
table before anything is built. An error names the parameter, the value and what is accepted:
``TypeError`` for a value of the wrong type, ``ValueError`` for one out of range.

>>> check_hyperparameters({"gamma": 0.99, "max_grad_norm": None})
>>> check_hyperparameters({"max_grad_norm": -1})
Traceback (most recent call last):
...
ValueError: max_grad_norm must be a number > 0 or None (None disables gradient clipping), got -1

:func:`check_observation` is the cheap finiteness check of observations (one ``isfinite`` per
batch) used by ``predict`` and the environment wrappers.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch as th

from sb3_comm.common.networks import PRECISIONS

__all__ = [
    "HYPERPARAMETERS",
    "POLICY_KWARGS",
    "Device",
    "FractionOrSchedule",
    "LearningRate",
    "Range",
    "check_hyperparameters",
    "check_observation",
    "check_policy_kwargs",
]


def _is_real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _is_whole(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


@dataclass(frozen=True)
class Range:
    """A number in an interval (finite), or one of a few special values.

    :param low: lower bound (``-inf``: none).
    :param high: upper bound (``inf``: none).
    :param low_open: the lower bound itself is excluded.
    :param high_open: the upper bound itself is excluded.
    :param whole: only whole numbers (``int``, NumPy integers) are accepted.
    :param special: values accepted as they are (e.g. None, -1), with what they mean in ``hint``.
    :param hint: what the special values mean.
    """

    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False
    whole: bool = False
    special: tuple[Any, ...] = ()
    hint: str = ""

    def describe(self) -> str:
        """What is accepted, e.g. ``"a whole number ≥ 1"`` or ``"a number in (0, 1]"``."""
        kind = "a whole number" if self.whole else "a number"
        low, high = f"{self.low:g}", f"{self.high:g}"
        if math.isinf(self.low) and math.isinf(self.high):
            text = f"a finite {kind[2:]}"
        elif math.isinf(self.high):
            text = f"{kind} {'>' if self.low_open else '≥'} {low}"
        elif math.isinf(self.low):
            text = f"{kind} {'<' if self.high_open else '≤'} {high}"
        else:
            text = f"{kind} in {'(' if self.low_open else '['}{low}, {high}{')' if self.high_open else ']'}"
        for value in self.special:
            text += f" or {value!r}"
        return text + (f" ({self.hint})" if self.hint else "")

    def _is_special(self, value: Any) -> bool:
        return any(
            value is s
            or (_is_whole(value) and _is_whole(s) and value == s)
            or (isinstance(value, str) and isinstance(s, str) and value == s)
            for s in self.special
        )

    def __call__(self, name: str, value: Any) -> None:
        if self._is_special(value):
            return
        if not (_is_whole(value) if self.whole else _is_real(value)):
            raise TypeError(f"{name} must be {self.describe()}, got {value!r} ({type(value).__name__})")
        number = float(value)
        inside = (
            math.isfinite(number)
            and (number > self.low if self.low_open else number >= self.low)
            and (number < self.high if self.high_open else number <= self.high)
        )
        if not inside:
            raise ValueError(f"{name} must be {self.describe()}, got {value!r}")


@dataclass(frozen=True)
class LearningRate:
    """A learning rate: a number > 0, or a callable schedule of the remaining progress (1 -> 0)
    whose value at the start of training (progress 1.0) is finite and > 0."""

    def __call__(self, name: str, value: Any) -> None:
        if callable(value):
            start = value(1.0)
            if not _is_real(start) or not math.isfinite(start) or start <= 0:
                raise ValueError(
                    f"{name}: the schedule's value at the start of training (progress 1.0) must be a "
                    f"finite number > 0, got {start!r}"
                )
            return
        if not _is_real(value):
            hint = ""
            if isinstance(value, str):
                hint = (
                    "; in a hyperparameter file or override write a number or 'lin_<number>' "
                    "(e.g. 'lin_1e-3'), which sb3_comm.config converts"
                )
            raise TypeError(
                f"{name} must be a float or a callable schedule (e.g. stable_baselines3.common.utils."
                f"LinearSchedule) with values > 0, got {value!r} ({type(value).__name__})"
                f"{hint}"
            )
        Range(0.0, low_open=True)(name, value)


@dataclass(frozen=True)
class FractionOrSchedule:
    """A number in [0, 1], or a callable schedule of the remaining progress (1 -> 0) whose values
    at the start (progress 1.0) and at the end (progress 0.0) of training are in [0, 1] (e.g. the
    Monte-Carlo mixing β, ``mc_mixing``)."""

    def __call__(self, name: str, value: Any) -> None:
        if callable(value):
            for progress in (1.0, 0.0):
                point = value(progress)
                if not _is_real(point) or not 0.0 <= float(point) <= 1.0:
                    raise ValueError(
                        f"{name}: the schedule's value at progress {progress} (1: start of training, "
                        f"0: end) must be a number in [0, 1], got {point!r}"
                    )
            return
        if isinstance(value, str):
            raise TypeError(
                f"{name} must be a number in [0, 1] or a callable schedule, got {value!r} (str); in a "
                "hyperparameter file or override write a number or 'lin_<number>' (e.g. 'lin_0.5', a "
                "linear decay to 0), which sb3_comm.config converts"
            )
        UNIT(name, value)


@dataclass(frozen=True)
class OneOf:
    """One of a few values (e.g. ``"epsilon"`` or ``"gaussian"``)."""

    choices: tuple[Any, ...]

    def __call__(self, name: str, value: Any) -> None:
        if not any(value is c or (type(value) is type(c) and value == c) for c in self.choices):
            accepted = " or ".join(repr(c) for c in self.choices)
            raise ValueError(f"{name} must be {accepted}, got {value!r}")


@dataclass(frozen=True)
class TrainFrequency:
    """SB3's ``train_freq``: a whole number ≥ 1 of steps, or a tuple ``(n, "step" | "episode")``."""

    def __call__(self, name: str, value: Any) -> None:
        if isinstance(value, tuple) and len(value) == 2:
            SIZE(f"{name}[0]", value[0])
            OneOf(("step", "episode"))(f"{name}[1]", value[1])
            return
        if not _is_whole(value):
            raise TypeError(
                f"{name} must be a whole number ≥ 1 or a tuple (n, 'step' | 'episode'), "
                f"got {value!r} ({type(value).__name__})"
            )
        SIZE(name, value)


@dataclass(frozen=True)
class Widths:
    """Hidden-layer widths: a list of whole numbers ≥ 1 (empty: no hidden layer).

    :param pi_qf: also accept SB3's ``{"pi": [...], "qf": [...]}`` (actor and critic apart).
    """

    pi_qf: bool = False

    def __call__(self, name: str, value: Any) -> None:
        if self.pi_qf and isinstance(value, Mapping):
            if set(value) != {"pi", "qf"}:
                raise ValueError(
                    f"{name} as a mapping must have the keys 'pi' and 'qf' only, got {sorted(value)}"
                )
            for key in ("pi", "qf"):
                Widths()(f"{name}[{key!r}]", value[key])
            return
        if not isinstance(value, list | tuple):
            accepted = "a list of layer widths (whole numbers ≥ 1)"
            if self.pi_qf:
                accepted += " or a mapping {pi: [...], qf: [...]}"
            raise TypeError(f"{name} must be {accepted}, got {value!r} ({type(value).__name__})")
        for width in value:
            try:
                SIZE(name, width)
            except (TypeError, ValueError):
                raise (TypeError if not _is_whole(width) else ValueError)(
                    f"{name} must be a list of layer widths, each a whole number ≥ 1, got {list(value)!r}"
                ) from None


@dataclass(frozen=True)
class Flag:
    """True or False (and None where ``none_means`` says what None stands for)."""

    none_means: str | None = None

    def __call__(self, name: str, value: Any) -> None:
        if value is None and self.none_means is not None:
            return
        if not isinstance(value, bool | np.bool_):
            accepted = "True or False" + (f" (or None: {self.none_means})" if self.none_means else "")
            raise TypeError(f"{name} must be {accepted}, got {value!r} ({type(value).__name__})")


@dataclass(frozen=True)
class Device:
    """A torch device: ``"auto"`` (a GPU where torch sees one, else the CPU), ``"cpu"``,
    ``"cuda"``, ``"cuda:<index>"``, another name torch knows, or a ``torch.device``.

    A GPU that torch cannot see is an error here: SB3 would fall back to the CPU without a word,
    and a run asked for on a GPU would train, many times slower, on the CPU.
    """

    def __call__(self, name: str, value: Any) -> None:
        if isinstance(value, str) and value == "auto":
            return
        if not isinstance(value, str | th.device):
            raise TypeError(
                f"{name} must be 'auto', 'cpu', 'cuda', 'cuda:<index>' or a torch.device, "
                f"got {value!r} ({type(value).__name__})"
            )
        try:
            device = th.device(value)
        except (RuntimeError, ValueError):
            raise ValueError(
                f"{name} must be 'auto', 'cpu', 'cuda', 'cuda:<index>' or another device name torch "
                f"knows, got {value!r}"
            ) from None
        if device.type == "cuda":
            count = th.cuda.device_count() if th.cuda.is_available() else 0
            if count == 0:
                build = f"CUDA {th.version.cuda}" if th.version.cuda else "a CPU-only build"
                raise ValueError(
                    f"{name}={str(value)!r} asks for a GPU, but torch {th.__version__} ({build}) sees no "
                    "CUDA device here; use 'cpu', or 'auto' (a GPU where there is one, else the CPU)"
                )
            if device.index is not None and device.index >= count:
                raise ValueError(
                    f"{name}={str(value)!r}: torch sees {count} CUDA device(s), indices 0 to {count - 1}"
                )


Check = Callable[[str, Any], None]

SIZE = Range(1, whole=True)
UNIT = Range(0.0, 1.0)
RATE = LearningRate()

EXPLORATIONS = ("epsilon", "gaussian", "epsilon+gaussian")
"""Exploration modes of :class:`~sb3_comm.hybrid_ddpg.HybridDDPG` (its ``exploration``)."""

SCORE_GRADIENTS = ("critic", "alternatives")
"""What moves the action scores of a hybrid actor (:class:`~sb3_comm.hybrid_ddpg.policies.HybridPolicy`'s
``score_gradient``)."""

POLICY_KWARGS: dict[str, Check] = {
    "net_arch": Widths(pi_qf=True),
    "n_critics": SIZE,
    "gsn_net_arch": Widths(),
    "gsn_reward_net_arch": Widths(),
    "share_parameters": Flag(),
    "gsn_normalize_rewards": Flag(),
    "gsn_maximising_head": Flag(),
    "gsn_reward_sees_teammate": Flag(),
    "gsn_effect_model": Flag(),
    "gsn_effect_paths": OneOf(("total", "action", "direct")),
    "score_gradient": OneOf(SCORE_GRADIENTS),
    "critic_layer_norm": Flag(),
    "actor_guard": Flag(),
    "averaged_actor": Flag(),
    "actor_average_tau": Range(
        0.0,
        1.0,
        low_open=True,
        special=(None, "auto"),
        hint="None: the target actor; 'auto': set from the run's budget, 10 / its actor updates",
    ),
    "precision": OneOf(tuple(PRECISIONS)),
}
"""What the checked entries of ``policy_kwargs`` accept (others are left to the policy)."""


def check_policy_kwargs(name: str, value: Any) -> None:
    """``policy_kwargs``: None or a mapping whose known entries pass :data:`POLICY_KWARGS`."""
    if value is None:
        return
    if not isinstance(value, Mapping):
        raise TypeError(
            f"{name} must be a mapping such as {{'net_arch': [256, 256]}}, "
            f"got {value!r} ({type(value).__name__})"
        )
    for key, entry in value.items():
        if key in POLICY_KWARGS:
            POLICY_KWARGS[key](f"{name}[{key!r}]", entry)


GSN_MAX_SIGNALS = ("both", "grounding", "maximising")
"""What trains GSN-MAX's message extractor: both signals, or one of them (the method's ablations)."""

HYPERPARAMETERS: dict[str, Check] = {
    "learning_rate": RATE,
    "actor_learning_rate": RATE,
    "gsn_learning_rate": RATE,
    "gsn_max_weight": Range(0.0, 1.0, special=(None,), hint="None: the design's default"),
    "gsn_max_signals": OneOf(GSN_MAX_SIGNALS),
    "gsn_max_explore_messages": Flag(none_means="the design's default"),
    "gsn_max_warmup": Range(0.0, 1.0, high_open=True),
    "gsn_max_centred": Flag(),
    "gsn_max_gain": Range(0.0, low_open=True, special=(None,), hint="None: each signal scaled to unit RMS"),
    "gsn_max_sgd": Range(0.0, low_open=True, special=(None,), hint="None: one Adam step on the mix"),
    "gsn_max_search": Range(0, whole=True, special=(None,), hint="0: the effect model's gradient; None: 16"),
    "gsn_max_explorers": Range(0.0, 1.0, high_open=True, special=(None,), hint="None: the design's default"),
    "buffer_size": SIZE,
    "learning_starts": Range(0, whole=True),
    "batch_size": SIZE,
    "tau": Range(0.0, 1.0, low_open=True),
    "gamma": UNIT,
    "train_freq": TrainFrequency(),
    "gradient_steps": Range(1, whole=True, special=(-1,), hint="-1: as many updates as steps collected"),
    "exploration": OneOf(EXPLORATIONS),
    "exploration_initial_eps": UNIT,
    "exploration_final_eps": UNIT,
    "exploration_fraction": UNIT,
    "gaussian_noise_std": Range(0.0),
    "mc_mixing": FractionOrSchedule(),
    "tcg_gain": Range(),
    "relabel_messages": Flag(),
    "shared_reward": Flag(none_means="the default, True"),
    "channel_size": Range(0, whole=True, special=(None,), hint="None: the environment's"),
    "share_parameters": Flag(),
    "max_grad_norm": Range(0.0, low_open=True, special=(None,), hint="None disables gradient clipping"),
    "policy_delay": SIZE,
    "target_policy_noise": Range(0.0),
    "target_noise_clip": Range(0.0),
    "stats_window_size": SIZE,
    "policy_kwargs": check_policy_kwargs,
    "device": Device(),
}
"""What each hyperparameter of :class:`~sb3_comm.CommDDPG` (and :class:`~sb3_comm.HybridDDPG`) accepts."""


def check_hyperparameters(values: Mapping[str, Any]) -> None:
    """Check every value whose name is in :data:`HYPERPARAMETERS` (other names are ignored).

    :param values: parameter names to values (e.g. a constructor's ``locals()``).
    :raises TypeError: a value of the wrong type, naming the parameter, the value and what is accepted.
    :raises ValueError: a value out of range, likewise.
    """
    for name, value in values.items():
        check = HYPERPARAMETERS.get(name)
        if check is not None:
            check(name, value)


def check_observation(
    observation: Any, agent_names: Sequence[str] | None = None, batch_name: str = "batch entries"
) -> None:
    """Raise a ``ValueError`` if an observation (or a batch of them) holds NaN or inf.

    Cheap when all is well (one ``isfinite`` over the array); the message, built only on failure,
    names the agent(s) and the feature indices, e.g. ``observation of agent 'blind' has non-finite
    values at features [3, 17]``.

    :param observation: ``(..., n_agents, obs_dim)`` rows of a team when ``agent_names`` is given,
        else ``(..., obs_dim)``.
    :param agent_names: the agents of the rows (None: one agent).
    :param batch_name: what the leading axis counts, for the message (e.g. ``"games"``).
    """
    array = np.asarray(observation)
    if array.dtype.kind not in "fc" or np.isfinite(array).all():
        return
    bad = ~np.isfinite(array)
    rows = len(agent_names) if agent_names else 1
    if array.ndim == 0 or array.size % (rows * array.shape[-1]):
        raise ValueError(f"observation has non-finite values at flat indices {np.flatnonzero(bad).tolist()}")
    per_row = bad.reshape(-1, rows, array.shape[-1])
    features = per_row.any(axis=0)
    if agent_names:
        parts = [
            f"observation of agent {name!r} has non-finite values at features {np.flatnonzero(row).tolist()}"
            for name, row in zip(agent_names, features, strict=True)
            if row.any()
        ]
    else:
        parts = [f"observation has non-finite values at features {np.flatnonzero(features[0]).tolist()}"]
    message = "; ".join(parts)
    batched = array.ndim > (2 if agent_names else 1)
    if batched:
        entries = np.flatnonzero(per_row.reshape(per_row.shape[0], -1).any(axis=1)).tolist()
        message += f" (in {batch_name} {entries})"
    raise ValueError(message)
