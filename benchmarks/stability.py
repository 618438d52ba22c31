"""Every seed, every evaluation: the stability criteria of a many-seed solve (issue "a learner that
works on every seed").

Reads the JSON that ``benchmarks/solve.py`` wrote and reports, per seed, the final return as a
fraction of the oracle, the first periodic evaluation at or above ``--reach`` × oracle, and the
lowest periodic evaluation after it. A seed passes when it ends at ≥ ``--reach`` × oracle and no
evaluation after that first one drops below ``--floor`` × oracle. Also the mean and the IQM of the
final fractions with their 95 % stratified-bootstrap intervals (rliable).

    python benchmarks/stability.py benchmarks/results/solve_guess_my_number_tcg_10seeds.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

from sb3_comm.analysis.stats import interval_estimates


def seed_row(run: dict[str, Any], oracle: float, reach: float, floor: float) -> dict[str, Any]:
    """The criteria of one run: final fraction, first step at ``reach``, lowest fraction after it."""
    final = run["final"]["none"]["mean_return"] / oracle
    curve = [(point["timesteps"], point["mean_return"] / oracle) for point in run["curve"]]
    first = next((i for i, (_, fraction) in enumerate(curve) if fraction >= reach), None)
    later = [fraction for _, fraction in curve[first + 1 :]] if first is not None else []
    lowest = min(later) if later else None
    return {
        "seed": run["seed"],
        "final_fraction": final,
        "first_reach_step": curve[first][0] if first is not None else None,
        "lowest_after_reach": lowest,
        "ends_above": final >= reach,
        "stays_above_floor": first is not None and (lowest is None or lowest >= floor),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("solve_json", help="a results file of benchmarks/solve.py")
    parser.add_argument("--reach", type=float, default=0.9)
    parser.add_argument("--floor", type=float, default=0.8)
    parser.add_argument("--name", default=None)
    args = parser.parse_args()
    data = json.loads(Path(args.solve_json).read_text())
    oracle = data["oracle_return"]
    rows_data = [
        seed_row(run, oracle, args.reach, args.floor) for run in sorted(data["runs"], key=lambda r: r["seed"])
    ]
    methods = sorted({run["method"] for run in data["runs"]})
    estimates = interval_estimates([r["final_fraction"] for r in rows_data])
    passed = [r for r in rows_data if r["ends_above"] and r["stays_above_floor"]]
    rows = [
        f"| seed | final (× oracle) | first ≥ {args.reach} × oracle at step "
        "| lowest later evaluation (× oracle) | ends ≥ bar | never below floor after | passes |",
        "|---:|---:|---:|---:|---|---|---|",
    ]
    for r in rows_data:
        first = f"{r['first_reach_step']:,}" if r["first_reach_step"] is not None else "never"
        lowest = f"{r['lowest_after_reach']:.2f}" if r["lowest_after_reach"] is not None else "—"
        ok = r["ends_above"] and r["stays_above_floor"]
        rows.append(
            f"| {r['seed']} | {r['final_fraction']:.2f} | {first} | {lowest} | "
            f"{'yes' if r['ends_above'] else 'no'} | {'yes' if r['stays_above_floor'] else 'no'} | "
            f"{'yes' if ok else '**no**'} |"
        )
    mean = estimates["mean"]
    summary = [f"mean {mean['point']:.2f} [{mean['low']:.2f}, {mean['high']:.2f}]"]
    if "iqm" in estimates:
        iqm = estimates["iqm"]
        summary.append(f"IQM {iqm['point']:.2f} [{iqm['low']:.2f}, {iqm['high']:.2f}]")
    worst = min(rows_data, key=lambda r: r["final_fraction"])
    notes = (
        f"\n\n{', '.join(methods)} on `{data['env']}`, from `{args.solve_json}` (oracle {oracle:.4f}). "
        f"**{len(passed)} of {len(rows_data)} seeds pass.** Final fraction of the oracle: "
        f"{'; '.join(summary)} (95 % stratified bootstrap, {estimates['backend']}); worst seed "
        f"{worst['seed']} at {worst['final_fraction']:.2f}. A seed passes when it ends at ≥ {args.reach} × "
        f"oracle (final evaluation, 100 games) and, after its first periodic evaluation at ≥ {args.reach} "
        f"× oracle, none drops below {args.floor} × oracle."
    )
    write_results(
        args.name or f"stability_{Path(args.solve_json).stem}",
        {"args": vars(args), "oracle": oracle, "seeds": rows_data, "final_fraction": estimates},
        "\n".join(rows) + notes,
        title=f"Every seed, every evaluation: {', '.join(methods)} on {data['env']}",
    )


if __name__ == "__main__":
    main()
