"""Train methods on a task and measure how close to the oracle they get, and how fast.

Each (method, seed) run trains CommDDPG with the packaged hyperparameters (``zoo_configs/``),
evaluates the deterministic team every ``--eval-freq`` steps on 100 parallel games
(``--eval-episodes``), records the wall-clock training time (evaluations excluded) and steps at
which the mean return first reached ``--target-fraction`` × the oracle's return, and ends with a
final evaluation on as many games with the messages intact, zeroed and shuffled (the paper's
ablation). More games measure the team's level more exactly (``benchmarks/checkpoint_level.py``:
one Blind Soccer team's 100-game readings spread by about 0.025 of the oracle) and leave the
training as it is. Runs go in parallel, one process per core, each with one torch thread.
Resumable: a run whose folder under ``--save-dir`` already holds a ``result.json`` with the same
settings is read instead of trained again, so a many-seed solve can be made in pieces (the same
command again, or more seeds), and an interrupted run starts over.

    python benchmarks/solve.py --env BlindSoccer-v0 --methods GSN NONE --seeds 0 --time-budget 1800
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import shutil
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import finished_run, write_results

from envs.registry import get_task, task_ids
from sb3_comm.analysis.references import REFERENCE_SEED, reference_returns

EVAL_EPISODES = 100
"""Games of every periodic and of the final evaluation, unless ``--eval-episodes`` says otherwise."""


def oracle_returns(env_id: str) -> tuple[float, float]:
    """Mean team return of the oracle and of the random policy (1,000 episodes, the report's
    :func:`~sb3_comm.analysis.references.reference_returns`)."""
    references = reference_returns(env_id, n_episodes=1000, seed=REFERENCE_SEED)
    assert references is not None  # --env is one of the registry's ids
    return references["oracle"], references["random"]


def run_one(job: dict[str, Any]) -> dict[str, Any]:
    """Train and evaluate one (method, seed) with :func:`sb3_comm.training.train_run`; returns its
    :class:`~sb3_comm.results.RunResult` as JSON."""
    import torch as th

    from sb3_comm.callbacks import TimeBudgetCallback
    from sb3_comm.config import RunConfig
    from sb3_comm.training import EvalSettings, train_run

    th.set_num_threads(1)
    env_id, method, seed = job["env"], job["method"], job["seed"]
    config = RunConfig.load(method, env_id, seed=seed, path=job.get("conf"), overrides=job["overrides"])
    run_dir = Path(job["save_dir"]) / f"{env_id}_{method}_seed{seed}"
    settings = run_dir / "solve_job.json"
    earlier = finished_run(run_dir, job, settings.name)  # resumable: read a run an earlier call finished
    if earlier is not None:
        return earlier.to_json()
    if run_dir.exists():  # an interrupted or failed run starts again from scratch
        shutil.rmtree(run_dir)
    run_dir.mkdir(parents=True)
    settings.write_text(json.dumps(job, indent=1))
    averages = []
    if job.get("actor_averages"):  # slower averages of the actor beside the checkpoints (a diagnostic)
        from _actor_averages import ActorAveragesCallback

        averages.append(ActorAveragesCallback(job["actor_averages"], job["save_freq"], run_dir))
    result = train_run(
        config,
        run_dir,
        evaluation=EvalSettings(
            freq=job["eval_freq"],
            episodes=job.get("eval_episodes", EVAL_EPISODES),
            curve_seed=10_000,
            final_seed=20_000,
            target_return=job["target"],
        ),
        save_freq=job.get("save_freq", 0),
        callbacks=[TimeBudgetCallback(job["time_budget"]), *averages],
    )
    return result.to_json()


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--env", default="BlindSoccer-v0", choices=task_ids())
    parser.add_argument("--methods", nargs="+", default=["GSN", "NONE"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0])
    parser.add_argument("--timesteps", type=int, default=None, help="override the config's n_timesteps")
    parser.add_argument("--time-budget", type=float, default=1800.0, help="seconds of training per run")
    parser.add_argument("--eval-freq", type=int, default=50_000)
    parser.add_argument(
        "--eval-episodes",
        type=int,
        default=EVAL_EPISODES,
        help="games of every evaluation, 1 to 1,000 (the scripted references are played on as many)",
    )
    parser.add_argument("--target-fraction", type=float, default=0.9)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--params", nargs="*", default=[], help="hyperparameter overrides key=value")
    parser.add_argument(
        "--conf",
        default=None,
        help="a hyperparameter file in rl-zoo3 format (default: the packaged zoo_configs/<method>.yml); "
        "an entry without a `policy` key serves every method",
    )
    parser.add_argument(
        "--save-freq", type=int, default=0, help="a checkpoint every this many steps (0: none)"
    )
    parser.add_argument(
        "--actor-averages",
        nargs="+",
        type=float,
        default=None,
        metavar="TAU",
        help="keep Polyak averages of the actor at these rates beside each checkpoint "
        "(benchmarks/_actor_averages.py; needs --save-freq; training is unchanged)",
    )
    parser.add_argument("--save-dir", default="runs/benchmarks", help="where the run folders go")
    parser.add_argument("--name", default=None, help="result file stem")
    args = parser.parse_args()

    from sb3_comm.cli import parse_overrides

    if not 1 <= args.eval_episodes <= 1000:
        parser.error(
            f"--eval-episodes must be between 1 and 1,000 (games played at once); got {args.eval_episodes}"
        )
    if args.actor_averages and not args.save_freq:
        parser.error("--actor-averages are saved with the checkpoints: give --save-freq too")
    oracle, random_return = oracle_returns(args.env)
    target = args.target_fraction * oracle
    overrides = parse_overrides(args.params)
    if args.timesteps is not None:
        overrides["n_timesteps"] = args.timesteps
    jobs = [
        {
            "env": args.env,
            "method": method.upper(),
            "seed": seed,
            "time_budget": args.time_budget,
            "eval_freq": args.eval_freq,
            "target": target,
            "overrides": overrides,
            "save_dir": args.save_dir,
            **({"save_freq": args.save_freq} if args.save_freq else {}),
            **({"actor_averages": args.actor_averages} if args.actor_averages else {}),
            # recorded where it is not the default, so that the runs of earlier solves are still read
            **({"eval_episodes": args.eval_episodes} if args.eval_episodes != EVAL_EPISODES else {}),
            **({"conf": str(Path(args.conf).resolve())} if args.conf else {}),
        }
        for method in args.methods
        for seed in args.seeds
    ]
    from sb3_comm.experiments.runner import start_worker

    # The workers end with this process (a killed benchmark leaves no orphan training on); a
    # GSN's updates use a second thread only where the parallel runs leave a core spare.
    workers = min(args.workers, len(jobs))
    with mp.get_context("spawn").Pool(workers, initializer=start_worker, initargs=(workers,)) as pool:
        runs: list[dict[str, Any]] = []
        for run in pool.imap_unordered(run_one, jobs):  # the summary so far, after every run
            runs.append(run)
            runs.sort(key=lambda r: (r["method"], r["seed"]))
            write_summary(args, runs, oracle, random_return, target, len(jobs))


def write_summary(
    args: argparse.Namespace,
    runs: list[dict[str, Any]],
    oracle: float,
    random_return: float,
    target: float,
    n_jobs: int,
) -> None:
    """The results files of the runs finished so far (all of them at the end)."""
    rows = [
        "| method | seed | env steps | train time (s) | final return | fraction of oracle | "
        "time to target (s) | steps to target | zeroed messages | shuffled messages |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for run in runs:
        fin = run["final"]
        ttt, stt = run["time_to_target_seconds"], run["steps_to_target"]
        rows.append(
            f"| {run['method']} | {run['seed']} | {run['timesteps']:,} | {run['train_seconds']:.0f} | "
            f"{fin['none']['mean_return']:.3f} | {fin['none']['mean_return'] / oracle:.2f} | "
            f"{'not reached' if ttt is None else f'{ttt:.0f}'} | "
            f"{'—' if stt is None else f'{stt:,}'} | "
            f"{fin['zero']['mean_return']:.3f} | {fin['shuffle']['mean_return']:.3f} |"
        )
    pending = n_jobs - len(runs)
    notes = (
        (f"\n\n**{pending} of {n_jobs} runs not finished yet.**" if pending else "")
        + f"\n\nOracle return {oracle:.4f}, random {random_return:.4f} "
        f"(1,000 episodes, seed {REFERENCE_SEED}); "
        f"target = {args.target_fraction} × oracle = {target:.4f}. Returns are team means over "
        f"{args.eval_episodes:,} deterministic evaluation episodes. Time to target is training "
        f"wall-clock time with the periodic evaluations (every {args.eval_freq:,} steps) excluded; each "
        f"run is one process with one torch thread, {min(args.workers, n_jobs)} runs in parallel on this "
        "machine. Time budget "
        f"per run: {args.time_budget:.0f} s."
    )
    write_results(
        args.name or f"solve_{get_task(args.env).key}",
        {
            "env": args.env,
            "oracle_return": oracle,
            "random_return": random_return,
            "target": target,
            "args": vars(args),
            "runs": runs,
        },
        "\n".join(rows) + notes,
        title=f"{args.env}: return as a fraction of the oracle, and time to {args.target_fraction} × oracle",
    )


if __name__ == "__main__":
    main()
