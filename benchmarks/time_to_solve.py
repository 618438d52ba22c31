"""Time to solve: wall-clock training seconds (and steps) until a method first reaches
``--target-fraction`` × the oracle's return, seed after seed, one run at a time.

Each run trains with the packaged configuration (``zoo_configs/``; ``--params key=value`` overrides
its settings, as in ``solve.py``) through
:func:`sb3_comm.training.train_run`, evaluates the deterministic team on 100 games every
``--eval-freq`` steps (evaluation time is not training time), and stops at the first evaluation
that reaches the target, or after ``--time-budget`` seconds of wall-clock or the configuration's
``n_timesteps``. Runs go one after the other, so that each has the machine to itself, with
torch's default threads or ``--threads`` (with one, a GSN's updates take the second core beside the
agents'); the load average before and after each run is recorded.

Three bars are reported, each ``--target-fraction`` × a reference: the oracle's 1,000-game return
(``oracle``), the oracle on the very games of the periodic evaluations (``paired``,
``benchmarks/stability.py``'s fair bar: 100 given games are easier or harder than the average, for
the oracle too) and, on Blind Soccer, the visible oracle on those games (``visible``: the oracle
less the games whose blind agent the sighted agent cannot see, which no protocol can be told about;
``benchmarks/hidden_teammate.py``). A run stops at the first evaluation at ``--bar`` (default
``oracle``). On Blind Soccer's periodic games the visible oracle is 0.909 of the oracle's
1,000-game return, so a run that stops at ``oracle`` must also win games nobody can see.
Resumable: a run whose folder under ``--save-dir`` already holds a finished ``result.json`` with the
same settings is read, not trained again (with the load averages recorded when it ran), so a
5-seed measurement can be made in pieces.

    python benchmarks/time_to_solve.py --env BlindSoccer-v0 --method GSN --seeds 0 1 2 3 4
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_threads_option, apply_threads_option, finished_run, write_results

from envs.registry import task_ids
from sb3_comm.analysis.references import REFERENCE_SEED, reference_returns
from sb3_comm.callbacks import TimeBudgetCallback
from sb3_comm.config import RunConfig
from sb3_comm.results import write_json
from sb3_comm.training import EvalSettings, train_run

BARS = {
    "oracle": "oracle (1,000 games)",
    "paired": "oracle, same games",
    "visible": "visible oracle, same games",
}
"""The references a bar is drawn from (module docstring), and how the tables name them."""


def _median_seconds(seconds: list[float | None]) -> float:
    """Median over runs, an unreached run counting as +inf (finite only if most reached it)."""
    reached = sorted(s for s in seconds if s is not None)
    return statistics.median(reached + [float("inf")] * (len(seconds) - len(reached)))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--env", default="BlindSoccer-v0", choices=task_ids())
    parser.add_argument("--method", default="GSN")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    parser.add_argument("--target-fraction", type=float, default=0.9)
    parser.add_argument("--eval-freq", type=int, default=10_000)
    parser.add_argument("--time-budget", type=float, default=900.0, help="wall-clock seconds per run")
    parser.add_argument(
        "--bar", default="oracle", choices=list(BARS), help="the bar a run stops at (all three are reported)"
    )
    parser.add_argument("--save-dir", default="runs/time_to_solve")
    parser.add_argument("--name", default=None)
    parser.add_argument(
        "--params", nargs="*", default=[], help="hyperparameter overrides key=value (as solve.py's)"
    )
    add_threads_option(parser)
    args = parser.parse_args()
    apply_threads_option(args)

    from sb3_comm.cli import parse_overrides

    overrides = parse_overrides(args.params)
    references = reference_returns(args.env, n_episodes=1000, seed=REFERENCE_SEED)
    assert references is not None
    curve_seed = EvalSettings().curve_seed
    games = reference_returns(args.env, n_episodes=EvalSettings().episodes, seed=curve_seed)
    assert games is not None
    bars = {
        "oracle": args.target_fraction * references["oracle"],
        "paired": args.target_fraction * games["oracle"],
    }
    if "visible_oracle" in games:
        bars["visible"] = args.target_fraction * games["visible_oracle"]
    if args.bar not in bars:
        parser.error(
            f"--bar {args.bar} needs a task with a visible oracle (Blind Soccer); {args.env} has {list(bars)}"
        )
    target = bars[args.bar]
    name = args.name or f"time_to_solve_{args.env.split('-')[0].lower()}_{args.method.lower()}"
    runs: list[dict[str, Any]] = []
    partial = Path(__file__).resolve().parent / "results" / f"{name}.partial.json"
    for seed in args.seeds:
        load_before: float | None = os.getloadavg()[0]
        config = RunConfig.load(args.method, args.env, seed=seed, overrides=overrides)
        settings = EvalSettings(
            freq=args.eval_freq,
            curve_seed=curve_seed,
            target_return=target,
            stop_at_target=True,
            projector_episodes=0,
        )
        run_dir = Path(args.save_dir) / f"{args.env}_{args.method}_seed{seed}"
        job = {"env": args.env, "method": args.method, "seed": seed, "eval_freq": args.eval_freq,
               "time_budget": args.time_budget, "target": target, "threads": args.threads,
               **({"overrides": args.params} if args.params else {})}  # fmt: skip
        result = finished_run(run_dir, job, "tts_job.json")
        if result is None:
            run_dir.mkdir(parents=True, exist_ok=True)
            (run_dir / "tts_job.json").write_text(json.dumps(job))
            result = train_run(
                config, run_dir, evaluation=settings, save_freq=0,
                callbacks=[TimeBudgetCallback(args.time_budget)],
            )  # fmt: skip
            load_after: float | None = os.getloadavg()[0]
            (run_dir / "tts_load.json").write_text(json.dumps([load_before, load_after]))
        else:
            loads = run_dir / "tts_load.json"
            load_before, load_after = json.loads(loads.read_text()) if loads.exists() else (None, None)
        assert int(result.eval["seeds"]["curve"]) == curve_seed
        run: dict[str, Any] = {
            "seed": seed,
            "solved": result.steps_to_target is not None,
            "seconds_to_target": result.time_to_target_seconds,
            "steps_to_target": result.steps_to_target,
            "train_seconds": result.train_seconds,
            "timesteps": result.timesteps,
            "final_return": result.final_return,
            "load_before": load_before,
            "load_after": load_after,
            "paired_oracle": games["oracle"],
        }
        for bar, value in bars.items():
            reached = next((p for p in result.curve if p["mean_return"] >= value), None)
            run[f"{bar}_seconds_to_target"] = None if reached is None else reached["seconds"]
            run[f"{bar}_steps_to_target"] = None if reached is None else reached["timesteps"]
        runs.append(run)
        print(run, flush=True)
        # written after every run, so that a session that ends keeps the seeds done
        write_json(partial, runs)
    medians = {bar: _median_seconds([r[f"{bar}_seconds_to_target"] for r in runs]) for bar in bars}
    rows = [
        "| seed | stopped at the bar | "
        + " | ".join(f"seconds / steps to {args.target_fraction} × {BARS[bar]}" for bar in bars)
        + " | training seconds | final return | load before / after |",
        "|---:|---|" + "---:|" * len(bars) + "---:|---:|---|",
    ]
    for r in runs:
        reached = [
            "never"
            if r[f"{bar}_seconds_to_target"] is None
            else f"{r[f'{bar}_seconds_to_target']:.0f} / {r[f'{bar}_steps_to_target']:,}"
            for bar in bars
        ]
        load = "read from an earlier call" if r["load_before"] is None else (
            f"{r['load_before']:.2f} / {r['load_after']:.2f}"
        )  # fmt: skip
        rows.append(
            f"| {r['seed']} | {'yes' if r['solved'] else 'no'} | {' | '.join(reached)} "
            f"| {r['train_seconds']:.0f} | {r['final_return']:.4f} | {load} |"
        )

    def median_text(bar: str) -> str:
        return "never" if medians[bar] == float("inf") else f"{medians[bar]:.0f} s"

    values = ", ".join(f"{BARS[bar]} {value / args.target_fraction:.4f}" for bar, value in bars.items())
    notes = (
        f"\n\n{args.method} on `{args.env}`, packaged configuration"
        f"{' with ' + ', '.join(args.params) if args.params else ''}; the mean return of 100 evaluation "
        f"games (seed {curve_seed}) every {args.eval_freq:,} steps against {args.target_fraction} × a "
        f"reference ({values}); a run stops at the first evaluation at the {BARS[args.bar]} bar "
        f"({target:.4f}), or after {args.time_budget:.0f} s of wall-clock. Median seconds to each bar over "
        f"the {len(runs)} seeds (an unreached bar counts as never): "
        + "; ".join(f"{BARS[bar]} {median_text(bar)}" for bar in bars)
        + " (a run stops at its own bar, so a higher bar can be missed). The visible oracle is the oracle "
        "less the games whose blind agent the sighted agent cannot see (`benchmarks/hidden_teammate.py`). "
        f"Runs one at a time, torch threads {args.threads}."
    )
    write_results(
        name,
        {
            "args": vars(args),
            "oracle": references["oracle"],
            "references_on_curve_games": {k: v for k, v in games.items() if not k.endswith("_ci95")},
            "bars": bars,
            "target": target,
            "runs": runs,
            "median_seconds": medians[args.bar],
            **{f"{bar}_median_seconds": value for bar, value in medians.items()},
        },
        "\n".join(rows) + notes,
        title=f"Time to solve: {args.method} on {args.env}",
    )
    partial.unlink(missing_ok=True)  # the full results are written: the per-run backup is done


if __name__ == "__main__":
    main()
