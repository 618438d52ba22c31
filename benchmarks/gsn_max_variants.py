"""The GSN-MAX variants tried, one table: what each design reached on each task.

Reads the single-run results that ``benchmarks/solve.py --methods GSN-MAX ... --name
gsn_max_variant_<variant>`` wrote (``benchmarks/results/gsn_max_variant_*.json``) and, with
``--solves``, other ``solve.py`` results under a name of their own, and with
``--experiments``, the runs of experiment folders (``runs/<task>/GSN-MAX/<seed>/result.json``),
and writes ``benchmarks/results/gsn_max_variants.{json,md}``: per run the design, the overrides,
the budget, the periodic evaluations and the final return as a fraction of the oracle.

    python benchmarks/gsn_max_variants.py --experiments v1=runs/experiments/gsn_max_v1
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import RESULTS_DIR, write_results

from sb3_comm.analysis.references import REFERENCE_SEED, reference_returns

DESIGNS = {
    "v1": "two Adam optimizers, one per signal (grounding lin_1e-3 on M and R, maximising lin_1e-4 on "
    "M); tanh messages; no inverting gradients; messages explored",
    "v2": "v1 + inverting gradients on the maximising message gradient",
    "v3": "one Adam on M: the two message gradients each scaled to unit RMS and mixed with weight w "
    "(gsn_max_weight, 0.5); inverting gradients on the maximising part; tanh messages",
    "v4": "v3 + the reward model also hears the message the teammate heard (the sender's previous one)",
    "v5": "v4 + inverting gradients on the mixed gradient instead, and linear messages "
    "(gsn_message_activation linear)",
    "v6": "v5 without the heard message in the reward model: zoo_configs/gsn-max.yml until v10",
    "v7 (head)": "v6 with a maximising head (policy_kwargs gsn_maximising_head): m = M(o) + H(o); M and R "
    "trained by the regression alone (tanh messages, as GSN), H (output layer zero at the start) by the "
    "receiver's critic alone, with its own Adam at the actor's learning rate",
    "v8 (effect gradient)": "v6's unit-RMS mix, but the maximising signal is the gradient of a "
    "centralised one-step effect model of the receiver's reward, E(s_j, s_i, m, mu_j(o_j + m)) (both "
    "agents' observations without the heard messages, the heard message, the receiver's response), "
    "trained on the replay; linear messages; no message exploration",
    "v9 (effect search)": "GSN's step on M and R (tanh messages), plus a pull of each message towards "
    "the best of 16 uniform candidates by one effect model's direct effect (receiver's action held "
    "fixed), where it beats the sent message by 0.5 reward std; pull weight w/(1-w) times the effect "
    "model's R^2; explorer games (1 in 8) send random messages and train only the effect model",
    "v9b": "v9 with two effect models (one picks the candidate, the other judges it) and the pull "
    "taken before the tanh",
    "v9c": "v9b with half the candidates near the sent message (Gaussian, std 0.1)",
    "v10": "v9c with a pull only where the judged gain exceeds the two models' disagreement "
    "(|gain_1 - gain_2|, floor 0.1 reward std); w 0.8, explorer games 1 in 4",
    "v11 (kept)": "v10 with a pull only where the judged gain also exceeds the effect models' own "
    "error (their RMS residual, sqrt(1 - R^2_E)): the packaged zoo_configs/gsn-max.yml",
}
"""The designs, in the order they were tried; each variant below is one of them plus its overrides."""

VERSIONS = {
    "gmn_maxonly": "v1",
    "gmn_eqlr": "v1",
    "gmn_maxonly_linear": "v1",
    "gmn_maxonly_lr3e-4": "v1",
    "bs_v1": "v1",
    "gmn_v1_both": "v1",
    "gmn_maxonly_inv": "v2",
    "gmn_maxonly_inv_linear": "v2",
    "gmn_v2_tanh": "v2",
    "gmn_v2_linear": "v2",
    "bs_v2_tanh": "v2",
    "bs_v2_tanh_noexplore": "v2",
    "gmn_v3": "v3",
    "gmn_v3_w0.8": "v3",
    "gmn_v4": "v4",
    "bs_v4": "v4",
    "gmn_v5": "v5",
    "bs_v5": "v5",
    "bs_v5_final": "v5",
    "bs_v5_maximising_only": "v5",
    "gmn_v5_w0.1": "v5",
    "bs_v5_w0.1_400k": "v5",
    "gmn_v6": "v6",
    "bs_v6": "v6",
    "bs_v6_w0.1_400k": "v6",
    "bs_v7_head": "v7 (head)",
    "gmn_v7_head": "v7 (head)",
    "bs_v7_head_explore": "v7 (head)",
    "gmn_v7_head_explore": "v7 (head)",
    "bs_v8": "v8 (effect gradient)",
    "gmn_v8": "v8 (effect gradient)",
    "bs_v9": "v9 (effect search)",
    "gmn_v9": "v9 (effect search)",
    "bs_v9b": "v9b",
    "gmn_v9b": "v9b",
    "gmn_v9c": "v9c",
    "bs_v9c_grounding_only": "v9c",
    "gmn_v9c_w0.8": "v9c",
    "bs_v9c_w0.8": "v9c",
    "gmn_v9c_w0.8_explorers0.25": "v9c",
    "gmn_v10": "v10",
    "bs_v10": "v10",
    "v10_5seeds_stopped": "v10",
    "v11_5seeds": "v11 (kept)",
    "v11_ablation": "v11 (kept)",
}
"""The design each variant ran with (any other: v6, the one packaged before v10)."""


def _design(name: str) -> str:
    version = VERSIONS.get(name, "v6")
    return f"{version}: {DESIGNS[version]}"


def _row(variant: str, run: dict[str, Any], oracle: float, overrides: list[str]) -> dict[str, Any]:
    curve = [(int(p["timesteps"]), float(p["mean_return"])) for p in run.get("curve", [])]
    final = run.get("final", {}).get("none", {}).get("mean_return")
    return {
        "variant": variant,
        "version": VERSIONS.get(variant, "v6"),
        "design": _design(variant),
        "task": run["task"],
        "seed": run["seed"],
        "timesteps": run["timesteps"],
        "overrides": overrides,
        "curve": curve,
        "best_periodic": max((r for _, r in curve), default=None),
        "final_return": final,
        "final_fraction": None if final is None else final / oracle,
        "zeroed": run.get("final", {}).get("zero", {}).get("mean_return"),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--experiments",
        nargs="*",
        default=[],
        help="NAME=FOLDER experiment folders whose GSN-MAX runs to add",
    )
    parser.add_argument(
        "--partial",
        nargs="*",
        default=[],
        help="NAME=RUN_DIR: a run of `sb3-comm train` (its result.json where it finished; its "
        "evaluations.json where it was stopped early; overrides from its config.yml)",
    )
    parser.add_argument(
        "--solves",
        nargs="*",
        default=[],
        help="NAME=FILE: more results of `benchmarks/solve.py --methods GSN-MAX` (its JSON), under NAME",
    )
    parser.add_argument(
        "--only-given",
        action="store_true",
        help="only the results named here (not every benchmarks/results/gsn_max_variant_*.json)",
    )
    parser.add_argument("--name", default="gsn_max_variants")
    args = parser.parse_args()

    oracles: dict[str, float] = {}

    def oracle(task: str) -> float:
        if task not in oracles:
            references = reference_returns(task, n_episodes=1000, seed=REFERENCE_SEED)
            assert references is not None
            oracles[task] = references["oracle"]
        return oracles[task]

    rows = []
    solves = [
        (path.stem.removeprefix("gsn_max_variant_"), path)
        for path in sorted(RESULTS_DIR.glob("gsn_max_variant_*.json"))
        if not args.only_given
    ]
    solves += [(label, Path(file)) for label, _, file in (item.partition("=") for item in args.solves)]
    for variant, path in solves:
        data = json.loads(path.read_text())
        for run in data["runs"]:
            rows.append(_row(variant, run, data["oracle_return"], data["args"]["params"]))
    for item in args.partial:
        label, _, folder = item.partition("=")
        run_dir = Path(folder)
        curve = json.loads((run_dir / "evaluations.json").read_text())
        curve = curve if isinstance(curve, list) else curve.get("curve", curve.get("evaluations", []))
        config = (run_dir / "config.yml").read_text() if (run_dir / "config.yml").is_file() else ""
        task = "BlindSoccer-v0" if "BlindSoccer" in str(run_dir) else "GuessMyNumber-v0"
        keys = ("gsn_", "activation", "n_timesteps")
        overrides = [line.strip() for line in config.splitlines() if any(k in line for k in keys)]
        seed = int(match.group(1)) if (match := re.search(r"seed(\d+)", run_dir.name)) else 0
        finished = run_dir / "result.json"
        if finished.is_file() and json.loads(finished.read_text()).get("status") == "done":
            rows.append(_row(label, json.loads(finished.read_text()), oracle(task), overrides))
            continue
        run = {
            "task": task,
            "seed": seed,
            "timesteps": curve[-1]["timesteps"] if curve else 0,
            "curve": curve,
        }
        rows.append(_row(label, run, oracle(task), ["stopped early", *overrides]))
    for item in args.experiments:
        label, _, folder = item.partition("=")
        for result in sorted(Path(folder).glob("runs/*/GSN-MAX/*/result.json")):
            run = json.loads(result.read_text())
            if run.get("status") != "done":
                continue
            signals = (run.get("hyperparams") or {}).get("gsn_max_signals", "both")
            shown = [f"experiment {folder}", *([f"gsn_max_signals={signals}"] if signals != "both" else [])]
            rows.append(_row(label, run, oracle(run["task"]), shown))

    rows.sort(key=lambda r: (r["version"], r["task"], r["variant"], r["seed"]))
    lines = [
        "| variant | design | task | seed | steps | overrides | periodic evaluations (k steps: return) | "
        "final return | fraction of oracle | zeroed |",
        "|---|---|---|---:|---:|---|---|---:|---:|---:|",
    ]
    for r in rows:
        curve = ", ".join(f"{t // 1000}: {v:.2f}" for t, v in r["curve"])
        fraction = "—" if r["final_fraction"] is None else f"{r['final_fraction']:.2f}"
        final = "—" if r["final_return"] is None else f"{r['final_return']:.3f}"
        zeroed = "—" if r["zeroed"] is None else f"{r['zeroed']:.3f}"
        lines.append(
            f"| {r['variant']} | {r['version']} | {r['task']} | {r['seed']} | {r['timesteps']:,} | "
            f"{' '.join(r['overrides']) or '—'} | {curve} | {final} | {fraction} | {zeroed} |"
        )
    designs = "\n".join(f"- **{version}**: {text}" for version, text in DESIGNS.items())
    notes = (
        "\n\nDesigns (the code of each version; a variant is a design plus the overrides shown):\n\n"
        f"{designs}\n\nBudgets below the packaged ones (150k on Guess My Number, 400k on Blind Soccer) "
        "shorten the linear learning-rate schedules too. Returns are team means over 100 deterministic "
        "evaluation games; the oracle is the scripted full-information team (1,000 games)."
    )
    write_results(
        args.name,
        {"designs": DESIGNS, "rows": rows},
        "\n".join(lines) + notes,
        title="GSN-MAX: the variants tried",
    )


if __name__ == "__main__":
    main()
