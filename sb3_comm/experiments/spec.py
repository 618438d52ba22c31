"""Experiment files: which methods, tasks and seeds to train, for how long, and how to evaluate them.

An experiment file is YAML; everything is checked, and every run resolved, before any training
starts. Example (the packaged ``paper.yml``)::

    name: paper
    methods: [NONE, RIAL, TCG, GSN]
    tasks: [BlindSoccer-v0, GuessMyNumber-v0]
    seeds: [0, 1, 2]
    timesteps: null                  # int, {task: int}, or null: the packaged n_timesteps
    eval_freq: 50000                 # learning-curve evaluation every N env steps
    eval_episodes: 100               # games per evaluation (also the final ablation evaluation)
    precision: null                  # optional: float32 or bfloat16 hidden layers in every run
    hyperparams:                     # optional overrides of the packaged zoo_configs/<method>.yml
      all: {}                        #   every run
      GSN: {}                        #   one method
      BlindSoccer-v0: {}             #   one task
      GSN/BlindSoccer-v0: {}         #   one method on one task (applied last)
    quick:                           # what --quick changes (same keys as the top level)
      seeds: [0]
      timesteps: {BlindSoccer-v0: 30000, GuessMyNumber-v0: 20000}
      eval_freq: 10000

Each (method, task) pair resolves to the packaged hyperparameters plus the overrides; the runs
of a pair differ only by seed. :func:`config_hash` fingerprints everything that defines a run
except its method, task and seed, so a changed configuration gets a new run folder.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from sb3_comm.common.hyperparams import canonical_value, coerce_number
from sb3_comm.config import RunConfig, check_keys

if TYPE_CHECKING:
    from sb3_comm.training import EvalSettings

__all__ = [
    "EVAL_SEEDS",
    "EXPERIMENTS_DIR",
    "TOP_LEVEL_KEYS",
    "ExperimentSpec",
    "ExperimentSpecError",
    "RunSpec",
    "config_hash",
    "load_experiment",
    "packaged_experiments",
    "parse_experiment",
]

EXPERIMENTS_DIR = Path(__file__).resolve().parent
"""Folder of the packaged experiment files (``paper.yml``)."""

TOP_LEVEL_KEYS = (
    "name",
    "description",
    "methods",
    "tasks",
    "seeds",
    "timesteps",
    "eval_freq",
    "eval_episodes",
    "analysis_episodes",
    "save_freq",
    "hyperparams",
    "precision",
    "quick",
)
"""Every key an experiment file may have."""

_QUICK_KEYS = tuple(key for key in TOP_LEVEL_KEYS if key not in ("name", "description", "quick"))

_RESERVED_HYPERPARAMS = {
    "policy": "the method is set by 'methods'",
    "n_timesteps": "the budget is set by 'timesteps'",
}

EVAL_SEEDS = {"curve": 12_345, "final": 20_000, "analysis": 0}
"""Seeds of the evaluation games: learning curve, final ablation evaluation, communication analysis."""

_DEFAULTS: dict[str, Any] = {
    "description": "",
    "timesteps": None,
    "eval_freq": 50_000,
    "eval_episodes": 100,
    "analysis_episodes": 10,
    "save_freq": 100_000,
    "hyperparams": {},
    "precision": None,
    "quick": {},
}


class ExperimentSpecError(ValueError):
    """An experiment file that cannot be run (raised before anything is trained)."""


def config_hash(config: Mapping[str, Any]) -> str:
    """First 8 hex characters of the SHA-256 of ``config`` as canonical JSON (sorted keys).

    :param config: JSON-friendly description of a run without its method, task and seed.
    """
    text = json.dumps(config, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return hashlib.sha256(text.encode()).hexdigest()[:8]


@dataclass(frozen=True)
class RunSpec:
    """One training run: a method on a task with one seed, fully resolved.

    :param method: communication method (``"GSN"``, ...).
    :param task: environment id.
    :param seed: training seed.
    :param timesteps: environment steps to train for.
    :param hyperparams: CommDDPG settings plus ``n_envs``, as written in YAML (``lin_0.001``).
    :param eval_freq: learning-curve evaluation every this many environment steps.
    :param eval_episodes: games per evaluation.
    :param analysis_episodes: games recorded for the communication analysis.
    :param save_freq: checkpoint every this many environment steps (not part of the hash).
    """

    method: str
    task: str
    seed: int
    timesteps: int
    hyperparams: dict[str, Any] = field(hash=False)
    eval_freq: int
    eval_episodes: int
    analysis_episodes: int
    save_freq: int = 100_000

    @property
    def key(self) -> str:
        """``METHOD/TASK/SEED``, as given to ``--only``."""
        return f"{self.method}/{self.task}/{self.seed}"

    @property
    def config(self) -> RunConfig:
        """The run's :class:`~sb3_comm.config.RunConfig` (what :func:`~sb3_comm.training.train_run` takes)."""
        entry = {**self.hyperparams, "n_timesteps": self.timesteps}
        return RunConfig.from_entry(entry, self.method, self.task, seed=self.seed)

    @property
    def eval_settings(self) -> EvalSettings:
        """How the run is evaluated (the seeds are :data:`EVAL_SEEDS`)."""
        from sb3_comm.training import EvalSettings

        return EvalSettings(
            freq=self.eval_freq,
            episodes=self.eval_episodes,
            curve_seed=EVAL_SEEDS["curve"],
            final_seed=EVAL_SEEDS["final"],
            analysis_episodes=self.analysis_episodes,
            analysis_seed=EVAL_SEEDS["analysis"],
        )

    @property
    def hash_input(self) -> dict[str, Any]:
        """Everything that defines the run except method, task and seed."""
        return {
            "hyperparams": self.hyperparams,
            "timesteps": self.timesteps,
            "eval": {
                "freq": self.eval_freq,
                "episodes": self.eval_episodes,
                "analysis_episodes": self.analysis_episodes,
                "seeds": EVAL_SEEDS,
            },
        }

    @property
    def config_hash(self) -> str:
        """:func:`config_hash` of :attr:`hash_input`."""
        return config_hash(self.hash_input)

    @property
    def tensorboard_dir(self) -> Path:
        """``tb/<method>/<task>/seed<seed>`` (relative to the experiment folder): one TensorBoard
        folder per experiment, each run named ``GSN/BlindSoccer-v0/seed0`` in its charts."""
        return Path("tb") / self.method / self.task / f"seed{self.seed}"

    @property
    def relative_dir(self) -> Path:
        """``runs/<task>/<method>/seed<seed>-<hash8>`` (relative to the experiment folder)."""
        return Path("runs") / self.task / self.method / f"seed{self.seed}-{self.config_hash}"


@dataclass
class ExperimentSpec:
    """A checked experiment file (see the module docstring for the keys).

    :param name: experiment name (default output folder ``runs/experiments/<name>``).
    :param methods: communication methods.
    :param tasks: environment ids.
    :param seeds: training seeds.
    :param timesteps: per task, the budget, or None for the packaged ``n_timesteps``.
    :param eval_freq: learning-curve evaluation every this many environment steps.
    :param eval_episodes: games per evaluation.
    :param analysis_episodes: games recorded for the communication analysis.
    :param save_freq: checkpoint every this many environment steps.
    :param hyperparams: override sections (``all``, a method, a task or ``METHOD/TASK``).
    :param precision: the arithmetic of every run's hidden layers, added to the ``policy_kwargs``
        of each configuration (``"float32"`` or ``"bfloat16"``; None: each configuration's own).
    :param quick: the top-level values that ``--quick`` replaces.
    :param description: free text.
    :param is_quick: whether :attr:`quick` has been applied.
    :param source: the file it was read from, if any.
    """

    name: str
    methods: list[str]
    tasks: list[str]
    seeds: list[int]
    timesteps: dict[str, int | None]
    eval_freq: int
    eval_episodes: int
    analysis_episodes: int
    save_freq: int
    hyperparams: dict[str, dict[str, Any]]
    quick: dict[str, Any]
    precision: str | None = None
    description: str = ""
    is_quick: bool = False
    source: str | None = None

    def overrides(self, method: str, task: str) -> dict[str, Any]:
        """The hyperparameter overrides of ``method`` on ``task``, least specific applied first."""
        merged: dict[str, Any] = {}
        for section in ("all", method, task, f"{method}/{task}"):
            merged.update(self.hyperparams.get(section, {}))
        return merged

    def resolve(self, method: str, task: str) -> tuple[int, dict[str, Any]]:
        """Budget and text-form hyperparameters (``n_envs`` included) of ``method`` on ``task``."""
        config = RunConfig.load(method, task, overrides=self.overrides(method, task))
        if self.precision is not None:  # added to the configuration's policy_kwargs, which stay
            config = config.with_precision(self.precision)
        budget = self.timesteps.get(task) or config.n_timesteps
        return int(budget), _plain({"n_envs": config.n_envs, **config.hyperparams})

    def runs(self) -> list[RunSpec]:
        """Every run of the experiment, in task, method, seed order."""
        result = []
        for task in self.tasks:
            for method in self.methods:
                budget, hyperparams = self.resolve(method, task)
                result.extend(
                    RunSpec(
                        method=method,
                        task=task,
                        seed=seed,
                        timesteps=budget,
                        hyperparams=hyperparams,
                        eval_freq=self.eval_freq,
                        eval_episodes=self.eval_episodes,
                        analysis_episodes=self.analysis_episodes,
                        save_freq=self.save_freq,
                    )
                    for seed in self.seeds
                )
        return result

    def to_dict(self) -> dict[str, Any]:
        """The spec as written to ``OUT/experiment.yml``, with each (method, task) resolved."""
        resolved = {}
        for task in self.tasks:
            for method in self.methods:
                budget, hyperparams = self.resolve(method, task)
                probe = RunSpec(method, task, 0, budget, hyperparams, self.eval_freq, self.eval_episodes,
                                self.analysis_episodes, self.save_freq)  # fmt: skip
                resolved[f"{method}/{task}"] = {
                    "timesteps": budget,
                    "config_hash": probe.config_hash,
                    "hyperparams": hyperparams,
                }
        return {
            "name": self.name,
            "description": self.description,
            "quick": self.is_quick,
            "source": self.source,
            "methods": self.methods,
            "tasks": self.tasks,
            "seeds": self.seeds,
            "timesteps": self.timesteps,
            "eval_freq": self.eval_freq,
            "eval_episodes": self.eval_episodes,
            "analysis_episodes": self.analysis_episodes,
            "save_freq": self.save_freq,
            "hyperparams": self.hyperparams,
            "precision": self.precision,
            "resolved": resolved,
        }


def _plain(value: Any) -> Any:
    """Tuples to lists, so that a spec and its JSON round trip hash the same."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def packaged_experiments() -> list[str]:
    """Names of the packaged experiment files (``paper``, ...)."""
    return sorted(path.stem for path in EXPERIMENTS_DIR.glob("*.yml"))


def _locate(file_or_name: str | Path) -> Path:
    path = Path(file_or_name)
    if path.is_file():
        return path
    packaged = EXPERIMENTS_DIR / f"{file_or_name}.yml"
    if isinstance(file_or_name, str) and "/" not in file_or_name and packaged.is_file():
        return packaged
    raise FileNotFoundError(
        f"No experiment file {str(file_or_name)!r}: give a YAML file or a packaged experiment name "
        f"({', '.join(packaged_experiments()) or 'none'})"
    )


def load_experiment(
    file_or_name: str | Path, quick: bool = False, overrides: Mapping[str, Any] | None = None
) -> ExperimentSpec:
    """Read and check an experiment file, or a packaged one by name (``"paper"``).

    :param file_or_name: a YAML path or the name of a packaged experiment.
    :param quick: apply the file's ``quick`` overrides.
    :param overrides: top-level values that replace the file's, ``quick``'s included (the command
        line's ``--seeds`` and ``--precision``: ``{"seeds": [0, 1, 2, 3, 4]}``), checked alike.
    :raises ExperimentSpecError: malformed YAML, unknown key, method, task or hyperparameter, or a
        bad value; the message names the entry and what is accepted.
    :raises FileNotFoundError: no such file and no such packaged experiment.
    """
    path = _locate(file_or_name)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as error:
        raise ExperimentSpecError(f"Experiment file {path} is not valid YAML: {error}") from error
    return parse_experiment(data, quick=quick, source=str(path), default_name=path.stem, overrides=overrides)


def parse_experiment(
    data: Any,
    quick: bool = False,
    source: str | None = None,
    default_name: str = "experiment",
    overrides: Mapping[str, Any] | None = None,
) -> ExperimentSpec:
    """Check an experiment given as a dict (the parsed YAML) and build its :class:`ExperimentSpec`.

    :param data: the parsed experiment file.
    :param quick: apply its ``quick`` overrides.
    :param source: where it came from (for messages).
    :param default_name: name when the data has none.
    :param overrides: top-level values that replace the data's and ``quick``'s (the command line's).
    """
    where = source or "experiment"
    if not isinstance(data, dict):
        raise ExperimentSpecError(
            f"{where}: an experiment must be a mapping of keys {list(TOP_LEVEL_KEYS)}, "
            f"got {type(data).__name__}"
        )
    _check_keys(data, TOP_LEVEL_KEYS, f"{where}: unknown key(s)")
    for key in ("methods", "tasks", "seeds"):
        if key not in data:
            raise ExperimentSpecError(
                f"{where}: missing key {key!r}; required: ['methods', 'tasks', 'seeds']"
            )
    given = {key: value for key, value in (overrides or {}).items() if value is not None}
    _check_keys(given, _QUICK_KEYS, "command-line override(s) of unknown key(s)")
    settings = {**_DEFAULTS, **data, **given}
    quick_values = settings["quick"] or {}
    if not isinstance(quick_values, dict):
        raise ExperimentSpecError(f"{where}: 'quick' must be a mapping of keys {list(_QUICK_KEYS)}")
    _check_keys(quick_values, _QUICK_KEYS, f"{where}: unknown key(s) in 'quick'")
    if quick and not quick_values:
        raise ExperimentSpecError(
            f"--quick: {where} has no 'quick' section (the values --quick replaces, e.g. "
            "'quick: {seeds: [0], timesteps: 20000, eval_freq: 5000}')"
        )
    applied = {**settings, **quick_values, **given}
    if "hyperparams" in quick_values:
        applied["hyperparams"] = _merge_sections(settings["hyperparams"], quick_values["hyperparams"])
    # Both variants are checked, so that a broken --quick shows up at once.
    full = _build(settings, where, default_name)
    short = _build(applied, f"{where} (quick)", default_name)
    spec = short if quick else full
    spec.is_quick = quick
    spec.quick = quick_values
    spec.source = source
    return spec


def _build(settings: dict[str, Any], context: str, default_name: str) -> ExperimentSpec:
    from sb3_comm.comm_ddpg import METHODS
    from sb3_comm.registration import TASK_IDS

    methods = [str(m).upper() for m in _list(settings["methods"], "methods", context)]
    _check_members(methods, METHODS, "method", context)
    tasks = [str(t) for t in _list(settings["tasks"], "tasks", context)]
    _check_members(tasks, TASK_IDS, "task", context)
    seeds = [_int(s, "seeds", context, minimum=0) for s in _list(settings["seeds"], "seeds", context)]
    if len(set(seeds)) != len(seeds):
        raise ExperimentSpecError(f"{context}: 'seeds' lists a seed twice: {seeds}")
    spec = ExperimentSpec(
        name=_name(settings.get("name") or default_name, context),
        description=str(settings["description"] or ""),
        methods=methods,
        tasks=tasks,
        seeds=seeds,
        timesteps=_timesteps(settings["timesteps"], tasks, context),
        eval_freq=_int(settings["eval_freq"], "eval_freq", context),
        eval_episodes=_int(settings["eval_episodes"], "eval_episodes", context),
        analysis_episodes=_int(settings["analysis_episodes"], "analysis_episodes", context),
        save_freq=_int(settings["save_freq"], "save_freq", context),
        hyperparams=_hyperparams(settings["hyperparams"], context),
        quick={},
        precision=_precision(settings["precision"], context),
    )
    for task in spec.tasks:  # the packaged configs exist and parse, for every pair
        for method in spec.methods:
            try:
                spec.resolve(method, task)
            except ValueError as error:
                raise ExperimentSpecError(f"{context}: {method} on {task}: {error}") from error
    return spec


def _check_keys(data: dict[str, Any], accepted: tuple[str, ...] | list[str], message: str) -> None:
    unknown = sorted(str(key) for key in set(data) - set(accepted))
    if unknown:
        raise ExperimentSpecError(f"{message} {unknown}; accepted: {list(accepted)}")


def _check_members(values: list[str], accepted: Any, what: str, context: str) -> None:
    for value in values:
        if value not in accepted:
            raise ExperimentSpecError(f"{context}: unknown {what} {value!r}; accepted: {sorted(accepted)}")
    if len(set(values)) != len(values):
        raise ExperimentSpecError(f"{context}: a {what} is listed twice: {values}")


def _name(value: Any, context: str) -> str:
    """The experiment name: a plain folder name, so that ``runs/experiments/<name>`` stays there."""
    name = str(value).strip()
    if name in ("", ".", "..") or any(c in name for c in "/\\\0") or name.startswith("~"):
        raise ExperimentSpecError(
            f"{context}: 'name' must be a plain folder name (letters, digits, '-', '_', '.'; no '/', "
            f"'\\', '..' or '~'), got {name!r} (--out chooses another output folder)"
        )
    return name


def _list(value: Any, key: str, context: str) -> list[Any]:
    if not isinstance(value, list) or not value:
        raise ExperimentSpecError(f"{context}: {key!r} must be a non-empty list, got {value!r}")
    return value


def _int(value: Any, key: str, context: str, minimum: int = 1) -> int:
    number = coerce_number(value)  # YAML 1.1 reads 3e5 as a string
    whole = isinstance(number, int | float) and not isinstance(number, bool) and math.isfinite(number)
    if not whole or number != int(number):
        raise ExperimentSpecError(f"{context}: {key!r} must be a whole number, got {value!r}")
    if number < minimum:
        raise ExperimentSpecError(f"{context}: {key!r} must be at least {minimum}, got {value!r}")
    return int(number)


def _precision(value: Any, context: str) -> str | None:
    from sb3_comm.common.networks import PRECISIONS

    if value is None or (isinstance(value, str) and value in PRECISIONS):
        return value
    raise ExperimentSpecError(
        f"{context}: 'precision' must be one of {list(PRECISIONS)} or null (each configuration's own), "
        f"got {value!r}"
    )


def _timesteps(value: Any, tasks: list[str], context: str) -> dict[str, int | None]:
    from sb3_comm.registration import TASK_IDS

    if value is None:
        return dict.fromkeys(tasks)
    if isinstance(value, dict):
        _check_members(list(value), TASK_IDS, "task in 'timesteps'", context)
        return {
            task: None if value.get(task) is None else _int(value[task], f"timesteps[{task}]", context)
            for task in tasks
        }
    budget = _int(value, "timesteps", context)
    return dict.fromkeys(tasks, budget)


def _hyperparams(value: Any, context: str) -> dict[str, dict[str, Any]]:
    from sb3_comm.comm_ddpg import METHODS
    from sb3_comm.registration import TASK_IDS

    if value is None:
        return {}
    sections_accepted = ["all", *METHODS, *TASK_IDS, "METHOD/TASK (e.g. GSN/BlindSoccer-v0)"]
    if not isinstance(value, dict):
        raise ExperimentSpecError(
            f"{context}: 'hyperparams' must map sections to settings; sections: {sections_accepted}"
        )
    result: dict[str, dict[str, Any]] = {}
    for raw_section, entry in value.items():
        section = _section_name(str(raw_section))
        if section is None:
            raise ExperimentSpecError(
                f"{context}: unknown hyperparams section {raw_section!r}; accepted: {sections_accepted}"
            )
        if entry is None:
            continue
        if not isinstance(entry, dict):
            raise ExperimentSpecError(
                f"{context}: hyperparams[{raw_section!r}] must be a mapping of settings"
            )
        for key in entry:
            if key in _RESERVED_HYPERPARAMS:
                raise ExperimentSpecError(
                    f"{context}: hyperparams[{raw_section!r}] may not set {key!r}: "
                    f"{_RESERVED_HYPERPARAMS[key]}"
                )
        where = f"{context}: hyperparams[{raw_section!r}]"
        try:
            check_keys(entry, where, exclude=tuple(_RESERVED_HYPERPARAMS))
        except ValueError as error:
            raise ExperimentSpecError(str(error)) from error
        checked = {}
        for key, raw in entry.items():
            try:
                checked[key] = _plain(canonical_value(key, raw))
            except ValueError as error:
                raise ExperimentSpecError(f"{where}: {error}") from error
        if "n_envs" in checked:
            _int(checked["n_envs"], f"hyperparams[{raw_section!r}]: n_envs", context)
        result.setdefault(section, {}).update(checked)
    return result


def _section_name(section: str) -> str | None:
    from sb3_comm.comm_ddpg import METHODS
    from sb3_comm.registration import TASK_IDS

    if section == "all" or section in TASK_IDS:
        return section
    if section.upper() in METHODS:
        return section.upper()
    method, sep, task = section.partition("/")
    if sep and method.upper() in METHODS and task in TASK_IDS:
        return f"{method.upper()}/{task}"
    return None


def _merge_sections(base: Any, extra: Any) -> Any:
    if not isinstance(base, dict) or not isinstance(extra, dict):
        return extra if extra is not None else base
    merged = {key: dict(value or {}) for key, value in base.items()}
    for key, value in extra.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key].update(value)
        else:
            merged[key] = value
    return merged
