"""What the actor's average costs in training speed: ``learn`` with and without it, alternated in
one process.

A new ``CommDDPG(method, env)`` plays a Polyak average of its actor (``policy_kwargs``
``averaged_actor=True, actor_average_tau="auto"``, since session 31): one ``torch._foreach_lerp_``
of the actor's parameters after every actor update, and nothing else. Here one model per method
(the constructor's defaults, the benchmark's layers and batch) trains ``learn(--steps)`` per timing,
alternately with its average kept and with the average removed (the policy's ``actor_average`` set
aside), the order swapped every round, so that a slow phase of the machine hits both alike. The
training is the same either way (``tests/test_averaged_actor.py``); only the lerp differs.

    python benchmarks/average_cost.py --rounds 12 --steps 1600 --threads 1
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
from collections.abc import Iterator
from pathlib import Path

import torch as th

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import alternated_learning_rates, write_results

from sb3_comm import METHODS, CommDDPG, make_comm_vec_env


@contextlib.contextmanager
def _without_average(model: CommDDPG) -> Iterator[None]:
    """The model trains without its average (no lerp), as a team that plays its actor does."""
    policy = model.policy
    kept = policy.actor_average, policy.actor_average_tau
    policy.actor_average, policy.actor_average_tau = None, None
    try:
        yield
    finally:
        policy.actor_average, policy.actor_average_tau = kept


def time_learning(method: str, args: argparse.Namespace) -> dict[str, list[float]]:
    """Environment steps per second of ``learn(args.steps)`` with and without the average, per round."""
    env = make_comm_vec_env(args.env, n_envs=args.n_envs, seed=0)
    model = CommDDPG(
        method, env, batch_size=args.batch_size, learning_starts=1000, seed=0, device="cpu",
        policy_kwargs={"net_arch": args.net_arch},
    )  # fmt: skip
    assert model.policy.actor_average is not None, "the constructor's default keeps the average"
    model.learn(args.warmup, log_interval=args.log_interval)
    variants = {"average": contextlib.nullcontext, "no average": lambda: _without_average(model)}
    return alternated_learning_rates(model, variants, args.rounds, args.steps, args.log_interval)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--env", default="BlindSoccer-v0")
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=list(METHODS))
    parser.add_argument("--n-envs", type=int, default=16)
    parser.add_argument("--net-arch", type=int, nargs="+", default=[256, 256])
    parser.add_argument("--batch-size", type=int, default=64)
    parser.add_argument("--warmup", type=int, default=3000, help="env steps trained before timing")
    parser.add_argument("--steps", type=int, default=1600, help="env steps per timing")
    parser.add_argument("--rounds", type=int, default=12, help="timings per variant (alternated)")
    parser.add_argument("--log-interval", type=int, default=4000, help="env steps per logged point")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--name", default=None, help="result file stem")
    args = parser.parse_args()
    th.set_num_threads(args.threads)

    results = {}
    for method in args.methods:
        rates = time_learning(method, args)
        ratios = [
            without / with_ for with_, without in zip(rates["average"], rates["no average"], strict=True)
        ]
        results[method] = {
            "env_steps_per_second": {name: statistics.median(values) for name, values in rates.items()},
            "rounds": rates,
            "slowdown": statistics.median(ratios),
            "slowdown_range": [min(ratios), max(ratios)],
        }
        r = results[method]
        print(
            f"{method:8s} average {r['env_steps_per_second']['average']:.0f}  no average "
            f"{r['env_steps_per_second']['no average']:.0f} env steps/s  time × {r['slowdown']:.3f}",
            flush=True,
        )
    rows = [
        "| method | env steps/s, with the average | env steps/s, without "
        "| time per step × (median of rounds) "
        "| range |",
        "|---|---:|---:|---:|---:|",
    ]
    for method, r in results.items():
        rates, (low, high) = r["env_steps_per_second"], r["slowdown_range"]
        rows.append(
            f"| {method} | {rates['average']:.0f} | {rates['no average']:.0f} | {r['slowdown']:.3f} "
            f"| {low:.2f} to {high:.2f} |"
        )
    notes = (
        f"\n\nEnv `{args.env}`, {args.n_envs} games, one update per VecEnv step, batch {args.batch_size}, "
        f"hidden layers {args.net_arch}, torch threads {args.threads}. Each method trains "
        f"{args.warmup:,} env steps with the constructor's defaults, then `learn({args.steps})` "
        f"{args.rounds} times per variant, alternated (the order swapped every round), logged points "
        f"every {args.log_interval:,} env steps. *With the average*: the default, one `_foreach_lerp_` "
        "of the actor's parameters after every actor update; *without*: the same model with its "
        "average set aside. Time per step ×: the rate without / the rate with, the median over the "
        "rounds' pairs (above 1: the average costs time)."
    )
    write_results(
        args.name or f"average_cost_{args.env.split('-')[0].lower()}",
        {"args": vars(args), "methods": results},
        "\n".join(rows) + notes,
        title="Training speed: the actor's average (the default) against none",
    )


if __name__ == "__main__":
    main()
