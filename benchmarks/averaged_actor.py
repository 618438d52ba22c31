"""A trained team played by its actor and by its averaged actor, on the same games.

``policy_kwargs={"averaged_actor": True}`` makes a policy play its target actor, the Polyak average
of the actor that DDPG keeps for the critic's targets, instead of the actor's latest iterate; the
training is the same either way. This script takes the final model (``model.zip``) of each run
folder of ``benchmarks/solve.py`` (any task: the environment id is read from the run's
``solve_job.json``) and plays it twice on the same ``--games`` games (game seed ``--game-seed``,
one episode per game, deterministic, as the final evaluation): with the actor and with the
average. It reports both mean returns and their difference, paired game by game, with a 95 %
interval of the mean difference.

    python benchmarks/averaged_actor.py /work/runs/s25/gmn_actorlin/GuessMyNumber-v0_TCG_seed* \\
        --name averaged_actor_final_defaults_gmn_tcg
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results


def paired_difference(actor: np.ndarray, average: np.ndarray) -> dict[str, float]:
    """Mean returns of the two players on the same games and the mean of the per-game
    differences (average − actor) with its 95 % half-width."""
    if actor.shape != average.shape:
        raise ValueError(f"the two players must play the same games: {actor.shape} != {average.shape}")
    diff = average - actor
    half = 1.96 * diff.std(ddof=1) / np.sqrt(len(diff)) if len(diff) > 1 else float("nan")
    return {
        "actor": float(actor.mean()),
        "average": float(average.mean()),
        "difference": float(diff.mean()),
        "difference_ci95": float(half),
    }


def play(model: Any, env_id: str, games: int, seed: int, averaged: bool) -> np.ndarray:
    """The deterministic team's return in each game, played by its actor or by its average."""
    from sb3_comm.evaluation import evaluate_team

    model.policy.averaged_actor = averaged
    return np.asarray(evaluate_team(model, env_id, n_episodes=games, seed=seed).team_returns)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("runs", nargs="+", help="run folders (benchmarks/solve.py --save-dir)")
    parser.add_argument("--games", type=int, default=1000, help="games per run (at most 1,000)")
    parser.add_argument("--game-seed", type=int, default=777)
    parser.add_argument("--name", required=True, help="result file stem")
    args = parser.parse_args()
    if not 2 <= args.games <= 1000:
        raise SystemExit(f"--games must be between 2 and 1,000; got {args.games}")

    import torch as th

    from sb3_comm import CommDDPG

    th.set_num_threads(1)
    results: dict[str, Any] = {}
    rows = [
        "| run | task | actor | averaged actor | difference (average − actor) [95 %] |",
        "|---|---|---:|---:|---:|",
    ]
    for folder in map(Path, args.runs):
        job_path = folder / "solve_job.json"
        if not (folder / "model.zip").exists() or not job_path.exists():
            raise SystemExit(f"{folder}: no model.zip or solve_job.json (not a finished run of solve.py?)")
        env_id = json.loads(job_path.read_text())["env"]
        model = CommDDPG.load(folder / "model.zip", device="cpu")
        row = paired_difference(
            play(model, env_id, args.games, args.game_seed, averaged=False),
            play(model, env_id, args.games, args.game_seed, averaged=True),
        )
        label = f"{folder.resolve().parent.name}/{folder.name}"
        results[label] = {"env": env_id, **row}
        rows.append(
            f"| {label} | {env_id} | {row['actor']:.4f} | {row['average']:.4f} | "
            f"{row['difference']:+.4f} ± {row['difference_ci95']:.4f} |"
        )
        print(rows[-1], flush=True)
    differences = [r["difference"] for r in results.values()]
    notes = (
        f"\n\nEach final model plays the same {args.games:,} games (game seed {args.game_seed}, one "
        "episode per game, deterministic) with its actor and with its averaged actor, the target "
        "actor (`policy_kwargs={'averaged_actor': True}`); returns are the team's mean per game. "
        f"Over the {len(differences)} runs the difference is {np.mean(differences):+.4f} on average "
        f"(from {min(differences):+.4f} to {max(differences):+.4f})."
    )
    write_results(
        args.name,
        {"args": vars(args), "runs": results},
        "\n".join(rows) + notes,
        title="Final teams played by their actor and by their averaged actor",
    )


if __name__ == "__main__":
    main()
