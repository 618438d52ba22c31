"""How much GSN-MAX's effect search acts, per run: the share of messages it pulls and the share of
the reward its effect models explain, read from the runs' TensorBoard event files.

``gsn/search_pulled`` (fraction of a replayed batch's messages pulled towards a better candidate)
and ``gsn/effect_r2`` (the running R² of the effect models) are logged as means between points
(README, "Watching training in TensorBoard"). For each run this writes their mean over the whole
run and over its last three quarters, and their range over that part.

    python benchmarks/gsn_max_search_stats.py runs/experiments/gsn_max
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

TAGS = ("gsn/search_pulled", "gsn/effect_r2")
"""The effect search's scalars summarised here."""


def run_stats(tb_dir: Path) -> dict[str, dict[str, float]]:
    """The :data:`TAGS` of one run's TensorBoard folder (every event file in it): mean over the run,
    and mean, min and max over its last three quarters (by environment step)."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    points: dict[str, list[tuple[int, float]]] = {tag: [] for tag in TAGS}
    for path in sorted(tb_dir.rglob("events.out.tfevents.*")):
        events = EventAccumulator(str(path), size_guidance={"scalars": 0})
        events.Reload()
        for tag in TAGS:
            if tag in events.Tags()["scalars"]:
                points[tag] += [(e.step, e.value) for e in events.Scalars(tag)]
    stats: dict[str, dict[str, float]] = {}
    for tag, pairs in points.items():
        if not pairs:
            continue
        steps = np.array([s for s, _ in pairs])
        values = np.array([v for _, v in pairs])
        late = values[steps >= steps.max() / 4]
        stats[tag] = {
            "mean": float(values.mean()),
            "late_mean": float(late.mean()),
            "late_min": float(late.min()),
            "late_max": float(late.max()),
            "points": len(values),
        }
    return stats


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("experiment", type=Path, help="an experiment folder (its tb/<method>/<task>/seed<k>)")
    parser.add_argument("--method", default="GSN-MAX")
    parser.add_argument("--name", default="gsn_max_search_stats", help="result file stem")
    args = parser.parse_args()

    root = args.experiment / "tb" / args.method
    if not root.is_dir():
        raise SystemExit(f"No TensorBoard folder {root}: pass an experiment folder that ran {args.method}")
    runs: list[dict[str, Any]] = []
    for task_dir in sorted(p for p in root.iterdir() if p.is_dir()):
        for seed_dir in sorted(task_dir.glob("seed*"), key=lambda p: int(p.name[4:])):
            stats = run_stats(seed_dir)
            if stats:
                runs.append({"task": task_dir.name, "seed": int(seed_dir.name[4:]), **stats})
    if not runs:
        raise SystemExit(f"No {', '.join(TAGS)} in {root}: not an effect-search run")

    def cell(run: dict[str, Any], tag: str) -> str:
        s = run.get(tag)
        if s is None:
            return "—"
        return f"{s['mean']:.3f} | {s['late_mean']:.3f} [{s['late_min']:.3f}, {s['late_max']:.3f}]"

    lines = [
        f"Experiment `{args.experiment}`, method {args.method}. Means of TensorBoard's points (each a mean "
        "over the updates since the previous point); *late*: the last three quarters of the run, "
        "mean [min, max] of its points.",
        "",
        "| task | seed | pulled, run mean | pulled, late | effect R², run mean | effect R², late |",
        "|---|---:|---:|---:|---:|---:|",
        *[f"| {r['task']} | {r['seed']} | {cell(r, TAGS[0])} | {cell(r, TAGS[1])} |" for r in runs],
    ]
    data = {"experiment": str(args.experiment), "method": args.method, "runs": runs}
    title = "GSN-MAX's effect search: messages pulled, reward explained"
    write_results(args.name, data, "\n".join(lines), title=title)


if __name__ == "__main__":
    main()
