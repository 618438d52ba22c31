"""What an experiment spends outside its runs' training: starting each run's process, and the report.

Two measurements, each of the current code against the way it was before session 36, alternated
over ``--rounds``:

* **run processes**: an experiment of ``--runs`` tiny runs (Guess My Number, 300 steps; NONE and
  GSN), two at a time, with each run in a new process forked from a server that has imported the
  trainer and the analysis (:func:`sb3_comm.experiments.runner.pool_context`) against a new
  ``spawn`` interpreter per run (which imports them again each time);
* **report**: ``sb3-comm report`` of a finished experiment folder (``--report-of``), with the
  bootstrap's replicate IQM of :func:`sb3_comm.analysis.stats.replicate_iqm` against rliable's
  ``aggregate_iqm`` (the same numbers; ``report.md`` is compared).

    python benchmarks/experiment_overheads.py --rounds 2 \\
        --report-of benchmarks/results/paper_fast_double_batch_5seeds --name experiment_overheads

writes ``benchmarks/results/<name>.{json,md}``.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

from sb3_comm.experiments import load_experiment, run_experiment
from sb3_comm.experiments import runner as runner_module

TINY = {
    "name": "tiny",
    "methods": ["NONE", "GSN"],
    "tasks": ["GuessMyNumber-v0"],
    "timesteps": 300,
    "eval_freq": 100_000,
    "eval_episodes": 2,
    "analysis_episodes": 2,
    "save_freq": 1_000,
    "hyperparams": {
        "all": {
            "n_envs": 2,
            "learning_starts": 50,
            "batch_size": 16,
            "buffer_size": 2_000,
            "policy_kwargs": {"net_arch": [8]},
        }
    },
}


def _spawn_context() -> Any:
    return mp.get_context("spawn")


def run_processes(runs: int, context: str) -> float:
    """Seconds of an experiment of ``runs`` tiny runs, two at a time, in processes of ``context``
    (``"server"``: the runner's own; ``"spawn"``: a new interpreter per run)."""
    seeds = list(range((runs + 1) // 2))
    original = runner_module.pool_context
    if context == "spawn":
        runner_module.pool_context = _spawn_context
    try:
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "tiny.yml"
            path.write_text(yaml.safe_dump({**TINY, "seeds": seeds}))
            began = time.perf_counter()
            run_experiment(load_experiment(path), Path(folder) / "out", workers=2, echo=lambda line: None)
            return time.perf_counter() - began
    finally:
        runner_module.pool_context = original
        _stop_fork_server()


def _stop_fork_server() -> None:
    """Stop multiprocessing's fork server, so that the next experiment starts (and pays for) its
    own, as every ``sb3-comm`` command does."""
    from multiprocessing import forkserver

    stop = getattr(forkserver._forkserver, "_stop", None)  # CPython's, private
    if stop is not None:
        stop()


def report(folder: Path, iqm: str) -> tuple[float, str]:
    """Seconds of ``sb3-comm report`` of ``folder`` with the bootstrap IQM ``iqm`` (``"replicate"``
    or ``"rliable"``), and its ``report.md``."""
    from rliable import metrics

    from sb3_comm.analysis import stats
    from sb3_comm.cli import main

    original = stats.replicate_iqm
    if iqm == "rliable":
        stats.replicate_iqm = metrics.aggregate_iqm
    try:
        with tempfile.TemporaryDirectory() as out:
            began = time.perf_counter()
            code = main(["report", str(folder), "--to", out])
            seconds = time.perf_counter() - began
            if code != 0:
                raise RuntimeError(f"sb3-comm report {folder} failed (exit {code})")
            return seconds, (Path(out) / "report.md").read_text().replace(out, "<out>")
    finally:
        stats.replicate_iqm = original


def _listed(seconds: list[float]) -> str:
    return ", ".join(f"{value:.1f} s" for value in seconds)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--runs", type=int, default=10, help="tiny runs per experiment (even)")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--report-of", type=Path, default=None, help="a finished experiment folder")
    parser.add_argument("--name", default="experiment_overheads")
    args = parser.parse_args()
    if args.report_of is not None and not (args.report_of / "runs").is_dir():
        parser.error(f"{args.report_of} is not an experiment folder (no runs/ in it)")
    times: dict[str, list[float]] = {"server": [], "spawn": []}
    reports: dict[str, list[float]] = {"replicate": [], "rliable": []}
    same_report = True
    for k in range(args.rounds):
        for context in ("server", "spawn")[:: 1 if k % 2 == 0 else -1]:
            times[context].append(run_processes(args.runs, context))
            print(f"round {k + 1}: {args.runs} tiny runs, {context}: {times[context][-1]:.1f} s", flush=True)
        if args.report_of is not None:
            texts = {}
            for iqm in ("replicate", "rliable")[:: 1 if k % 2 == 0 else -1]:
                seconds, texts[iqm] = report(args.report_of, iqm)
                reports[iqm].append(seconds)
                print(f"round {k + 1}: report, {iqm} IQM: {seconds:.1f} s", flush=True)
            same_report &= texts["replicate"] == texts["rliable"]
    median = {name: statistics.median(values) for name, values in times.items() if values}
    lines = [
        "| what | now | before session 36 | saved |",
        "|---|---|---|---:|",
        f"| {args.runs} tiny runs, two at a time: processes forked from a server that imported the "
        f"trainer (now) / a new `spawn` interpreter per run (before) | "
        f"{_listed(times['server'])} | {_listed(times['spawn'])} | "
        f"{(median['spawn'] - median['server']) / args.runs:.2f} s of wall-clock per run |",
    ]
    if args.report_of is not None:
        median.update({f"report_{name}": statistics.median(values) for name, values in reports.items()})
        lines.append(
            f"| `sb3-comm report {args.report_of}`: the bootstrap's replicate IQM (now) / rliable's "
            f"`aggregate_iqm` (before) | {_listed(reports['replicate'])} | {_listed(reports['rliable'])} | "
            f"{median['report_rliable'] - median['report_replicate']:.0f} s |"
        )
        lines += ["", f"The two reports' `report.md` are {'identical' if same_report else 'DIFFERENT'}."]
    lines += ["", f"{args.rounds} rounds, the order of the two variants swapped every round."]
    data = {"runs": args.runs, "rounds": args.rounds, "run_processes": times, "report": reports}
    data.update({"report_of": str(args.report_of), "same_report": same_report, "medians": median})
    title = "Experiment overheads: the runs' processes and the report"
    for path in write_results(args.name, data, "\n".join(lines), title):
        print(path)


if __name__ == "__main__":
    main()
