"""Every seed, every evaluation: the stability criteria of a many-seed solve (issue "a learner that
works on every seed").

Reads the JSON that ``benchmarks/solve.py`` wrote and reports, per seed, the final return as a
fraction of the oracle, the first periodic evaluation at or above ``--reach`` × oracle, and the
lowest periodic evaluation after it, each as a fraction of the oracle's return on the same games
(:func:`paired_oracles`) and of its 1,000-game return. A seed passes when it ends at
≥ ``--reach`` × oracle and no evaluation after that first one drops below ``--floor`` × oracle.
Also the mean and the IQM of the final fractions with their 95 % stratified-bootstrap intervals (rliable).
On Blind Soccer a third table judges the same runs against the visible oracle on the same games
(:func:`envs.oracles.blind_soccer_visible_oracle`: the oracle less the games whose blind agent the
sighted agent cannot see, which no protocol can be told about; ``benchmarks/hidden_teammate.py``).

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


def seed_row(
    run: dict[str, Any], oracle: float, reach: float, floor: float, final_oracle: float | None = None
) -> dict[str, Any]:
    """The criteria of one run: final fraction, first step at ``reach``, lowest fraction after it.

    :param oracle: the oracle's return that the periodic evaluations are divided by.
    :param final_oracle: the one the final evaluation is divided by (None: ``oracle``).
    """
    final = run["final"]["none"]["mean_return"] / (oracle if final_oracle is None else final_oracle)
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


def reach_cells(row: dict[str, Any]) -> tuple[str, str]:
    """A :func:`seed_row`'s first step at the bar and lowest later fraction, as table cells."""
    first = f"{row['first_reach_step']:,}" if row["first_reach_step"] is not None else "never"
    lowest = f"{row['lowest_after_reach']:.2f}" if row["lowest_after_reach"] is not None else "—"
    return first, lowest


def estimate_cells(estimates: dict[str, Any]) -> list[str]:
    """``["mean 0.94 [0.93, 0.95]", "IQM 0.94 [0.93, 0.95]"]`` from
    :func:`sb3_comm.analysis.stats.interval_estimates` (the IQM only where it was computed)."""
    return [
        f"{label} {estimates[key]['point']:.2f} [{estimates[key]['low']:.2f}, {estimates[key]['high']:.2f}]"
        for key, label in (("mean", "mean"), ("iqm", "IQM"))
        if key in estimates
    ]


def paired_references(env_id: str, runs: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Every scripted reference's mean return on the very games of the periodic and final
    evaluations (:func:`~sb3_comm.analysis.references.reference_returns`, by game seed).

    Every run of a solve plays its periodic evaluations on the same 100 games (the curve seed) and
    its final one on another 100 (the final seed). A set of 100 games is easier or harder than the
    average (Blind Soccer's oracle: 0.96 of its 1,000-game return on the curve games of
    ``benchmarks/solve.py``, 1.05 on its final games), so a fixed bar drawn from the 1,000-game
    oracle moves with the games; divided by the oracle on the same games, it does not.
    """
    from sb3_comm.analysis.references import reference_returns

    seeds = {run["eval"]["seeds"][key] for run in runs for key in ("curve", "final")}
    episodes = {run["eval"]["episodes"] for run in runs}
    if len(episodes) != 1:
        raise ValueError(f"the runs were evaluated on different numbers of games: {sorted(episodes)}")
    (n_episodes,) = episodes
    out = {}
    for seed in sorted(seeds):
        references = reference_returns(env_id, n_episodes=n_episodes, seed=seed)
        assert references is not None
        out[str(seed)] = references
    return out


def paired_oracles(
    env_id: str,
    runs: list[dict[str, Any]],
    reference: str = "oracle",
    by_seed: dict[str, dict[str, Any]] | None = None,
) -> dict[str, float]:
    """One reference's mean return on the very games of the evaluations, by game seed
    (:func:`paired_references`; ``by_seed``: its result, when the caller has it already).

    :param reference: ``"oracle"``, or a task baseline such as Blind Soccer's ``"visible_oracle"``.
    :raises KeyError: naming the references the task has, when it has no ``reference``.
    """
    by_seed = paired_references(env_id, runs) if by_seed is None else by_seed
    out = {}
    for seed, references in by_seed.items():
        if reference not in references:
            known = [k for k in references if k not in ("n_episodes", "seed") and not k.endswith("_ci95")]
            raise KeyError(f"{env_id} has no reference {reference!r}; it has {known}")
        out[seed] = references[reference]
    return out


def has_visible_oracle(by_seed: dict[str, dict[str, Any]]) -> bool:
    """Whether the task of :func:`paired_references`'s result has a visible oracle (Blind Soccer)."""
    return all("visible_oracle" in references for references in by_seed.values())


def judge_runs(
    runs: list[dict[str, Any]], references: dict[str, float], reach: float, floor: float
) -> list[dict[str, Any]]:
    """:func:`seed_row` of every run, each evaluation divided by the reference's return on its own
    games (``references``: :func:`paired_oracles`, by game seed)."""
    return [
        seed_row(
            run,
            references[str(run["eval"]["seeds"]["curve"])],
            reach,
            floor,
            final_oracle=references[str(run["eval"]["seeds"]["final"])],
        )
        for run in runs
    ]


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("solve_json", help="a results file of benchmarks/solve.py")
    parser.add_argument("--reach", type=float, default=0.9)
    parser.add_argument("--floor", type=float, default=0.8)
    parser.add_argument("--method", default=None, help="judge this method's runs only (default: all)")
    parser.add_argument("--name", default=None)
    args = parser.parse_args()
    data = json.loads(Path(args.solve_json).read_text())
    oracle = data["oracle_return"]
    runs = sorted(data["runs"], key=lambda r: r["seed"])
    present = sorted({run["method"] for run in runs})
    if args.method is not None:
        runs = [run for run in runs if run["method"] == args.method.upper()]
        if not runs:
            raise SystemExit(f"{args.solve_json} has no run of method {args.method!r}; it has {present}")
    elif len(present) > 1:
        raise SystemExit(f"{args.solve_json} holds runs of {present}: pick one with --method")
    by_seed = paired_references(data["env"], runs)
    paired = paired_oracles(data["env"], runs, by_seed=by_seed)
    judged = {
        "oracle": [seed_row(run, oracle, args.reach, args.floor) for run in runs],
        "paired": judge_runs(runs, paired, args.reach, args.floor),
    }
    headings = [
        ("paired", "Against the oracle on the same 100 games (the fair bar)"),
        ("oracle", f"Against the oracle's 1,000-game return ({oracle:.4f})"),
    ]
    visible: dict[str, float] = {}
    if has_visible_oracle(by_seed):
        visible = paired_oracles(data["env"], runs, reference="visible_oracle", by_seed=by_seed)
        judged["visible"] = judge_runs(runs, visible, args.reach, args.floor)
        headings.append(
            (
                "visible",
                "Against the visible oracle on the same 100 games (the oracle less the games whose "
                "blind agent the sighted agent cannot see)",
            )
        )
    methods = sorted({run["method"] for run in runs})
    sections, summaries = [], {}
    for key, heading in headings:
        rows_data = judged[key]
        estimates = interval_estimates([r["final_fraction"] for r in rows_data])
        passed = [r for r in rows_data if r["ends_above"] and r["stays_above_floor"]]
        rows = [
            f"## {heading}",
            "",
            f"| seed | final (× oracle) | first ≥ {args.reach} × oracle at step "
            "| lowest later evaluation (× oracle) | ends ≥ bar | never below floor after | passes |",
            "|---:|---:|---:|---:|---|---|---|",
        ]
        for r in rows_data:
            first, lowest = reach_cells(r)
            ok = r["ends_above"] and r["stays_above_floor"]
            rows.append(
                f"| {r['seed']} | {r['final_fraction']:.2f} | {first} | {lowest} | "
                f"{'yes' if r['ends_above'] else 'no'} | {'yes' if r['stays_above_floor'] else 'no'} | "
                f"{'yes' if ok else '**no**'} |"
            )
        summary = estimate_cells(estimates)
        worst = min(rows_data, key=lambda r: r["final_fraction"])
        rows.append(
            f"\n**{len(passed)} of {len(rows_data)} seeds pass.** Final fraction of the oracle: "
            f"{'; '.join(summary)} (95 % stratified bootstrap, {estimates['backend']}); worst seed "
            f"{worst['seed']} at {worst['final_fraction']:.2f}."
        )
        sections.append("\n".join(rows))
        summaries[key] = {"seeds": rows_data, "final_fraction": estimates, "passed": len(passed)}
    oracle_text = ", ".join(f"{value:.4f} on the games of seed {seed}" for seed, value in paired.items())
    notes = (
        f"\n\n{', '.join(methods)} on `{data['env']}`, from `{args.solve_json}`. A seed passes when it "
        f"ends at ≥ {args.reach} × oracle (final evaluation, 100 games) and, after its first periodic "
        f"evaluation at ≥ {args.reach} × oracle, none drops below {args.floor} × oracle. The oracle's "
        f"return on the evaluation games themselves: {oracle_text} (periodic evaluations: the curve "
        "seed; final: the final seed)."
    )
    if visible:
        visible_text = ", ".join(
            f"{value:.4f} on the games of seed {seed}" for seed, value in visible.items()
        )
        notes += (
            " The visible oracle (`envs.oracles.blind_soccer_visible_oracle`: the oracle while the "
            "sighted agent sees the blind agent, waiting while HFO 2016's teammate filter hides it at "
            f"x <= 0, SPEC §6 item 1) on the same games: {visible_text}; see "
            "`benchmarks/hidden_teammate.py`."
        )
    write_results(
        args.name or f"stability_{Path(args.solve_json).stem}",
        {
            "args": vars(args),
            "oracle": oracle,
            "paired_oracle": paired,
            "visible_oracle": visible,
            **summaries,
        },
        "\n\n".join(sections) + notes,
        title=f"Every seed, every evaluation: {', '.join(methods)} on {data['env']}",
    )


if __name__ == "__main__":
    main()
