"""What a Blind Soccer team does before, during and after a collapse: the checkpoints of one run,
each played on the same 100 games.

For every checkpoint ``model_<steps>_steps.zip`` of a run folder (``benchmarks/solve.py
--save-freq``), the deterministic team plays the periodic-evaluation games (one episode per game)
and the script records, over the steps of the episodes still running, what each agent executes:
the share of dashes, turns and kicks, and for the blind agent the share of forward dashes
(direction within ±22.5°, the server's 45° grid rounds it to 0), the mean |turn| asked for, and how
often a turn follows a turn. The return is given as a fraction of the oracle on the same games.

With ``--swap STEPS ...`` (checkpoints around a collapse) it also asks which part collapsed:

* the return of every pairing of one checkpoint's agents (actor and critic) with another
  checkpoint's GSN (message network): a collapse that follows the rows is the agents', one that
  follows the columns the messages';
* how each checkpoint's critic rates each checkpoint's actor: the blind agent's mean ``Q`` of the
  actions that actor takes, on the observations of the first checkpoint's team playing the same
  games (does the critic still prefer the good actor to its own?).

    python benchmarks/collapse_anatomy.py /work/bsruns/diag/BlindSoccer-v0_GSN_seed7 \\
        --name collapse_anatomy_blind_soccer_gsn_seed7
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import checkpoints, write_results

ENV_ID = "BlindSoccer-v0"
KINDS = ("dash", "turn", "kick")


def anatomy(model_path: Path, seed: int, n_games: int) -> dict[str, Any]:
    """Play ``n_games`` games of seed ``seed`` with one checkpoint and count what each agent does."""
    from sb3_comm import make_comm_vec_env

    model = load(model_path)
    env = make_comm_vec_env(ENV_ID, n_envs=n_games, seed=seed)
    layout = env.comm_layout
    names = list(layout.agent_names)
    blind = names.index("blind")
    obs = env.reset()
    live = np.ones(n_games, dtype=bool)
    returns = np.zeros(n_games)
    kinds = np.zeros((2, 3))
    forward = turn_size = turn_after_turn = turns = 0.0
    previous_kind = np.full(n_games, -1)
    seen = []
    while live.any():
        seen.append(obs[live].copy())
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
    scores = score_statistics(model, np.concatenate(seen), blind)
    steps = kinds.sum(axis=1, keepdims=True)
    shares = kinds / np.maximum(steps, 1)
    return {
        "mean_return": float(returns.mean()),
        "shares": {name: dict(zip(KINDS, shares[a].tolist(), strict=True)) for a, name in enumerate(names)},
        "blind_forward_dash_share": forward / max(kinds[blind, 0], 1),
        "blind_mean_turn_degrees": turn_size / max(turns, 1),
        "blind_turn_after_turn_share": turn_after_turn / max(turns, 1),
        **scores,
    }


def score_statistics(model: Any, observations: np.ndarray, agent: int) -> dict[str, Any]:
    """The agent's action scores on the observations its team met: their means, the margin of the
    chosen score over the next one, and the critic's gradient ``dQ/ds`` on the chosen score and on
    the others (the ICLR 2016 agent's score gradient)."""
    import torch as th

    policy = model.policy
    obs = th.as_tensor(observations, dtype=th.float32).reshape(-1, *model.observation_space.shape)
    out = policy.actor_outputs(obs).detach().requires_grad_(True)
    grad = th.autograd.grad(policy.q_values(obs, out)[0][:, agent].sum(), out)[0][:, agent, :3]
    scores = out.detach()[:, agent, :3]
    top = scores.topk(2, dim=-1).values
    chosen = th.zeros_like(scores, dtype=th.bool)
    chosen[th.arange(len(scores)), scores.argmax(dim=-1)] = True
    return {
        "blind_scores_mean": scores.mean(dim=0).tolist(),
        "blind_score_margin": float((top[:, 0] - top[:, 1]).mean()),
        "blind_dq_chosen_score": float(grad[chosen].mean()),
        "blind_dq_other_scores": float(grad[~chosen].mean()),
    }


def load(path: Path) -> Any:
    from sb3_comm import CommDDPG

    return CommDDPG.load(path, device="cpu")


def swap_tables(paths: dict[int, Path], seed: int, n_games: int, oracle: float) -> dict[str, Any]:
    """Agents × GSN returns and critic × actor ratings of the checkpoints ``paths`` (see above)."""
    import copy

    import torch as th

    from sb3_comm import make_comm_vec_env
    from sb3_comm.evaluation import evaluate_team

    models = {steps: load(path) for steps, path in paths.items()}
    steps = sorted(models)
    returns = []
    for agents in steps:
        row = []
        for gsn in steps:
            model = models[agents]
            if gsn != agents:
                model = copy.deepcopy(model)
                model.policy.gsn.load_state_dict(models[gsn].policy.gsn.state_dict())
            team = evaluate_team(model, ENV_ID, n_episodes=n_games, seed=seed).team_returns
            row.append(float(team.mean()) / oracle)
        returns.append(row)
    # observations of the first checkpoint's team on the same games (60 steps, finished games too)
    first = models[steps[0]]
    env = make_comm_vec_env(ENV_ID, n_envs=n_games, seed=seed)
    obs, rows = env.reset(), []
    for _ in range(60):
        rows.append(obs.copy())
        obs, *_ = env.step(first.predict(obs, deterministic=True)[0])
    observations = th.as_tensor(np.concatenate(rows), dtype=th.float32)
    observations = observations.reshape(-1, *first.observation_space.shape)
    blind = list(first.comm_layout.agent_names).index("blind")
    ratings = []
    with th.no_grad():
        for critic in steps:
            policy = models[critic].policy
            ratings.append(
                [
                    float(
                        policy.q_values(observations, models[actor].policy.actor_outputs(observations))[0][
                            :, blind
                        ].mean()
                    )
                    for actor in steps
                ]
            )
    return {"steps": steps, "returns": returns, "critic_ratings": ratings}


def matrix(title: str, corner: str, labels: list[str], values: list[list[float]], fmt: str) -> list[str]:
    """A Markdown section with a square table of ``values``, rows and columns named ``labels``."""
    return [
        "",
        f"## {title}",
        "",
        f"| {corner} | " + " | ".join(labels) + " |",
        "|---|" + "---:|" * len(labels),
        *(
            f"| {label} | " + " | ".join(fmt.format(v) for v in row) + " |"
            for label, row in zip(labels, values, strict=True)
        ),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("run_dir", help="a run folder with checkpoints/model_<steps>_steps.zip")
    parser.add_argument("--seed", type=int, default=10_000, help="the games (solve.py's curve seed)")
    parser.add_argument("--games", type=int, default=100)
    parser.add_argument("--min-steps", type=int, default=0, help="skip earlier checkpoints")
    parser.add_argument("--swap", type=int, nargs="*", default=[], help="checkpoint steps to cross")
    parser.add_argument("--name", required=True)
    args = parser.parse_args()
    from sb3_comm.analysis.references import reference_returns

    oracle = reference_returns(ENV_ID, n_episodes=args.games, seed=args.seed)["oracle"]  # type: ignore[index]
    found = checkpoints(args.run_dir, args.min_steps)
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
        "blind mean turn (°) | blind turns after a turn | sighted: dash / turn / kick | "
        "blind scores (dash, turn, kick) | blind score margin | blind dQ/ds chosen | blind dQ/ds others |",
        "|---:|---:|---|---:|---:|---:|---|---|---:|---:|---:|",
    ]
    for p in points:
        blind, sighted = (" / ".join(f"{p['shares'][a][k]:.2f}" for k in KINDS) for a in ("blind", "sighted"))
        rows.append(
            f"| {p['timesteps']:,} | {p['fraction']:.2f} | {blind} | {p['blind_forward_dash_share']:.2f} | "
            f"{p['blind_mean_turn_degrees']:.0f} | {p['blind_turn_after_turn_share']:.2f} | {sighted} | "
            f"{', '.join(f'{v:.2f}' for v in p['blind_scores_mean'])} | {p['blind_score_margin']:.2f} | "
            f"{p['blind_dq_chosen_score']:+.4f} | {p['blind_dq_other_scores']:+.4f} |"
        )
    swap = None
    if args.swap:
        by_steps = dict(found)
        missing = [steps for steps in args.swap if steps not in by_steps]
        if missing:
            raise SystemExit(f"--swap: no checkpoints at steps {missing}; found {sorted(by_steps)}")
        swap = swap_tables({steps: by_steps[steps] for steps in args.swap}, args.seed, args.games, oracle)
        labels = [f"{steps // 1000}k" for steps in swap["steps"]]
        rows += matrix(
            "Which part collapsed: agents (rows) with another checkpoint's GSN (columns)",
            "agents from \\ GSN from", labels, swap["returns"], "{:.2f}",
        )  # fmt: skip
        rows += matrix(
            f"The blind agent's mean Q: each critic (rows) rates each actor (columns), on the "
            f"{labels[0]} team's observations",
            "critic from \\ actor from", labels, swap["critic_ratings"], "{:.3f}",
        )  # fmt: skip
    notes = (
        f"\n\nRun `{args.run_dir}`; every checkpoint plays the same {args.games} games (seed {args.seed}), "
        f"one episode each, deterministic; oracle on those games {oracle:.4f}. Shares are over the steps "
        "of the episodes still running. 'Dashes straight ahead': dashes whose direction is within "
        "±22.5° (the server's 45° grid makes them 0°). The sighted agent cannot move: its dash is a no-op. "
        "Scores, margin (chosen score minus the next highest) and the critic's gradient on the chosen "
        "score and on the others: the blind agent's, on the observations its team met in those games."
    )
    write_results(
        args.name,
        {"args": vars(args), "oracle": oracle, "points": points, "swap": swap},
        "\n".join(rows) + notes,
        title="Anatomy of a collapse: what the team does at each checkpoint",
    )


if __name__ == "__main__":
    main()
