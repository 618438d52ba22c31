"""Where GSN's updates should run on this machine: env steps per second of a GSN Blind Soccer run
with its updates in the worker process (one torch thread), after the agents' in the trainer (one
torch thread), and in the trainer with torch's threads on every core (no core spare, no worker).

Every placement trains the same model (the worker changes the time only); each is warmed up,
then timed in ``--repeats`` rounds, every placement in turn per round.

    python benchmarks/gsn_placement.py --steps 4000 --repeats 3
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import torch as th

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

from sb3_comm import CommDDPG, make_comm_vec_env
from sb3_comm.comm_ddpg import gsn

PLACEMENTS = {
    "worker process, 1 torch thread": (1, True),
    "in the trainer, 1 torch thread": (1, False),
    "in the trainer, torch threads on every core": (None, False),
}


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--env", default="BlindSoccer-v0")
    parser.add_argument("--n-envs", type=int, default=16)
    parser.add_argument("--steps", type=int, default=4000)
    parser.add_argument("--warmup", type=int, default=800)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--name", default="gsn_placement_blindsoccer")
    args = parser.parse_args()
    cores = len(os.sched_getaffinity(0))
    models = {}
    for label, (threads, _) in PLACEMENTS.items():
        th.set_num_threads(threads or cores)
        env = make_comm_vec_env(args.env, n_envs=args.n_envs, seed=0)
        model = CommDDPG(
            "GSN", env, policy_kwargs={"net_arch": [256, 256]}, batch_size=64, learning_starts=64,
            seed=0, device="cpu",
        )  # fmt: skip
        model.learn(args.warmup)
        models[label] = model
    rates: dict[str, list[float]] = {label: [] for label in PLACEMENTS}
    used_worker: dict[str, bool] = {}
    for k in range(args.repeats):
        for label, (threads, beside) in PLACEMENTS.items():
            th.set_num_threads(threads or cores)
            gsn.BESIDE_AGENTS = beside  # the switch the experiment runner uses
            model = models[label]
            began = time.perf_counter()
            model.learn(args.steps, reset_num_timesteps=False)
            rates[label].append(args.steps / (time.perf_counter() - began))
            used_worker[label] = model.gsn_callback.uses_worker()
        print(f"round {k + 1}: " + "  ".join(f"{n}: {r[-1]:.0f}" for n, r in rates.items()), flush=True)
    medians = {label: statistics.median(r) for label, r in rates.items()}
    rows = ["| GSN's updates | worker used | env steps/s, median | best |", "|---|---|---:|---:|"]
    rows += [
        f"| {label} | {'yes' if used_worker[label] else 'no'} | {medians[label]:.0f} "
        f"| {max(rates[label]):.0f} |"
        for label in PLACEMENTS
    ]
    notes = (
        f"\n\nGSN on `{args.env}`, {args.n_envs} games, [256, 256] layers, batch 64, one gradient step per "
        f"VecEnv step; {args.repeats} rounds of {args.steps} env steps after {args.warmup} warm-up steps, "
        f"every placement in turn per round; {cores} cores."
    )
    write_results(
        args.name,
        {"args": vars(args), "cores": cores, "rates": rates, "median": medians, "worker_used": used_worker},
        "\n".join(rows) + notes,
        title="Where GSN's updates run: worker process or trainer",
    )


if __name__ == "__main__":
    main()
