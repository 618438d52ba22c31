"""A foreign benchmark: every method, with the constructor's defaults, on mpe2's simple_reference.

The task (``MPESimpleReference-v0``, :mod:`sb3_comm.foreign.simple_reference`) was never used to tune
sb3-comm. Its own channel is silenced, so the target landmark can pass between the agents only
through our channel (size ``--channel-size``). Each (method, seed) trains
``CommDDPG(method, env, seed=seed)`` with no other hyperparameter, on ``--n-envs`` games, for
``--timesteps`` environment steps; every ``--eval-freq`` steps the deterministic team plays 100
evaluation games (seed 10,000), and at the end 100 other games (seed 20,000) with the messages
intact, zeroed and shuffled.

The references play the same final games, and 1,000 more for precision: the full-information
oracle, the best scripted policy without communication (the landmarks' geometric median) and
random actions. The figure that counts is the fraction of the communication gap closed,
``(method − no-comm) / (oracle − no-comm)``, per seed; the summary gives its mean and rliable's
IQM with the 95 % stratified-bootstrap interval. Goal: a method that closes ≥ 0.7 of the gap,
with a message ablation that shows the gain comes from the messages.

The games are sb3-comm's batched numpy re-implementation of the task
(:mod:`sb3_comm.foreign.batched_simple_reference`, equal to mpe2's step for step); ``--no-batched``
plays mpe2's own environment (slower), as the first results file, ``simple_reference.md``, did.
``--perfect-channel`` is a diagnostic, not a method: every agent hears its own target's colour
where its teammate's message would be, which measures what the learner reaches when the channel
carries exactly what is needed (run it with NONE, whose own messages are zeros).

Runs are resumable: each finished run is one JSON file under ``--runs-dir``, and a run whose file
exists is not run again. The summary (``benchmarks/results/<name>.{json,md}`` and a curve figure)
is made from all the files present.

    python benchmarks/simple_reference.py --methods NONE RIAL TCG GSN --seeds 0 1 2 3 4
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import RESULTS_DIR, write_results

from sb3_comm.common.hyperparams import algorithm_kwargs
from sb3_comm.foreign.simple_reference import ENV_ID
from sb3_comm.results import to_jsonable, write_json

CURVE_SEED = 10_000
FINAL_SEED = 20_000
REFERENCE_SEED = 30_000


def _perfect_channel_task(n: int, seed: int, channel_size: int, time_feature: bool = False) -> Any:
    """The batched game with a perfect channel: each agent hears its own target's colour."""
    from sb3_comm.foreign.batched_simple_reference import LANDMARK_COLOURS, N_FEATURES, SimpleReferenceTask

    class PerfectChannelTask(SimpleReferenceTask):
        def _observe(self, games: Any = None) -> np.ndarray:
            obs = super()._observe(games)
            index = slice(None) if games is None else games
            # agent i's target is the landmark its teammate knows: goal[:, j]
            obs[..., N_FEATURES : N_FEATURES + 3] = LANDMARK_COLOURS[self.goal[index][:, ::-1]]
            return obs

    if channel_size < 3:
        raise ValueError(f"--perfect-channel needs --channel-size >= 3 (a colour), got {channel_size}")
    return PerfectChannelTask(n, seed=seed, channel_size=channel_size, time_feature=time_feature)


def _vec_env(
    n: int,
    seed: int,
    channel_size: int,
    batched: bool,
    perfect_channel: bool = False,
    time_feature: bool = False,
) -> Any:
    from sb3_comm import make_comm_vec_env
    from sb3_comm.wrappers import BatchedTwoAgentVecEnv

    if perfect_channel:
        vec_env = BatchedTwoAgentVecEnv(_perfect_channel_task(n, seed, channel_size, time_feature))
        vec_env.seed(seed)
        return vec_env
    options: dict[str, Any] = {"channel_size": channel_size}
    if time_feature:  # the batched game's option; on mpe2's own, TwoAgentEnv(time_limit=max_cycles)
        options["time_feature"] = True
    return make_comm_vec_env(ENV_ID, n_envs=n, seed=seed, env_kwargs=options, batched=batched)


def references(channel_size: int, episodes: int, seed: int, batched: bool) -> dict[str, float]:
    """Mean team return of each scripted reference over ``episodes`` games."""
    from sb3_comm.evaluation import evaluate_team
    from sb3_comm.foreign.simple_reference import NoCommTeam, OracleTeam, RandomTeam

    out = {}
    for name, team in (("oracle", OracleTeam), ("no_comm", NoCommTeam), ("random", RandomTeam)):
        env = _vec_env(episodes, seed, channel_size, batched)
        out[name] = evaluate_team(team(env, seed=seed), env).mean
        env.close()
    return out


def run_one(job: dict[str, Any]) -> dict[str, Any]:
    """Train one (method, seed) with the constructor's defaults; curve and final evaluations."""
    import torch as th
    from stable_baselines3.common.callbacks import BaseCallback

    from sb3_comm import CommDDPG
    from sb3_comm.evaluation import evaluate_team

    th.set_num_threads(1)
    method, seed, channel, batched = job["method"], job["seed"], job["channel_size"], job["batched"]
    perfect, timed = job.get("perfect_channel", False), job.get("time_feature", False)
    curve_env = _vec_env(100, CURVE_SEED, channel, batched, perfect, timed)
    curve: list[tuple[int, float]] = []
    eval_seconds = [0.0]

    class Curve(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.next_at = job["eval_freq"]

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next_at:
                began = time.perf_counter()
                curve_env.seed(CURVE_SEED)  # the same 100 games at every point
                curve.append((self.num_timesteps, evaluate_team(self.model, curve_env).mean))
                eval_seconds[0] += time.perf_counter() - began
                self.next_at += job["eval_freq"]
            return True

    env = _vec_env(job["n_envs"], seed, channel, batched, perfect, timed)
    # 'lin_<start>' learning rates (and mc_mixing) become linear schedules, as in a config file
    model = CommDDPG(method, env, seed=seed, device="cpu", **algorithm_kwargs(job.get("params", {})))
    began = time.perf_counter()
    model.learn(job["timesteps"], callback=Curve())
    seconds = time.perf_counter() - began - eval_seconds[0]
    final = {}
    for ablation in ("none", "zero", "shuffle"):
        final_env = _vec_env(100, FINAL_SEED, channel, batched, perfect, timed)
        final[ablation] = evaluate_team(model, final_env, seed=FINAL_SEED, ablation=ablation).mean
        final_env.close()
    result = {
        "method": method,
        "seed": seed,
        "timesteps": job["timesteps"],
        "n_envs": job["n_envs"],
        "channel_size": channel,
        "batched": batched,
        "perfect_channel": perfect,
        "time_feature": timed,
        "params": job.get("params", {}),
        "train_seconds": seconds,
        "curve": curve,
        "final": final,
    }
    write_json(Path(job["runs_dir"]) / f"{method}_seed{seed}.json", result)
    print(f"{method} seed {seed}: final {final['none']:.3f} ({seconds:.0f} s)", flush=True)
    return result


def summarise(runs: list[dict[str, Any]], refs: dict[str, Any], args: argparse.Namespace) -> None:
    """Tables of every seed, the gap fractions with mean/IQM and intervals, and the curve figure."""
    from sb3_comm.analysis.stats import interval_estimates

    final_refs = refs["final_games"]
    gap = final_refs["oracle"] - final_refs["no_comm"]

    def fraction(value: float) -> float:
        return (value - final_refs["no_comm"]) / gap

    methods = [m for m in args.methods if any(r["method"] == m for r in runs)]
    per_method: dict[str, Any] = {}
    rows = [
        "| method | seed | final return | gap closed | zeroed messages | shuffled messages "
        "| train time (s) | periodic evaluations: peak (step), last |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    curve_rows = ["| method | step | mean | worst seed |", "|---|---:|---:|---:|"]
    for method in methods:
        mine = sorted((r for r in runs if r["method"] == method), key=lambda r: r["seed"])
        fractions = [fraction(r["final"]["none"]) for r in mine]
        curves = [[(step, fraction(value)) for step, value in r["curve"]] for r in mine]
        for r, f, curve in zip(mine, fractions, curves, strict=True):
            peak_step, peak = max(curve, key=lambda point: point[1])
            rows.append(
                f"| {method} | {r['seed']} | {r['final']['none']:.3f} | {f:.2f} | {r['final']['zero']:.3f} "
                f"| {r['final']['shuffle']:.3f} | {r['train_seconds']:.0f} "
                f"| {peak:.2f} ({peak_step:,}), {curve[-1][1]:.2f} |"
            )
        if len({tuple(step for step, _ in curve) for curve in curves}) == 1:  # the same steps
            for i, (step, _) in enumerate(curves[0]):
                points = [curve[i][1] for curve in curves]
                curve_rows.append(f"| {method} | {step:,} | {np.mean(points):.2f} | {min(points):.2f} |")
        per_method[method] = {
            "seeds": [r["seed"] for r in mine],
            "gap_closed": fractions,
            "worst_gap_closed": min(fractions),
            "gap_closed_estimates": interval_estimates(fractions),
            "final_return": [r["final"]["none"] for r in mine],
            "zeroed_gap_closed": [fraction(r["final"]["zero"]) for r in mine],
            "shuffled_gap_closed": [fraction(r["final"]["shuffle"]) for r in mine],
        }
    summary = [
        "",
        "| method | seeds | gap closed: mean [95 % CI] | IQM [95 % CI] | worst seed | zeroed (mean) "
        "| shuffled (mean) |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for method, s in per_method.items():
        est = s["gap_closed_estimates"]
        iqm = est.get("iqm")
        iqm_text = f"{iqm['point']:.2f} [{iqm['low']:.2f}, {iqm['high']:.2f}]" if iqm else "— (< 5 seeds)"
        m = est["mean"]
        summary.append(
            f"| {method} | {len(s['seeds'])} | {m['point']:.2f} [{m['low']:.2f}, {m['high']:.2f}] "
            f"| {iqm_text} "
            f"| {s['worst_gap_closed']:.2f} | {np.mean(s['zeroed_gap_closed']):.2f} "
            f"| {np.mean(s['shuffled_gap_closed']):.2f} |"
        )
    figure = _plot(runs, methods, refs, args.name)
    extra = "".join(f", {k}={v!r}" for k, v in args.constructor_params.items())
    game = "sb3-comm's batched game (equal to mpe2's step for step)" if args.batched else "mpe2's own game"
    if args.time_feature:
        game += (
            ", **time-aware** (`time_feature=True`: the agents observe the remaining time and the "
            "25-step limit terminates the episode; the same games, and the references play them unchanged)"
        )
    if args.perfect_channel:
        game += (
            ", with a **perfect channel**: every agent hears its own target's colour in its first three "
            "message entries instead of its teammate's message (a ceiling for the learner, not a method)"
        )
    ref_text = (
        f"\n\nReferences on the 100 final games (seed {FINAL_SEED}): oracle {final_refs['oracle']:.3f}, "
        f"no-comm {final_refs['no_comm']:.3f}, random {final_refs['random']:.3f}; on "
        f"{refs['episodes']} other games (seed {REFERENCE_SEED}): oracle {refs['many_games']['oracle']:.3f}, "
        f"no-comm {refs['many_games']['no_comm']:.3f}, random {refs['many_games']['random']:.3f}. "
        "*Gap closed* = (return − no-comm) / (oracle − no-comm) on the same final games: 0 is no better "
        "than the scripted no-communication policy, 1 is the oracle. Zeroed/shuffled: the same "
        "fraction with every received message set to 0, or taken from another game. Every model is "
        f"`CommDDPG(method, env, seed=seed{extra})` "
        f"with no other argument, {args.n_envs} games, "
        f"{args.timesteps:,} steps, channel size {args.channel_size}; {game}; one torch thread per run, "
        f"{args.workers} run{'s' if args.workers != 1 else ''} at a time. "
        "Goal: a method whose gap closed is ≥ 0.7. "
        f"Learning curves: [{figure.name}]({figure.name}) (mean, 95 % t-interval and the worst seed "
        "per method)."
    )
    ref_text += (
        "\n\nPeriodic evaluations (100 other games, seed "
        f"{CURVE_SEED}, read against the final games' references), as gap closed, the mean of the seeds "
        "and the worst seed at each step:\n\n" + "\n".join(curve_rows)
    )
    if args.note:
        ref_text += f"\n\n{args.note}"
    write_results(
        args.name,
        {"args": vars(args), "references": refs, "methods": per_method, "runs": runs},
        "\n".join(rows + summary) + ref_text,
        title="mpe2 simple_reference (own channel silenced): every method with the constructor's defaults",
    )


def _plot(runs: list[dict[str, Any]], methods: list[str], refs: dict[str, Any], name: str) -> Path:
    from sb3_comm.analysis.plots import plot_learning_curves

    curves = {
        method: [
            (np.asarray(r["curve"])[:, 0], np.asarray(r["curve"])[:, 1])
            for r in runs
            if r["method"] == method and r["curve"]
        ]
        for method in methods
    }
    paths = plot_learning_curves(
        curves,
        RESULTS_DIR / f"{name.replace('.', '_')}_curves",  # no dot: it would read as a suffix
        title="simple_reference, own channel silenced, constructor defaults",
        references={k: refs["many_games"][k] for k in ("oracle", "no_comm", "random")},
        ylabel="team return (100 evaluation games)",
    )
    return paths[0]


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--methods", nargs="+", default=["NONE", "RIAL", "TCG", "GSN"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    parser.add_argument("--timesteps", type=int, default=200_000)
    parser.add_argument("--n-envs", type=int, default=8)
    parser.add_argument("--channel-size", type=int, default=4)
    parser.add_argument("--eval-freq", type=int, default=20_000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--reference-episodes", type=int, default=1000)
    parser.add_argument(
        "--runs-dir", default=None, help="one JSON per finished run (default: results/<name>_runs)"
    )
    parser.add_argument(
        "--batched",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="train and evaluate on sb3-comm's batched numpy game (default), or on mpe2's own",
    )
    parser.add_argument(
        "--perfect-channel",
        action="store_true",
        help="a diagnostic: every agent hears its own target (batched game only); the learner's ceiling",
    )
    parser.add_argument(
        "--time-feature",
        action="store_true",
        help="train and evaluate on the time-aware game (time_feature=True: the agents see the "
        "remaining time, the limit terminates); the references play the same games",
    )
    parser.add_argument("--name", default="simple_reference")
    parser.add_argument("--summary-only", action="store_true", help="summarise the runs present, train none")
    parser.add_argument("--note", default="", help="a paragraph added to the Markdown summary")
    parser.add_argument(
        "--params",
        nargs="*",
        default=[],
        help="constructor arguments key=value (YAML values; learning rates and mc_mixing may be "
        "'lin_<start>', a linear schedule to 0), else defaults",
    )
    args = parser.parse_args()
    import yaml

    params = {}
    for item in args.params:
        key, sep, value = item.partition("=")
        if not sep:
            parser.error(f"--params takes key=value, got {item!r}")
        params[key] = yaml.safe_load(value)
    try:
        algorithm_kwargs(params)  # a malformed 'lin_' schedule stops here, before any run
    except ValueError as error:
        parser.error(f"--params: {error}")
    args.constructor_params = params
    if args.perfect_channel and not args.batched:
        parser.error("--perfect-channel needs the batched game (drop --no-batched)")
    runs_dir = Path(args.runs_dir or RESULTS_DIR / f"{args.name}_runs")
    runs_dir.mkdir(parents=True, exist_ok=True)

    jobs = [
        {
            "method": m,
            "seed": s,
            "timesteps": args.timesteps,
            "n_envs": args.n_envs,
            "channel_size": args.channel_size,
            "batched": args.batched,
            "perfect_channel": args.perfect_channel,
            "eval_freq": args.eval_freq,
            "runs_dir": str(runs_dir),
            "params": params,
            **({"time_feature": True} if args.time_feature else {}),
        }
        for s in args.seeds
        for m in args.methods
        if not (runs_dir / f"{m}_seed{s}.json").exists()
    ]
    if jobs and not args.summary_only:
        from sb3_comm.experiments.runner import start_worker

        # A fresh process per run (max_tasks_per_child=1). multiprocessing.Pool with
        # maxtasksperchild hung at its exit twice, with terminate() and with close() + join().
        with ProcessPoolExecutor(
            min(args.workers, len(jobs)),
            mp_context=mp.get_context("spawn"),
            initializer=start_worker,
            initargs=(args.workers,),
            max_tasks_per_child=1,
        ) as pool:
            for future in as_completed([pool.submit(run_one, job) for job in jobs]):
                future.result()  # a failed run stops the benchmark with its error

    import json

    runs = [json.loads(p.read_text()) for p in sorted(runs_dir.glob("*_seed*.json"))]
    runs = [r for r in runs if r["timesteps"] == args.timesteps]
    runs = [r for r in runs if r.get("batched", False) == args.batched]  # earlier runs: mpe2's own
    runs = [r for r in runs if r.get("perfect_channel", False) == args.perfect_channel]
    runs = [r for r in runs if r.get("time_feature", False) == args.time_feature]
    runs = [r for r in runs if r["method"] in args.methods and r["seed"] in args.seeds]
    backend = "" if not args.batched else "_batched"  # earlier reference files: mpe2's own game
    refs_path = runs_dir / f"references_{args.channel_size}{backend}.json"
    if refs_path.exists():
        refs = json.loads(refs_path.read_text())
    else:
        refs = {
            "final_games": references(args.channel_size, 100, FINAL_SEED, args.batched),
            "many_games": references(
                args.channel_size, args.reference_episodes, REFERENCE_SEED, args.batched
            ),
            "episodes": args.reference_episodes,
        }
        write_json(refs_path, to_jsonable(refs))
    summarise(runs, refs, args)


if __name__ == "__main__":
    main()
