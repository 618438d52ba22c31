"""The record of one training run, and how results are written as JSON.

:class:`RunResult` is what :func:`sb3_comm.training.train_run` returns and writes to a run's
``result.json``; the experiment runner, the report and the benchmarks read it back with
:meth:`RunResult.load`. Every JSON file of the project goes through :func:`to_jsonable` (one
policy: NumPy values become Python values, NaN and infinities become ``null``, as standard JSON
has no NaN) and :func:`write_json` (a temporary file in the same folder, then ``os.replace``, so
that a reader never sees half a file: :func:`sb3_comm.common.files.atomic_path`).
:func:`machine_info` describes the machine that made them (with ``speed=True``, also how fast it
computes right now: :func:`speed_reference`).
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import json
import math
import os
import platform
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sb3_comm.common.files import write_text

__all__ = [
    "SPEED_REFERENCE",
    "RunResult",
    "git_commit",
    "machine_info",
    "read_json",
    "speed_reference",
    "to_jsonable",
    "usable_cores",
    "write_json",
]


def to_jsonable(value: Any) -> Any:
    """A JSON-safe copy: NumPy scalars and arrays to Python, paths to strings, NaN/inf to None."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = dataclasses.asdict(value)
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_json(path: str | Path, data: Any) -> Path:
    """Write ``data`` (through :func:`to_jsonable`) atomically to ``path``; returns the path."""
    text = json.dumps(to_jsonable(data), indent=2, allow_nan=False) + "\n"
    return write_text(path, text)


def read_json(path: str | Path) -> Any:
    """Parse a JSON file (``NaN`` literals written by older versions are read as NaN)."""
    return json.loads(Path(path).read_text())


def usable_cores() -> int:
    """Number of cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def git_commit(where: str | Path | None = None) -> str | None:
    """The commit checked out in the git work tree at ``where`` (default: this package's), or None
    outside one."""
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=Path(where) if where is not None else Path(__file__).resolve().parent,
            capture_output=True,
            text=True,
            timeout=5,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def _package_version() -> str | None:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("sb3-comm")
    except PackageNotFoundError:
        return None


SPEED_REFERENCE = "one Adam update of a 64-256-256-1 MLP on 256 rows, float32, one torch thread"
"""What :func:`speed_reference` times."""


def speed_reference(updates: int = 20, repeats: int = 5) -> float:
    """Microseconds per update of a fixed small network (:data:`SPEED_REFERENCE`), the median of
    ``repeats`` timings of ``updates`` updates each: how fast this machine does the arithmetic of a
    training step right now. This VM's speed drifts between days by more than most changes measured
    on it, so every result file records it beside the load average, to compare timings made on
    different days; lower is faster.
    """
    import torch as th

    threads = th.get_num_threads()
    th.set_num_threads(1)
    try:
        with th.random.fork_rng(devices=[]):  # the caller's random stream is left as it was
            th.manual_seed(0)
            inputs, targets = th.randn(256, 64), th.randn(256, 1)
            net = th.nn.Sequential(
                th.nn.Linear(64, 256),
                th.nn.ReLU(),
                th.nn.Linear(256, 256),
                th.nn.ReLU(),
                th.nn.Linear(256, 1),
            )
        optimizer = th.optim.Adam(net.parameters(), lr=1e-4)

        def update() -> None:
            loss = th.nn.functional.mse_loss(net(inputs), targets)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()

        for _ in range(5):  # warm-up: allocations, Adam's state
            update()
        timings = []
        for _ in range(repeats):
            began = time.perf_counter()
            for _ in range(updates):
                update()
            timings.append((time.perf_counter() - began) / updates * 1e6)
        return sorted(timings)[len(timings) // 2]
    finally:
        th.set_num_threads(threads)


def machine_info(speed: bool = False) -> dict[str, Any]:
    """The machine and software that produced a result.

    Keys: ``cpu_model``, ``cores``, ``usable_cores``, ``platform``, ``python``, ``numpy``,
    ``torch``, ``sb3_comm`` (this package's version), ``hostname``, ``date`` (UTC), ``git_commit``
    (None outside a git checkout) and ``load_average_1min`` (other processes share the cores: a
    high load means slower timings).

    :param speed: also ``speed_reference_us`` (:func:`speed_reference`, measured now, a fraction
        of a second) and ``speed_reference`` (what it times), for a record of timings.
    """
    try:
        import torch

        torch_version: str | None = torch.__version__
    except ImportError:  # pragma: no cover - torch is a dependency
        torch_version = None
    info = {
        "cpu_model": _cpu_model(),
        "cores": os.cpu_count(),
        "usable_cores": usable_cores(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "torch": torch_version,
        "sb3_comm": _package_version(),
        "hostname": platform.node(),
        "date": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
        "git_commit": git_commit(),
        "load_average_1min": round(os.getloadavg()[0], 2) if hasattr(os, "getloadavg") else None,
    }
    if speed:
        info.update(speed_reference_us=round(speed_reference(), 1), speed_reference=SPEED_REFERENCE)
    return info


@dataclass
class RunResult:
    """What one training run produced (``result.json``).

    :param method: communication method.
    :param task: environment id.
    :param seed: training seed.
    :param status: ``"done"``, or ``"failed"`` (then :attr:`error` says why).
    :param config_hash: fingerprint of the configuration (experiment runs), if any.
    :param timesteps: environment steps trained.
    :param budget: environment steps asked for.
    :param n_envs: parallel games.
    :param updates: gradient updates of the agents.
    :param train_seconds: wall-clock training time, evaluations excluded.
    :param eval_seconds: wall-clock time of the periodic evaluations.
    :param wall_seconds: wall-clock time of the whole run.
    :param started: start time (UTC, ISO 8601).
    :param finished: end time (UTC, ISO 8601).
    :param hyperparams: the settings in text form, ``n_envs`` included.
    :param eval: how it was evaluated (frequency, episodes, seeds).
    :param curve: the periodic evaluations (``timesteps``, ``seconds``, ``mean_return``, ...).
    :param final: per message ablation (``none``, ``zero``, ``shuffle``), the final evaluation.
    :param communication: the communication metrics, if measured.
    :param communication_error: why the communication analysis failed, if it did.
    :param target_return: the return that counts as solved, if one was set.
    :param time_to_target_seconds: training seconds until an evaluation first reached it.
    :param steps_to_target: environment steps until then.
    :param error: why the run failed.
    """

    method: str
    task: str
    seed: int
    status: str = "done"
    config_hash: str | None = None
    timesteps: int = 0
    budget: int = 0
    n_envs: int = 0
    updates: int = 0
    train_seconds: float = 0.0
    eval_seconds: float = 0.0
    wall_seconds: float = 0.0
    started: str | None = None
    finished: str | None = None
    hyperparams: dict[str, Any] = field(default_factory=dict)
    eval: dict[str, Any] = field(default_factory=dict)
    curve: list[dict[str, Any]] = field(default_factory=list)
    final: dict[str, dict[str, Any]] = field(default_factory=dict)
    communication: dict[str, Any] | None = None
    communication_error: str | None = None
    target_return: float | None = None
    time_to_target_seconds: float | None = None
    steps_to_target: int | None = None
    error: str | None = None

    @property
    def final_return(self) -> float:
        """Mean team return of the final evaluation with messages intact (NaN if there is none)."""
        try:
            value = self.final["none"]["mean_return"]
        except (KeyError, TypeError):
            return float("nan")
        return float("nan") if value is None else float(value)

    def to_json(self) -> dict[str, Any]:
        """A JSON-safe dict (see :func:`to_jsonable`)."""
        return to_jsonable(self)

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> RunResult:
        """Read a dict written by :meth:`to_json` (or an older ``result.json``; unknown keys are
        ignored, missing ones take their defaults).

        :raises ValueError: not a mapping, or no ``method``, ``task`` or ``seed``.
        """
        if not isinstance(data, dict):
            raise ValueError(f"a run result must be a JSON object, got {type(data).__name__}")
        missing = [key for key in ("method", "task", "seed") if key not in data]
        if missing:
            raise ValueError(f"a run result needs {missing}")
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{key: value for key, value in data.items() if key in names})

    def save(self, path: str | Path) -> Path:
        """Write atomically to ``path`` (usually ``RUN_DIR/result.json``)."""
        return write_json(path, self.to_json())

    @classmethod
    def load(cls, path: str | Path) -> RunResult:
        """Read ``result.json``.

        :raises ValueError: a file that is not JSON or not a run result (the message names it).
        """
        try:
            return cls.from_json(read_json(path))
        except ValueError as error:
            raise ValueError(f"{path}: {error}") from error
