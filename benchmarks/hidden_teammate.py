"""Blind Soccer's hidden teammate: how much of the oracle's return no protocol can be told about.

HFO 2016's features hide a teammate whose x <= 0 (SPEC §6 item 1): in about 10 % of Blind Soccer
resets the sighted agent starts without seeing the blind agent, so no message can say where the
ball is relative to it, while the full-information oracle, which every result is divided by,
steers it by the true state all the same. This script measures, on given sets of evaluation
games (by default the 1,000 reference games and the periodic and final games of
``benchmarks/solve.py``):

* the games whose blind agent starts hidden, and the oracle's return on them and on the others;
* :func:`envs.oracles.blind_soccer_visible_oracle` (the oracle while the sighted agent sees the
  blind agent, waiting while it does not) as a fraction of the oracle: what a protocol that
  conveys everything the sighted agent sees reaches;
* for each trained team given (``--runs``: run folders with ``model.zip``), its return on the same
  games, split the same way, as a fraction of both oracles.

    python benchmarks/hidden_teammate.py --runs /work/bsruns/rerun/BlindSoccer-v0_GSN_seed2
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

from envs import oracles
from envs.registry import get_task
from sb3_comm import CommDDPG
from sb3_comm.evaluation import evaluate_team

ENV_ID = "BlindSoccer-v0"
GAME_SETS = {"reference": (0, 1000), "curve": (10_000, 100), "final": (20_000, 100)}
"""Name -> (seed, games): the 1,000 reference games (``benchmarks/oracles.py``), and the games of
the periodic and of the final evaluations of ``benchmarks/solve.py`` (its ``eval.seeds``)."""


def play_once(policy: oracles.Policy, seed: int, n_games: int) -> tuple[np.ndarray, np.ndarray]:
    """One episode in each of ``n_games`` games of ``seed``: per-game team returns, in game order
    (as :func:`sb3_comm.evaluation.evaluate_team` gives a team's), and whether each game's blind
    agent starts hidden from the sighted agent."""
    task = get_task(ENV_ID).batched_env(n_games=n_games)
    task.reset(seed=seed)
    hidden = oracles.hidden_from_sighted(task.state)
    result = oracles.evaluate(task, policy, n_games, seed=seed)  # resets to the same games
    return result["returns"].mean(axis=1)[np.argsort(result["games"])], hidden


def split(returns: np.ndarray, hidden: np.ndarray, oracle: np.ndarray, visible: np.ndarray) -> dict[str, Any]:
    """Means over all games, the games starting hidden and the others, and fractions of both
    oracles on the same games."""
    out: dict[str, Any] = {"mean": float(returns.mean())}
    for key, mask in (("hidden", hidden), ("seen", ~hidden)):
        out[f"{key}_mean"] = float(returns[mask].mean()) if mask.any() else None
        out[f"{key}_fraction_of_oracle"] = (
            float(returns[mask].sum() / oracle[mask].sum()) if mask.any() else None
        )
    out["fraction_of_oracle"] = float(returns.sum() / oracle.sum())
    out["fraction_of_visible_oracle"] = float(returns.sum() / visible.sum())
    return out


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--runs", nargs="*", default=[], help="run folders holding model.zip")
    parser.add_argument("--name", default="hidden_teammate_blind_soccer")
    args = parser.parse_args()

    sets: dict[str, Any] = {}
    for name, (seed, n_games) in GAME_SETS.items():
        oracle, hidden = play_once(oracles.blind_soccer_oracle, seed, n_games)
        visible, hidden_again = play_once(oracles.blind_soccer_visible_oracle, seed, n_games)
        assert (hidden == hidden_again).all(), "the same seed must give the same games"
        sets[name] = {
            "seed": seed,
            "games": n_games,
            "hidden_games": int(hidden.sum()),
            "oracle": split(oracle, hidden, oracle, visible),
            "visible_oracle": split(visible, hidden, oracle, visible),
            "_arrays": (oracle, visible, hidden),
        }
        print(f"{name}: {int(hidden.sum())} of {n_games} games start hidden", flush=True)

    teams: dict[str, Any] = {}
    for run in args.runs:
        run_dir = Path(run)
        model = CommDDPG.load(run_dir / "model.zip", device="cpu")
        label = f"{run_dir.parent.name}/{run_dir.name}"  # the solve's folder names its settings
        teams[label] = {}
        for name, (seed, n_games) in GAME_SETS.items():
            if n_games != 100:
                continue  # the runs are judged on their 100-game sets
            oracle, visible, hidden = sets[name]["_arrays"]
            returns = evaluate_team(model, ENV_ID, n_episodes=n_games, seed=seed).team_returns
            teams[label][name] = split(returns, hidden, oracle, visible)
            print(f"{label} {name}: {teams[label][name]}", flush=True)
    for entry in sets.values():
        del entry["_arrays"]

    def cell(value: float | None, digits: int = 3) -> str:
        return "—" if value is None else f"{value:.{digits}f}"

    rows = [
        "| games (seed) | games starting hidden | oracle, all / hidden / seen | visible oracle, all / "
        "hidden / seen | visible oracle ÷ oracle | share of the oracle's return in hidden games |",
        "|---|---:|---|---|---:|---:|",
    ]
    for name, entry in sets.items():
        o, v = entry["oracle"], entry["visible_oracle"]
        share = 1.0 - (o["seen_mean"] * (entry["games"] - entry["hidden_games"])) / (
            o["mean"] * entry["games"]
        )
        rows.append(
            f"| {name}, {entry['games']} ({entry['seed']}) | {entry['hidden_games']} | "
            f"{cell(o['mean'])} / {cell(o['hidden_mean'])} / {cell(o['seen_mean'])} | "
            f"{cell(v['mean'])} / {cell(v['hidden_mean'])} / {cell(v['seen_mean'])} | "
            f"{v['fraction_of_oracle']:.3f} | {share:.3f} |"
        )
    if teams:
        rows += [
            "",
            "| run | games | return | × oracle | × visible oracle | × oracle on games starting hidden "
            "| × oracle on the others |",
            "|---|---|---:|---:|---:|---:|---:|",
        ]
        for run_name, per_set in teams.items():
            for name, t in per_set.items():
                rows.append(
                    f"| {run_name} | {name} ({GAME_SETS[name][0]}) | {t['mean']:.4f} | "
                    f"{t['fraction_of_oracle']:.3f} | {t['fraction_of_visible_oracle']:.3f} | "
                    f"{cell(t['hidden_fraction_of_oracle'])} | {cell(t['seen_fraction_of_oracle'])} |"
                )
    notes = (
        "\n\nA game *starts hidden* when the blind agent's reset puts it at x <= 0, where HFO 2016's "
        "features do not show a teammate (SPEC §6 item 1): the sighted agent sees nothing of it. The "
        "*visible oracle* (`envs.oracles.blind_soccer_visible_oracle`) plays the oracle while the "
        "sighted agent sees the blind agent and waits while it does not: what a protocol that conveys "
        "everything the sighted agent sees reaches, at once (real messages arrive a step later). A "
        "fraction is a sum of returns over a sum of the oracle's on the same games; 'curve' are the "
        "games of `benchmarks/solve.py`'s periodic evaluations, 'final' those of its final one."
    )
    write_results(
        args.name,
        {"env": ENV_ID, "game_sets": sets, "teams": teams},
        "\n".join(rows) + notes,
        title="Blind Soccer: the games whose blind agent the sighted agent cannot see",
    )


if __name__ == "__main__":
    main()
