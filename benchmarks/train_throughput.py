"""Training throughput: environment steps per second of CommDDPG per method against plain SB3 TD3.

Every model gets the same environment (a batched VecEnv of ``--n-envs`` games), the same hidden
layers, batch size and update ratio (one gradient step per VecEnv step). TD3 is configured as
DDPG (one critic, no policy delay, no target smoothing) so that it does the same number of
network passes as CommDDPG's NONE; it sees the two agents as one flat agent. The ratio
``TD3 steps/s ÷ method steps/s`` is the overhead of the method, measured in the same run.

    python benchmarks/train_throughput.py --env BlindSoccer-v0 --n-envs 8 --steps 3000
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch as th
from stable_baselines3 import TD3

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

from sb3_comm import METHODS, CommDDPG, make_comm_vec_env


def measure(model, steps: int, warmup: int) -> float:
    """Env steps per second of ``model.learn`` after a warm-up that fills the buffer."""
    model.learn(warmup)
    began = time.perf_counter()
    model.learn(steps, reset_num_timesteps=False)
    return steps / (time.perf_counter() - began)


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
    parser.add_argument("--repeats", type=int, default=2, help="best of this many timings")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--name", default=None, help="result file stem")
    args = parser.parse_args()
    th.set_num_threads(args.threads)

    common = dict(batch_size=args.batch_size, learning_starts=args.batch_size, seed=0, device="cpu")
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

    def comm(method: str) -> CommDDPG:
        env = make_comm_vec_env(args.env, n_envs=args.n_envs, seed=0)
        return CommDDPG(method, env, policy_kwargs={"net_arch": args.net_arch}, **common)

    builders = {"TD3": td3, **{m: (lambda m=m: comm(m)) for m in METHODS}}
    for name, build in builders.items():
        rates[name] = max(measure(build(), args.steps, args.warmup) for _ in range(args.repeats))
        print(f"{name:5s} {rates[name]:9.1f} env steps/s", flush=True)

    overhead = {m: rates["TD3"] / rates[m] for m in METHODS}
    rows = ["| model | env steps/s | overhead vs TD3 (×) |", "|---|---:|---:|"]
    rows.append(f"| TD3 (DDPG settings, flat team) | {rates['TD3']:.0f} | 1.00 |")
    rows += [f"| CommDDPG {m} | {rates[m]:.0f} | {overhead[m]:.2f} |" for m in METHODS]
    notes = (
        f"\n\nEnv `{args.env}`, {args.n_envs} games per VecEnv step, one gradient step per VecEnv step, "
        f"batch {args.batch_size}, hidden layers {args.net_arch}, {args.steps} timed env steps after "
        f"{args.warmup} warm-up steps, best of {args.repeats}, torch threads {args.threads}. "
        "Target: overhead ≤ 1.3× for GSN and TCG."
    )
    write_results(
        args.name or f"train_throughput_{args.env.split('-')[0].lower()}",
        {"args": vars(args), "env_steps_per_second": rates, "overhead_vs_td3": overhead},
        "\n".join(rows) + notes,
        title="Training throughput: CommDDPG vs SB3 TD3",
    )


if __name__ == "__main__":
    main()
