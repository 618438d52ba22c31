"""Loading an experiment folder: its runs, their results and how they were made.

This module is the one place that reads what the runner wrote, so that a change of the result
format touches nothing else:

* :func:`load_runs`: every run folder under ``experiment_dir/runs/`` with its ``result.json``
  (a :class:`~sb3_comm.results.RunResult`) or the reason it cannot be used (the entries the rest
  of the report works on);
* :func:`group_runs`: the usable runs by task and method, in report order;
* :func:`final_return`, :func:`learning_curve`, :func:`communication_of`: what a run measured;
* :func:`provenance`: the runner's command, machine and timing (``summary.json``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from sb3_comm.comm_ddpg import METHODS
from sb3_comm.results import RunResult

__all__ = [
    "communication_of",
    "final_return",
    "group_runs",
    "learning_curve",
    "load_runs",
    "method_order",
    "provenance",
]


def _load_summary(experiment_dir: Path) -> Any:
    """The runner's ``summary.json`` as parsed JSON, or ``{}`` when it is missing or corrupt."""
    try:
        return json.loads((experiment_dir / "summary.json").read_text())
    except (OSError, ValueError):
        return {}


def _read_summary(experiment_dir: Path) -> dict[Path, dict[str, Any]]:
    """Runner's ``summary.json`` entries by run folder (whatever shape the table has)."""
    data = _load_summary(experiment_dir)
    rows = data.get("runs", data) if isinstance(data, dict) else data
    if isinstance(rows, dict):
        rows = list(rows.values())
    entries = {}
    for row in rows if isinstance(rows, list) else []:
        if isinstance(row, dict) and isinstance(row.get("dir"), str):
            run_dir = Path(row["dir"])
            run_dir = run_dir if run_dir.is_absolute() else experiment_dir / run_dir
            entries[run_dir.resolve()] = row
    return entries


def provenance(experiment_dir: Path, runs: list[dict[str, Any]]) -> dict[str, Any]:
    """How the runs were made: the runner's command, machine and timing (from ``summary.json``)."""
    data = _load_summary(experiment_dir)
    data = data if isinstance(data, dict) else {}
    keys = ("command", "finished", "wall_seconds", "backend", "workers", "machine", "env_steps")
    out = {key: data.get(key) for key in keys}
    results = [r["result"] for r in runs if r.get("used") and isinstance(r.get("result"), RunResult)]
    out["runs_used"] = len(results)
    out["run_wall_seconds_total"] = float(sum(r.wall_seconds or 0.0 for r in results))
    out["run_env_steps"] = sorted({int(r.timesteps or 0) for r in results})
    return out


def _seed_of(name: str) -> int | None:
    digits = name.removeprefix("seed").split("-")[0]
    return int(digits) if digits.isdigit() else None


def load_runs(experiment_dir: str | Path) -> list[dict[str, Any]]:
    """Every run folder under ``experiment_dir/runs/`` with its result or why it cannot be used.

    A run folder is ``runs/<task>/<method>/<seed dir>/``, any folder holding a ``result.json``
    or an ``error.txt``, or a folder named in ``summary.json``, unless it lies inside another run
    folder (such as the runner's ``previous_attempts/``). Each entry has ``dir`` (relative
    to ``experiment_dir``), ``task``, ``method``, ``seed``, ``used`` (bool), ``reason`` (why not
    used), ``issues`` (what is missing for some parts, e.g. ``messages.npz``) and ``result`` (the
    :class:`~sb3_comm.results.RunResult`, or None).
    """
    root = Path(experiment_dir).resolve()
    runs_dir = root / "runs"
    summary = _read_summary(root)
    candidates = set(summary)
    if runs_dir.is_dir():
        candidates |= {p.resolve() for p in runs_dir.glob("*/*/*") if p.is_dir()}
        for name in ("result.json", "error.txt"):
            candidates |= {p.parent.resolve() for p in runs_dir.rglob(name)}
    # A folder inside a run (e.g. the runner's previous_attempts/) is part of that run.
    candidates = {c for c in candidates if not any(a in candidates for a in c.parents)}
    entries = []
    for run_dir in sorted(candidates):
        rel = run_dir.relative_to(root) if run_dir.is_relative_to(root) else run_dir
        parts = rel.parts
        entry: dict[str, Any] = {
            "dir": str(rel),
            "task": parts[1] if len(parts) > 3 and parts[0] == "runs" else None,
            "method": parts[2] if len(parts) > 3 and parts[0] == "runs" else None,
            "seed": _seed_of(run_dir.name),
            "used": False,
            "reason": None,
            "issues": [],
            "result": None,
        }
        runner = summary.get(run_dir, {})
        result_path = run_dir / "result.json"
        if not result_path.is_file():
            reason = "no result.json"
            if runner.get("status"):
                reason += f" (runner status: {runner['status']})"
            error = run_dir / "error.txt"
            if error.is_file():
                lines = [line for line in error.read_text(errors="replace").splitlines() if line.strip()]
                reason += f"; error.txt: {lines[-1].strip() if lines else '(empty)'}"
            entry["reason"] = reason
            entries.append(entry)
            continue
        try:
            result = RunResult.from_json(json.loads(result_path.read_text()))
        except (OSError, ValueError, TypeError) as error:
            entry["reason"] = f"corrupt result.json: {error}"
            entries.append(entry)
            continue
        entry["task"] = result.task or entry["task"]
        entry["method"] = str(result.method or entry["method"] or "").upper() or None
        entry["seed"] = result.seed if result.seed is not None else entry["seed"]
        if result.status != "done":
            entry["reason"] = f"status {result.status!r}"
            entries.append(entry)
            continue
        try:
            float(result.final["none"]["mean_return"])
        except (KeyError, TypeError, ValueError):
            entry["reason"] = "result.json has no final['none']['mean_return']"
            entries.append(entry)
            continue
        if not entry["task"] or not entry["method"]:
            entry["reason"] = "task or method unknown"
            entries.append(entry)
            continue
        entry.update(used=True, result=result)
        if not (run_dir / "messages.npz").is_file():
            entry["issues"].append("messages.npz missing: no t-SNE from this run")
        if not (run_dir / "model.zip").is_file():
            entry["issues"].append("model.zip missing")
        if not isinstance(result.communication, dict):
            lines = str(result.communication_error or "").strip().splitlines()
            detail = f" ({lines[-1].strip()})" if lines else ""
            entry["issues"].append(f"no communication metrics in result.json{detail}")
        entries.append(entry)
    return entries


def method_order(methods: list[str]) -> list[str]:
    """``methods`` sorted GSN first, then the other :data:`~sb3_comm.comm_ddpg.METHODS` in order,
    then unknown names alphabetically."""
    rank = {m: k for k, m in enumerate(("GSN", *[m for m in METHODS if m != "GSN"]))}
    return sorted(methods, key=lambda m: (rank.get(m, len(rank)), m))


def group_runs(runs: list[dict[str, Any]]) -> dict[str, dict[str, list[dict[str, Any]]]]:
    """The used runs of :func:`load_runs` by task and method (methods in :func:`method_order`,
    runs by seed)."""
    grouped: dict[str, dict[str, list[dict]]] = {}
    for run in runs:
        if run["used"]:
            grouped.setdefault(run["task"], {}).setdefault(run["method"], []).append(run)
    for task in grouped:
        grouped[task] = {
            m: sorted(grouped[task][m], key=lambda r: (r["seed"] is None, r["seed"] or 0))
            for m in method_order(list(grouped[task]))
        }
    return grouped


def final_return(run: dict[str, Any], ablation: str) -> float:
    """Mean final return of a run with its messages ``"none"`` (intact), ``"zero"`` or
    ``"shuffle"`` (NaN when not measured)."""
    try:
        return float(run["result"].final[ablation]["mean_return"])
    except (KeyError, TypeError, ValueError):
        return float("nan")


def learning_curve(run: dict[str, Any], root: Path) -> tuple[np.ndarray, np.ndarray]:
    """(timesteps, mean return) of a run's evaluations, from ``result.json`` or, when it has none,
    ``evaluations.json``; ``root`` is the experiment folder."""
    points = run["result"].curve
    if not points:
        try:
            points = json.loads((root / run["dir"] / "evaluations.json").read_text())
        except (OSError, ValueError):
            points = []
    pairs = [(p["timesteps"], p["mean_return"]) for p in points if isinstance(p, dict) and "timesteps" in p]
    pairs.sort()
    array = np.array(pairs, dtype=np.float64).reshape(-1, 2)
    return array[:, 0], array[:, 1]


def communication_of(run: dict[str, Any]) -> dict[str, Any] | None:
    """The communication metrics of a run (``{"directions": {"sighted->blind": {...}}}``), or
    None when it has none."""
    comm = run["result"].communication
    return comm if isinstance(comm, dict) else None
