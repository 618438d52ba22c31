"""Simulator throughput: agent-steps per second of the batched tasks and the PettingZoo shell.

For Blind Soccer and Guess My Number, with 1, 64 and 1,024 parallel games: random actions
(pre-drawn, cycled, so that drawing them is not timed), features computed, autoreset on. Each
configuration runs for ``--duration`` seconds, ``--repeats`` times; the best run is reported.
On a shared machine the batched configurations are also timed step by step, and the 5th
percentile of single-step times (the steps that ran least disturbed) is reported as well.
The single-game ``ParallelEnv`` path (dict in, dict out, reset when the episode ends) is measured
the same way. A per-function breakdown of one step at the largest batch size says where the time
goes. An agent-step is one agent acting once: a step of N two-agent games is 2N agent-steps.

Run from the repository root::

    python -m benchmarks.sim_throughput            # full run, writes benchmarks/results/
    python -m benchmarks.sim_throughput --quick    # a smoke run (not written)
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))

from benchmarks._common import write_results
from envs.registry import TASKS as REGISTRY
from envs.soccer import features, physics, referee
from envs.soccer.reset import reset_state
from envs.tasks.batched import BatchedTask
from envs.tasks.hfo_actions import decode_actions

TASKS = {spec.key: spec for spec in REGISTRY.values()}
"""Task key -> its registry record (``batched_env``, ``parallel_env``)."""
TARGET = 1_000_000
POOL = 32  # pre-drawn action batches


def _action_pool(task: BatchedTask, rng: np.random.Generator) -> np.ndarray:
    shape = (POOL, task.n_games, task.n_players, task.action_size)
    return rng.uniform(task.action_low, task.action_high, size=shape).astype(np.float32)


def _timed(run_steps: Callable[[int], None], duration: float, repeats: int) -> tuple[float, list[float]]:
    """Best steps-per-second over ``repeats`` runs of at least ``duration`` seconds each."""
    run_steps(20)  # warm-up
    # calibrate a chunk of about 0.1 s so that the clock is read rarely
    start = time.perf_counter()
    run_steps(20)
    chunk = max(1, int(20 * 0.1 / max(time.perf_counter() - start, 1e-9)))
    rates = []
    for _ in range(repeats):
        steps = 0
        start = time.perf_counter()
        while True:
            run_steps(chunk)
            steps += chunk
            elapsed = time.perf_counter() - start
            if elapsed >= duration:
                break
        rates.append(steps / elapsed)
    return max(rates), rates


def bench_batched(module: Any, n_games: int, duration: float, repeats: int) -> dict[str, Any]:
    task = module.batched_env(n_games=n_games, seed=0)
    pool = _action_pool(task, np.random.default_rng(0))
    counter = [0]

    def run(steps: int) -> None:
        for _ in range(steps):
            task.step(pool[counter[0] % POOL])
            counter[0] += 1

    best, rates = _timed(run, duration, repeats)
    agents = task.n_players * n_games
    singles = []
    deadline = time.perf_counter() + duration
    while time.perf_counter() < deadline or len(singles) < 50:
        start = time.perf_counter()
        run(1)
        singles.append(time.perf_counter() - start)
    p5 = float(np.percentile(singles, 5))
    return {
        "n_games": n_games,
        "steps_per_s": best,
        "agent_steps_per_s": best * agents,
        "runs_agent_steps_per_s": [r * agents for r in rates],
        "ms_per_step": 1e3 / best,
        "ms_per_step_p5": 1e3 * p5,
        "agent_steps_per_s_p5": agents / p5,
    }


def bench_parallel(module: Any, duration: float, repeats: int) -> dict[str, Any]:
    env = module.parallel_env(seed=0)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    pool = [
        {
            agent: rng.uniform(env.task.action_low, env.task.action_high).astype(np.float32)
            for agent in env.possible_agents
        }
        for _ in range(POOL)
    ]
    counter = [0]

    def run(steps: int) -> None:
        for _ in range(steps):
            env.step(pool[counter[0] % POOL])
            counter[0] += 1
            if not env.agents:
                env.reset()

    best, rates = _timed(run, duration, repeats)
    n = len(env.possible_agents)
    return {
        "n_games": 1,
        "steps_per_s": best,
        "agent_steps_per_s": best * n,
        "runs_agent_steps_per_s": [r * n for r in rates],
        "ms_per_step": 1e3 / best,
    }


def _per_call_us(fn: Callable[[], Any], min_time: float = 0.5) -> float:
    fn()
    calls, start = 0, time.perf_counter()
    while time.perf_counter() - start < min_time:
        fn()
        calls += 1
    return 1e6 * (time.perf_counter() - start) / calls


def breakdown(module: Any, n_games: int) -> dict[str, float]:
    """Microseconds per call of each function one task step calls, at ``n_games`` games."""
    task = module.batched_env(n_games=n_games, seed=0)
    rng = np.random.default_rng(0)
    pool = _action_pool(task, rng)
    for i in range(30):  # a mid-episode state
        task.step(pool[i % POOL])
    state, params = task.state, task.params
    actions = pool[0]
    commands = decode_actions(actions, state, params, task.can_dash)
    after = physics.step(state, commands, params, np.random.default_rng(1))
    # games that end per step on average: n_games / mean episode length (at most max_steps)
    n_reset = max(1, n_games // 50)
    counter = [0]

    def full_step() -> None:
        task.step(pool[counter[0] % POOL])
        counter[0] += 1

    parts = {
        "decode_actions": _per_call_us(lambda: decode_actions(actions, state, params, task.can_dash)),
        "physics.step": _per_call_us(lambda: physics.step(state, commands, params, np.random.default_rng(1))),
        "features.low_level_features": _per_call_us(lambda: features.low_level_features(after, params)),
        "referee.judge": _per_call_us(
            lambda: referee.judge(after, params, task.max_steps, task.untouched_cycles, state)
        ),
        "physics.kickable": _per_call_us(lambda: physics.kickable(after, params)),
        "physics.resolve_collisions": _per_call_us(
            lambda: physics.resolve_collisions(
                after.ball_pos.copy(), after.ball_vel.copy(), after.pos.copy(), after.vel.copy(), params
            )
        ),
        f"reset.reset_state ({n_reset} games)": _per_call_us(
            lambda: reset_state(rng, n_reset, task.n_players, params, task.ball_x_range)
        ),
        "task.step (total)": _per_call_us(full_step, min_time=1.0),
    }
    return parts


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--duration", type=float, default=3.0, help="seconds per run")
    parser.add_argument("--repeats", type=int, default=3, help="runs per configuration (best kept)")
    parser.add_argument(
        "--sizes", type=int, nargs="+", default=[1, 64, 1024], help="numbers of parallel games"
    )
    parser.add_argument("--quick", action="store_true", help="0.3 s x 1 run, nothing written")
    parser.add_argument("--name", default="sim_throughput", help="result file stem")
    args = parser.parse_args(argv)
    if args.quick:
        args.duration, args.repeats = 0.3, 1

    results: dict[str, Any] = {
        "target_agent_steps_per_s": TARGET,
        "duration_s": args.duration,
        "repeats": args.repeats,
    }
    rows = []
    for name, module in TASKS.items():
        task_results: dict[str, Any] = {"batched": [], "parallel_env": None, "breakdown_us": None}
        for n in args.sizes:
            r = bench_batched(module, n, args.duration, args.repeats)
            task_results["batched"].append(r)
            rows.append((name, f"batched, {n} games", r))
            print(
                f"{name:16s} batched {n:5d} games: {r['agent_steps_per_s']:12,.0f} agent-steps/s", flush=True
            )
        r = bench_parallel(module, args.duration, args.repeats)
        task_results["parallel_env"] = r
        rows.append((name, "ParallelEnv, 1 game", r))
        print(f"{name:16s} ParallelEnv 1 game : {r['agent_steps_per_s']:12,.0f} agent-steps/s", flush=True)
        task_results["breakdown_us"] = breakdown(module, max(args.sizes))
        results[name] = task_results

    lines = [
        "Agent-steps per second (best of "
        f"{args.repeats} runs of {args.duration:g} s; random actions, features computed, autoreset on; "
        f"target {TARGET:,} at 1,024 games).",
        "",
        "| task | configuration | agent-steps/s | steps/s | ms per step | agent-steps/s, 5th pct step |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for name, config, r in rows:
        rates = f"{r['agent_steps_per_s']:,.0f} | {r['steps_per_s']:,.1f} | {r['ms_per_step']:.3f}"
        p5 = f"{r['agent_steps_per_s_p5']:,.0f}" if "agent_steps_per_s_p5" in r else "—"
        lines.append(f"| {name} | {config} | {rates} | {p5} |")
    n_max = max(args.sizes)
    lines += ["", f"Time per call at {n_max:,} games (microseconds):", ""]
    names = list(results[next(iter(TASKS))]["breakdown_us"])
    lines.append("| function | " + " | ".join(TASKS) + " |")
    lines.append("|---|" + "---:|" * len(TASKS))
    for fn in names:
        lines.append(
            f"| {fn} | " + " | ".join(f"{results[t]['breakdown_us'][fn]:,.0f}" for t in TASKS) + " |"
        )
    table = "\n".join(lines)
    print(table)
    if not args.quick:
        paths = write_results(args.name, results, table, title="Simulator throughput")
        print("wrote", *paths)


if __name__ == "__main__":
    main()
