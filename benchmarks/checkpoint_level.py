"""Is a dip in a Blind Soccer learning curve the team or the 100 games? Each checkpoint measured on
many games.

``benchmarks/solve.py`` evaluates a run every ``--eval-freq`` steps on the same 100 games, and
``benchmarks/stability.py`` fails a seed when one of those evaluations, after the first at
0.9 × oracle, reads below 0.8 × oracle. One game's return spreads by about 0.27 (0.44 of the
oracle's mean), so a 100-game mean of a team is uncertain by several hundredths of the oracle,
and a learning team's small changes re-draw which of the 100 games it wins. This script takes the
checkpoints a solve kept (``--save-freq``, at the evaluations' steps) and the final ``model.zip``
of each run folder, and plays each model, deterministic as the evaluations:

* on the periodic evaluation's own 100 games (game seed ``--curve-seed``, 10,000 in ``solve.py``):
  the replay must give the return ``evaluations.json`` holds for that step (checked, so that the
  checkpoint is the team the curve measured);
* on ``--blocks`` other sets of 100 games (game seeds ``--block-seed`` … ``+ blocks − 1``), each
  divided by the oracle's return on the very same games: the level on ``100 × blocks`` games with
  a 95 % interval (from the blocks' readings), and the spread of the 100-game readings of one
  unchanged team (the standard deviation over the blocks, what a 100-game evaluation of that team
  can read).

With ``--averaged-actor`` every model plays its target actor, the actor's Polyak average
(``policy_kwargs={"averaged_actor": True}``), after the replay of the periodic games has checked
the checkpoint as it was saved: the readings of a run trained without the option, played as if it
had it (its training would be the same: the option changes only what the policy plays). The
summary then also pairs the readings as saved and as played, checkpoint by checkpoint, from step
``--compare-from`` on. With ``--actor-average TAU`` as well, the average played is not the target
actor but the slower one at rate ``TAU`` that ``solve.py --actor-averages`` kept beside each
checkpoint (``benchmarks/_actor_averages.py``).

Each run is then judged twice by ``stability.py``'s rule (ends ≥ ``--reach``; after the first
reading at ≥ ``--reach``, none below ``--floor``): by its 100-game curve, as ``stability.py`` does,
and by the curve of the levels on the many games. Runs without checkpoints give their final
model's row only.

    python benchmarks/solve.py --conf benchmarks/configs/constructor_defaults.yml --seeds 14 10 \\
        --eval-freq 50000 --save-freq 50000 --save-dir /work/runs/ckpt --name diag_…
    python benchmarks/checkpoint_level.py /work/runs/ckpt/BlindSoccer-v0_GSN_seed14 … --name …

``--workers N`` measures N run folders at a time (one process and one torch thread each).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import sys
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import final_level
from _actor_averages import average_path, load_actor_average
from _common import checkpoints, write_results
from stability import estimate_cells, seed_row
from stability_variants import drawdown

ENV_ID = final_level.ENV_ID
GAMES = 100
"""Games of one reading: a periodic evaluation of ``benchmarks/solve.py``."""


def oracle_returns(seed: int) -> tuple[float, float]:
    """The oracle's and the visible oracle's mean returns on the 100 games of ``seed``."""
    from sb3_comm.analysis.references import reference_returns

    references = reference_returns(ENV_ID, n_episodes=GAMES, seed=seed)
    assert references is not None
    return float(references["oracle"]), float(references["visible_oracle"])


def team_returns(model: Any, seed: int) -> np.ndarray:
    """The deterministic team's return in each of the 100 games of ``seed``."""
    return final_level.team_returns(model, GAMES, seed)


def measure(
    model: Any, curve_seed: int, block_seeds: list[int], oracles: dict[int, float], visible: dict[int, float]
) -> dict[str, Any]:
    """One model: its reading on the curve's games and its level over the blocks (also against the
    visible oracle: what a protocol that conveys all the sighted agent sees can reach)."""
    curve = team_returns(model, curve_seed)
    blocks = [team_returns(model, seed) for seed in block_seeds]
    team = np.concatenate(blocks)
    oracle_mean = float(np.mean([oracles[seed] for seed in block_seeds]))  # 100 games per block
    fractions = [float(b.mean() / oracles[seed]) for b, seed in zip(blocks, block_seeds, strict=True)]
    return {
        "curve_return": float(curve.mean()),
        "curve_fraction": float(curve.mean() / oracles[curve_seed]),
        "level": float(team.mean() / oracle_mean),
        # paired with the oracle block by block: the spread of the blocks' fractions
        "level_ci95": float(1.96 * np.std(fractions, ddof=1) / np.sqrt(len(fractions))),
        "block_fractions": fractions,
        "block_sd": float(np.std(fractions, ddof=1)) if len(fractions) > 1 else float("nan"),
        "visible_level": float(team.mean() / np.mean([visible[seed] for seed in block_seeds])),
    }


def judge(readings: list[float], final: float, reach: float, floor: float) -> dict[str, Any]:
    """``stability.py``'s rule (:func:`stability.seed_row`) on one curve of fractions (periodic
    readings in step order) and its final reading."""
    run = {
        "seed": None,
        "final": {"none": {"mean_return": final}},
        "curve": [{"timesteps": i, "mean_return": value} for i, value in enumerate(readings)],
    }
    row = seed_row(run, 1.0, reach, floor)  # the readings are fractions already
    return {
        "first_index": row["first_reach_step"],
        "lowest_after": row["lowest_after_reach"],
        "passes": row["ends_above"] and row["stays_above_floor"],
    }


def summary(results: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """The runs with checkpoints judged together: which pass by the 100-game curve and by the
    levels, each run's largest fall, and the mean and IQM (rliable) of the final evaluations'
    readings and of the final levels."""
    from sb3_comm.analysis.stats import interval_estimates

    judged = {label: r for label, r in results.items() if r["judged"]}
    out: dict[str, Any] = {"runs": len(judged)}
    for kind in ("curve", "level", "saved_curve"):
        out[kind] = {
            "passed": [label for label, r in judged.items() if r["judged"][kind]["passes"]],
            "failed": [label for label, r in judged.items() if not r["judged"][kind]["passes"]],
        }
    if judged:
        out["falls"] = {
            kind: [r["falls"][kind] for r in judged.values()] for kind in ("curve", "level", "saved_curve")
        }
        out["final_fraction"] = interval_estimates([r["final"]["final_fraction"] for r in judged.values()])
        out["final_level"] = interval_estimates([r["final"]["level"] for r in judged.values()])
    return out


def as_saved_then_played(model: Any, seed: int, averaged_actor: bool) -> float | None:
    """With ``averaged_actor``, the mean return of ``model`` as saved on the 100 games of ``seed``,
    then the model switched to play its averaged actor; None where what it plays does not change
    (its readings as played are then those as saved)."""
    if not averaged_actor or model.policy.averaged_actor:
        return None
    saved = float(team_returns(model, seed).mean())
    model.policy.averaged_actor = True
    return saved


def paired_readings(results: dict[str, dict[str, Any]], since: int, floor: float) -> dict[str, Any]:
    """The periodic readings from step ``since`` on, the policy as saved against as played here,
    checkpoint by checkpoint: how many fall below ``floor``, each run's lowest (their mean and the
    four lowest), and how many readings are higher or lower as played, with the mean difference."""
    pairs = {
        label: [
            (c["saved_curve_fraction"], c["curve_fraction"]) for c in r["checkpoints"] if c["step"] >= since
        ]
        for label, r in results.items()
    }
    pairs = {label: p for label, p in pairs.items() if p}
    flat = [pair for p in pairs.values() for pair in p]
    out: dict[str, Any] = {"since": since, "readings": len(flat)}
    if not flat:
        return out
    for index, kind in enumerate(("saved", "played")):
        lowest = sorted(min(pair[index] for pair in p) for p in pairs.values())
        out[kind] = {
            "below_floor": sum(pair[index] < floor for pair in flat),
            "lowest_mean": float(np.mean(lowest)),
            "four_lowest": lowest[:4],
        }
    differences = [played - saved for saved, played in flat]
    out["higher"] = sum(d > 0 for d in differences)
    out["lower"] = sum(d < 0 for d in differences)
    out["mean_difference"] = float(np.mean(differences))
    return out


def measure_run(
    folder: Path,
    args: argparse.Namespace,
    block_seeds: list[int],
    oracles: dict[int, float],
    visible: dict[int, float],
) -> dict[str, Any]:
    """One run folder: every checkpoint and the final model measured, and the run judged."""
    import torch as th

    from sb3_comm import CommDDPG

    th.set_num_threads(1)
    label = f"{folder.resolve().parent.name}/{folder.name}"
    recorded = recorded_returns(folder)
    steps = []
    for step, path in checkpoints(folder):
        model = CommDDPG.load(path, device="cpu")
        if args.actor_average is not None:  # a slower average kept beside the checkpoint
            load_actor_average(model, average_path(folder, step), args.actor_average)
        saved = as_saved_then_played(model, args.curve_seed, args.averaged_actor)
        row = {"step": step, **measure(model, args.curve_seed, block_seeds, oracles, visible)}
        replayed = row["curve_return"] if saved is None else saved  # the team the curve measured
        row["recorded_return"] = recorded.get(step)
        row["replay_matches"] = row["recorded_return"] is not None and np.isclose(
            row["recorded_return"], replayed, rtol=0, atol=1e-9
        )
        row["saved_curve_fraction"] = replayed / oracles[args.curve_seed]  # the policy as saved
        steps.append(row)
        print(label, step, f"{row['curve_fraction']:.3f} {row['level']:.3f}", flush=True)
    final_model = CommDDPG.load(folder / "model.zip", device="cpu")
    if args.actor_average is not None:
        load_actor_average(final_model, average_path(folder, None), args.actor_average)
    # the final evaluation of solve.py (its own 100 games), by the policy as saved and as played here
    saved = as_saved_then_played(final_model, args.final_seed, args.averaged_actor)
    final = measure(final_model, args.curve_seed, block_seeds, oracles, visible)
    final_return = float(team_returns(final_model, args.final_seed).mean())
    final["final_fraction"] = final_return / oracles[args.final_seed]
    final["saved_final_fraction"] = (final_return if saved is None else saved) / oracles[args.final_seed]
    saved_final = final["saved_final_fraction"]
    judged = {}
    if steps:
        judged["curve"] = judge(
            [r["curve_fraction"] for r in steps], final["final_fraction"], args.reach, args.floor
        )
        judged["level"] = judge([r["level"] for r in steps], final["level"], args.reach, args.floor)
        # the policy as saved, on the same 100-game curve (what solve.py's evaluations measured)
        judged["saved_curve"] = judge(
            [r["saved_curve_fraction"] for r in steps], saved_final, args.reach, args.floor
        )
    # the largest fall below the best reading before it (stability_variants.py's drawdown)
    falls = {
        "curve": drawdown([r["curve_fraction"] for r in steps]),
        "level": drawdown([r["level"] for r in steps]),
        "saved_curve": drawdown([r["saved_curve_fraction"] for r in steps]),
    }
    return {"checkpoints": steps, "final": final, "judged": judged, "falls": falls}


def recorded_returns(run_dir: Path) -> dict[int, float]:
    """The periodic evaluations ``evaluations.json`` holds, by step."""
    path = run_dir / "evaluations.json"
    if not path.exists():
        return {}
    return {int(e["timesteps"]): float(e["mean_return"]) for e in json.loads(path.read_text())}


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("runs", nargs="+", help="run folders (benchmarks/solve.py --save-dir)")
    parser.add_argument("--blocks", type=int, default=10, help="sets of 100 other games per model")
    parser.add_argument("--block-seed", type=int, default=777, help="game seed of the first set")
    parser.add_argument(
        "--curve-seed", type=int, default=10_000, help="game seed of the periodic evaluations"
    )
    parser.add_argument("--final-seed", type=int, default=20_000, help="game seed of the final evaluation")
    parser.add_argument(
        "--averaged-actor",
        action="store_true",
        help="play every model's target actor (the actor's Polyak average) after the replay check",
    )
    parser.add_argument(
        "--actor-average",
        type=float,
        default=None,
        metavar="TAU",
        help="with --averaged-actor: play the average at this rate that solve.py --actor-averages "
        "kept beside each checkpoint, instead of the target actor",
    )
    parser.add_argument("--workers", type=int, default=1, help="run folders measured in parallel")
    parser.add_argument("--reach", type=float, default=0.9)
    parser.add_argument("--floor", type=float, default=0.8)
    parser.add_argument(
        "--compare-from",
        type=int,
        default=250_000,
        help="with --averaged-actor: pair the readings as saved and as played from this step on",
    )
    parser.add_argument("--name", required=True, help="result file stem")
    args = parser.parse_args()
    if args.blocks < 2:
        raise SystemExit(f"--blocks must be at least 2 (the spread needs two readings); got {args.blocks}")
    if args.actor_average is not None and not args.averaged_actor:
        raise SystemExit("--actor-average TAU chooses which average --averaged-actor plays: give both")
    if args.workers < 1:
        raise SystemExit(f"--workers must be at least 1; got {args.workers}")
    import torch as th

    th.set_num_threads(1)  # before the workers fork: one thread each
    block_seeds = [args.block_seed + b for b in range(args.blocks)]
    if {args.curve_seed, args.final_seed} & set(block_seeds):
        raise SystemExit(
            f"--curve-seed {args.curve_seed} and --final-seed {args.final_seed} must not be game seeds "
            f"of the blocks, {block_seeds}"
        )
    both = {seed: oracle_returns(seed) for seed in [args.curve_seed, args.final_seed, *block_seeds]}
    oracles = {seed: pair[0] for seed, pair in both.items()}
    visible = {seed: pair[1] for seed, pair in both.items()}
    folders = [Path(run) for run in args.runs]
    labels = [f"{folder.resolve().parent.name}/{folder.name}" for folder in folders]
    for folder, label in zip(folders, labels, strict=True):
        if not (folder / "model.zip").exists():
            raise SystemExit(f"{folder}: no model.zip (a run that has not finished?)")
        if labels.count(label) > 1:
            raise SystemExit(f"{folder}: run {label} given twice")
    work = partial(measure_run, args=args, block_seeds=block_seeds, oracles=oracles, visible=visible)
    if args.workers > 1:
        with multiprocessing.get_context("fork").Pool(args.workers) as pool:
            measured = pool.map(work, folders, chunksize=1)
    else:
        measured = [work(folder) for folder in folders]
    results: dict[str, Any] = dict(zip(labels, measured, strict=True))

    md = []
    for label, r in results.items():
        if not r["checkpoints"]:
            continue
        md += [
            f"### {label}",
            "",
            f"| step | 100 periodic games (× oracle) | replay = evaluations.json | {100 * args.blocks:,} "
            "other games (× oracle) [95 %] | 100-game readings of this team: min – max (sd) |",
            "|---:|---:|---|---:|---:|",
        ]
        for row in r["checkpoints"]:
            md.append(
                f"| {row['step']:,} | {row['curve_fraction']:.2f} | "
                f"{'yes' if row['replay_matches'] else '**no**'} | "
                f"{row['level']:.3f} ± {row['level_ci95']:.3f} | {min(row['block_fractions']):.2f} – "
                f"{max(row['block_fractions']):.2f} ({row['block_sd']:.3f}) |"
            )
        verdicts = []
        for kind, text in (
            ("curve", "by the 100-game curve"),
            ("level", f"by the {100 * args.blocks:,}-game levels"),
        ):
            j = r["judged"][kind]
            lowest = "—" if j["lowest_after"] is None else f"{j['lowest_after']:.2f}"
            verdicts.append(
                f"{text}: {'passes' if j['passes'] else '**fails**'} (lowest after the bar {lowest})"
            )
        final = r["final"]
        md += [
            "",
            f"Final model: {final['final_fraction']:.2f} on the final evaluation's 100 games, "
            f"{final['level']:.3f} ± {final['level_ci95']:.3f} on the others. Judged "
            + "; ".join(verdicts)
            + f". Largest fall below the best reading before it (once at 0.5): "
            f"{r['falls']['curve']:.2f} on the 100-game curve, {r['falls']['level']:.2f} on the levels.",
            "",
        ]
    pooled = summary(results)
    if pooled["runs"]:
        n = pooled["runs"]
        saved_failed = pooled["saved_curve"]["failed"]
        md += [
            "### All runs with checkpoints",
            "",
            f"- As played here, by the 100-game curve: **{len(pooled['curve']['passed'])} of {n} pass**"
            + (f"; fail: {', '.join(pooled['curve']['failed'])}" if pooled["curve"]["failed"] else "")
            + ".",
            f"- As played here, by the {100 * args.blocks:,}-game levels: "
            f"{len(pooled['level']['passed'])} of {n} pass"
            + (f"; fail: {', '.join(pooled['level']['failed'])}" if pooled["level"]["failed"] else "")
            + ".",
            f"- The policy as saved, by the 100-game curve it was evaluated on (`evaluations.json`): "
            f"{len(pooled['saved_curve']['passed'])} of {n} pass"
            + (f"; fail: {', '.join(saved_failed)}" if saved_failed else "")
            + f"; largest fall per run median {np.median(pooled['falls']['saved_curve']):.2f}, worst "
            f"{max(pooled['falls']['saved_curve']):.2f}.",
            "- As played here, the largest fall of a run below its best reading before (once at 0.5): "
            f"on the {100 * args.blocks:,}-game levels median {np.median(pooled['falls']['level']):.2f}, "
            f"worst {max(pooled['falls']['level']):.2f}; on the 100-game curve median "
            f"{np.median(pooled['falls']['curve']):.2f}, worst {max(pooled['falls']['curve']):.2f}.",
            "- Final evaluation's 100 games (× oracle): "
            + ", ".join(estimate_cells(pooled["final_fraction"]))
            + f"; final level on {100 * args.blocks:,} games: "
            + ", ".join(estimate_cells(pooled["final_level"]))
            + " (95 % stratified-bootstrap intervals, rliable).",
        ]
        paired = paired_readings(results, args.compare_from, args.floor) if args.averaged_actor else {}
        if paired.get("readings"):
            pooled["paired"] = paired
            cells = {
                kind: f"{paired[kind]['below_floor']} below {args.floor}, each run's lowest "
                f"{paired[kind]['lowest_mean']:.3f} on average, the four lowest "
                + ", ".join(f"{x:.2f}" for x in paired[kind]["four_lowest"])
                for kind in ("saved", "played")
            }
            md += [
                f"- The {paired['readings']} periodic readings from step {args.compare_from:,} on, paired: "
                f"as saved {cells['saved']}; as played here {cells['played']}. As played here "
                f"{paired['higher']} are higher, {paired['lower']} lower, mean difference "
                f"{paired['mean_difference']:+.4f}.",
            ]
        md += [""]
    md += [
        "### Final models",
        "",
        f"| run | {100 * args.blocks:,} games (× oracle) [95 %] | 100-game readings: min – max | sd | "
        f"readings < {args.reach} | readings < {args.floor} | "
        f"{100 * args.blocks:,} games (× visible oracle) |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for label, r in results.items():
        f = r["final"]
        below_reach = sum(x < args.reach for x in f["block_fractions"])
        below_floor = sum(x < args.floor for x in f["block_fractions"])
        md.append(
            f"| {label} | {f['level']:.3f} ± {f['level_ci95']:.3f} | {min(f['block_fractions']):.2f} – "
            f"{max(f['block_fractions']):.2f} | {f['block_sd']:.3f} | {below_reach} of {args.blocks} | "
            f"{below_floor} of {args.blocks} | {f['visible_level']:.3f} |"
        )
    sds = [r["final"]["block_sd"] for r in results.values()]
    block_oracle = np.mean([oracles[s] for s in block_seeds])
    block_visible = np.mean([visible[s] for s in block_seeds])
    played = (
        "its target actor, the actor's Polyak average (`--averaged-actor`; the replay of the periodic "
        "games checks the checkpoint as saved)"
        if args.averaged_actor
        else "the policy as saved"
    )
    if args.actor_average is not None:
        played = (
            f"the actor's Polyak average at rate {args.actor_average:g} that the run kept beside the "
            "checkpoint (`--averaged-actor --actor-average`, benchmarks/_actor_averages.py; the replay "
            "of the periodic games checks the checkpoint as saved)"
        )
    md.append(
        f"\nEvery model plays {played}. Every model deterministic, one episode per game; a reading is "
        "a team's mean over 100 games divided by the oracle's mean on the same games (the oracle: "
        f"{oracles[args.curve_seed]:.4f} on the periodic games of seed {args.curve_seed}; "
        f"{block_oracle:.4f} over the blocks, game seeds {block_seeds[0]}–{block_seeds[-1]}; "
        f"the visible oracle {block_visible:.4f} there, {block_visible / block_oracle:.3f} of the oracle). "
        "The interval of a level is 1.96 standard errors of the mean of its blocks' readings (each "
        "paired with the oracle on its games). "
        "The spread of one unchanged team's 100-game readings over the final models: median sd "
        f"{np.median(sds):.3f} of the oracle. "
        f"Judged by `benchmarks/stability.py`'s rule: ends ≥ {args.reach}; after the first reading ≥ "
        f"{args.reach}, none below {args.floor}; the 100-game curve ends on the final evaluation's games "
        f"(seed {args.final_seed}, oracle {oracles[args.final_seed]:.4f}), the levels on the blocks."
    )
    write_results(
        args.name,
        {
            "args": vars(args),
            "oracles": {str(k): v for k, v in oracles.items()},
            "visible_oracles": {str(k): v for k, v in visible.items()},
            "runs": results,
            "summary": pooled,
        },
        "\n".join(md),
        title="Blind Soccer: each checkpoint on the periodic 100 games and on many others",
    )


if __name__ == "__main__":
    main()
