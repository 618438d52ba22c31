"""Training throughput: environment steps per second of CommDDPG per method against plain SB3 TD3.

Every model gets the same environment (a batched VecEnv of ``--n-envs`` games), the same hidden
layers, batch size and update ratio (one gradient step per VecEnv step). TD3 is configured as
DDPG (one critic, no policy delay, no target smoothing) so that it does the same number of
network passes as CommDDPG's NONE; it sees the two agents as one flat agent. The ratio
``TD3 steps/s ÷ method steps/s`` is the overhead of the method, measured in the same run. Every
model writes its logged training points as often as in a real run (CommDDPG: the default interval
of the packaged configuration's budget; TD3: SB3's default).

    python benchmarks/train_throughput.py --env BlindSoccer-v0 --n-envs 8 --steps 3000

With ``--precisions float32 bfloat16`` every method is also timed with its networks' hidden layers
in bfloat16 (``policy_kwargs={"precision": "bfloat16"}``), in the same rounds; TD3 stays SB3's
float32.

With ``--logging`` it measures instead what TensorBoard logging costs: every method trains with
its event files written at the default interval of its packaged configuration (about 200 points
over ``n_timesteps``: losses, Q statistics, timings, message histograms), and with no training
points at all; on and off alternate, best of ``--repeats`` each.

    python benchmarks/train_throughput.py --env BlindSoccer-v0 --logging --steps 6000 --repeats 5
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import torch as th
from stable_baselines3 import TD3

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

from sb3_comm import METHODS, CommDDPG, make_comm_vec_env
from sb3_comm.common.networks import PRECISIONS


class _Stopwatch:
    """Wraps a bound method and adds up the seconds spent in it."""

    def __init__(self, owner: object, name: str) -> None:
        self.seconds = 0.0
        self.calls = 0
        inner = getattr(owner, name)

        def timed(*args, **kwargs):
            began = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - began
                self.calls += 1

        setattr(owner, name, timed)


def logging_overhead(args: argparse.Namespace, common: dict) -> None:
    """What TensorBoard logging costs: the share of training time spent writing points and
    gathering the values they average, at the packaged default interval, plus an on/off timing."""
    from sb3_comm.config import RunConfig
    from sb3_comm.hybrid_ddpg.hybrid_ddpg import default_log_interval
    from sb3_comm.tensorboard import event_logger

    results: dict[str, dict[str, float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for method in METHODS:
            config = RunConfig.load(method, args.env)
            interval = default_log_interval(config.n_timesteps, config.n_envs)
            if args.log_interval is not None:
                interval = args.log_interval
            rates: dict[bool, list[float]] = {True: [], False: []}
            shares = []
            for k in range(args.repeats):
                for logged in (True, False):
                    env = make_comm_vec_env(args.env, n_envs=args.n_envs, seed=0)
                    model = CommDDPG(method, env, policy_kwargs={"net_arch": args.net_arch}, **common)
                    model.set_logger(event_logger(Path(tmp) / f"{method}_{k}_{logged}"))
                    model.learn(args.warmup, log_interval=interval if logged else 0)
                    points = _Stopwatch(model, "dump_logs")
                    gathering = _Stopwatch(model.train_log, "add")
                    began = time.perf_counter()
                    model.learn(args.steps, reset_num_timesteps=False, log_interval=interval if logged else 0)
                    seconds = time.perf_counter() - began
                    rates[logged].append(args.steps / seconds)
                    if logged:
                        shares.append(((points.seconds + gathering.seconds) / seconds, points.calls))
                    model.logger.close()
            share = min(shares)
            results[method] = {
                "interval": interval,
                "points_in_timed_window": share[1],
                "logging_share": share[0],
                "steps_per_s_logging": max(rates[True]),
                "steps_per_s_no_points": max(rates[False]),
            }
            print(
                f"{method:5s} interval {interval:6d}  logging share {share[0]:.2%}  "
                f"on {max(rates[True]):7.1f}  off {max(rates[False]):7.1f} steps/s",
                flush=True,
            )
    rows = [
        "| method | log interval (env steps) | points timed | time in logging "
        "| steps/s, logging | steps/s, no points |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    rows += [
        f"| {m} | {r['interval']:,} | {r['points_in_timed_window']} | {r['logging_share']:.2%} | "
        f"{r['steps_per_s_logging']:.0f} | {r['steps_per_s_no_points']:.0f} |"
        for m, r in results.items()
    ]
    notes = (
        f"\n\nEnv `{args.env}`, {args.n_envs} games per VecEnv step, batch {args.batch_size}, hidden layers "
        f"{args.net_arch}, {args.steps} timed env steps after {args.warmup} warm-up steps, {args.repeats} "
        f"repeats; torch threads {args.threads}. *Time in logging* is the share of the timed training spent "
        "writing the points (`dump_logs`: means, histograms, event files) and gathering the values they "
        "average (`TrainLog.add`), measured inside the run (the smallest of the repeats): on a shared "
        "machine it resolves what an on/off timing cannot, whose noise is larger than the cost (the two "
        "steps/s columns, best of the repeats each, for reference). The interval is the default of the "
        "packaged configuration (n_timesteps / 200, on the grid of n_envs) unless `--log-interval` is "
        "given. Target: ≤ 3 %."
    )
    write_results(
        args.name or f"train_throughput_logging_{args.env.split('-')[0].lower()}",
        {"args": vars(args), "logging": results},
        "\n".join(rows) + notes,
        title="What TensorBoard logging costs in training",
    )


def log_interval(method: str, args: argparse.Namespace) -> int:
    """Environment steps between CommDDPG's logged training points in the timed runs: ``--log-interval``,
    or the default of a run of the packaged configuration (``n_timesteps`` / 200 on the grid of
    ``--n-envs``)."""
    from sb3_comm.config import RunConfig
    from sb3_comm.hybrid_ddpg.hybrid_ddpg import default_log_interval

    if args.log_interval is not None:
        return args.log_interval
    return default_log_interval(RunConfig.load(method, args.env).n_timesteps, args.n_envs)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--env", default="BlindSoccer-v0")
    parser.add_argument("--n-envs", type=int, default=8)
    parser.add_argument("--steps", type=int, default=3000, help="timed env steps (games x steps)")
    parser.add_argument("--warmup", type=int, default=800)
    parser.add_argument("--net-arch", type=int, nargs="+", default=[256, 256])
    parser.add_argument("--batch-size", type=int, default=64)
    parser.add_argument("--repeats", type=int, default=5, help="rounds of timings (every model per round)")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--name", default=None, help="result file stem")
    parser.add_argument("--logging", action="store_true", help="measure the cost of TensorBoard logging")
    parser.add_argument(
        "--precisions",
        nargs="+",
        choices=list(PRECISIONS),
        default=["float32"],
        help="CommDDPG's policy_kwargs precision; every method is timed with each",
    )
    parser.add_argument(
        "--log-interval",
        type=int,
        default=None,
        help="env steps between CommDDPG's logged points, instead of the packaged configuration's default",
    )
    args = parser.parse_args()
    th.set_num_threads(args.threads)

    common = dict(batch_size=args.batch_size, learning_starts=args.batch_size, seed=0, device="cpu")
    if args.logging:
        logging_overhead(args, common)
        return
    rates: dict[str, float] = {}

    def td3() -> TD3:
        env = make_comm_vec_env(args.env, n_envs=args.n_envs, seed=0)
        return TD3(
            "MlpPolicy",
            env,
            policy_delay=1,
            target_policy_noise=0.0,
            policy_kwargs={"net_arch": args.net_arch, "n_critics": 1},
            **common,
        )

    def comm(method: str, precision: str) -> CommDDPG:
        env = make_comm_vec_env(args.env, n_envs=args.n_envs, seed=0)
        policy_kwargs = {"net_arch": args.net_arch, "precision": precision}
        return CommDDPG(method, env, policy_kwargs=policy_kwargs, **common)

    # a method's row: its name, with the precision where it is not float32
    labels = {(m if p == "float32" else f"{m} {p}"): (m, p) for p in args.precisions for m in METHODS}
    builders = {"TD3": td3, **{label: (lambda mp=mp: comm(*mp)) for label, mp in labels.items()}}
    # Logged training points as often as in a real run: CommDDPG's default interval of the packaged
    # configuration's budget (about 200 points per run; ``learn(args.steps)`` alone would default
    # to a point every VecEnv step), TD3 SB3's default (every 4 episodes).
    intervals = {"TD3": 4, **{label: log_interval(m, args) for label, (m, _) in labels.items()}}
    # Every model is built and warmed up once, then timed in rounds, each round every model in
    # turn: a slow phase of a shared machine then hits every model of that round alike, and the
    # overhead is the median over rounds of the ratio within a round.
    models = {}
    for name, build in builders.items():
        models[name] = build()
        models[name].learn(args.warmup, log_interval=intervals[name])
    rounds: dict[str, list[float]] = {name: [] for name in builders}
    for k in range(args.repeats):
        for name, model in models.items():
            began = time.perf_counter()
            model.learn(args.steps, reset_num_timesteps=False, log_interval=intervals[name])
            rounds[name].append(args.steps / (time.perf_counter() - began))
        print(f"round {k + 1}: " + "  ".join(f"{n} {r[-1]:.0f}" for n, r in rounds.items()), flush=True)
    gsn_model = next((models[label] for label, (m, _) in labels.items() if m == "GSN"), None)
    worker = bool(
        gsn_model is not None and gsn_model.gsn_callback is not None and gsn_model.gsn_callback.uses_worker()
    )
    rates = {name: max(r) for name, r in rounds.items()}
    medians = {name: statistics.median(r) for name, r in rounds.items()}
    overhead = {
        m: statistics.median(td3_rate / rate for td3_rate, rate in zip(rounds["TD3"], rounds[m], strict=True))
        for m in labels
    }
    rows = [
        "| model | env steps/s, best | env steps/s, median | overhead vs TD3 (×), median of rounds |",
        "|---|---:|---:|---:|",
    ]
    rows.append(f"| TD3 (DDPG settings, flat team) | {rates['TD3']:.0f} | {medians['TD3']:.0f} | 1.00 |")
    rows += [f"| CommDDPG {m} | {rates[m]:.0f} | {medians[m]:.0f} | {overhead[m]:.2f} |" for m in labels]
    notes = (
        f"\n\nEnv `{args.env}`, {args.n_envs} games per VecEnv step, one gradient step per VecEnv step, "
        f"batch {args.batch_size}, hidden layers {args.net_arch}, torch threads {args.threads}; CommDDPG's "
        f"hidden layers in {' and in '.join(args.precisions)} (`policy_kwargs` `precision`; TD3: SB3's "
        "float32). Each model "
        f"is warmed up for {args.warmup} env steps, then timed for {args.steps} env steps in each of "
        f"{args.repeats} rounds; a round times every model in turn, and the overhead is the median over "
        "rounds of TD3's rate over the model's in that round (a slow phase of the machine hits a whole "
        "round). Overhead < 1: faster than TD3. Target: ≤ 1.0 for every method. GSN's updates in a "
        f"worker process on a spare core (`sb3_comm/comm_ddpg/gsn_worker.py`): {'yes' if worker else 'no'}; "
        "the other models use no second process. Logged training points: CommDDPG every "
        f"{', '.join(f'{m} {log_interval(m, args):,}' for m in METHODS)} env steps (the default of a run of "
        "the packaged configuration, or `--log-interval`), TD3 every 4 episodes (SB3's default)."
    )
    write_results(
        args.name or f"train_throughput_{args.env.split('-')[0].lower()}",
        {
            "args": vars(args),
            "env_steps_per_second": rates,
            "env_steps_per_second_median": medians,
            "env_steps_per_second_rounds": rounds,
            "overhead_vs_td3": overhead,
            "gsn_worker": worker,
            "log_interval": intervals,
        },
        "\n".join(rows) + notes,
        title="Training throughput: CommDDPG vs SB3 TD3",
    )


if __name__ == "__main__":
    main()
