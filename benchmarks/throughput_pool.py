"""Pool the rounds of several ``train_throughput.py`` runs into one overhead per method, with a
95 % bootstrap interval.

On a shared VM one run's median over 8 rounds moves by ±0.1 between runs of the same code (the
round ratios against TD3 of one model spread over 0.8-1.5). Every round is a paired measurement
(each model timed right after the others), so the rounds of runs of the same code can be pooled:
the overhead is the median of all their ratios, the interval a percentile bootstrap of that median.
Groups of runs (e.g. before and after a change) are compared side by side.

    python benchmarks/throughput_pool.py --group before train_throughput_a train_throughput_b \\
        --group after train_throughput_c train_throughput_d --name train_throughput_pooled
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import RESULTS_DIR, write_results

from sb3_comm.results import read_json


def round_ratios(names: list[str]) -> dict[str, list[float]]:
    """Per method, TD3's rate over the method's in every round of the result files ``names``."""
    ratios: dict[str, list[float]] = {}
    for name in names:
        data = read_json(RESULTS_DIR / f"{name}.json")
        rounds = data.get("env_steps_per_second_rounds")
        if not rounds or "TD3" not in rounds:
            raise ValueError(
                f"{name}.json holds no rounds of train_throughput.py (env_steps_per_second_rounds)"
            )
        for method, rates in rounds.items():
            if method != "TD3":
                ratios.setdefault(method, []).extend(t / r for t, r in zip(rounds["TD3"], rates, strict=True))
    return ratios


def median_interval(values: list[float], samples: int = 5000, seed: int = 0) -> tuple[float, float, float]:
    """The median of ``values`` and a 95 % percentile-bootstrap interval of it."""
    array = np.asarray(values)
    rng = np.random.default_rng(seed)
    medians = np.median(rng.choice(array, size=(samples, len(array))), axis=1)
    return float(np.median(array)), float(np.percentile(medians, 2.5)), float(np.percentile(medians, 97.5))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--group",
        nargs="+",
        action="append",
        required=True,
        metavar=("LABEL", "RESULT"),
        help="a label, then the result names (stems in benchmarks/results) of its runs",
    )
    parser.add_argument("--name", required=True, help="result file stem")
    args = parser.parse_args()
    groups = {}
    for label, *names in args.group:
        if not names:
            parser.error(f"--group {label}: no result names")
        groups[label] = {"runs": names, "ratios": round_ratios(names)}
    methods = list(next(iter(groups.values()))["ratios"])
    summary: dict[str, dict[str, dict[str, float]]] = {}
    for label, group in groups.items():
        summary[label] = {}
        for method in methods:
            median, low, high = median_interval(group["ratios"][method])
            summary[label][method] = {
                "median": median,
                "low": low,
                "high": high,
                "rounds": len(group["ratios"][method]),
            }
    header = " | ".join(f"{label} ({len(g['runs'])} runs)" for label, g in groups.items())
    rows = [f"| method | {header} |", "|---|" + "---:|" * len(groups)]
    for method in methods:
        cells = [
            f"{c['median']:.2f} [{c['low']:.2f}, {c['high']:.2f}] ({c['rounds']} rounds)"
            for c in (s[method] for s in summary.values())
        ]
        rows.append(f"| {method} | " + " | ".join(cells) + " |")
    runs = "; ".join(f"{label}: " + ", ".join(f"`{n}`" for n in g["runs"]) for label, g in groups.items())
    notes = (
        "\n\nTime per environment step against SB3 TD3 (below 1: faster), the median of every round's "
        f"ratio in the group's runs, with a 95 % bootstrap interval of that median. Runs: {runs}."
    )
    write_results(
        args.name,
        {"groups": {label: g["runs"] for label, g in groups.items()}, "overhead_vs_td3": summary},
        "\n".join(rows) + notes,
        title="Training throughput, rounds pooled over runs",
    )


if __name__ == "__main__":
    main()
