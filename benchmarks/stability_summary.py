"""Many solves judged at once: how many seeds of each pass the stability criteria, against the
oracle on the same games and, on Blind Soccer, against the visible oracle (``benchmarks/stability.py``
judges one solve in full; this is its one-line-per-solve summary).

    python benchmarks/stability_summary.py benchmarks/results/solve_blind_soccer_gsn_buffer1m_10seeds.json \\
        benchmarks/results/solve_blind_soccer_gsn_relabel_buffer1m_10seeds.json --method GSN
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results
from stability import has_visible_oracle, judge_runs, paired_oracles, paired_references


def judge(data: dict[str, Any], method: str, reach: float, floor: float) -> dict[str, Any]:
    """Per reference (``paired``: the oracle on the same games; ``visible``: Blind Soccer's
    visible oracle on the same games), the seeds that pass and the worst final fraction."""
    runs = sorted((r for r in data["runs"] if r["method"] == method), key=lambda r: r["seed"])
    if not runs:
        raise SystemExit(f"no run of method {method!r} in {data['name']}")
    by_seed = paired_references(data["env"], runs)
    references = {"paired": "oracle"}
    if has_visible_oracle(by_seed):
        references["visible"] = "visible_oracle"
    out: dict[str, Any] = {"seeds": [run["seed"] for run in runs], "params": data["args"].get("params", [])}
    for key, reference in references.items():
        paired = paired_oracles(data["env"], runs, reference=reference, by_seed=by_seed)
        rows = judge_runs(runs, paired, reach, floor)
        out[key] = {
            "passed": [r["seed"] for r in rows if r["ends_above"] and r["stays_above_floor"]],
            "failed": [r["seed"] for r in rows if not (r["ends_above"] and r["stays_above_floor"])],
            "worst_final": min(r["final_fraction"] for r in rows),
            "mean_final": sum(r["final_fraction"] for r in rows) / len(rows),
        }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("solve_json", nargs="+", help="results files of benchmarks/solve.py")
    parser.add_argument("--method", required=True)
    parser.add_argument("--reach", type=float, default=0.9)
    parser.add_argument("--floor", type=float, default=0.8)
    parser.add_argument("--name", required=True, help="result file stem")
    args = parser.parse_args()
    method = args.method.upper()
    judged = {}
    for path in args.solve_json:
        data = json.loads(Path(path).read_text())
        judged[Path(path).stem] = judge(data, method, args.reach, args.floor)
    visible = any("visible" in j for j in judged.values())
    header = "| solve | seeds | --params | passes (× oracle, same games) | worst final |"
    rule = "|---|---|---|---|---:|"
    if visible:
        header += " passes (× visible oracle, same games) | worst final | fails |"
        rule += "---|---:|---|"
    rows = [header, rule]
    for stem, j in judged.items():
        seeds = j["seeds"]
        span = f"{seeds[0]}–{seeds[-1]}" if seeds == list(range(seeds[0], seeds[-1] + 1)) else str(seeds)
        params = " ".join(f"`{p}`" for p in j["params"]) or "packaged"
        row = (
            f"| [{stem}]({stem}.md) | {span} | {params} | {len(j['paired']['passed'])} of {len(seeds)} | "
            f"{j['paired']['worst_final']:.2f} |"
        )
        if visible:
            v = j.get("visible")
            row += (
                f" {len(v['passed'])} of {len(seeds)} | {v['worst_final']:.2f} | {v['failed'] or '—'} |"
                if v
                else " — | — | — |"
            )
        rows.append(row)
    notes = (
        f"\n\n{method}'s runs in each solve, judged by `benchmarks/stability.py`'s rule: a seed passes "
        f"when its final evaluation is ≥ {args.reach} × the reference and, after its first periodic "
        f"evaluation at ≥ {args.reach} ×, none is below {args.floor} ×; each evaluation divided by the "
        "reference's return on the very games it played. The visible oracle "
        "(`envs.oracles.blind_soccer_visible_oracle`) is the oracle less the games whose blind agent "
        "the sighted agent cannot see (HFO 2016 hides a teammate at x <= 0; `benchmarks/hidden_teammate.py`)."
    )
    write_results(
        args.name,
        {"args": vars(args), "solves": judged},
        "\n".join(rows) + notes,
        title=f"Every seed, every evaluation: {method}, many solves",
    )


if __name__ == "__main__":
    main()
