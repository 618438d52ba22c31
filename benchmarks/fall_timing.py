"""When do the collapses happen? Falls of the periodic evaluations, by training step, over many runs.

Takes ``label=path`` pairs of ``benchmarks/solve.py`` results files (the same task) and counts, for
every evaluation step, the runs that had already learned (their best evaluation so far at
≥ ``--learned`` × oracle) and, among them, those whose evaluation falls ``--fall`` × oracle or more
below that best. Fractions are of the oracle on the same games (:func:`stability.paired_oracles`).
Also, per run: the first step at ``--learned``, the steps of its falls, and how long after the
first step they came. A fall that follows the training step (a schedule, the replay's length)
clusters in the first table; one that follows the learning (time since the team learned) in the
second column of the per-run list.

    python benchmarks/fall_timing.py packaged=benchmarks/results/solve_blind_soccer_gsn_10seeds.json \\
        --name fall_timing_blind_soccer_gsn
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results
from stability import paired_oracles
from stability_variants import labelled_paths, sources_text, step_fractions

BIN = 25_000
"""Evaluation steps are grouped by this many steps (``benchmarks/solve.py --eval-freq 25000``)."""


def run_falls(run: dict[str, Any], oracle: float, learned: float, fall: float) -> dict[str, Any]:
    """One run's curve: first step at ``learned`` × oracle, and the evaluations that fell.

    :return: ``first_learned`` (step or None), ``eligible`` (bins evaluated after learning),
        ``falls`` (``(bin, fraction)``).
    """
    best, first, eligible, falls = -float("inf"), None, [], []
    for point in run["curve"]:
        step, fraction = point["timesteps"], point["mean_return"] / oracle
        here = step // BIN * BIN
        if best >= learned:
            eligible.append(here)
            if best - fraction >= fall:
                falls.append((here, round(fraction, 2)))
        if fraction >= learned and first is None:
            first = here
        best = max(best, fraction)
    return {"first_learned": first, "eligible": eligible, "falls": falls}


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("variants", nargs="+", help="label=path of a benchmarks/solve.py results file")
    parser.add_argument("--learned", type=float, default=0.7, help="a run has learned from this fraction on")
    parser.add_argument("--fall", type=float, default=0.25, help="a fall: this far below the best so far")
    parser.add_argument("--name", required=True)
    args = parser.parse_args()
    rows, tasks = [], set()
    pairs = labelled_paths(args.variants)
    for label, path in pairs:
        data = json.loads(Path(path).read_text())
        tasks.add(data["env"])
        paired = paired_oracles(data["env"], data["runs"])
        for run in sorted(data["runs"], key=lambda r: r["seed"]):
            oracle = paired[str(run["eval"]["seeds"]["curve"])]
            falls = run_falls(run, oracle, args.learned, args.fall)
            rows.append({"variant": label, "seed": run["seed"], **falls})
    if len(tasks) != 1:
        raise SystemExit(f"the runs were made on different tasks: {sorted(tasks)}")

    eligible = Counter(step for r in rows for step in r["eligible"])
    falling = Counter(step for r in rows for step, _ in r["falls"])
    by_step = [
        "| evaluation at step | runs that had learned | of them falling | share |",
        "|---:|---:|---:|---:|",
    ]
    for step in sorted(eligible):
        share = falling[step] / eligible[step]
        by_step.append(f"| {step // 1000}k | {eligible[step]} | {falling[step]} | {share:.2f} |")
    per_run = [
        f"| variant | seed | first ≥ {args.learned} at | falls (step: fraction) | steps after the first |",
        "|---|---:|---:|---|---|",
    ]
    for r in rows:
        first = r["first_learned"]
        falls = step_fractions(r["falls"])
        after = ", ".join(f"{(s - first) // 1000}k" for s, _ in r["falls"]) if first is not None else ""
        per_run.append(
            f"| {r['variant']} | {r['seed']} | {'never' if first is None else f'{first // 1000}k'} | "
            f"{falls} | {after or '—'} |"
        )
    sources = sources_text(pairs)
    notes = (
        f"\n\nTask `{tasks.pop()}`, {len(rows)} runs. A run has learned once a periodic evaluation "
        f"reached {args.learned} × oracle; an evaluation falls when it is ≥ {args.fall} × oracle below "
        f"the best one before it. Steps are grouped by {BIN // 1000}k. Fractions of the oracle on the "
        f"same games. Sources: {sources}."
    )
    write_results(
        args.name,
        {"args": vars(args), "rows": rows, "eligible": dict(eligible), "falling": dict(falling)},
        "\n".join(by_step) + "\n\n" + "\n".join(per_run) + notes,
        title="When the collapses happen: falls of the periodic evaluations by training step",
    )


if __name__ == "__main__":
    main()
