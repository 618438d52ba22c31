"""Many solves judged at once: how many seeds of each pass the stability criteria, against the
oracle on the same games and, on Blind Soccer, against the visible oracle (``benchmarks/stability.py``
judges one solve in full; this is its one-line-per-solve summary).

    python benchmarks/stability_summary.py benchmarks/results/solve_blind_soccer_gsn_buffer1m_10seeds.json \\
        benchmarks/results/solve_blind_soccer_gsn_relabel_buffer1m_10seeds.json --method GSN

With ``--pool``, the solves are pieces of one experiment (the same model on different seeds, run
in several sittings): a last row judges all their seeds together, with the mean and rliable's IQM
of the final fractions and their 95 % stratified-bootstrap intervals. A seed found in two of them
is an error.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results
from stability import estimate_cells, has_visible_oracle, judge_runs, paired_oracles, paired_references

from sb3_comm.analysis.stats import interval_estimates


def judge(data: dict[str, Any], method: str, reach: float, floor: float) -> dict[str, Any]:
    """Per reference (``paired``: the oracle on the same games; ``visible``: Blind Soccer's
    visible oracle on the same games), the seeds that pass, the worst final fraction and every
    seed's final fraction (``finals``, in the order of ``seeds``)."""
    runs = sorted((r for r in data["runs"] if r["method"] == method), key=lambda r: r["seed"])
    if not runs:
        raise SystemExit(f"no run of method {method!r} in {data['name']}")
    by_seed = paired_references(data["env"], runs)
    references = {"paired": "oracle"}
    if has_visible_oracle(by_seed):
        references["visible"] = "visible_oracle"
    out: dict[str, Any] = {
        "seeds": [run["seed"] for run in runs],
        "params": data["args"].get("params", []),
        "conf": data["args"].get("conf"),
    }
    for key, reference in references.items():
        paired = paired_oracles(data["env"], runs, reference=reference, by_seed=by_seed)
        rows = judge_runs(runs, paired, reach, floor)
        out[key] = {
            "passed": [r["seed"] for r in rows if r["ends_above"] and r["stays_above_floor"]],
            "failed": [r["seed"] for r in rows if not (r["ends_above"] and r["stays_above_floor"])],
            "worst_final": min(r["final_fraction"] for r in rows),
            "mean_final": sum(r["final_fraction"] for r in rows) / len(rows),
            "finals": [r["final_fraction"] for r in rows],
        }
    return out


def pool(judged: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """All the solves' seeds judged together: passes, worst final and the interval estimates of
    the final fractions per reference. Raises ``SystemExit`` when a seed is in two solves, or when
    some solves have a reference (the visible oracle) that others lack."""
    seeds = [seed for j in judged.values() for seed in j["seeds"]]
    repeated = sorted({seed for seed in seeds if seeds.count(seed) > 1})
    if repeated:
        raise SystemExit(f"--pool: seeds {repeated} are in more than one solve; pool distinct seeds only")
    keys = [k for k in ("paired", "visible") if k in next(iter(judged.values()))]
    if any([k for k in ("paired", "visible") if k in j] != keys for j in judged.values()):
        raise SystemExit("--pool: the solves are not judged against the same references (different envs?)")
    out: dict[str, Any] = {"seeds": sorted(seeds)}
    for key in keys:
        finals = [f for j in judged.values() for f in j[key]["finals"]]
        out[key] = {
            "passed": sorted(s for j in judged.values() for s in j[key]["passed"]),
            "failed": sorted(s for j in judged.values() for s in j[key]["failed"]),
            "worst_final": min(finals),
            "final_fraction": interval_estimates(finals),
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
    parser.add_argument(
        "--pool", action="store_true", help="add a row judging all the solves' seeds together"
    )
    args = parser.parse_args()
    method = args.method.upper()
    judged = {}
    for path in args.solve_json:
        data = json.loads(Path(path).read_text())
        judged[Path(path).stem] = judge(data, method, args.reach, args.floor)
    visible = any("visible" in j for j in judged.values())
    header = "| solve | seeds | configuration, --params | passes (× oracle, same games) | worst final |"
    rule = "|---|---|---|---|---:|"
    if visible:
        header += " passes (× visible oracle, same games) | worst final | fails |"
        rule += "---|---:|---|"
    rows = [header, rule]
    for stem, j in judged.items():
        seeds = j["seeds"]
        span = f"{seeds[0]}–{seeds[-1]}" if seeds == list(range(seeds[0], seeds[-1] + 1)) else str(seeds)
        conf = f"`--conf {j['conf']}`" if j.get("conf") else "packaged"
        params = " ".join([conf] + [f"`{p}`" for p in j["params"]])
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
    pooled = pool(judged) if args.pool else None
    if pooled is not None:
        n = len(pooled["seeds"])
        p = pooled["paired"]
        rows.append(
            f"| **all, pooled** | {n} seeds | — | **{len(p['passed'])} of {n}**; "
            f"{', '.join(estimate_cells(p['final_fraction']))} | {p['worst_final']:.2f} |"
            + (
                f" **{len(pooled['visible']['passed'])} of {n}** | {pooled['visible']['worst_final']:.2f} | "
                f"{pooled['visible']['failed'] or '—'} |"
                if "visible" in pooled
                else (" — | — | — |" if visible else "")
            )
        )
    notes = (
        f"\n\n{method}'s runs in each solve, judged by `benchmarks/stability.py`'s rule: a seed passes "
        f"when its final evaluation is ≥ {args.reach} × the reference and, after its first periodic "
        f"evaluation at ≥ {args.reach} ×, none is below {args.floor} ×; each evaluation divided by the "
        "reference's return on the very games it played. The visible oracle "
        "(`envs.oracles.blind_soccer_visible_oracle`) is the oracle less the games whose blind agent "
        "the sighted agent cannot see (HFO 2016 hides a teammate at x <= 0; `benchmarks/hidden_teammate.py`)."
    )
    if pooled is not None:
        notes += (
            f" The pooled row judges the {len(pooled['seeds'])} seeds of all the solves together "
            f"(`--pool`: pieces of one experiment); against the oracle on the same games the seeds "
            f"{pooled['paired']['failed'] or 'none'} fail. Mean and IQM of the final fractions with "
            f"95 % stratified-bootstrap intervals ({pooled['paired']['final_fraction']['backend']})."
        )
    write_results(
        args.name,
        {"args": vars(args), "solves": judged, "pooled": pooled},
        "\n".join(rows) + notes,
        title=f"Every seed, every evaluation: {method}, many solves",
    )


if __name__ == "__main__":
    main()
