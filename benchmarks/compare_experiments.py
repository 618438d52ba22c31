"""Two experiment folders with the same runs, compared: which runs trained the same models, and how
their times differ.

Runs of the same configuration and code train the same model on this machine, so a run whose
curve and final returns (intact, zeroed and shuffled messages) are equal to the bit in both
folders measures only the machine's speed: the ratio of their times is the machine's drift
between the two starts. Runs whose code changed are then compared net of that drift::

    python benchmarks/compare_experiments.py benchmarks/results/paper_fast_double_batch_5seeds \\
        benchmarks/results/paper_fast_one_go_5seeds \\
        --paused BlindSoccer-v0/GSN-MAX/4=61.36 BlindSoccer-v0/NONE/0=61.36 \\
        --speedup GSN-MAX/BlindSoccer-v0=1.21 GSN-MAX/GuessMyNumber-v0=1.26 \\
        --name paper_fast_one_go_vs_session35

``--paused`` takes seconds out of a run of the second folder (a pause made while it ran);
``--speedup`` gives the speedup of a changed method measured side by side
(``benchmarks/checkout_speed.py``). For the changed runs, two estimates of the second folder's
run time at the first folder's machine speed are given: its changed runs divided by the drift, and
the first folder's changed runs divided by the side-by-side speedups. Writes
``benchmarks/results/<name>.{json,md}``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

from sb3_comm.analysis import load_runs


def _runs(folder: Path) -> dict[str, Any]:
    """``task/method/seed`` -> the :class:`~sb3_comm.results.RunResult` of every finished run
    (:func:`sb3_comm.analysis.load_runs`)."""
    return {
        f"{entry['task']}/{entry['method']}/{entry['seed']}": entry["result"]
        for entry in load_runs(folder)
        if entry["used"]
    }


def _returns(result: Any) -> list[float]:
    curve = [point["mean_return"] for point in result.curve]
    return curve + [result.final[kind]["mean_return"] for kind in ("none", "zero", "shuffle")]


def _pairs(values: list[str], what: str) -> dict[str, float]:
    pairs = {}
    for value in values:
        key, sep, number = value.rpartition("=")
        if not sep:
            raise SystemExit(f"{what} takes KEY=NUMBER, got {value!r}")
        pairs[key] = float(number)
    return pairs


def compare(
    before: Path, after: Path, paused: dict[str, float], speedups: dict[str, float]
) -> dict[str, Any]:
    """The comparison's numbers (see the module docstring)."""
    first, second = _runs(before), _runs(after)
    if set(first) != set(second):
        raise SystemExit(
            f"the folders hold different runs: only in {before}: {sorted(set(first) - set(second))}, "
            f"only in {after}: {sorted(set(second) - set(first))}"
        )
    unknown = sorted(set(paused) - set(second))
    if unknown:
        raise SystemExit(f"--paused names runs that are not in {after}: {unknown}")
    times = {key: second[key].wall_seconds - paused.get(key, 0.0) for key in second}
    same = {key: _returns(first[key]) == _returns(second[key]) for key in first}
    groups: dict[str, dict[str, Any]] = {}
    for key in sorted(first):
        task, method, _ = key.split("/")
        group = groups.setdefault(f"{method}/{task}", {"before": [], "after": [], "ratios": [], "same": []})
        group["before"].append(first[key].wall_seconds)
        group["after"].append(times[key])
        group["ratios"].append(times[key] / first[key].wall_seconds)
        group["same"].append(same[key])
    unchanged = [key for key in first if same[key]]
    changed = [key for key in first if not same[key]]
    if not unchanged:
        raise SystemExit(
            "no run trained the same model in both folders (equal curve and final returns), so the "
            "machine's drift between them cannot be measured"
        )
    drift = sum(times[k] for k in unchanged) / sum(first[k].wall_seconds for k in unchanged)

    def speedup(key: str) -> float:
        task, method, _ = key.split("/")
        return speedups.get(f"{method}/{task}", 1.0)

    by_speedup = sum(first[k].wall_seconds / (1.0 if same[k] else speedup(k)) for k in first)
    return {
        "runs": len(first),
        "groups": groups,
        "unchanged_runs": len(unchanged),
        "changed_runs": sorted(changed),
        "sum_before": sum(first[k].wall_seconds for k in first),
        "sum_after": sum(times.values()),
        "drift": drift,
        "estimate_by_drift": sum(times.values()) / drift,
        "estimate_by_speedup": by_speedup,
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("before", type=Path, help="the earlier experiment folder")
    parser.add_argument("after", type=Path, help="the later one")
    parser.add_argument("--paused", nargs="*", default=[], help="TASK/METHOD/SEED=SECONDS to take out")
    parser.add_argument("--speedup", nargs="*", default=[], help="METHOD/TASK=X measured side by side")
    parser.add_argument("--name", default="compare_experiments")
    args = parser.parse_args()
    for folder in (args.before, args.after):
        if not (folder / "runs").is_dir():
            parser.error(f"{folder} is not an experiment folder (no runs/ in it)")
    data = compare(
        args.before, args.after, _pairs(args.paused, "--paused"), _pairs(args.speedup, "--speedup")
    )
    lines = [
        "| method / task | same models | run times before (s) | after (s) | after / before, median [range] |",
        "|---|---|---|---|---|",
    ]
    for name, group in data["groups"].items():
        same = f"{sum(group['same'])} of {len(group['same'])}"
        ratios = group["ratios"]
        lines.append(
            f"| {name} | {same} | {', '.join(f'{t:.0f}' for t in sorted(group['before']))} | "
            f"{', '.join(f'{t:.0f}' for t in sorted(group['after']))} | {statistics.median(ratios):.2f} "
            f"[{min(ratios):.2f}, {max(ratios):.2f}] |"
        )
    before, after = data["sum_before"], data["sum_after"]
    by_drift, by_speedup = data["estimate_by_drift"], data["estimate_by_speedup"]
    paused = f" less the pauses given ({', '.join(args.paused)})" if args.paused else ""
    lines += [
        "",
        f"- Runs that trained the same models (curve and final returns equal to the bit): "
        f"{data['unchanged_runs']} of {data['runs']}; their total time after / before, the machine's "
        f"drift: **{data['drift']:.3f}**.",
        f"- Sum of the runs' times: before {before:,.0f} s ({before / 120:.1f} minutes at two at a "
        f"time), after {after:,.0f} s ({after / 120:.1f} minutes){paused}.",
        f"- The after folder at the before folder's machine speed: {by_drift:,.0f} s "
        f"(**{by_drift / 120:.1f} minutes** at two at a time), every run divided by the drift; "
        f"{by_speedup:,.0f} s (**{by_speedup / 120:.1f} minutes**), the before folder's runs with its "
        f"changed ones divided by the side-by-side speedups ({', '.join(args.speedup) or 'none given'}).",
    ]
    data.update({"before": str(args.before), "after": str(args.after), "paused": args.paused})
    data["speedups"] = args.speedup
    for path in write_results(args.name, data, "\n".join(lines), "Two experiment folders compared"):
        print(path)


if __name__ == "__main__":
    main()
