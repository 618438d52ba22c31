"""rl-zoo-style hyperparameter files: find, read and check them before any training starts.

A file maps environment ids to CommDDPG arguments plus rl-zoo3's ``n_envs``, ``n_timesteps`` and
``policy`` (the method). The packaged files live in the repository's ``zoo_configs/`` folder,
one per method (``gsn.yml``, ``rial.yml``, ``tcg.yml``, ``none.yml``).
"""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Any

import yaml

from sb3_comm.comm_ddpg import METHODS, CommDDPG
from sb3_comm.common.hyperparams import coerce_value

__all__ = ["CONFIG_DIR", "ZOO_KEYS", "accepted_keys", "config_path", "load_hyperparams"]

_PACKAGE_DIR = Path(__file__).resolve().parent
CONFIG_DIR = next(
    (p for p in (_PACKAGE_DIR / "zoo_configs", _PACKAGE_DIR.parent / "zoo_configs") if p.is_dir()),
    _PACKAGE_DIR / "zoo_configs",
)
"""Folder of the packaged hyperparameter files."""

ZOO_KEYS = ("policy", "n_envs", "n_timesteps")
"""rl-zoo3 keys that are not CommDDPG arguments."""

_NOT_CONFIGURABLE = {
    "self",
    "policy",
    "env",
    "tensorboard_log",
    "verbose",
    "seed",
    "device",
    "_init_setup_model",
}


def accepted_keys() -> list[str]:
    """Every key a hyperparameter entry may have."""
    params = inspect.signature(CommDDPG.__init__).parameters
    return sorted({*ZOO_KEYS, *(p for p in params if p not in _NOT_CONFIGURABLE)})


def config_path(method: str) -> Path:
    """The packaged file of a method (e.g. ``zoo_configs/gsn.yml``)."""
    method = method.upper()
    if method not in METHODS:
        raise ValueError(f"Unknown communication method {method!r}; accepted: {list(METHODS)}")
    return CONFIG_DIR / f"{method.lower()}.yml"


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


def load_hyperparams(method: str, env_id: str, path: str | Path | None = None) -> dict[str, Any]:
    """The checked settings of ``method`` on ``env_id``.

    :param method: ``"NONE"``, ``"RIAL"``, ``"TCG"`` or ``"GSN"``.
    :param env_id: environment id, a key of the file.
    :param path: a hyperparameter file (default: the packaged file of the method).
    :return: a dict with ``policy``, ``n_envs``, ``n_timesteps`` and the CommDDPG keyword arguments.
    :raises ValueError: unknown method, missing environment entry, unknown key, or a ``policy``
        that contradicts ``method`` — before anything is trained.
    """
    method = method.upper()
    file = Path(path) if path is not None else config_path(method)
    data = _read(file)
    if env_id not in data:
        raise ValueError(f"{file} has no entry for {env_id!r}; it configures: {sorted(data)}")
    entry = data[env_id]
    if not isinstance(entry, dict):
        raise ValueError(f"{file}: the entry of {env_id!r} must be a mapping of settings")
    accepted = accepted_keys()
    unknown = sorted(set(entry) - set(accepted))
    if unknown:
        raise ValueError(f"{file}: unknown key(s) {unknown} for {env_id!r}; accepted keys: {accepted}")
    # YAML 1.1 reads 1e-3 (no dot) as a string: accept numbers written that way.
    settings = {key: coerce_value(key, value) for key, value in entry.items()}
    policy = str(settings.get("policy", method)).upper()
    if policy != method:
        raise ValueError(f"{file}: {env_id!r} is configured for method {policy}, but {method} was requested")
    settings["policy"] = method
    if isinstance(settings.get("policy_kwargs"), str):
        raise ValueError(
            f"{file}: write policy_kwargs as a YAML mapping "
            "(e.g. 'policy_kwargs: {net_arch: [256, 256]}'), "
            f"got the string {settings['policy_kwargs']!r}"
        )
    settings["n_envs"] = int(settings.get("n_envs", 1))
    settings["n_timesteps"] = int(float(settings.get("n_timesteps", 100_000)))
    return settings
