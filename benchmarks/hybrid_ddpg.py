"""Single-agent check of the hybrid-action DDPG on the HFO tasks of the ICLR 2016 paper.

Trains :class:`sb3_comm.HybridDDPG` with ``zoo_configs/hybrid_ddpg.yml`` and evaluates the
deterministic policy on 100 episodes: on move-to-ball the fraction of episodes that reach the ball
(the player can kick it), on score-on-an-empty-goal the goal rate.

    python benchmarks/hybrid_ddpg.py --envs HFOMoveToBall-v0 HFOScoreEmptyGoal-v0 --time-budget 1200
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import sys
import time
from pathlib import Path
from typing import Any

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results
from solve import TimeBudget

CONFIG = Path(__file__).resolve().parent.parent / "zoo_configs" / "hybrid_ddpg.yml"
GOAL = 1  # envs.soccer.referee.GOAL


def evaluate(model: Any, env_id: str, n_episodes: int, seed: int) -> dict[str, float]:
    """Deterministic episodes: mean return, fraction terminated (ball reached / episode won), goals."""
    import gymnasium as gym

    env = gym.make(env_id)
    returns, reached, goals, lengths = [], 0, 0, []
    for episode in range(n_episodes):
        obs, _ = env.reset(seed=seed + episode)
        total, done, steps, info, terminated = 0.0, False, 0, {}, False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            steps += 1
            done = terminated or truncated
        returns.append(total)
        lengths.append(steps)
        reached += int(terminated)
        goals += int(info.get("outcome") == GOAL)
    return {
        "mean_return": sum(returns) / n_episodes,
        "success_rate": reached / n_episodes,
        "goal_rate": goals / n_episodes,
        "mean_length": sum(lengths) / n_episodes,
        "n_episodes": n_episodes,
    }


def run_one(job: dict[str, Any]) -> dict[str, Any]:
    """Train and evaluate HybridDDPG on one env."""
    import torch as th
    from stable_baselines3.common.env_util import make_vec_env

    import envs  # noqa: F401  (registers the HFO ids)
    from sb3_comm import HybridDDPG

    th.set_num_threads(1)
    settings = dict(yaml.safe_load(CONFIG.read_text())[job["env"]])
    n_envs = int(settings.pop("n_envs"))
    timesteps = int(job["timesteps"] or float(settings.pop("n_timesteps")))
    settings.pop("n_timesteps", None)
    policy = settings.pop("policy")
    model = HybridDDPG(
        policy,
        make_vec_env(job["env"], n_envs=n_envs, seed=job["seed"]),
        seed=job["seed"],
        device="cpu",
        **settings,
    )
    began = time.perf_counter()
    model.learn(timesteps, callback=TimeBudget.make(job["time_budget"]))
    seconds = time.perf_counter() - began
    return {
        "env": job["env"],
        "seed": job["seed"],
        "timesteps": model.num_timesteps,
        "train_seconds": seconds,
        "evaluation": evaluate(model, job["env"], 100, seed=50_000),
        "settings": settings,
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--envs", nargs="+", default=["HFOMoveToBall-v0", "HFOScoreEmptyGoal-v0"])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timesteps", type=int, default=None)
    parser.add_argument("--time-budget", type=float, default=1200.0)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    jobs = [
        {"env": env, "seed": args.seed, "timesteps": args.timesteps, "time_budget": args.time_budget}
        for env in args.envs
    ]
    with mp.get_context("spawn").Pool(min(args.workers, len(jobs))) as pool:
        runs = pool.map(run_one, jobs)
    rows = [
        "| task | env steps | train time (s) | mean return | reached ball / success | goal rate |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for run in runs:
        ev = run["evaluation"]
        rows.append(
            f"| {run['env']} | {run['timesteps']:,} | {run['train_seconds']:.0f} | {ev['mean_return']:.3f} | "
            f"{ev['success_rate']:.2f} | {ev['goal_rate']:.2f} |"
        )
    notes = (
        "\n\n100 deterministic evaluation episodes per task after training (seed "
        f"{args.seed}, time budget {args.time_budget:.0f} s per run, one torch thread per run). "
        "'Success' is an episode that terminated: the player reached the ball (move to ball) or the "
        "episode ended on a goal (empty goal). Oracle references: `benchmarks/results/oracles.md`."
    )
    write_results(
        "hybrid_ddpg",
        {"args": vars(args), "runs": runs},
        "\n".join(rows) + notes,
        title="Single-agent hybrid DDPG on HFO tasks",
    )


if __name__ == "__main__":
    main()
