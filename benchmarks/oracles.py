"""Reference returns: scripted full-information oracles and random policies on every task.

The communication tasks and their oracle, random and baseline policies come from the task
registry (:data:`envs.registry.TASKS`); the single-agent HFO tasks are added here. These are
the denominators of every later result (SPEC §5: a method's return is reported as a
fraction of the oracle's). For each task, ``--episodes`` (default 1,000) episodes per policy, one
per parallel game, seeded; the mean, standard deviation and normal-approximation 95% confidence
interval (1.96 std / sqrt(n)) of the episode return, the mean episode length and how the
episodes ended. The team return is the mean of the agents' returns (Blind Soccer's reward is
shared, so it equals each agent's).

Run from the repository root::

    python -m benchmarks.oracles                  # writes benchmarks/results/oracles.{json,md}
    python -m benchmarks.oracles --episodes 100   # quicker, not written unless --write
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
from envs.oracles import empty_goal_oracle, evaluate, move_to_ball_oracle, random_policy
from envs.registry import TASKS as COMM_TASKS
from envs.tasks.batched import BatchedTask
from envs.tasks.single_agent import MoveToBallTask, ScoreEmptyGoalTask

DEFAULT_EPISODES = 1000
SEED = 0


def _random(seed: int) -> Callable[[BatchedTask], np.ndarray]:
    rng = np.random.default_rng(seed)
    return lambda task: random_policy(task, rng)


Policies = dict[str, Callable[[BatchedTask], np.ndarray]]

TASKS: dict[str, tuple[Callable[[int], BatchedTask], Policies]] = {
    # the communication tasks of the registry, by short key: oracle, random, then their baselines
    **{
        spec.key: (spec.batched_env, spec.reference_policies(np.random.default_rng(k + 1)))
        for k, spec in enumerate(COMM_TASKS.values())
    },
    # the authors' rules (dqn-hfo) of the same tasks
    **{
        f"{spec.key}_dqn_hfo": (
            lambda n, spec=spec: spec.batched_env(n_games=n, rules="dqn-hfo"),
            {"oracle": spec.oracle, "random": _random(2 * len(COMM_TASKS) + 1 + k)},
        )
        for k, spec in enumerate(COMM_TASKS.values())
    },
    "hfo_move_to_ball": (
        lambda n: MoveToBallTask(n_games=n),
        {"oracle": move_to_ball_oracle, "random": _random(len(COMM_TASKS) + 1)},
    ),
    "hfo_score_empty_goal": (
        lambda n: ScoreEmptyGoalTask(n_games=n),
        {"oracle": empty_goal_oracle, "random": _random(len(COMM_TASKS) + 2)},
    ),
}
"""Task key -> (``make(n_games)``, policies by name). The random policy of the k-th task (from 1)
draws from seed k, so the stored ``oracles.json`` is reproduced exactly."""

NOTES = """
Notes:

- Blind Soccer: the oracle steers the blind agent with the true ball position (turn when the
  ball is more than 10 degrees off, else dash at full power); it needs no messages, so it bounds
  what any protocol can reach. The paper reports a maximum of about 0.6. `blind_dash_forward`
  is a communication-free baseline (the blind agent dashes straight ahead, as the paper's GSN
  policy did with its messages disabled); standing still would score 0. A success ends the
  episode with the referee still `IN_GAME` (the blind agent can kick the ball).
  `visible_oracle` is the oracle limited to what the sighted agent sees: HFO 2016 hides a
  teammate at x <= 0 (SPEC §6 item 1), and while it is hidden the blind agent waits (about 10 %
  of resets start so; the `OUT_OF_TIME` episodes): what a protocol that conveys everything the
  sighted agent sees reaches (`benchmarks/hidden_teammate.py`).
- Guess My Number: the analytic maximum is 99 x 0.1 = 9.9 (the first step hears the initial
  message 0); the oracle sends each teammate its hidden number and reaches it.
- `*_dqn_hfo`: the same tasks under `rules="dqn-hfo"`, as the authors' code ran them (SPEC §6
  items 6, 7): Blind Soccer ends when either agent can kick the ball; Guess My Number rewards the
  message sent in the same step (maximum 100 x 0.1 = 10) and ends on a goal or the ball out.
- Simulator fidelity (SPEC §6): kickable means librcsc's test (1.03), goal posts are the
  server's circles and deflect the ball, the referee judges the ball's path and its previous
  position, ball-player collisions move both objects (see the README, "How faithful is the
  simulator").
- HFO single-agent tasks: move to ball ends `IN_GAME` when the player can kick the ball; the
  empty-goal oracle runs to the ball and kicks it at full power towards the goal centre.
"""


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--episodes", type=int, default=DEFAULT_EPISODES, help="episodes per task and policy")
    parser.add_argument("--seed", type=int, default=SEED, help="seed of the tasks")
    parser.add_argument(
        "--write", action="store_true", help="write results even with a non-default --episodes"
    )
    args = parser.parse_args(argv)

    results: dict[str, Any] = {
        "episodes": args.episodes,
        "seed": args.seed,
        "ci": "normal, 1.96 std / sqrt(n)",
    }
    lines = [
        f"Episode returns over {args.episodes:,} episodes per task and policy (seed {args.seed}); "
        "95% CI = 1.96 std / sqrt(n).",
        "",
        "| task | policy | team return | std | 95% CI | per agent | mean length | outcomes |",
        "|---|---|---:|---:|---:|---|---:|---|",
    ]
    for task_name, (make, policies) in TASKS.items():
        results[task_name] = {}
        for policy_name, policy in policies.items():
            start = time.perf_counter()
            task = make(min(args.episodes, 1000))
            r = evaluate(task, policy, args.episodes, seed=args.seed)
            elapsed = time.perf_counter() - start
            team = r["team_return"]
            per_agent = ", ".join(f"{a}: {r['return'][a]['mean']:.4f}" for a in r["agents"])
            outcomes = ", ".join(f"{k} {v}" for k, v in r["outcomes"].items() if v)
            results[task_name][policy_name] = {
                "team_return": team,
                "return": r["return"],
                "length": r["length"],
                "outcomes": r["outcomes"],
                "terminated": r["terminated"],
                "n_episodes": r["n_episodes"],
                "seconds": elapsed,
            }
            lines.append(
                f"| {task_name} | {policy_name} | {team['mean']:.4f} | {team['std']:.4f} | "
                f"± {team['ci95']:.4f} | {per_agent} | {r['length']['mean']:.1f} | {outcomes} |"
            )
            print(lines[-1], flush=True)
    table = "\n".join(lines) + "\n" + NOTES
    print(NOTES)
    if args.episodes == DEFAULT_EPISODES or args.write:
        paths = write_results("oracles", results, table, title="Oracle and random reference returns")
        print("wrote", *paths)


if __name__ == "__main__":
    main()
