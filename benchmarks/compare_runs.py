"""Compare two run folders of ``sb3-comm train``: learning curves and trained parameters.

Used to show that a change of the code leaves training unchanged: train the same command before
and after the change (two checkouts), then

    python benchmarks/compare_runs.py BEFORE_RUN_DIR AFTER_RUN_DIR --name restructure_same_curve

compares every point of ``evaluations.json`` (steps, mean and standard deviation of the return,
per-agent returns, episode length) and every tensor of the saved policy (``policy.pth`` inside
``model.zip``, read with ``weights_only=True``), and writes ``benchmarks/results/<name>.{json,md}``.
"""

from __future__ import annotations

import argparse
import io
import json
import sys
import zipfile
from pathlib import Path
from typing import Any

import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

KEYS = ("timesteps", "mean_return", "std_return", "agent_mean_returns", "mean_length")


def _policy(run_dir: Path) -> dict[str, torch.Tensor]:
    with zipfile.ZipFile(run_dir / "model.zip") as archive:
        return torch.load(io.BytesIO(archive.read("policy.pth")), map_location="cpu", weights_only=True)


def compare(before: Path, after: Path) -> dict[str, Any]:
    """Point-by-point curve comparison and tensor-by-tensor parameter comparison."""
    curve_a = json.loads((before / "evaluations.json").read_text())
    curve_b = json.loads((after / "evaluations.json").read_text())
    points = [
        {
            "timesteps": a["timesteps"],
            "before": a["mean_return"],
            "after": b["mean_return"],
            "identical": all(a[k] == b[k] for k in KEYS),
        }
        for a, b in zip(curve_a, curve_b, strict=False)
    ]
    pa, pb = _policy(before), _policy(after)
    same_keys = sorted(pa) == sorted(pb)
    differing = [k for k in pa if k in pb and not torch.equal(pa[k], pb[k])]
    return {
        "before": str(before),
        "after": str(after),
        "curve": points,
        "curve_identical": len(curve_a) == len(curve_b) and all(p["identical"] for p in points),
        "n_tensors": [len(pa), len(pb)],
        "tensor_names_identical": same_keys,
        "tensors_differing": differing,
        "parameters_identical": same_keys and not differing,
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    parser.add_argument("--name", default="compare_runs")
    parser.add_argument("--note", default="", help="a sentence on what the two runs are")
    args = parser.parse_args()
    result = compare(args.before, args.after)
    rows = ["| env steps | return before | return after | identical |", "|---:|---:|---:|---|"]
    rows += [
        f"| {p['timesteps']:,} | {p['before']:.6f} | {p['after']:.6f} | {'yes' if p['identical'] else 'NO'} |"
        for p in result["curve"]
    ]
    body = "\n".join(rows) + (
        f"\n\nCurves identical: **{result['curve_identical']}**. Trained parameters identical "
        f"({result['n_tensors'][0]} tensors, same names): **{result['parameters_identical']}**."
        f"\n\n{args.note}"
    )
    write_results(
        args.name, {**result, "note": args.note}, body, title=f"Same run before and after: {args.name}"
    )


if __name__ == "__main__":
    main()
