"""Time of one agent update per method, with the fused Adam kernel called directly and through
``Optimizer.step``, alternated in one process; with ``--learn``, the training speed (environment
steps per second of ``learn``) of the current optimizer steps against the previous ones.

A whole-training comparison between two versions of the code runs them in different processes,
minutes apart, and on this shared VM the speed drifts by more than the difference sought (round
ratios against TD3 of one model spread over 0.8-1.5 within one run). Here one model per method
times ``train(--updates)`` (the agents' critic and actor updates on replayed batches, no
environment steps, no GSN update) with :func:`sb3_comm.common.networks.adam_step` as it is and with
it replaced by ``optimizer.step()``, the order of the two swapped every round, so that a slow phase
hits both alike. The two make the same parameters to the bit (``tests/test_fast_update.py``).

    python benchmarks/update_time.py --rounds 20 --updates 100 --threads 1

With ``--learn``, each method's model instead trains ``learn(--steps)`` per timing, alternately
with the optimizer steps as they are (``adam_step``; gradients cleared by setting them to None;
replay samples that share their gathered arrays) and as they were before (``optimizer.zero_grad()``,
``optimizer.step()``, samples copied once more): environment steps, the GSN's updates (in its
worker where a core is spare) and logging included.

    python benchmarks/update_time.py --learn --rounds 12 --steps 1600 --threads 1
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import torch as th
from stable_baselines3.common.buffers import BaseBuffer

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import alternated_learning_rates, warmed_up_model, write_results

from sb3_comm import METHODS, CommDDPG
from sb3_comm.common import networks

VARIANTS = {
    "adam_step": networks.adam_step,
    "Optimizer.step": lambda optimizer: optimizer.step(),
}


def _warmed_up(method: str, args: argparse.Namespace) -> CommDDPG:
    """A model of ``method`` trained ``args.warmup`` env steps (:func:`_common.warmed_up_model`)."""
    return warmed_up_model(method, args.env, args.n_envs, args.batch_size, args.net_arch, args.warmup)


def time_method(method: str, args: argparse.Namespace) -> dict[str, list[float]]:
    """Milliseconds per agent update of each variant, one value per round."""
    model = _warmed_up(method, args)
    times: dict[str, list[float]] = {name: [] for name in VARIANTS}
    order = list(VARIANTS)
    try:
        for k in range(args.rounds):
            for name in order if k % 2 == 0 else order[::-1]:
                networks.adam_step = VARIANTS[name]
                began = time.perf_counter()
                model.train(args.updates, args.batch_size)
                times[name].append(1000.0 * (time.perf_counter() - began) / args.updates)
    finally:
        networks.adam_step = VARIANTS["adam_step"]
    return times


def _previous_gradient_step(
    optimizer: th.optim.Optimizer, loss: th.Tensor, max_grad_norm: float | None
) -> None:
    """:func:`sb3_comm.common.networks.gradient_step` as it was before ``adam_step``."""
    optimizer.zero_grad()
    loss.backward()
    if max_grad_norm:
        networks.clip_gradients(
            [p for group in optimizer.param_groups for p in group["params"]], max_grad_norm
        )
    optimizer.step()


def _copying_to_torch(self: BaseBuffer, array: object, copy: bool = True) -> th.Tensor:
    """SB3's ``to_torch``, copying whatever ``copy`` says (the samples before they shared their gathers)."""
    return BaseBuffer.to_torch(self, array, copy=True)  # type: ignore[arg-type]


def _use_previous_steps(previous: bool) -> None:
    """Switch the learners' optimizer steps (and the replay's tensor copies) to the previous code, or back."""
    from sb3_comm.comm_ddpg import gsn
    from sb3_comm.common.buffers import MonteCarloReplayBuffer
    from sb3_comm.hybrid_ddpg import hybrid_ddpg

    if previous:
        hybrid_ddpg.gradient_step = gsn.gradient_step = _previous_gradient_step
        gsn.adam_step = VARIANTS["Optimizer.step"]
        MonteCarloReplayBuffer.to_torch = _copying_to_torch  # type: ignore[method-assign]
    else:
        hybrid_ddpg.gradient_step = gsn.gradient_step = networks.gradient_step
        gsn.adam_step = networks.adam_step
        if "to_torch" in MonteCarloReplayBuffer.__dict__:
            del MonteCarloReplayBuffer.to_torch


@contextlib.contextmanager
def _steps_of(previous: bool) -> Iterator[None]:
    """The learners train with the previous optimizer steps (or the current ones), then the current."""
    _use_previous_steps(previous)
    try:
        yield
    finally:
        _use_previous_steps(False)


def time_learning(method: str, args: argparse.Namespace) -> dict[str, list[float]]:
    """Environment steps per second of ``learn(args.steps)``, current and previous steps, per round."""
    model = _warmed_up(method, args)
    variants = {"current": lambda: _steps_of(False), "previous": lambda: _steps_of(True)}
    return alternated_learning_rates(model, variants, args.rounds, args.steps, args.log_interval)


def learning_main(args: argparse.Namespace) -> None:
    """``--learn``: the training speed of the current optimizer steps against the previous ones."""
    results = {}
    for method in args.methods:
        rates = time_learning(method, args)
        ratios = [c / p for c, p in zip(rates["current"], rates["previous"], strict=True)]
        results[method] = {
            "env_steps_per_second": {name: statistics.median(values) for name, values in rates.items()},
            "rounds": rates,
            "speedup": statistics.median(ratios),
            "speedup_range": [min(ratios), max(ratios)],
        }
        r = results[method]
        print(
            f"{method:8s} current {r['env_steps_per_second']['current']:.0f}  previous "
            f"{r['env_steps_per_second']['previous']:.0f} env steps/s  speed-up {r['speedup']:.3f}",
            flush=True,
        )
    rows = [
        "| method | env steps/s, current | env steps/s, previous | speed-up (median of rounds) | range |",
        "|---|---:|---:|---:|---:|",
    ]
    for method, r in results.items():
        rates, (low, high) = r["env_steps_per_second"], r["speedup_range"]
        rows.append(
            f"| {method} | {rates['current']:.0f} | {rates['previous']:.0f} | {r['speedup']:.3f} "
            f"| {low:.2f} to {high:.2f} |"
        )
    notes = (
        f"\n\nEnv `{args.env}`, {args.n_envs} games, one update per VecEnv step, batch {args.batch_size}, "
        f"hidden layers {args.net_arch}, torch threads {args.threads}. Each method trains "
        f"{args.warmup:,} env steps, then `learn({args.steps})` {args.rounds} times per variant, "
        "alternated (the order swapped every round), logged points every "
        f"{args.log_interval:,} env steps. *Current*: `adam_step`, gradients cleared by setting them to "
        "None, replay samples sharing their gathered arrays; *previous*: `optimizer.zero_grad()`, "
        "`optimizer.step()`, samples copied once more. Both train the same parameters, to the bit. "
        "Speed-up: current rate / previous rate, the median over the rounds' pairs."
    )
    write_results(
        args.name or f"learn_speed_{args.env.split('-')[0].lower()}",
        {"args": vars(args), "methods": results},
        "\n".join(rows) + notes,
        title="Training speed: the current optimizer steps against the previous ones",
    )


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
    parser.add_argument("--updates", type=int, default=100, help="agent updates per timing")
    parser.add_argument("--rounds", type=int, default=20, help="timings per variant (alternated)")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--name", default=None, help="result file stem")
    parser.add_argument("--learn", action="store_true", help="time learn(), current vs previous steps")
    parser.add_argument("--steps", type=int, default=1600, help="with --learn: env steps per timing")
    parser.add_argument("--log-interval", type=int, default=4000, help="with --learn: env steps per point")
    args = parser.parse_args()
    th.set_num_threads(args.threads)
    if args.learn:
        learning_main(args)
        return

    results = {}
    for method in args.methods:
        times = time_method(method, args)
        ratios = [slow / fast for fast, slow in zip(times["adam_step"], times["Optimizer.step"], strict=True)]
        results[method] = {
            "ms_per_update": {name: statistics.median(values) for name, values in times.items()},
            "rounds_ms": times,
            "saving": 1.0 - 1.0 / statistics.median(ratios),
            "saving_range": [1.0 - 1.0 / min(ratios), 1.0 - 1.0 / max(ratios)],
        }
        print(
            f"{method:8s} adam_step {results[method]['ms_per_update']['adam_step']:.2f} ms  "
            f"Optimizer.step {results[method]['ms_per_update']['Optimizer.step']:.2f} ms  "
            f"saving {results[method]['saving']:.1%}",
            flush=True,
        )
    rows = [
        "| method | ms per agent update, `adam_step` | ms, `Optimizer.step` | time saved (median of rounds) "
        "| range over rounds |",
        "|---|---:|---:|---:|---:|",
    ]
    for method, r in results.items():
        low, high = r["saving_range"]
        ms = r["ms_per_update"]
        rows.append(
            f"| {method} | {ms['adam_step']:.2f} | {ms['Optimizer.step']:.2f} "
            f"| {r['saving']:.1%} | {low:.1%} to {high:.1%} |"
        )
    notes = (
        f"\n\nEnv `{args.env}`, {args.n_envs} games, batch {args.batch_size}, hidden layers {args.net_arch}, "
        f"torch threads {args.threads}. Each method trains {args.warmup:,} env steps, then times "
        f"`train({args.updates})` (the agents' updates only: no environment step, no GSN update) "
        f"{args.rounds} times per variant, the two variants alternated (their order swapped every round). "
        "Time saved: 1 − (time with `adam_step`) / (time with `Optimizer.step`), the median over the "
        "rounds' pairs. Both variants make the same parameters, to the bit."
    )
    write_results(
        args.name or f"update_time_{args.env.split('-')[0].lower()}",
        {"args": vars(args), "methods": results},
        "\n".join(rows) + notes,
        title="Agent update time: the fused Adam kernel called directly vs through Optimizer.step",
    )


if __name__ == "__main__":
    main()
