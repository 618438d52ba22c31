"""Learner variants side by side, seed by seed: what each did to the mid-run collapses.

Takes ``label=path`` pairs of ``benchmarks/solve.py`` results files (one variant each, the same
task) and writes one table: per variant and seed, the final return and the lowest periodic
evaluation after the first one at ≥ ``--reach`` × oracle, each as a fraction of the oracle on the
same games (:func:`stability.paired_oracles`), and the collapses (evaluations below ``--floor`` ×
oracle after that first one), and the largest fall of a periodic evaluation below the best one
before it, once one reached :data:`LEARNED` (a collapse, whether or not the seed reached the bar).

    python benchmarks/stability_variants.py packaged=benchmarks/results/solve_a.json \\
        relabel=benchmarks/results/solve_b.json --name blind_soccer_gsn_variants
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results
from stability import paired_oracles, reach_cells, seed_row

LEARNED = 0.5
"""A collapse is measured from the first periodic evaluation at this fraction of the oracle on: the
early swings of a team that has learned nothing yet are not collapses."""


def drawdown(fractions: list[float]) -> float:
    """The largest fall of a curve below the best reading before it, counted once the best has
    reached :data:`LEARNED` (0 for a curve that never falls or never learns)."""
    best, fall = -float("inf"), 0.0
    for fraction in fractions:
        best = max(best, fraction)
        if best >= LEARNED:
            fall = max(fall, best - fraction)
    return fall


def labelled_paths(items: list[str]) -> list[tuple[str, str]]:
    """``label=path`` arguments as ``(label, path)`` pairs; anything else is an error."""
    pairs = []
    for item in items:
        label, _, path = item.partition("=")
        if not path:
            raise SystemExit(f"expected label=path, got {item!r}")
        pairs.append((label, path))
    return pairs


def sources_text(pairs: list[tuple[str, str]]) -> str:
    """The results files a table was made from: ``label: `path`; ...``."""
    return "; ".join(f"{label}: `{path}`" for label, path in pairs)


def step_fractions(points: list[tuple[int, float]]) -> str:
    """``(step, fraction)`` pairs as ``425k: 0.50, ...``, or ``none``."""
    return ", ".join(f"{step // 1000}k: {value:.2f}" for step, value in points) or "none"


def variant_rows(label: str, path: str, reach: float, floor: float) -> tuple[str, list[dict[str, Any]]]:
    """The per-seed criteria of one variant's results file; returns its task and the rows."""
    data = json.loads(Path(path).read_text())
    runs = sorted(data["runs"], key=lambda r: r["seed"])
    paired = paired_oracles(data["env"], runs)
    rows = []
    for run in runs:
        curve_oracle = paired[str(run["eval"]["seeds"]["curve"])]
        row = seed_row(
            run, curve_oracle, reach, floor, final_oracle=paired[str(run["eval"]["seeds"]["final"])]
        )
        fractions = [(p["timesteps"], p["mean_return"] / curve_oracle) for p in run["curve"]]
        first = row["first_reach_step"]
        row["collapses"] = [
            (step, round(fraction, 2))
            for step, fraction in fractions
            if first is not None and step > first
            if fraction < floor
        ]
        row["drawdown"] = drawdown([fraction for _, fraction in fractions])
        row.update(variant=label, source=path, settings=run.get("hyperparams", {}))
        rows.append(row)
    return data["env"], rows


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("variants", nargs="+", help="label=path of a benchmarks/solve.py results file")
    parser.add_argument("--reach", type=float, default=0.9)
    parser.add_argument("--floor", type=float, default=0.8)
    parser.add_argument("--name", required=True)
    args = parser.parse_args()
    tasks, all_rows = set(), []
    pairs = labelled_paths(args.variants)
    for label, path in pairs:
        task, rows = variant_rows(label, path, args.reach, args.floor)
        tasks.add(task)
        all_rows.extend(rows)
    if len(tasks) != 1:
        raise SystemExit(f"the variants were run on different tasks: {sorted(tasks)}")
    table = [
        f"| variant | seed | final (× oracle) | first ≥ {args.reach} at step | lowest later | "
        f"evaluations below {args.floor} after it (step: fraction) | largest fall from the best so far | "
        "passes |",
        "|---|---:|---:|---:|---:|---|---:|---|",
    ]
    for r in all_rows:
        first, lowest = reach_cells(r)
        collapses = step_fractions(r["collapses"])
        ok = r["ends_above"] and r["stays_above_floor"]
        table.append(
            f"| {r['variant']} | {r['seed']} | {r['final_fraction']:.2f} | {first} | {lowest} | "
            f"{collapses} | {r['drawdown']:.2f} | {'yes' if ok else '**no**'} |"
        )
    sources = sources_text(pairs)
    notes = (
        f"\n\nTask `{tasks.pop()}`. Fractions of the oracle's return on the same 100 games (periodic "
        f"evaluations and final evaluation each on their own games). A seed passes when it ends at ≥ "
        f"{args.reach} × oracle and, after its first periodic evaluation at ≥ {args.reach}, none drops "
        f"below {args.floor}. The largest fall is counted from the first evaluation at ≥ {LEARNED} on. "
        f"Sources: {sources}."
    )
    write_results(
        args.name,
        {"args": vars(args), "rows": all_rows},
        "\n".join(table) + notes,
        title="Learner variants, seed by seed",
    )


if __name__ == "__main__":
    main()
