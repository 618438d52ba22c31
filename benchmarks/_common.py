"""Shared helpers of the benchmark scripts: result files with the machine and the command.

Every script writes ``benchmarks/results/<name>.json`` (all numbers, the machine, the exact
command line) and ``benchmarks/results/<name>.md`` (a table for humans, same provenance).
"""

from __future__ import annotations

import argparse
import json
import pathlib
import re
import shlex
import sys
import time
from collections.abc import Callable, Mapping
from contextlib import AbstractContextManager
from typing import Any

from sb3_comm.results import SPEED_REFERENCE, RunResult, machine_info, write_json

__all__ = [
    "RESULTS_DIR",
    "add_threads_option",
    "alternated_learning_rates",
    "apply_threads_option",
    "checkpoints",
    "command_line",
    "finished_run",
    "machine_info",
    "warmed_up_model",
    "write_results",
]

RESULTS_DIR = pathlib.Path(__file__).resolve().parent / "results"


def checkpoints(run_dir: str | pathlib.Path, min_steps: int = 0) -> list[tuple[int, pathlib.Path]]:
    """The checkpoints ``checkpoints/model_<steps>_steps.zip`` of a run folder (``benchmarks/solve.py
    --save-freq``) from ``min_steps`` on, as ``(steps, path)`` sorted by step (empty if none)."""
    return sorted(
        (int(m.group(1)), path)
        for path in pathlib.Path(run_dir, "checkpoints").glob("model_*_steps.zip")
        if (m := re.fullmatch(r"model_(\d+)_steps\.zip", path.name)) and int(m.group(1)) >= min_steps
    )


def alternated_learning_rates(
    model: Any,
    variants: Mapping[str, Callable[[], AbstractContextManager[Any]]],
    rounds: int,
    steps: int,
    log_interval: int,
) -> dict[str, list[float]]:
    """Environment steps per second of ``model.learn(steps)`` under each variant, one value per
    round: each variant is a context in which the model trains, and their order is reversed every
    round, so that a slow phase of a shared machine hits them alike."""
    names = list(variants)
    rates: dict[str, list[float]] = {name: [] for name in names}
    for k in range(rounds):
        for name in names if k % 2 == 0 else names[::-1]:
            with variants[name]():
                began = time.perf_counter()
                model.learn(steps, reset_num_timesteps=False, log_interval=log_interval)
                rates[name].append(steps / (time.perf_counter() - began))
    return rates


def add_threads_option(parser: argparse.ArgumentParser) -> None:
    """``--threads``: torch's intra-op threads (default: torch's own choice)."""
    parser.add_argument(
        "--threads", type=int, default=None,
        help="torch threads (default: torch's); fewer than the cores: a GSN trains in a worker process",
    )  # fmt: skip


def apply_threads_option(args: argparse.Namespace) -> int:
    """Set torch's threads from ``args.threads`` where given; record and return the count in use."""
    import torch as th

    if args.threads is not None:
        th.set_num_threads(args.threads)
    args.threads = th.get_num_threads()
    return args.threads


def command_line() -> str:
    """The command line that started this process, as typed (``sys.orig_argv``)."""
    return shlex.join(getattr(sys, "orig_argv", [sys.executable, *sys.argv]))


def finished_run(run_dir: pathlib.Path, job: dict[str, Any], settings_name: str) -> RunResult | None:
    """The result of a run that an earlier call of a resumable benchmark finished, or None.

    :param run_dir: the run's folder.
    :param job: the settings of the run to make (JSON-able); the folder's ``settings_name`` file
        holds those the earlier call made it with.
    :param settings_name: the file name of those settings in the folder.
    :return: the earlier result where it finished (status ``"done"``), None where there is none or
        it did not finish (the run is to be made again).
    :raises ValueError: the folder holds a run made with other settings.
    """
    finished, settings = run_dir / "result.json", run_dir / settings_name
    if not (finished.exists() and settings.exists()):
        return None
    if json.loads(settings.read_text()) != json.loads(json.dumps(job)):
        raise ValueError(f"{run_dir} holds a run with other settings: use another --save-dir")
    earlier = RunResult.load(finished)
    if earlier.status != "done":
        return None
    print(f"{run_dir}: finished earlier, read from {finished.name}", flush=True)
    return earlier


def warmed_up_model(
    method: str,
    env_id: str,
    n_envs: int,
    batch_size: int,
    net_arch: list[int],
    warmup: int,
    precision: str | None = None,
) -> Any:
    """A CPU ``CommDDPG`` of ``method`` (seed 0) trained ``warmup`` env steps, learning from its
    first ``batch_size`` transitions: a replay buffer to sample from, and optimizer state, for
    timing its updates. ``precision`` (None: the default) goes into ``policy_kwargs``."""
    from sb3_comm import CommDDPG, make_comm_vec_env

    policy_kwargs: dict[str, Any] = {"net_arch": net_arch}
    if precision is not None:
        policy_kwargs["precision"] = precision
    env = make_comm_vec_env(env_id, n_envs=n_envs, seed=0)
    model = CommDDPG(
        method,
        env,
        batch_size=batch_size,
        learning_starts=batch_size,
        seed=0,
        device="cpu",
        policy_kwargs=policy_kwargs,
    )
    model.learn(warmup, log_interval=0)
    return model


def write_results(
    name: str, data: dict[str, Any], markdown_table: str, title: str | None = None
) -> tuple[pathlib.Path, pathlib.Path]:
    """Write ``results/<name>.json`` and ``results/<name>.md`` with the machine, its speed now
    (:func:`~sb3_comm.results.speed_reference`) and the command.

    :param name: file stem.
    :param data: the numbers (numpy values are converted).
    :param markdown_table: the Markdown body (tables and notes).
    :param title: heading of the Markdown file (default: ``name``).
    :return: the two paths.
    """
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    machine = machine_info(speed=True)
    command = command_line()
    json_path = write_json(
        RESULTS_DIR / f"{name}.json", {"name": name, "command": command, "machine": machine, **data}
    )
    md_lines = [
        f"# {title or name}",
        "",
        f"Produced by `{command}` on {machine['date']}.",
        "",
        f"Machine: {machine['cpu_model']}, {machine['usable_cores']} cores; Python {machine['python']}, "
        f"numpy {machine['numpy']}; {machine['platform']}; commit {machine['git_commit'] or 'n/a'}; "
        f"load average {machine['load_average_1min']} (1 min, at the end of the run); speed reference "
        f"{machine['speed_reference_us']:,.0f} µs per update at the end of the run ({SPEED_REFERENCE}; "
        "lower is faster: this VM's speed drifts between days).",
        "",
        markdown_table.rstrip(),
        "",
    ]
    md_path = RESULTS_DIR / f"{name}.md"
    md_path.write_text("\n".join(md_lines))
    return json_path, md_path
