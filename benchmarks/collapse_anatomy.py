"""What a Blind Soccer team does before, during and after a collapse: the checkpoints of one run,
each played on the same 100 games.

For every checkpoint ``model_<steps>_steps.zip`` of a run folder (``benchmarks/solve.py
--save-freq``), the deterministic team plays the periodic-evaluation games (one episode per game)
and the script records, over the steps of the episodes still running, what each agent executes:
the share of dashes, turns and kicks, and for the blind agent the share of forward dashes
(direction within ±22.5°, the server's 45° grid rounds it to 0), the mean |turn| asked for, and how
often a turn follows a turn. The return is given as a fraction of the oracle on the same games.

    python benchmarks/collapse_anatomy.py /work/bsruns/diag/BlindSoccer-v0_GSN_seed7 \\
        --name collapse_anatomy_blind_soccer_gsn_seed7
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

ENV_ID = "BlindSoccer-v0"
KINDS = ("dash", "turn", "kick")


def anatomy(model_path: Path, seed: int, n_games: int) -> dict[str, Any]:
    """Play ``n_games`` games of seed ``seed`` with one checkpoint and count what each agent does."""
    from sb3_comm import CommDDPG, make_comm_vec_env

    model = CommDDPG.load(model_path, device="cpu")
    env = make_comm_vec_env(ENV_ID, n_envs=n_games, seed=seed)
    layout = env.comm_layout
    low, high = env.action_space.low.reshape(2, -1), env.action_space.high.reshape(2, -1)
    names = list(layout.agent_names)
    blind = names.index("blind")
    obs = env.reset()
    live = np.ones(n_games, dtype=bool)
    returns = np.zeros(n_games)
    kinds = np.zeros((2, 3))
    forward = turn_size = turn_after_turn = turns = 0.0
    previous_kind = np.full(n_games, -1)
    while live.any():
        action, _ = model.predict(obs, deterministic=True)
        rows = np.asarray(action).reshape(n_games, 2, -1)
        kind = np.argmax(rows[..., :3], axis=-1)  # ties to the lowest index, as the task
        # parameters in the environment's units (the predicted action is already unscaled)
        dash_direction = rows[:, blind, 4]
        turn_direction = rows[:, blind, 5]
        for agent in range(2):
            kinds[agent] += np.bincount(kind[live, agent], minlength=3)
        b = kind[:, blind]
        forward += np.sum(live & (b == 0) & (np.abs(dash_direction) < 22.5))
        turn_size += np.sum(np.abs(turn_direction)[live & (b == 1)])
        turns += np.sum(live & (b == 1))
        turn_after_turn += np.sum(live & (b == 1) & (previous_kind == 1))
        previous_kind = np.where(live, b, previous_kind)
        obs, _, dones, infos = env.step(action)
        for i in np.flatnonzero(dones & live):
            returns[i] = float(np.mean(infos[i]["agent_returns"]))
            live[i] = False
    steps = kinds.sum(axis=1, keepdims=True)
    shares = kinds / np.maximum(steps, 1)
    assert np.all(high >= low)
    return {
        "mean_return": float(returns.mean()),
        "shares": {name: dict(zip(KINDS, shares[a].tolist(), strict=True)) for a, name in enumerate(names)},
        "blind_forward_dash_share": forward / max(kinds[blind, 0], 1),
        "blind_mean_turn_degrees": turn_size / max(turns, 1),
        "blind_turn_after_turn_share": turn_after_turn / max(turns, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("run_dir", help="a run folder with checkpoints/model_<steps>_steps.zip")
    parser.add_argument("--seed", type=int, default=10_000, help="the games (solve.py's curve seed)")
    parser.add_argument("--games", type=int, default=100)
    parser.add_argument("--name", required=True)
    args = parser.parse_args()
    from sb3_comm.analysis.references import reference_returns

    oracle = reference_returns(ENV_ID, n_episodes=args.games, seed=args.seed)["oracle"]  # type: ignore[index]
    found = sorted(
        (int(m.group(1)), path)
        for path in Path(args.run_dir, "checkpoints").glob("model_*_steps.zip")
        if (m := re.fullmatch(r"model_(\d+)_steps\.zip", path.name))
    )
    if not found:
        raise SystemExit(f"no checkpoints in {args.run_dir}/checkpoints")
    points = []
    for steps, path in found:
        point = {"timesteps": steps, **anatomy(path, args.seed, args.games)}
        point["fraction"] = point["mean_return"] / oracle
        points.append(point)
        print(steps, round(point["fraction"], 2), flush=True)
    rows = [
        "| steps | return (× oracle) | blind: dash / turn / kick | blind dashes straight ahead | "
        "blind mean turn (°) | blind turns after a turn | sighted: dash / turn / kick |",
        "|---:|---:|---|---:|---:|---:|---|",
    ]
    for p in points:
        blind, sighted = (" / ".join(f"{p['shares'][a][k]:.2f}" for k in KINDS) for a in ("blind", "sighted"))
        rows.append(
            f"| {p['timesteps']:,} | {p['fraction']:.2f} | {blind} | {p['blind_forward_dash_share']:.2f} | "
            f"{p['blind_mean_turn_degrees']:.0f} | {p['blind_turn_after_turn_share']:.2f} | {sighted} |"
        )
    notes = (
        f"\n\nRun `{args.run_dir}`; every checkpoint plays the same {args.games} games (seed {args.seed}), "
        f"one episode each, deterministic; oracle on those games {oracle:.4f}. Shares are over the steps "
        "of the episodes still running. 'Dashes straight ahead': dashes whose direction is within "
        "±22.5° (the server's 45° grid makes them 0°). The sighted agent cannot move: its dash is a no-op."
    )
    write_results(
        args.name,
        {"args": vars(args), "oracle": oracle, "points": points},
        "\n".join(rows) + notes,
        title="Anatomy of a collapse: what the team does at each checkpoint",
    )


if __name__ == "__main__":
    main()
