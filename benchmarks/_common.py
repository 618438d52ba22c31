"""Shared helpers of the benchmark scripts: machine description and result files.

Every script writes ``benchmarks/results/<name>.json`` (all numbers, the machine, the exact
command line) and ``benchmarks/results/<name>.md`` (a table for humans, same provenance).
"""

from __future__ import annotations

import datetime
import json
import os
import pathlib
import platform
import shlex
import subprocess
import sys
from typing import Any

import numpy as np

__all__ = ["RESULTS_DIR", "command_line", "machine_info", "to_jsonable", "write_results"]

RESULTS_DIR = pathlib.Path(__file__).resolve().parent / "results"


def _cpu_model() -> str:
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _git_commit() -> str | None:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=RESULTS_DIR.parent,
            capture_output=True,
            text=True,
            timeout=5,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def machine_info() -> dict[str, Any]:
    """CPU model, usable core count, Python / numpy versions, platform, date (UTC), git commit
    and the 1-minute load average when the results were written."""
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    return {
        "cpu": _cpu_model(),
        "cores": usable,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "platform": platform.platform(),
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "git_commit": _git_commit(),
        # other processes share the cores: a high load average means slower, noisier timings
        "load_average_1min": round(os.getloadavg()[0], 2) if hasattr(os, "getloadavg") else None,
    }


def command_line() -> str:
    """The command line that started this process, as typed (``sys.orig_argv``)."""
    return shlex.join(getattr(sys, "orig_argv", [sys.executable, *sys.argv]))


def to_jsonable(value: Any) -> Any:
    """numpy scalars and arrays to Python numbers and lists, recursively."""
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def write_results(
    name: str, data: dict[str, Any], markdown_table: str, title: str | None = None
) -> tuple[pathlib.Path, pathlib.Path]:
    """Write ``results/<name>.json`` and ``results/<name>.md`` with the machine and the command.

    :param name: file stem.
    :param data: the numbers (numpy values are converted).
    :param markdown_table: the Markdown body (tables and notes).
    :param title: heading of the Markdown file (default: ``name``).
    :return: the two paths.
    """
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    machine = machine_info()
    command = command_line()
    payload = {"name": name, "command": command, "machine": machine, **to_jsonable(data)}
    json_path = RESULTS_DIR / f"{name}.json"
    json_path.write_text(json.dumps(payload, indent=2) + "\n")
    md_lines = [
        f"# {title or name}",
        "",
        f"Produced by `{command}` on {machine['date']}.",
        "",
        f"Machine: {machine['cpu']}, {machine['cores']} cores; Python {machine['python']}, "
        f"numpy {machine['numpy']}; {machine['platform']}; commit {machine['git_commit'] or 'n/a'}; "
        f"load average {machine['load_average_1min']} (1 min, at the end of the run).",
        "",
        markdown_table.rstrip(),
        "",
    ]
    md_path = RESULTS_DIR / f"{name}.md"
    md_path.write_text("\n".join(md_lines))
    return json_path, md_path
