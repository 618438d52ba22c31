"""Memory: the replay buffer at its configured size and at 1M transitions, and the peak resident
memory of a training run.

The buffer's arrays are allocated up front (numpy zeros: pages are only backed once written), so
their size is counted from the arrays themselves; a run's peak resident set size comes from the
kernel (``ru_maxrss``) after ``--steps`` of training with the packaged configuration.

    python benchmarks/memory.py --env BlindSoccer-v0 --method GSN --steps 50000

``--precision bfloat16`` trains with the networks' hidden layers in bfloat16 (added to the packaged
``policy_kwargs``).
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_threads_option, apply_threads_option, write_results

from sb3_comm.common.networks import PRECISIONS
from sb3_comm.config import RunConfig
from sb3_comm.training import build_model


def buffer_bytes(model) -> tuple[int, int]:
    """(bytes of the replay buffer's arrays, transitions it holds)."""
    buffer = model.replay_buffer
    arrays = [value for value in vars(buffer).values() if isinstance(value, np.ndarray)]
    return sum(a.nbytes for a in arrays), buffer.buffer_size * buffer.n_envs


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--env", default="BlindSoccer-v0")
    parser.add_argument("--method", default="GSN")
    parser.add_argument("--steps", type=int, default=50_000, help="training steps for the peak RSS")
    parser.add_argument("--name", default=None)
    parser.add_argument(
        "--precision", choices=list(PRECISIONS), default="float32", help="the hidden layers' arithmetic"
    )
    add_threads_option(parser)
    args = parser.parse_args()
    apply_threads_option(args)

    config = RunConfig.load(args.method, args.env).with_precision(args.precision)  # pins kept
    model = build_model(config)
    configured, configured_n = buffer_bytes(model)
    million = build_model(config.with_overrides({"buffer_size": 1_000_000}))
    big, big_n = buffer_bytes(million)
    del million
    began = time.perf_counter()
    model.learn(args.steps, log_interval=0)
    seconds = time.perf_counter() - began
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB
    # the GSN's worker process (joined at the end of learn), if it ran: its own peak
    worker_peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
    results = {
        "buffer_configured": {"transitions": configured_n, "bytes": configured},
        "buffer_1m": {"transitions": big_n, "bytes": big, "bytes_per_transition": big / big_n},
        "training_steps": args.steps,
        "training_seconds": seconds,
        "peak_rss_bytes": peak,
        "worker_peak_rss_bytes": worker_peak,
    }
    gib = 2**30
    rows = [
        "| what | size |",
        "|---|---:|",
        f"| replay buffer, configured ({configured_n:,} transitions) | {configured / gib:.2f} GiB |",
        f"| replay buffer, {big_n:,} transitions | {big / gib:.2f} GiB ({big / big_n:,.0f} bytes each) |",
        f"| peak resident memory of the process after {args.steps:,} training steps | {peak / gib:.2f} GiB |",
        f"| peak resident memory of the GSN's worker process (0: none ran) | {worker_peak / gib:.2f} GiB |",
    ]
    notes = (
        f"\n\n{args.method} on `{args.env}`, packaged configuration ({config.n_envs} games), hidden "
        f"layers in {args.precision}. A transition "
        "holds both agents' observation and next observation, actions, rewards and Monte-Carlo returns "
        "(float32). The buffer's pages are backed as they fill, so the peak RSS of a short run counts "
        "only the part written so far; a full buffer adds its size. The worker's resident set counts "
        "the pages it shares with the trainer (the torch libraries, the networks); it lets go of its "
        f"inherited replay buffer at its start. Torch threads: {args.threads}."
    )
    write_results(
        args.name or f"memory_{args.env.split('-')[0].lower()}_{args.method.lower()}",
        {"args": vars(args), **results},
        "\n".join(rows) + notes,
        title="Memory of a training run",
    )
    print("\n".join(rows))


if __name__ == "__main__":
    main()
