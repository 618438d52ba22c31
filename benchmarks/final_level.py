"""The level a trained team has reached, measured on many games instead of 100.

``benchmarks/solve.py`` ends every run with a 100-game evaluation, and ``benchmarks/stability.py``
judges a seed by it against the oracle on the same 100 games. On Blind Soccer one game's return
has a standard deviation of about 0.27 (0.44 of the oracle's mean), so 100 games measure a team's
level to within several hundredths of the oracle: a seed at the bar can read a few hundredths
above or below it. This script plays each run's final model (``model.zip`` of a run folder) on
``--games`` games of each of ``--game-seeds`` (one episode per game, deterministic, as the final
evaluation), and divides by the oracle and by the visible oracle on the very same games
(:func:`sb3_comm.analysis.references.reference_returns`), with a 95 % interval from the spread of
the team's returns over the games (the reference's mean taken as exact).

    python benchmarks/final_level.py /work/runs/b128eps/BlindSoccer-v0_GSN_seed*/ \\
        --name final_level_blind_soccer_gsn_batch128_eps0.01
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

ENV_ID = "BlindSoccer-v0"


def team_returns(model: Any, n_games: int, seed: int) -> np.ndarray:
    """The deterministic team's return in each of ``n_games`` games of ``seed``."""
    from sb3_comm.evaluation import evaluate_team

    return np.asarray(evaluate_team(model, ENV_ID, n_episodes=n_games, seed=seed).team_returns)


def reference_games(n_games: int, seed: int) -> dict[str, float]:
    """The oracle's and the visible oracle's mean return on the same games."""
    from sb3_comm.analysis.references import reference_returns

    references = reference_returns(ENV_ID, n_episodes=n_games, seed=seed)
    assert references is not None
    return {"oracle": references["oracle"], "visible_oracle": references["visible_oracle"]}


def level(returns: list[np.ndarray], references: list[dict[str, float]], reference: str) -> dict[str, float]:
    """The team's mean over all games divided by the reference's mean on them; the 95 % half-width
    of that fraction from the games' spread (the reference's own mean taken as exact)."""
    team = np.concatenate(returns)
    reference_mean = float(np.mean([r[reference] for r in references]))  # equal numbers of games per seed
    fraction = float(team.mean() / reference_mean)
    half_width = float(1.96 * team.std(ddof=1) / np.sqrt(len(team)) / reference_mean)
    return {"fraction": fraction, "ci95": half_width, "reference_return": reference_mean}


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "runs", nargs="+", help="run folders holding model.zip (benchmarks/solve.py --save-dir)"
    )
    parser.add_argument("--games", type=int, default=1000, help="games per game seed (at most 1,000)")
    parser.add_argument("--game-seeds", type=int, nargs="+", default=[777, 778])
    parser.add_argument("--reach", type=float, default=0.9)
    parser.add_argument("--name", required=True, help="result file stem")
    args = parser.parse_args()
    if not 1 <= args.games <= 1000:
        raise SystemExit(f"--games must be between 1 and 1,000; got {args.games}")

    import torch as th

    from sb3_comm import CommDDPG

    th.set_num_threads(1)
    references = [reference_games(args.games, seed) for seed in args.game_seeds]
    results: dict[str, Any] = {}
    for folder in args.runs:
        path = Path(folder) / "model.zip"
        if not path.exists():
            raise SystemExit(f"{folder}: no model.zip (a run that has not finished?)")
        label = f"{Path(folder).resolve().parent.name}/{Path(folder).name}"  # solves reuse run names
        if label in results:
            raise SystemExit(f"{folder}: run {label} given twice")
        model = CommDDPG.load(path, device="cpu")
        returns = [team_returns(model, args.games, seed) for seed in args.game_seeds]
        results[label] = {
            "mean_return": float(np.concatenate(returns).mean()),
            "oracle": level(returns, references, "oracle"),
            "visible_oracle": level(returns, references, "visible_oracle"),
        }
        print(label, results[label], flush=True)
    rows = [
        f"| run | games | mean return | × oracle on the same games [95 %] | ≥ {args.reach} | "
        "× visible oracle on the same games [95 %] |",
        "|---|---:|---:|---:|---|---:|",
    ]
    games = args.games * len(args.game_seeds)
    for label, r in results.items():
        o, v = r["oracle"], r["visible_oracle"]
        rows.append(
            f"| {label} | {games:,} | {r['mean_return']:.4f} | {o['fraction']:.3f} ± {o['ci95']:.3f} | "
            f"{'yes' if o['fraction'] >= args.reach else '**no**'} | {v['fraction']:.3f} ± {v['ci95']:.3f} |"
        )
    oracle = np.mean([r["oracle"] for r in references])
    visible = np.mean([r["visible_oracle"] for r in references])
    notes = (
        f"\n\nEach run's final `model.zip`, deterministic, one episode in each of {args.games:,} games of "
        f"each game seed {args.game_seeds}; the oracle returns {oracle:.4f} and the visible oracle "
        f"{visible:.4f} on the same games. The interval is 1.96 standard errors of the team's mean over "
        "the games, divided by the reference's mean."
    )
    write_results(
        args.name,
        {"args": vars(args), "references": references, "runs": results},
        "\n".join(rows) + notes,
        title="The level a trained Blind Soccer team has reached, on many games",
    )


if __name__ == "__main__":
    main()
