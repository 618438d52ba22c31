"""What a Blind Soccer team's protocol says, and how well its blind agent follows it.

For every checkpoint of each run folder (``benchmarks/solve.py --save-freq``), the deterministic
team plays ``--steps`` steps of ``--n-games`` games. At every step where the sighted agent sees
the blind agent (HFO 2016's features hide a blind agent at x <= 0), the script records the
message the blind agent hears, the true bearing of the ball from it (where the full-information
oracle would steer) and what the blind agent does. It then reports:

* *what the messages carry*: the share of the variance of the bearing's (sin, cos) that a probe
  fitted on the heard messages explains on held-out steps (R², scikit-learn: a linear probe and
  a k-nearest-neighbours one, which finds any function of the 4 numbers); high R² means the
  protocol tells the blind agent where the ball is;
* *how the blind agent uses them*: the share of its steps that are dashes, and the error of its
  heading when it dashes (the bearing less the dash direction, in degrees; the server rounds a
  dash direction to its 45° grid, so 22.5° is the best a dash can do everywhere);
* *how fast the protocol still changes*: between consecutive checkpoints, the mean change of the
  sighted agent's message on the same observations (those the last checkpoint's team meets), and
  the R² of a linear map from the earlier messages to the later ones (1: a re-coding at most).

A slow seed whose messages carry as much as a good seed's, and change as fast, has agents that
have not learned to read them; one whose messages carry less has a weaker protocol.

    python benchmarks/protocol_probe.py --runs seed0=runs/solve/BlindSoccer-v0_GSN_seed0 \\
        seed9=runs/solve/BlindSoccer-v0_GSN_seed9 --name protocol_probe_blind_soccer_gsn
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import checkpoints, write_results

ENV_ID = "BlindSoccer-v0"


def record(model: Any, n_games: int, steps: int, seed: int) -> dict[str, np.ndarray]:
    """Heard messages, ball bearings and the blind agent's actions on the visible steps, and every
    observation the team met (for :func:`drift`)."""
    from envs.oracles import _relative_angle, hidden_from_sighted
    from envs.tasks.blind_soccer import BLIND
    from sb3_comm import make_comm_vec_env

    env = make_comm_vec_env(ENV_ID, n_envs=n_games, seed=seed)
    layout = env.comm_layout
    blind = list(layout.agent_names).index("blind")
    heard_slice = layout.obs_message_slice
    obs = env.reset()
    heard, bearing, kind, dash_error, seen = [], [], [], [], []
    for _ in range(steps):
        state = env.task.state
        visible = ~hidden_from_sighted(state)
        target = state.ball_pos + state.ball_vel
        angle = _relative_angle(state, BLIND, target)  # degrees, relative to the blind agent's body
        action, _ = model.predict(obs, deterministic=True)
        rows = np.asarray(action).reshape(n_games, 2, -1)
        chosen = np.argmax(rows[:, blind, :3], axis=-1)  # 0 dash, 1 turn, 2 kick (ties: lowest)
        error = (angle - rows[:, blind, 4] + 180.0) % 360.0 - 180.0  # against the dash direction
        seen.append(obs.copy())
        heard.append(obs[visible, blind, heard_slice])
        bearing.append(np.radians(angle[visible]))
        kind.append(chosen[visible])
        dash_error.append(np.abs(error[visible]))
        obs, _, _, _ = env.step(action)
    return {
        "heard": np.concatenate(heard),
        "bearing": np.concatenate(bearing),
        "kind": np.concatenate(kind),
        "dash_error": np.concatenate(dash_error),
        "observations": np.concatenate(seen),
    }


def probe(data: dict[str, np.ndarray], seed: int) -> dict[str, float]:
    """Held-out R² of the bearing's (sin, cos) from the heard messages, and the blind agent's dashes."""
    from sklearn.linear_model import LinearRegression
    from sklearn.model_selection import train_test_split
    from sklearn.neighbors import KNeighborsRegressor

    x = data["heard"]
    y = np.stack([np.sin(data["bearing"]), np.cos(data["bearing"])], axis=1)
    x_train, x_test, y_train, y_test = train_test_split(x, y, test_size=0.3, random_state=seed)
    dash = data["kind"] == 0
    errors = data["dash_error"][dash]
    return {
        "visible_steps": len(x),
        "r2_linear": float(LinearRegression().fit(x_train, y_train).score(x_test, y_test)),
        "r2_knn": float(KNeighborsRegressor(n_neighbors=25).fit(x_train, y_train).score(x_test, y_test)),
        "dash_share": float(dash.mean()),
        "dash_heading_error_deg": float(errors.mean()) if dash.any() else float("nan"),
        "dash_within_22_5_deg": float((errors <= 22.5).mean()) if dash.any() else float("nan"),
    }


def sighted_messages(model: Any, observations: np.ndarray) -> np.ndarray:
    """The sighted agent's messages on ``observations`` ``(N, 2, obs_dim)``."""
    import torch as th

    policy = model.policy
    sighted = list(policy.comm_layout.agent_names).index("sighted")
    obs = th.as_tensor(observations, dtype=th.float32)
    with th.no_grad():
        return policy.comm_method.messages(policy, obs, policy.actor_outputs(obs))[:, sighted].numpy()


def drift(earlier: np.ndarray, later: np.ndarray) -> dict[str, float]:
    """How much the messages changed: their mean absolute change, and the R² of a linear map from
    the earlier messages to the later ones."""
    from sklearn.linear_model import LinearRegression

    return {
        "mean_abs_change": float(np.abs(later - earlier).mean()),
        "r2_linear_map": float(LinearRegression().fit(earlier, later).score(earlier, later)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--runs", nargs="+", required=True, help="label=run_folder ...")
    parser.add_argument("--n-games", type=int, default=64)
    parser.add_argument("--steps", type=int, default=400)
    parser.add_argument("--seed", type=int, default=4242, help="seed of the games played")
    parser.add_argument(
        "--every", type=int, default=200_000, help="probe the checkpoints at multiples of this"
    )
    parser.add_argument("--name", default="protocol_probe_blind_soccer")
    args = parser.parse_args()

    import torch as th

    from sb3_comm import CommDDPG

    th.set_num_threads(1)
    results: dict[str, Any] = {}
    probe_rows = [
        "| run | steps | visible steps | R² linear | R² k-NN | blind agent's dashes | "
        "dash heading error (°) | dashes within 22.5° |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    drift_rows = [
        "| run | checkpoints | mean change of a message | R² of a linear map |",
        "|---|---|---:|---:|",
    ]
    for item in args.runs:
        label, _, folder = item.partition("=")
        if not folder:
            raise SystemExit(f"--runs takes label=run_folder; got {item!r}")
        found = checkpoints(folder)
        if not found:
            raise SystemExit(f"{folder}: no checkpoints/model_<steps>_steps.zip (train with --save-freq)")
        models = {step: CommDDPG.load(path, device="cpu") for step, path in found}
        last = max(models)
        probes, recorded = {}, {}
        for step, model in models.items():
            if step % args.every == 0 or step == last:
                recorded[step] = record(model, args.n_games, args.steps, args.seed)
                probes[step] = probe(recorded[step], args.seed)
                r = probes[step]
                cells = [
                    f"{r['visible_steps']:,}",
                    f"{r['r2_linear']:.3f}",
                    f"{r['r2_knn']:.3f}",
                    f"{r['dash_share']:.3f}",
                    f"{r['dash_heading_error_deg']:.1f}",
                    f"{r['dash_within_22_5_deg']:.3f}",
                ]
                probe_rows.append(f"| {label} | {step:,} | " + " | ".join(cells) + " |")
                print(label, step, r, flush=True)
        observations = recorded[last]["observations"]
        messages = {step: sighted_messages(model, observations) for step, model in models.items()}
        steps = sorted(messages)
        drifts = {}
        for a, b in itertools.pairwise(steps):
            d = drifts[f"{a}-{b}"] = drift(messages[a], messages[b])
            span = f"{a // 1000}k → {b // 1000}k"
            drift_rows.append(f"| {label} | {span} | {d['mean_abs_change']:.3f} | {d['r2_linear_map']:.2f} |")
        results[label] = {"run": folder, "probe": {str(k): v for k, v in probes.items()}, "drift": drifts}
    notes = (
        f"\n\n{args.n_games} games × {args.steps} steps of each checkpoint's deterministic team (games of "
        f"seed {args.seed}, reset when they end), on the steps where the sighted agent sees the blind agent. "
        "R²: the share of the variance of the ball's bearing from the blind agent, as (sin, cos), that a "
        "probe fitted on the message the blind agent hears explains on 30 % held-out steps (k-NN: 25 "
        "neighbours). Heading error: |bearing − dash direction| on the blind agent's dashes (the server "
        "rounds a dash direction to 45°). Second table: the sighted agent's messages of consecutive "
        "checkpoints on the observations that the last checkpoint's team met."
    )
    write_results(
        args.name,
        {"args": vars(args), "runs": results},
        "\n".join(probe_rows) + "\n\n" + "\n".join(drift_rows) + notes,
        title="What a Blind Soccer protocol says, how the blind agent follows it, how fast it changes",
    )


if __name__ == "__main__":
    main()
