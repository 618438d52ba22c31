"""Single-agent check of the hybrid-action DDPG on the HFO tasks of the ICLR 2016 paper.

Trains :class:`sb3_comm.HybridDDPG` with ``zoo_configs/hybrid_ddpg.yml`` on each seed and
evaluates the deterministic policy on 100 episodes every ``--eval-freq`` steps and at the end: on
move-to-ball the fraction of episodes that reach the ball (the player can kick it), on
score-on-an-empty-goal the goal rate. Reports, per seed, the curve, the final rates and the first
evaluation at which the rate reached ``--bar`` (issue: ≥ 0.9 within 3M steps, on each of 3 seeds).

Runs are resumable, so that a long run can be made in pieces that each finish: a piece trains for
at most ``--time-budget`` seconds, then saves the model, its replay buffer and the curve in
``--save-dir``; the same command continues every unfinished run from there (the checkpoint's
settings must match, or it is an error) and reads the finished ones::

    python benchmarks/hybrid_ddpg.py --envs HFOScoreEmptyGoal-v0 --seeds 0 1 2 \\
        --timesteps 3000000 --time-budget 3000 --save-dir runs/hybrid_ddpg

A piece keeps the evaluations it made; the episodes running at its cut restart in the next piece
(their transitions keep the TD target alone). Results go to ``benchmarks/results/<--name>.{json,md}``
(default ``hybrid_ddpg_<tasks>``, e.g. ``hybrid_ddpg_scoreemptygoal``).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import sys
import time
from pathlib import Path
from typing import Any

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

from sb3_comm.cli import parse_overrides

CONFIG = Path(__file__).resolve().parent.parent / "zoo_configs" / "hybrid_ddpg.yml"
GOAL = 1  # envs.soccer.referee.GOAL
RATE = {"HFOMoveToBall-v0": "success_rate", "HFOScoreEmptyGoal-v0": "goal_rate"}
"""The rate that counts per task: reaching the ball, scoring."""


def evaluate(model: Any, env_id: str, n_episodes: int, seed: int) -> dict[str, float]:
    """One deterministic episode in each of ``n_episodes`` games played at once (the same games for
    the same ``seed``): mean return, fraction terminated (ball reached / episode won), goals."""
    import numpy as np

    from envs.tasks.single_agent import SINGLE_AGENT_TASKS

    task = SINGLE_AGENT_TASKS[env_id](n_games=n_episodes, seed=seed, autoreset=False)
    obs = task.obs  # the constructor reset every game from the seed
    running = np.ones(n_episodes, dtype=bool)
    returns, lengths = np.zeros(n_episodes), np.zeros(n_episodes, dtype=np.int64)
    terminated, outcome = np.zeros(n_episodes, dtype=bool), np.zeros(n_episodes, dtype=np.int64)
    while running.any():
        actions, _ = model.predict(obs[:, 0], deterministic=True)
        obs, rewards, ended_in_goal_or_out, truncated, info = task.step(actions[:, None])
        returns[running] += rewards[running, 0]
        lengths[running] += 1
        ended = running & (ended_in_goal_or_out | truncated)
        terminated[ended] = ended_in_goal_or_out[ended]
        outcome[ended] = info["outcome"][ended]
        running &= ~ended  # a game that ended plays on unseen until all have ended
    return {
        "mean_return": float(returns.mean()),
        "success_rate": float(terminated.mean()),
        "goal_rate": float((outcome == GOAL).mean()),
        "mean_length": float(lengths.mean()),
        "n_episodes": n_episodes,
    }


def job_settings(env_id: str, overrides: dict[str, Any]) -> dict[str, Any]:
    """The packaged settings of ``env_id`` with ``overrides`` applied (checked keys)."""
    settings = dict(yaml.safe_load(CONFIG.read_text())[env_id])
    accepted = set(settings) | {"gradient_steps", "train_freq"}
    unknown = sorted(set(overrides) - accepted)
    if unknown:
        raise ValueError(f"Unknown --params key(s) {unknown}; accepted: {sorted(accepted)}")
    settings.update(overrides)
    return settings


def same_run(key: dict[str, Any]) -> dict[str, Any]:
    """What must match for a saved run to be continued: the run's key (JSON form), without the
    config's ``n_timesteps``, which only gives ``timesteps`` a default (the key has ``timesteps``)."""
    comparable = json.loads(json.dumps(key))
    comparable["settings"].pop("n_timesteps", None)
    return comparable


def run_one(job: dict[str, Any]) -> dict[str, Any]:
    """Train (or continue) one seed on one env for one piece; evaluate on the way.

    :param job: ``key`` (the run: env, seed, timesteps, settings, evaluation), ``time_budget`` (the
        piece's seconds) and ``run_dir``.
    """
    import torch as th
    from stable_baselines3.common.callbacks import BaseCallback

    from sb3_comm import HybridDDPG, make_comm_vec_env
    from sb3_comm.callbacks import TimeBudgetCallback
    from sb3_comm.common.hyperparams import algorithm_kwargs

    th.set_num_threads(1)
    run_dir = Path(job["run_dir"])
    run_dir.mkdir(parents=True, exist_ok=True)
    state_path, model_path = run_dir / "state.json", run_dir / "model.zip"
    buffer_path = run_dir / "replay.pkl"
    key = job["key"]
    state: dict[str, Any] = {"job": key, "curve": [], "train_seconds": 0.0, "done": False}
    if state_path.exists():
        state = json.loads(state_path.read_text())
        if same_run(state["job"]) != same_run(key):
            raise ValueError(f"{run_dir} holds a run with other settings: use another --save-dir")
    if state["done"]:
        print(f"{run_dir}: finished earlier", flush=True)
        return state

    settings = dict(key["settings"])
    n_envs = int(settings.pop("n_envs"))
    settings.pop("n_timesteps")
    policy = settings.pop("policy")
    env = make_comm_vec_env(key["env"], n_envs=n_envs, seed=key["seed"] + 1000 * len(state["curve"]))
    if model_path.exists():
        model = HybridDDPG.load(model_path, env=env, device="cpu")
        model.load_replay_buffer(buffer_path)
    else:
        model = HybridDDPG(policy, env, seed=key["seed"], device="cpu", **algorithm_kwargs(settings))
    timesteps, every, episodes = key["timesteps"], key["eval_freq"], key["eval_episodes"]

    class Evaluate(BaseCallback):
        """Evaluate every ``every`` env steps on the same episodes; keep the curve in ``state``."""

        def __init__(self) -> None:
            super().__init__()
            self.next = (model.num_timesteps // every + 1) * every
            self.began = time.perf_counter()
            self.evaluating = 0.0  # seconds of this piece spent in evaluations

        def train_seconds(self) -> float:
            """Training time of the run so far, evaluations left out."""
            return state["train_seconds"] + time.perf_counter() - self.began - self.evaluating

        def point(self) -> None:
            seconds, began = self.train_seconds(), time.perf_counter()
            result = evaluate(model, key["env"], episodes, seed=50_000)
            self.evaluating += time.perf_counter() - began
            state["curve"].append({"timesteps": model.num_timesteps, "train_seconds": seconds, **result})
            print(f"{key['env']} seed {key['seed']}: {state['curve'][-1]}", flush=True)

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next:
                self.next += every
                self.point()
            return True

    evaluation = Evaluate()
    model.learn(
        timesteps - model.num_timesteps,
        callback=[evaluation, TimeBudgetCallback(job["time_budget"])],
        reset_num_timesteps=not model_path.exists(),
    )
    state["train_seconds"] = evaluation.train_seconds()
    state["timesteps"] = model.num_timesteps
    if model.num_timesteps >= timesteps:
        if not state["curve"] or state["curve"][-1]["timesteps"] != model.num_timesteps:
            evaluation.point()
        state["done"] = True
    model.save(model_path)
    model.save_replay_buffer(buffer_path)
    state_path.write_text(json.dumps(state, indent=1))
    return state


def first_at(curve: list[dict[str, Any]], rate: str, bar: float) -> dict[str, Any] | None:
    """The first evaluation whose ``rate`` is at least ``bar``."""
    return next((point for point in curve if point[rate] >= bar), None)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--envs", nargs="+", default=["HFOScoreEmptyGoal-v0"], choices=sorted(RATE))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--timesteps", type=int, default=None, help="default: the config's n_timesteps")
    parser.add_argument("--params", nargs="*", default=[], help="config overrides, key=value")
    parser.add_argument("--eval-freq", type=int, default=100_000)
    parser.add_argument("--eval-episodes", type=int, default=100)
    parser.add_argument("--bar", type=float, default=0.9, help="rate to reach (goal rate on the empty goal)")
    parser.add_argument("--time-budget", type=float, default=3000.0, help="seconds of training per piece")
    parser.add_argument("--save-dir", type=Path, default=Path("runs/hybrid_ddpg"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--name", default=None, help="result file stem (default: hybrid_ddpg_<tasks>)")
    args = parser.parse_args()
    overrides = parse_overrides(args.params)
    if args.name is None:
        args.name = "hybrid_ddpg_" + "_".join(
            e.removeprefix("HFO").removesuffix("-v0").lower() for e in args.envs
        )
    jobs = []
    for env_id in args.envs:
        settings = job_settings(env_id, overrides)
        timesteps = int(args.timesteps or float(settings["n_timesteps"]))
        for seed in args.seeds:
            key = {
                "env": env_id,
                "seed": seed,
                "timesteps": timesteps,
                "settings": settings,
                "eval_freq": args.eval_freq,
                "eval_episodes": args.eval_episodes,
            }
            run_dir = str(args.save_dir / env_id / f"seed_{seed}")
            jobs.append({"key": key, "time_budget": args.time_budget, "run_dir": run_dir})
    with mp.get_context("spawn").Pool(min(args.workers, len(jobs))) as pool:
        runs = pool.map(run_one, jobs)

    rows = [
        "| task | seed | env steps | train time (s) | final return | final rate | best rate | "
        f"first ≥ {args.bar} (steps, s) |",
        "|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for run in runs:
        key, rate, curve = run["job"], RATE[run["job"]["env"]], run["curve"]
        final = curve[-1] if curve else None
        hit = first_at(curve, rate, args.bar)
        run["first_at_bar"] = hit
        rows.append(
            f"| {key['env']} | {key['seed']} | {run.get('timesteps', 0):,} | {run['train_seconds']:.0f} | "
            + (
                f"{final['mean_return']:.3f} | {final[rate]:.2f} | {max(p[rate] for p in curve):.2f} | "
                if final
                else "– | – | – | "
            )
            + (f"{hit['timesteps']:,}, {hit['train_seconds']:.0f} |" if hit else "never |")
            + ("" if run["done"] else " (unfinished)")
        )
    rows += ["", f"Curves (rate at each evaluation, every {args.eval_freq:,} env steps):", ""]
    for run in runs:
        key, rate = run["job"], RATE[run["job"]["env"]]
        rows.append(f"- {key['env']} seed {key['seed']}: " + " ".join(f"{p[rate]:.2f}" for p in run["curve"]))
    notes = (
        f"\n\n{args.eval_episodes} deterministic evaluation episodes (the same games each time, played "
        f"at once) every "
        f"{args.eval_freq:,} env steps and at the end; one torch thread per run, {args.workers} runs in "
        f"parallel. Settings: `zoo_configs/hybrid_ddpg.yml`"
        + (f" with {overrides}" if overrides else "")
        + ". The rate is the goal rate on the empty goal, the fraction of episodes that reach the "
        "ball on move-to-ball. Training steps all games of a run in one call "
        "(`make_comm_vec_env`, `BatchedSingleAgentVecEnv`). Runs are resumable: a run that an earlier "
        "call of the command finished is read from `--save-dir`, not trained again, so the commit above "
        "is the one that wrote this file, and a run may have been trained at an earlier one. Oracle "
        "references: `benchmarks/results/oracles.md`."
    )
    write_results(
        args.name,
        {"args": {**vars(args), "save_dir": str(args.save_dir)}, "runs": runs},
        "\n".join(rows) + notes,
        title="Single-agent hybrid DDPG on HFO tasks",
    )


if __name__ == "__main__":
    main()
