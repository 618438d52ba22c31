"""What a trained team's messages look like, and how much its receivers' critics read them.

For each model, the deterministic team plays ``--steps`` steps of ``--n-envs`` games; at every
step this records each sender's message ``m_i`` (per channel dimension: its mean and its spread
over the states visited) and the receiver's critic slope ``∂Q_j(o'_j ⊕ m_i, a'_j)/∂m_i`` at the
receiver's next observation (TCG's and GSN-MAX's maximising signal, before any scaling): its mean
and its spread over the states. A channel in use has messages that vary with the state and a
receiver whose slope is large and changes with the state; a slope that is small and the same in
every state pushes every message the same way.

    python benchmarks/message_anatomy.py --models both=runs/x/model.zip grounding=runs/y/model.zip
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch as th

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

from sb3_comm import CommDDPG, make_comm_vec_env
from sb3_comm.comm_ddpg.methods import TCG


def anatomy(model: CommDDPG, env_id: str, n_envs: int, steps: int, seed: int) -> dict[str, list]:
    """Per agent and channel dimension: message mean and spread, the receiver's slope mean and spread."""
    policy = model.policy
    env = make_comm_vec_env(env_id, n_envs=n_envs, seed=seed)
    obs = env.reset()
    sent, slopes = [], []
    for _ in range(steps):
        obs_t = th.as_tensor(obs, dtype=th.float32)
        with th.no_grad():
            messages = policy.comm_method.messages(policy, obs_t, policy.actor_outputs(obs_t))
        actions, _ = model.predict(obs, deterministic=True)
        obs, _, dones, _ = env.step(actions)
        done = th.as_tensor(dones, dtype=th.float32).reshape(-1, 1)
        next_t = th.as_tensor(obs, dtype=th.float32)
        slopes.append(TCG.receiver_message_gradients(policy, messages, next_t, done)[done[:, 0] == 0].numpy())
        sent.append(messages.numpy())
    env.close()
    m, g = np.concatenate(sent), np.concatenate(slopes)  # (N, 2, n)
    return {
        "message_mean": m.mean(0).tolist(),
        "message_std": m.std(0).tolist(),
        "slope_mean": g.mean(0).tolist(),
        "slope_std": g.std(0).tolist(),
        "states": len(g),
    }


def _fmt(values: list[float], digits: int) -> str:
    return " ".join(f"{v:+.{digits}f}" for v in values)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--models", nargs="+", required=True, help="label=path/to/model.zip")
    parser.add_argument("--env", default="BlindSoccer-v0")
    parser.add_argument("--n-envs", type=int, default=16)
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--name", default="message_anatomy")
    args = parser.parse_args()
    th.set_num_threads(1)
    results, rows = {}, []
    rows.append(
        "| model | method, signals | agent (sender) | message mean per dimension "
        "| message spread over states | receiver slope mean | receiver slope spread over states |"
    )
    rows.append("|---|---|---:|---|---|---|---|")
    for item in args.models:
        label, _, path = item.partition("=")
        if not path:
            raise SystemExit(f"--models takes label=path pairs, got {item!r}")
        model = CommDDPG.load(path, device="cpu")
        result = anatomy(model, args.env, args.n_envs, args.steps, args.seed)
        signals = getattr(model, "gsn_max_signals", "both") if model.method == "GSN-MAX" else "—"
        results[label] = {
            "path": path,
            "method": model.method,
            "signals": signals,
            "steps": model.num_timesteps,
            **result,
        }
        for agent in range(2):
            rows.append(
                f"| {label} ({model.num_timesteps:,} steps) | {model.method}, {signals} | {agent} "
                f"| {_fmt(result['message_mean'][agent], 3)} | {_fmt(result['message_std'][agent], 3)} "
                f"| {_fmt(result['slope_mean'][agent], 4)} | {_fmt(result['slope_std'][agent], 4)} |"
            )
    notes = (
        f"\n\n`{args.env}`, {args.n_envs} games × {args.steps} steps of the deterministic team "
        f"(seed {args.seed}). "
        "Message spread: the standard deviation over the states visited, per channel dimension. Receiver "
        "slope: ∂Q_j/∂m_i of the sender's receiver's critic at its next observation holding m_i (terminal "
        "steps left out), per dimension, its mean and standard deviation over the states."
    )
    write_results(
        args.name,
        {"args": vars(args), "models": results},
        "\n".join(rows) + notes,
        title="Messages and the receivers' critic slopes of trained teams",
    )


if __name__ == "__main__":
    main()
