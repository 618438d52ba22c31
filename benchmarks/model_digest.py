"""Whether two versions of the code train the same models: a digest of every method's parameters.

Each method trains CommDDPG on ``--env`` for ``--steps`` environment steps from one seed, with the
packaged layer sizes; the script writes the SHA-256 of each policy's parameters and buffers. Run
it at two commits (the older one with ``PYTHONPATH`` pointing at its checkout) and compare the
files: equal digests mean the same model, to the bit. Speed work must keep them equal.

    python benchmarks/model_digest.py --name model_digest_after
    cd ../old && PYTHONPATH=. python benchmarks/model_digest.py --name model_digest_before
"""

from __future__ import annotations

import argparse
import hashlib
import sys
from pathlib import Path

import torch as th

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_threads_option, apply_threads_option, write_results

from sb3_comm import METHODS, CommDDPG, make_comm_vec_env


def digest(model: CommDDPG) -> str:
    """SHA-256 of the policy's state (names, shapes and bytes, in order)."""
    sha = hashlib.sha256()
    for name, tensor in model.policy.state_dict().items():
        sha.update(name.encode())
        sha.update(str(tuple(tensor.shape)).encode())
        sha.update(tensor.detach().cpu().contiguous().numpy().tobytes())
    return sha.hexdigest()


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--env", default="BlindSoccer-v0")
    parser.add_argument("--methods", nargs="+", default=list(METHODS))
    parser.add_argument("--steps", type=int, default=4000)
    parser.add_argument("--n-envs", type=int, default=16)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--name", default="model_digest")
    add_threads_option(parser)
    args = parser.parse_args()
    apply_threads_option(args)
    digests = {}
    for method in args.methods:
        env = make_comm_vec_env(args.env, n_envs=args.n_envs, seed=args.seed)
        # GSN pinned to the paper's reward model and every method to its actor playing, so that
        # digests compare with those made before CommDDPG's defaults became
        # gsn_reward_sees_teammate=True and averaged_actor=True (whose average adds parameters)
        kwargs = {
            "net_arch": [256, 256],
            "averaged_actor": False,
            **({"gsn_reward_sees_teammate": False} if method == "GSN" else {}),
        }
        model = CommDDPG(
            method, env, policy_kwargs=kwargs, batch_size=64, learning_starts=500,
            mc_mixing=0.5, seed=args.seed, device="cpu",
        )  # fmt: skip
        model.learn(args.steps)
        digests[method] = digest(model)
        print(method, digests[method], flush=True)
    rows = ["| method | SHA-256 of the policy's state |", "|---|---|"]
    rows += [f"| {m} | `{d}` |" for m, d in digests.items()]
    notes = (
        f"\n\n`{args.env}`, {args.n_envs} games, {args.steps} env steps, seed {args.seed}, "
        f"[256, 256] layers, batch 64, learning from 500 steps, β 0.5, torch threads {th.get_num_threads()}. "
        "Equal digests from two commits: the same trained model, to the bit."
    )
    write_results(args.name, {"args": vars(args), "digests": digests}, "\n".join(rows) + notes,
                  title="Trained-model digests")  # fmt: skip


if __name__ == "__main__":
    main()
