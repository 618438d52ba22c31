"""Run configurations: rl-zoo-style hyperparameter files, read and checked once.

A hyperparameter file maps environment ids to CommDDPG arguments plus rl-zoo3's ``n_envs``,
``n_timesteps`` and ``policy`` (the method), and ``env_kwargs``: the task's own options (what
rl-zoo3's ``--env-kwargs`` gives on its command line), e.g. ``env_kwargs: {time_feature: true}``.
The packaged files live in the repository's
``zoo_configs/`` folder, one per method (``gsn.yml``, ``rial.yml``, ``tcg.yml``, ``none.yml``,
``gsn-max.yml``).

:class:`RunConfig` is what one training run is made of: method, task, seed, parallel games,
budget and the algorithm's hyperparameters. It is parsed, coerced and validated once, from a
file's entry plus overrides, and keeps the hyperparameters in their text form
(:mod:`sb3_comm.common.hyperparams`): that form is what ``config.yml`` holds and what the
experiment runner fingerprints, and :meth:`RunConfig.algorithm_kwargs` turns it into the plain
Python values the algorithm takes.

>>> config = RunConfig.load("GSN", "BlindSoccer-v0", seed=1, overrides={"batch_size": 32})
>>> config.n_envs, config.hyperparams["batch_size"], config.hyperparams["learning_rate"]
(16, 32, 'lin_0.001')
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from sb3_comm.common.hyperparams import algorithm_kwargs, canonical_value
from sb3_comm.common.validation import check_hyperparameters

__all__ = [
    "CONFIG_DIR",
    "ZOO_KEYS",
    "RunConfig",
    "accepted_keys",
    "check_keys",
    "config_path",
    "read_entry",
]

_PACKAGE_DIR = Path(__file__).resolve().parent
CONFIG_DIR = next(
    (p for p in (_PACKAGE_DIR / "zoo_configs", _PACKAGE_DIR.parent / "zoo_configs") if p.is_dir()),
    _PACKAGE_DIR / "zoo_configs",
)
"""Folder of the packaged hyperparameter files."""

ZOO_KEYS = ("policy", "n_envs", "n_timesteps", "env_kwargs")
"""Keys that are not CommDDPG arguments: rl-zoo3's ``policy``, ``n_envs`` and ``n_timesteps``, and
``env_kwargs`` (the task's options)."""

DEFAULT_N_ENVS = 1
DEFAULT_N_TIMESTEPS = 100_000
UNCONFIGURED_N_ENVS = 8
"""Games of a run on a task no packaged file configures (:meth:`RunConfig.constructor_defaults`)."""
UNCONFIGURED_N_TIMESTEPS = 300_000
"""Budget of a run on a task no packaged file configures."""


def _methods() -> tuple[str, ...]:
    from sb3_comm.comm_ddpg import METHODS

    return tuple(METHODS)


def accepted_keys() -> list[str]:
    """Every key a hyperparameter entry may have: rl-zoo3's keys and CommDDPG's arguments."""
    from sb3_comm.comm_ddpg import CommDDPG
    from sb3_comm.hybrid_ddpg.hybrid_ddpg import NOT_HYPERPARAMETERS

    params = inspect.signature(CommDDPG.__init__).parameters
    return sorted({*ZOO_KEYS, *(p for p in params if p not in NOT_HYPERPARAMETERS)})


def check_keys(settings: Mapping[str, Any], where: str, exclude: tuple[str, ...] = ()) -> None:
    """Raise if ``settings`` has a key that is not a hyperparameter (the one check of keys).

    :param settings: an entry of a file, or overrides.
    :param where: what the settings are, for the message (e.g. ``"gsn.yml: 'BlindSoccer-v0'"``).
    :param exclude: accepted keys that may not be set here.
    :raises ValueError: naming the unknown keys and every accepted one.
    """
    accepted = [key for key in accepted_keys() if key not in exclude]
    unknown = sorted(str(key) for key in set(settings) - set(accepted))
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {unknown}; accepted keys: {accepted}")


def _check_method(method: str) -> str:
    method = method.upper()
    if method not in _methods():
        raise ValueError(f"Unknown communication method {method!r}; accepted: {list(_methods())}")
    return method


def config_path(method: str) -> Path:
    """The packaged file of a method (e.g. ``zoo_configs/gsn.yml``)."""
    return CONFIG_DIR / f"{_check_method(method).lower()}.yml"


def _read(path: Path) -> dict[str, Any]:
    try:
        with open(path) as handle:
            data = yaml.safe_load(handle)
    except FileNotFoundError:
        raise FileNotFoundError(f"Hyperparameter file {path} does not exist") from None
    except yaml.YAMLError as error:
        raise ValueError(f"Hyperparameter file {path} is not valid YAML: {error}") from error
    if not isinstance(data, dict):
        raise ValueError(
            f"Hyperparameter file {path} must map environment ids to settings, got {type(data).__name__}"
        )
    return data


def read_entry(path: str | Path, env_id: str) -> dict[str, Any]:
    """The settings of ``env_id`` in a hyperparameter file, as written (not yet checked).

    :raises FileNotFoundError: no such file.
    :raises ValueError: not YAML, not a mapping, or no entry for ``env_id``.
    """
    file = Path(path)
    data = _read(file)
    if env_id not in data:
        raise ValueError(f"{file} has no entry for {env_id!r}; it configures: {sorted(data)}")
    entry = data[env_id]
    if not isinstance(entry, dict):
        raise ValueError(f"{file}: the entry of {env_id!r} must be a mapping of settings")
    return entry


def _whole(value: Any, key: str, where: str) -> int:
    number = canonical_value(key, value)
    if isinstance(number, bool) or not isinstance(number, int | float) or number != int(number) or number < 1:
        raise ValueError(f"{where}: {key} must be a whole number ≥ 1, got {value!r}")
    return int(number)


def _env_kwargs(value: Any, task: str, where: str) -> dict[str, Any]:
    """``env_kwargs`` of an entry, checked against the task's options where sb3-comm builds it.

    :raises ValueError: not a mapping, or an option the task does not take (naming those it does).
    """
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ValueError(
            f"{where}: write env_kwargs as a YAML mapping of the task's options "
            f"(e.g. 'env_kwargs: {{time_feature: true}}'), got {value!r}"
        )
    options = {str(key): item for key, item in value.items()}
    accepted = task_options(task)
    if accepted is not None:
        unknown = sorted(set(options) - set(accepted))
        if unknown:
            raise ValueError(
                f"{where}: env_kwargs has unknown option(s) {unknown}; {task} accepts: {accepted}"
            )
    return options


_NOT_OPTIONS = ("self", "kwargs", "n_games", "autoreset", "seed", "params")
"""Task arguments a file cannot set: the vectorised environment's own, the run's seed, and the
server parameters (a Python object)."""


def task_options(task: str) -> list[str] | None:
    """The options ``env_kwargs`` may set for ``task`` when sb3-comm builds it (None: a task built
    by Gymnasium, whose options only its constructor knows)."""
    from envs.registry import TASKS
    from envs.tasks.single_agent import SINGLE_AGENT_TASKS

    if task in TASKS:
        factory: Any = TASKS[task].batched_env
    elif task in SINGLE_AGENT_TASKS:
        factory = SINGLE_AGENT_TASKS[task]
    elif task == "MPESimpleReference-v0":
        from sb3_comm.foreign.batched_simple_reference import SimpleReferenceTask

        factory = SimpleReferenceTask
    else:
        return None
    params = inspect.signature(factory).parameters
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        factory = type(factory(n_games=1))  # a task module's batched_env(**kwargs): ask its class
        params = inspect.signature(factory).parameters
    return sorted(name for name in params if name not in _NOT_OPTIONS)


@dataclass(frozen=True)
class RunConfig:
    """One training run's configuration, checked (see the module docstring).

    :param method: communication method (``"GSN"``, ``"TCG"``, ``"RIAL"``, ``"NONE"``, ``"GSN-MAX"``).
    :param task: environment id.
    :param n_envs: parallel games.
    :param n_timesteps: environment steps to train for.
    :param hyperparams: CommDDPG keyword arguments in text form (``lin_0.001``, numbers, mappings).
    :param seed: training seed.
    :param source: the file the settings came from, if any.
    :param env_kwargs: the task's options (``make_comm_vec_env``'s ``env_kwargs``), for training and
        for every evaluation of the run.
    """

    method: str
    task: str
    n_envs: int
    n_timesteps: int
    hyperparams: dict[str, Any] = field(default_factory=dict)
    seed: int = 0
    source: str | None = None
    env_kwargs: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def from_entry(
        cls,
        entry: Mapping[str, Any],
        method: str,
        task: str,
        seed: int = 0,
        source: str | None = None,
    ) -> RunConfig:
        """Check a file's entry (rl-zoo3 keys plus CommDDPG arguments) and build the configuration.

        :raises ValueError: unknown method or key, a ``policy`` that contradicts ``method``,
            ``policy_kwargs`` that is not a mapping, a bad ``lin_`` schedule or budget, or a value of
            the wrong type or out of range (:data:`sb3_comm.common.validation.HYPERPARAMETERS`).
        """
        method = _check_method(method)
        where = f"{source or 'hyperparameters'}: {task!r}"
        check_keys(entry, where)
        settings = {str(key): canonical_value(str(key), value) for key, value in entry.items()}
        policy = str(settings.pop("policy", method)).upper()
        if policy != method:
            raise ValueError(f"{where} is configured for method {policy}, but {method} was requested")
        if "policy_kwargs" in settings and not isinstance(settings["policy_kwargs"], dict):
            raise ValueError(
                f"{where}: write policy_kwargs as a YAML mapping "
                f"(e.g. 'policy_kwargs: {{net_arch: [256, 256]}}'), got {settings['policy_kwargs']!r}"
            )
        n_envs = _whole(settings.pop("n_envs", DEFAULT_N_ENVS), "n_envs", where)
        n_timesteps = _whole(settings.pop("n_timesteps", DEFAULT_N_TIMESTEPS), "n_timesteps", where)
        env_kwargs = _env_kwargs(entry.get("env_kwargs", {}), task, where)
        settings.pop("env_kwargs", None)
        try:  # the algorithm's own checks, on the values it will receive, before anything is built
            check_hyperparameters(algorithm_kwargs(settings))
        except (TypeError, ValueError) as error:
            raise ValueError(f"{where}: {error}") from None
        return cls(method, task, n_envs, n_timesteps, settings, int(seed), source, env_kwargs)

    @classmethod
    def load(
        cls,
        method: str,
        task: str,
        seed: int = 0,
        path: str | Path | None = None,
        overrides: Mapping[str, Any] | None = None,
    ) -> RunConfig:
        """The configuration of ``method`` on ``task`` from a file (default: the packaged one).

        :param method: communication method.
        :param task: environment id, a key of the file.
        :param seed: training seed.
        :param path: a hyperparameter file (default: ``zoo_configs/<method>.yml``).
        :param overrides: settings that replace the file's (``n_envs`` and ``n_timesteps`` too).
        """
        file = Path(path) if path is not None else config_path(method)
        config = cls.from_entry(read_entry(file, task), method, task, seed=seed, source=str(file))
        return config.with_overrides(overrides or {})

    @classmethod
    def constructor_defaults(cls, method: str, task: str, seed: int = 0) -> RunConfig:
        """``CommDDPG(method, env)`` with nothing set, for a task that no packaged file configures:
        :data:`UNCONFIGURED_N_ENVS` games and :data:`UNCONFIGURED_N_TIMESTEPS` steps (the foreign
        benchmark's), every hyperparameter the constructor's default.

        :param method: communication method.
        :param task: environment id.
        :param seed: training seed.
        """
        entry = {"n_envs": UNCONFIGURED_N_ENVS, "n_timesteps": UNCONFIGURED_N_TIMESTEPS}
        return cls.from_entry(entry, method, task, seed=seed, source="the constructor's defaults")

    def with_overrides(self, overrides: Mapping[str, Any], seed: int | None = None) -> RunConfig:
        """A copy with some settings replaced, checked like a file's entry.

        :param overrides: hyperparameters, ``n_envs`` or ``n_timesteps`` (``policy`` may not change
            the method).
        :param seed: a new training seed (None: keep).
        """
        if not overrides and seed is None:
            return self
        merged = {**self.to_entry(), **overrides}
        where = f"{self.source} + overrides" if self.source else "overrides"
        config = RunConfig.from_entry(merged, self.method, self.task, self.seed, where)
        return dataclasses.replace(config, source=self.source, seed=self.seed if seed is None else int(seed))

    @property
    def precision(self) -> str:
        """The arithmetic of the networks' hidden layers (``policy_kwargs`` ``precision``; float32
        where unset)."""
        return (self.hyperparams.get("policy_kwargs") or {}).get("precision", "float32")

    def with_precision(self, precision: str) -> RunConfig:
        """A copy whose ``policy_kwargs`` add ``precision``, keeping their other entries (an override
        of ``policy_kwargs`` replaces them whole); the configuration itself where it already trains
        in that arithmetic (so that its hash stays).

        :param precision: ``"float32"`` or ``"bfloat16"`` (checked like a file's entry).
        """
        if precision == self.precision:
            return self
        policy_kwargs = {**(self.hyperparams.get("policy_kwargs") or {}), "precision": precision}
        return self.with_overrides({"policy_kwargs": policy_kwargs})

    def to_entry(self) -> dict[str, Any]:
        """The entry as an rl-zoo3 file holds it: ``policy``, ``n_envs``, ``n_timesteps``,
        ``env_kwargs`` (only when the task has options) and the hyperparameters in text form."""
        return {
            "policy": self.method,
            "n_envs": self.n_envs,
            "n_timesteps": self.n_timesteps,
            **self.options_entry(),
            **self.hyperparams,
        }

    def options_entry(self) -> dict[str, Any]:
        """``{"env_kwargs": ...}`` when the task has options, else ``{}`` (an entry or a run's
        record without options reads as before they existed)."""
        return {"env_kwargs": dict(self.env_kwargs)} if self.env_kwargs else {}

    def to_yaml(self) -> str:
        """``config.yml`` of a run: ``{task: entry}``, a file that :meth:`load` reads back."""
        return yaml.safe_dump({self.task: self.to_entry()})

    def algorithm_kwargs(self) -> dict[str, Any]:
        """The hyperparameters as CommDDPG keyword arguments (schedules as callables)."""
        return algorithm_kwargs(self.hyperparams)
