"""Time of one agent update by batch size: whether larger batches (with fewer updates) would be cheaper.

Each method's model trains ``--warmup`` environment steps (a replay buffer to sample from, and
optimizer state), then times ``train(--updates, batch)`` for every batch of ``--batches`` in turn,
``--rounds`` times with the order reversed every other round, so that a slow phase of this shared
VM hits every batch alike. ``train`` is the agents' critic and actor updates on replayed batches
(no environment steps, no GSN update). If an update's time grows in proportion to its batch, the
arithmetic dominates, and fewer, larger updates save nothing: only fewer samples per environment
step do.

    python benchmarks/batch_cost.py --methods NONE TCG --batches 128 256 512 --threads 1
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import torch as th

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import warmed_up_model, write_results

from sb3_comm import METHODS
from sb3_comm.common.networks import PRECISIONS


def time_batches(method: str, args: argparse.Namespace) -> dict[int, list[float]]:
    """Milliseconds per agent update of ``method`` for every batch size, one value per round."""
    model = warmed_up_model(
        method, args.env, args.n_envs, min(args.batches), args.net_arch, args.warmup, args.precision
    )
    times: dict[int, list[float]] = {batch: [] for batch in args.batches}
    for k in range(args.rounds):
        for batch in args.batches if k % 2 == 0 else args.batches[::-1]:
            began = time.perf_counter()
            model.train(args.updates, batch)
            times[batch].append(1000.0 * (time.perf_counter() - began) / args.updates)
    model.env.close()
    return times


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--env", default="BlindSoccer-v0")
    parser.add_argument("--methods", nargs="+", default=["NONE", "TCG"], choices=list(METHODS))
    parser.add_argument("--batches", type=int, nargs="+", default=[128, 256, 512])
    parser.add_argument("--precision", default="float32", choices=list(PRECISIONS))
    parser.add_argument("--n-envs", type=int, default=16)
    parser.add_argument("--net-arch", type=int, nargs="+", default=[256, 256])
    parser.add_argument("--warmup", type=int, default=3000, help="env steps trained before timing")
    parser.add_argument("--updates", type=int, default=100, help="agent updates per timing")
    parser.add_argument("--rounds", type=int, default=6, help="timings per batch size (alternated)")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--name", default=None, help="result file stem")
    args = parser.parse_args()
    if any(batch < 1 for batch in args.batches):
        parser.error(f"--batches must be positive, got {args.batches}")
    th.set_num_threads(args.threads)
    smallest = min(args.batches)
    results = {}
    rows = [
        "| method | batch | ms per update (median of rounds) | range | × the smallest batch's time | "
        "× its batch |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for method in args.methods:
        times = time_batches(method, args)
        medians = {batch: statistics.median(values) for batch, values in times.items()}
        results[method] = {"ms_per_update": medians, "rounds": times}
        for batch in args.batches:
            rows.append(
                f"| {method} | {batch} | {medians[batch]:.2f} | {min(times[batch]):.2f} to "
                f"{max(times[batch]):.2f} | {medians[batch] / medians[smallest]:.2f} "
                f"| {batch / smallest:.2f} |"
            )
        print("\n".join(rows[-len(args.batches) :]), flush=True)
    notes = (
        f"\n\nEnv `{args.env}`, {args.n_envs} games, hidden layers {args.net_arch}, {args.precision}, "
        f"torch threads {args.threads}. Each method trains {args.warmup:,} env steps, then "
        f"`train({args.updates}, batch)` {args.rounds} times per batch size, the order reversed every "
        "other round. An update is both agents' critic and actor steps on one replayed batch (no "
        "environment step, no GSN update)."
    )
    write_results(
        args.name or f"batch_cost_{args.env.split('-')[0].lower()}_{args.precision}",
        {"args": vars(args), "methods": results},
        "\n".join(rows) + notes,
        title="Time of one agent update by batch size",
    )


if __name__ == "__main__":
    main()
