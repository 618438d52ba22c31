"""rl-zoo3 integration: CommDDPG as an rl-zoo3 algorithm, with every rl-zoo3 flag.

    python -m sb3_comm.zoo train --env BlindSoccer-v0 --method GSN -n 20000 -f logs -tb tb
    python -m sb3_comm.zoo enjoy --env BlindSoccer-v0 -f logs -n 500
    python -m sb3_comm.zoo record_video --env BlindSoccer-v0 -f logs -n 200
    python -m sb3_comm.zoo train --env BlindSoccer-v0 --method GSN -optimize --n-trials 20 \\
        --storage sqlite:///study.db --study-name gsn   # start it twice: two workers share the study

(``sb3-comm zoo ...`` is the same.) :func:`register` adds the algorithms ``commddpg`` and
``hybrid_ddpg`` to rl-zoo3's ``ALGOS`` together with a hyperparameter sampler for Optuna, then the
command is rl-zoo3's own ``train``, ``enjoy`` or ``record_video``. Two additions before that:

* ``--method NONE|RIAL|TCG|GSN|GSN-MAX`` picks the packaged hyperparameter file ``zoo_configs/<method>.yml``
  when no ``-conf`` is given (``--algo`` defaults to ``commddpg``);
* for ``train``, the file's entry for ``--env`` and any ``-params`` are checked first: an unknown
  key, a method that does not exist or a file without the env fail with a message naming them,
  before rl-zoo3 starts (and so before it creates a log folder).

The environments only render ``rgb_array``: ``enjoy`` runs without a window (``--no-render`` is
added); ``record_video`` writes an MP4.

rl-zoo3 records the Optuna ``--storage`` URL in ``args.yml``, ``command.txt`` and, inside the
pickled study, its ``report_*.pkl``; here they are written with the password masked
(``postgresql://user:***@host/db``), and the report pickle holds an in-memory copy of the study
(its trials and attributes) rather than a connection to the database.
"""

from __future__ import annotations

import argparse
import contextlib
import pickle
import random
import runpy
import sys
import time
from collections.abc import Iterator
from typing import Any

from sb3_comm.comm_ddpg import METHODS, CommDDPG, HybridDDPG
from sb3_comm.common.files import mask_command, mask_url
from sb3_comm.common.hyperparams import canonical_value, python_value
from sb3_comm.config import CONFIG_DIR, RunConfig, accepted_keys, check_keys, config_path, read_entry

__all__ = [
    "ZOO_ALGOS",
    "convert_commddpg_params",
    "detached_study",
    "main",
    "register",
    "sample_commddpg_params",
    "storage_masked",
]


def _from_file(kwargs: dict[str, Any]) -> dict[str, Any]:
    """Hyperparameters as rl-zoo3 hands them over (as written in the YAML file, e.g. ``lin_1e-4``
    for an actor learning rate) to the Python values the algorithm takes."""
    keys = set(accepted_keys())
    return {k: python_value(k, canonical_value(k, v)) if k in keys else v for k, v in kwargs.items()}


class _FromFile:
    """rl-zoo3 converts only its own schedule keys (``learning_rate``): the other values of the
    file arrive as written, and are converted here, both when building and when loading (``-i``)."""

    def __init__(self, policy: Any, env: Any, **kwargs: Any) -> None:
        super().__init__(policy, env, **_from_file(kwargs))  # type: ignore[call-arg]

    @classmethod
    def load(cls, path: Any, env: Any = None, **kwargs: Any) -> Any:
        """SB3's ``load``, with the extra keyword arguments converted as in ``__init__``."""
        return super().load(path, env=env, **_from_file(kwargs))  # type: ignore[misc]


class ZooCommDDPG(_FromFile, CommDDPG):
    """:class:`~sb3_comm.CommDDPG` as rl-zoo3 builds and loads it."""


class ZooHybridDDPG(_FromFile, HybridDDPG):
    """:class:`~sb3_comm.HybridDDPG` as rl-zoo3 builds and loads it."""


ZOO_ALGOS: dict[str, type[CommDDPG]] = {"commddpg": ZooCommDDPG, "hybrid_ddpg": ZooHybridDDPG}
"""rl-zoo3 algorithm names of this package."""

COMMANDS = ("train", "enjoy", "record_video")

NET_ARCHS = {"small": [64, 64], "medium": [256, 256], "big": [400, 300]}


def sample_commddpg_params(trial: Any, n_actions: int, n_envs: int, additional_args: dict) -> dict[str, Any]:
    """Optuna search space of CommDDPG (rl-zoo3's ``HYPERPARAMS_SAMPLER`` signature).

    Learning rates of critic, actor and GSN, batch size, τ, γ, the Monte-Carlo mixing β, the
    exploration schedule and the hidden layers. The GSN rate is sampled for every method and only
    used by GSN.
    """
    sampled = {
        "learning_rate": trial.suggest_float("learning_rate", 1e-4, 3e-3, log=True),
        "actor_learning_rate": trial.suggest_float("actor_learning_rate", 1e-5, 1e-3, log=True),
        "gsn_learning_rate": trial.suggest_float("gsn_learning_rate", 1e-5, 3e-3, log=True),
        "batch_size_pow": trial.suggest_int("batch_size_pow", 5, 8),
        "tau": trial.suggest_float("tau", 1e-3, 2e-2, log=True),
        "one_minus_gamma": trial.suggest_float("one_minus_gamma", 1e-3, 3e-2, log=True),
        "mc_mixing": trial.suggest_float("mc_mixing", 0.0, 1.0),
        "exploration_fraction": trial.suggest_float("exploration_fraction", 0.05, 0.5),
        "exploration_final_eps": trial.suggest_float("exploration_final_eps", 0.01, 0.2),
        "net_arch": trial.suggest_categorical("net_arch", list(NET_ARCHS)),
    }
    return convert_commddpg_params(sampled)


def convert_commddpg_params(sampled: dict[str, Any]) -> dict[str, Any]:
    """Optuna's sampled values (``batch_size_pow``, ``one_minus_gamma``, ``net_arch`` names) to
    CommDDPG keyword arguments (rl-zoo3's ``HYPERPARAMS_CONVERTER`` signature)."""
    params = dict(sampled)
    if "batch_size_pow" in params:
        params["batch_size"] = 2 ** params.pop("batch_size_pow")
    if "one_minus_gamma" in params:
        params["gamma"] = 1.0 - params.pop("one_minus_gamma")
    if "net_arch" in params:
        params["policy_kwargs"] = {"net_arch": NET_ARCHS[params.pop("net_arch")]}
    return params


def register() -> None:
    """Make ``commddpg`` and ``hybrid_ddpg`` rl-zoo3 algorithms, with their Optuna sampler.

    Idempotent. rl-zoo3's scripts read the same dictionaries, so after this call
    ``rl_zoo3.train.train()`` accepts ``--algo commddpg``.
    """
    import rl_zoo3.hyperparams_opt as opt
    import rl_zoo3.utils as zoo_utils

    import sb3_comm.registration  # noqa: F401  (registers the gym ids)

    zoo_utils.ALGOS.update(ZOO_ALGOS)
    for name in ZOO_ALGOS:
        opt.HYPERPARAMS_SAMPLER[name] = sample_commddpg_params
        opt.HYPERPARAMS_CONVERTER[name] = convert_commddpg_params


def _parse_zoo_params(items: list[str]) -> dict[str, str]:
    """rl-zoo3's ``-params key:value`` items as a dict (values are not evaluated here)."""
    params = {}
    for item in items:
        if ":" not in item:
            raise ValueError(f"-params takes key:value items (rl-zoo3 format), got {item!r}")
        key, value = item.split(":", 1)
        params[key] = value
    return params


def prepare_args(command: str, argv: list[str]) -> list[str]:
    """Check and complete the arguments of an rl-zoo3 ``command`` (see the module docstring).

    :return: the arguments to hand to rl-zoo3.
    :raises ValueError: an unknown command, method, env entry, or hyperparameter key.
    """
    if command not in COMMANDS:
        raise ValueError(f"Unknown rl-zoo3 command {command!r}; accepted: {list(COMMANDS)}")
    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--algo", default="commddpg")
    parser.add_argument("--method", type=str.upper, default=None)
    parser.add_argument("--env", default=None)
    parser.add_argument("-conf", "--conf-file", dest="conf", default=None)
    parser.add_argument("-params", "--hyperparams", dest="params", nargs="+", default=[])
    parser.add_argument("--no-render", action="store_true")
    known, rest = parser.parse_known_args(argv)
    if known.algo not in ZOO_ALGOS:
        # Another rl-zoo3 algorithm: hand over untouched (the ids are registered anyway).
        return argv
    if known.method is not None and known.method not in METHODS:
        raise ValueError(f"Unknown communication method {known.method!r}; accepted: {list(METHODS)}")
    args = ["--algo", known.algo, *rest]
    if known.env is not None:
        args += ["--env", known.env]
    if known.params:
        args += ["-params", *known.params]
    if command == "enjoy":
        args.append("--no-render")  # rgb_array only: no window to show
    elif known.no_render:
        args.append("--no-render")
    if command != "train":
        return args
    if known.env is None:
        raise ValueError("train needs --env (e.g. --env BlindSoccer-v0)")
    conf = known.conf
    if conf is None:
        conf = str(CONFIG_DIR / "hybrid_ddpg.yml") if known.algo == "hybrid_ddpg" else None
        conf = conf or str(config_path(known.method or "GSN"))
        print(f"sb3-comm: hyperparameters from {conf}", file=sys.stderr)
    entry = read_entry(conf, known.env)
    if known.algo == "commddpg":
        method = known.method or str(entry.get("policy", "GSN")).upper()
        RunConfig.from_entry(entry, method, known.env, source=conf)  # raises on a bad method or key
    else:
        check_keys(entry, f"{conf}: {known.env!r}")
    check_keys(_parse_zoo_params(known.params), "-params")
    options = entry.get("env_kwargs") or {}
    if options and not {"--env-kwargs", "--eval-env-kwargs"} & set(rest):
        # rl-zoo3 2.9 trains with a file's env_kwargs but evaluates on the task without them
        # unless told on its command line (its StoreDict reads Python literals)
        args += ["--eval-env-kwargs", *(f"{key}:{value!r}" for key, value in dict(options).items())]
    return [*args, "-conf", conf]


def init_storage(url: str, attempts: int = 10) -> None:
    """Create Optuna's tables in the database at ``url`` once, tolerating concurrent workers.

    Two workers started together on a new database both try to create its tables; the one that
    loses the race gets an integrity error from SQLAlchemy. Trying again, after a short random
    pause, finds the tables made by the other worker.
    """
    import optuna

    for attempt in range(attempts):
        try:
            optuna.storages.RDBStorage(url)
            return
        except Exception:  # sqlalchemy IntegrityError / OperationalError from the losing worker
            if attempt == attempts - 1:
                raise
            time.sleep(0.2 + random.random())


def detached_study(study: Any) -> Any:
    """An in-memory copy of an Optuna study: its trials, name, directions and attributes, without
    the storage (whose URL may hold a password) that pickling the study itself would record."""
    import optuna

    copy = optuna.create_study(study_name=study.study_name, directions=study.directions)
    copy.add_trials(study.trials)
    for key, value in study.user_attrs.items():
        copy.set_user_attr(key, value)
    return copy


class _PickleWithoutStorage:
    """``pickle`` for rl-zoo3's report: an Optuna study is pickled as :func:`detached_study`."""

    def __getattr__(self, name: str) -> Any:
        return getattr(pickle, name)

    @staticmethod
    def dump(obj: Any, file: Any, *args: Any, **kwargs: Any) -> None:
        import optuna

        if isinstance(obj, optuna.Study):
            obj = detached_study(obj)
        pickle.dump(obj, file, *args, **kwargs)


@contextlib.contextmanager
def storage_masked() -> Iterator[None]:
    """While rl-zoo3 runs, what it writes about the ``--storage`` URL has the password masked."""
    import rl_zoo3.exp_manager as exp_manager

    manager = exp_manager.ExperimentManager
    save_config, saved_pickle = manager._save_config, exp_manager.pkl
    orig_argv = getattr(sys, "orig_argv", None)

    def _save_config(self: Any, saved_hyperparams: dict[str, Any]) -> None:
        storage = getattr(self.args, "storage", None)
        if isinstance(storage, str):
            self.args.storage = mask_url(storage)
        try:
            save_config(self, saved_hyperparams)
        finally:
            if isinstance(storage, str):
                self.args.storage = storage

    manager._save_config = _save_config  # type: ignore[method-assign]
    exp_manager.pkl = _PickleWithoutStorage()  # type: ignore[assignment]
    if orig_argv is not None:
        sys.orig_argv = mask_command(orig_argv)  # command.txt and args.yml's command
    try:
        yield
    finally:
        manager._save_config = save_config  # type: ignore[method-assign]
        exp_manager.pkl = saved_pickle
        if orig_argv is not None:
            sys.orig_argv = orig_argv


def run(command: str, argv: list[str]) -> int:
    """Register, check the arguments, and run rl-zoo3's ``command`` with them."""
    args = prepare_args(command, argv)
    register()
    if command == "train" and "--storage" in args:
        url = args[args.index("--storage") + 1]
        if not url.endswith(".log"):  # rl-zoo3 opens a .log path as a journal file: no tables
            init_storage(url)
    from rl_zoo3.enjoy import enjoy
    from rl_zoo3.train import train

    def record_video() -> None:  # rl-zoo3's record_video is a __main__ script
        runpy.run_module("rl_zoo3.record_video", run_name="__main__")

    scripts = {"train": train, "enjoy": enjoy, "record_video": record_video}
    saved_argv = sys.argv
    sys.argv = [f"rl_zoo3 {command}", *args]
    try:
        with storage_masked():
            scripts[command]()
    finally:
        sys.argv = saved_argv
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m sb3_comm.zoo COMMAND [rl-zoo3 flags]``."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(__doc__)
        return 0
    try:
        return run(argv[0], argv[1:])
    except (ValueError, FileNotFoundError) as error:
        print(f"sb3-comm zoo: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
