"""Turn an experiment folder into figures, tables and the paper's claims next to measured numbers.

:func:`make_report` reads every run under ``experiment_dir/runs/<task>/<method>/<seed dir>/``
(``result.json``, ``messages.npz``, ``evaluations.json``; see the runner) and writes into
``out_dir`` (default ``experiment_dir/report/``)::

    report.json, report.md            everything below in one file each
    tables/{final_returns,communication,claims,runs}.{json,md}
    figures/curves_<task>.{png,svg}   learning curves, mean and 95% interval over seeds (Figs. 2, 4)
    figures/ablation_<task>.{png,svg} returns with messages intact, zeroed, shuffled
    figures/tsne_<task>_<method>.{png,svg}  the sender's messages coloured by the receiver's next
                                      action (Fig. 3; Blind Soccer, GSN first)

A run that is not done, has a missing or corrupt ``result.json`` or lacks what a part needs
(``messages.npz`` for the t-SNE) is listed with the reason, in the returned dict and in the
Markdown, and never stops the others. Final returns are also given as fractions of the oracle's
return (:func:`envs.oracles.evaluate`, cached in ``report.json``), with stratified-bootstrap
intervals over seeds (:func:`~sb3_comm.analysis.stats.interval_estimates`).
"""

from __future__ import annotations

import importlib
import json
import math
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sb3_comm.analysis.metrics import linear_probe
from sb3_comm.analysis.plots import plot_ablation, plot_learning_curves, plot_tsne
from sb3_comm.analysis.rollout import ACTION_NAMES, Rollout, communication_directions
from sb3_comm.analysis.stats import interval_estimates
from sb3_comm.comm_ddpg import METHODS
from sb3_comm.registration import TASK_IDS

__all__ = ["MIN_SEEDS", "SOLVED_FRACTION", "load_runs", "make_report", "reference_returns"]

SOLVED_FRACTION = 0.9
"""A method solves a task when its mean final return reaches this fraction of the oracle's."""

MIN_SEEDS = 3
"""Training seeds a claim needs to count as reproduced (SPEC §5)."""

REFERENCE_SEED = 0
"""Seed of the oracle and random-policy evaluations (as ``benchmarks/oracles.py``)."""

_ABLATIONS = ("none", "zero", "shuffle")
_METRICS = ("cic", "speaker_consistency", "instantaneous_coordination", "probe_accuracy", "majority_rate")


# --------------------------------------------------------------------------------- loading --
def _load_summary(experiment_dir: Path) -> Any:
    """The runner's ``summary.json`` as parsed JSON, or ``{}`` when it is missing or corrupt."""
    try:
        return json.loads((experiment_dir / "summary.json").read_text())
    except (OSError, ValueError):
        return {}


def _read_summary(experiment_dir: Path) -> dict[Path, dict[str, Any]]:
    """Runner's ``summary.json`` entries by run folder (whatever shape the table has)."""
    data = _load_summary(experiment_dir)
    rows = data.get("runs", data) if isinstance(data, dict) else data
    if isinstance(rows, dict):
        rows = list(rows.values())
    entries = {}
    for row in rows if isinstance(rows, list) else []:
        if isinstance(row, dict) and isinstance(row.get("dir"), str):
            run_dir = Path(row["dir"])
            run_dir = run_dir if run_dir.is_absolute() else experiment_dir / run_dir
            entries[run_dir.resolve()] = row
    return entries


def _provenance(experiment_dir: Path, runs: list[dict[str, Any]]) -> dict[str, Any]:
    """How the runs were made: the runner's command, machine and timing (from ``summary.json``)."""
    data = _load_summary(experiment_dir)
    data = data if isinstance(data, dict) else {}
    keys = ("command", "finished", "wall_seconds", "backend", "workers", "machine", "env_steps")
    out = {key: data.get(key) for key in keys}
    results = [r["result"] for r in runs if r.get("used") and isinstance(r.get("result"), dict)]
    out["runs_used"] = len(results)
    out["run_wall_seconds_total"] = float(sum(r.get("wall_seconds") or 0.0 for r in results))
    out["run_env_steps"] = sorted({int(r.get("timesteps") or 0) for r in results})
    return out


def _provenance_md(info: dict[str, Any]) -> list[str]:
    machine = info.get("machine") or {}
    wall = info.get("wall_seconds")
    return [
        f"- Command (last start of the runner): `{info.get('command')}`, finished {info.get('finished')}",
        f"- Machine: {machine.get('cpu_model', '?')}, {machine.get('usable_cores', '?')} usable cores;"
        f" backend {info.get('backend')}, {info.get('workers')} runs at a time",
        f"- Wall-clock time of that start: {'?' if wall is None else f'{wall:.0f} s'}; "
        f"sum over the {info['runs_used']} runs used: {info['run_wall_seconds_total']:.0f} s of run time; "
        f"environment steps per run: {', '.join(f'{n:,}' for n in info['run_env_steps'])}",
        "",
    ]


def _seed_of(name: str) -> int | None:
    digits = name.removeprefix("seed").split("-")[0]
    return int(digits) if digits.isdigit() else None


def load_runs(experiment_dir: str | Path) -> list[dict[str, Any]]:
    """Every run folder under ``experiment_dir/runs/`` with its result or why it cannot be used.

    A run folder is ``runs/<task>/<method>/<seed dir>/``, any folder holding a ``result.json``
    or an ``error.txt``, or a folder named in ``summary.json``, unless it lies inside another run
    folder (such as the runner's ``previous_attempts/``). Each entry has ``dir`` (relative
    to ``experiment_dir``), ``task``, ``method``, ``seed``, ``used`` (bool), ``reason`` (why not
    used), ``issues`` (what is missing for some parts, e.g. ``messages.npz``) and ``result``.
    """
    root = Path(experiment_dir).resolve()
    runs_dir = root / "runs"
    summary = _read_summary(root)
    candidates = set(summary)
    if runs_dir.is_dir():
        candidates |= {p.resolve() for p in runs_dir.glob("*/*/*") if p.is_dir()}
        for name in ("result.json", "error.txt"):
            candidates |= {p.parent.resolve() for p in runs_dir.rglob(name)}
    # A folder inside a run (e.g. the runner's previous_attempts/) is part of that run.
    candidates = {c for c in candidates if not any(a in candidates for a in c.parents)}
    entries = []
    for run_dir in sorted(candidates):
        rel = run_dir.relative_to(root) if run_dir.is_relative_to(root) else run_dir
        parts = rel.parts
        entry: dict[str, Any] = {
            "dir": str(rel),
            "task": parts[1] if len(parts) > 3 and parts[0] == "runs" else None,
            "method": parts[2] if len(parts) > 3 and parts[0] == "runs" else None,
            "seed": _seed_of(run_dir.name),
            "used": False,
            "reason": None,
            "issues": [],
            "result": None,
        }
        runner = summary.get(run_dir, {})
        result_path = run_dir / "result.json"
        if not result_path.is_file():
            reason = "no result.json"
            if runner.get("status"):
                reason += f" (runner status: {runner['status']})"
            error = run_dir / "error.txt"
            if error.is_file():
                lines = [line for line in error.read_text(errors="replace").splitlines() if line.strip()]
                reason += f"; error.txt: {lines[-1].strip() if lines else '(empty)'}"
            entry["reason"] = reason
            entries.append(entry)
            continue
        try:
            result = json.loads(result_path.read_text())
            if not isinstance(result, dict):
                raise ValueError(f"expected a JSON object, got {type(result).__name__}")
        except (OSError, ValueError) as error:
            entry["reason"] = f"corrupt result.json: {error}"
            entries.append(entry)
            continue
        entry["task"] = result.get("task", entry["task"])
        entry["method"] = str(result.get("method", entry["method"]) or "").upper() or None
        entry["seed"] = result.get("seed", entry["seed"])
        if result.get("status") != "done":
            entry["reason"] = f"status {result.get('status')!r}"
            entries.append(entry)
            continue
        final = result.get("final")
        try:
            float(final["none"]["mean_return"])  # type: ignore[index]
        except (KeyError, TypeError, ValueError):
            entry["reason"] = "result.json has no final['none']['mean_return']"
            entries.append(entry)
            continue
        if not entry["task"] or not entry["method"]:
            entry["reason"] = "task or method unknown"
            entries.append(entry)
            continue
        entry.update(used=True, result=result)
        if not (run_dir / "messages.npz").is_file():
            entry["issues"].append("messages.npz missing: no t-SNE from this run")
        if not (run_dir / "model.zip").is_file():
            entry["issues"].append("model.zip missing")
        if not isinstance(result.get("communication"), dict):
            lines = str(result.get("communication_error") or "").strip().splitlines()
            detail = f" ({lines[-1].strip()})" if lines else ""
            entry["issues"].append(f"no communication metrics in result.json{detail}")
        entries.append(entry)
    return entries


# ------------------------------------------------------------------------------ references --
def reference_returns(
    env_id: str, n_episodes: int = 1000, seed: int = REFERENCE_SEED
) -> dict[str, Any] | None:
    """Mean team return of the oracle and of the uniform random policy on a task (None if unknown).

    Blind Soccer also gets ``blind_dash_forward`` (the blind agent dashes straight ahead: what
    the paper's GSN policy did with its messages disabled).
    """
    if env_id not in TASK_IDS:
        return None
    from envs import oracles

    module = importlib.import_module(f"envs.{TASK_IDS[env_id]}")
    rng = np.random.default_rng(seed + 1)
    policies: dict[str, Callable[[Any], np.ndarray]] = {
        "random": lambda task: oracles.random_policy(task, rng)
    }
    if env_id == "BlindSoccer-v0":
        policies = {
            "oracle": oracles.blind_soccer_oracle,
            **policies,
            "blind_dash_forward": oracles.blind_dash_forward,
        }
    elif env_id == "GuessMyNumber-v0":
        policies = {"oracle": oracles.guess_my_number_oracle, **policies}
    out: dict[str, Any] = {"n_episodes": n_episodes, "seed": seed}
    for name, policy in policies.items():
        task = module.batched_env(n_games=min(n_episodes, 1000))
        summary = oracles.evaluate(task, policy, n_episodes, seed=seed)["team_return"]
        out[name] = summary["mean"]
        out[f"{name}_ci95"] = summary["ci95"]
    return out


# ------------------------------------------------------------------------------- analysis --
def _clean(value: Any) -> Any:
    """JSON-safe copy: NaN/inf -> None, NumPy scalars and arrays -> Python."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return _clean(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _method_order(methods: list[str]) -> list[str]:
    rank = {m: k for k, m in enumerate(("GSN", *[m for m in METHODS if m != "GSN"]))}
    return sorted(methods, key=lambda m: (rank.get(m, len(rank)), m))


def _final(run: dict[str, Any], ablation: str) -> float:
    try:
        return float(run["result"]["final"][ablation]["mean_return"])
    except (KeyError, TypeError, ValueError):
        return float("nan")


def _curve(run: dict[str, Any], root: Path) -> tuple[np.ndarray, np.ndarray]:
    points = run["result"].get("curve")
    if not points:
        try:
            points = json.loads((root / run["dir"] / "evaluations.json").read_text())
        except (OSError, ValueError):
            points = []
    pairs = [(p["timesteps"], p["mean_return"]) for p in points if isinstance(p, dict) and "timesteps" in p]
    pairs.sort()
    array = np.array(pairs, dtype=np.float64).reshape(-1, 2)
    return array[:, 0], array[:, 1]


def _estimate(values: list[float], reps: int, seed: int) -> dict[str, Any]:
    return interval_estimates(np.asarray(values, dtype=np.float64), reps=reps, seed=seed)


def _final_table(runs: dict[str, list[dict]], ref: dict | None, reps: int, seed: int) -> dict:
    oracle = ref.get("oracle") if ref else None
    random_return = ref.get("random") if ref else None
    table: dict[str, Any] = {}
    for method, method_runs in runs.items():
        row: dict[str, Any] = {"seeds": [r["seed"] for r in method_runs]}
        for ablation in _ABLATIONS:
            values = [_final(r, ablation) for r in method_runs]
            row[ablation] = {"per_seed": values, **_estimate(values, reps, seed)}
        intact = np.array(row["none"]["per_seed"])
        zero = np.array(row["zero"]["per_seed"])
        drop = (intact - zero).tolist()
        row["zero_drop"] = {"per_seed": drop, **_estimate(drop, reps, seed)}
        if oracle:
            fractions = (intact / oracle).tolist()
            row["fraction_of_oracle"] = {"per_seed": fractions, **_estimate(fractions, reps, seed)}
            if random_return is not None and oracle != random_return:
                drops = ((intact - zero) / (oracle - random_return)).tolist()
                row["zero_drop_normalised"] = {"per_seed": drops, **_estimate(drops, reps, seed)}
        table[method] = row
    return table


def _communication_table(runs: dict[str, list[dict]]) -> dict[str, Any]:
    table: dict[str, Any] = {}
    for method, method_runs in runs.items():
        per_direction: dict[str, dict[str, list]] = {}
        for run in method_runs:
            comm = run["result"].get("communication")
            if not isinstance(comm, dict):
                continue
            for key, values in (comm.get("directions") or {}).items():
                bucket = per_direction.setdefault(key, {name: [] for name in _METRICS} | {"seeds": []})
                bucket["seeds"].append(run["seed"])
                for name in _METRICS:
                    value = values.get(name)
                    bucket[name].append(float(value) if value is not None else float("nan"))
        table[method] = {
            key: {
                "seeds": bucket["seeds"],
                **{
                    name: {
                        "per_seed": bucket[name],
                        "mean": float(np.nanmean(bucket[name])) if np.isfinite(bucket[name]).any() else None,
                    }
                    for name in _METRICS
                },
            }
            for key, bucket in per_direction.items()
        }
    return table


def _has_blind_receiver(task: str, runs: dict[str, list[dict]]) -> bool:
    """Blind Soccer, or any task whose measured channel goes to a ``blind`` agent."""
    if task == "BlindSoccer-v0":
        return True
    for method_runs in runs.values():
        for run in method_runs:
            directions = (run["result"].get("communication") or {}).get("directions") or {}
            if any(key.endswith("->blind") for key in directions):
                return True
    return False


def _tsne(task: str, runs: dict[str, list[dict]], root: Path, figures: Path, seed: int) -> dict[str, Any]:
    """Figure 3 for every method with a messages.npz (GSN first); its probe accuracy as a number."""
    out: dict[str, Any] = {}
    for method in _method_order(list(runs)):
        run = next((r for r in runs[method] if (root / r["dir"] / "messages.npz").is_file()), None)
        if run is None:
            out[method] = {"error": "no run with messages.npz"}
            continue
        try:
            rollout = Rollout.load(root / run["dir"] / "messages.npz")
            directions = communication_directions(rollout.agent_names)
            if not directions:
                raise ValueError(f"no channel direction between agents {list(rollout.agent_names)}")
            sender, receiver = directions[0]
            messages, next_actions = rollout.message_then_action(sender, receiver)
            stem = figures / f"tsne_{task}_{method}"
            probe = linear_probe(messages, next_actions, seed=seed)
            title = (
                f"{task} {method} seed {run['seed']}: {rollout.agent_names[sender]}'s messages\n"
                f"probe accuracy {probe['accuracy']:.2f} vs majority {probe['majority_rate']:.2f}"
            )
            paths = plot_tsne(messages, next_actions, stem, ACTION_NAMES, title=title, seed=seed)
            out[method] = {
                "run": run["dir"],
                "seed": run["seed"],
                "sender": rollout.agent_names[sender],
                "receiver": rollout.agent_names[receiver],
                "n_messages": len(messages),
                "probe": probe,
                "files": [str(p) for p in paths],
            }
        except Exception as error:  # one broken file must not stop the report
            out[method] = {"run": run["dir"], "error": f"{type(error).__name__}: {error}"}
    return out


# --------------------------------------------------------------------------------- claims --
def _fmt(value: float | None, digits: int = 3) -> str:
    return "n/a" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def _interval_text(est: dict[str, Any]) -> str:
    mean = est.get("mean", {})
    return f"{_fmt(mean.get('point'))} [{_fmt(mean.get('low'))}, {_fmt(mean.get('high'))}]"


def _solved_claim(cid: str, task: str, method: str, finals: dict, paper: str) -> dict[str, Any]:
    claim = {
        "id": cid,
        "task": task,
        "claim": f"{task}: {method} reaches >= {SOLVED_FRACTION} of the oracle's return",
        "paper": paper,
        "rule": f"reproduced: mean fraction >= {SOLVED_FRACTION}; partly: mean >= 0.5 or the 95% interval "
        f"reaches {SOLVED_FRACTION}; not: otherwise",
    }
    row = finals.get(task, {}).get(method)
    if not row or "fraction_of_oracle" not in row or row["fraction_of_oracle"]["n_runs"] == 0:
        return {**claim, "measured": "no runs", "verdict": "not measured"}
    est = row["fraction_of_oracle"]
    point, high = est["mean"]["point"], est["mean"]["high"]
    verdict = (
        "reproduced"
        if point >= SOLVED_FRACTION
        else ("partly" if point >= 0.5 or high >= SOLVED_FRACTION else "not")
    )
    measured = f"fraction of oracle {_interval_text(est)} over {est['n_runs']} seeds"
    return {**claim, "measured": measured, "value": point, "verdict": verdict, "n_seeds": est["n_runs"]}


def _only_claim(cid: str, task: str, winner: str, finals: dict, paper: str, main_verdict: str) -> dict:
    claim = {
        "id": cid,
        "task": task,
        "claim": f"{task}: only {winner} solves it; the other methods stay below {SOLVED_FRACTION} "
        "of the oracle",
        "paper": paper,
        "rule": f"reproduced: {winner} solves it and every other measured method's mean fraction < "
        f"{SOLVED_FRACTION}; partly: the others stay below but {winner} does not reach it; not: another "
        "method reaches it",
    }
    measured_rows = {
        m: row["fraction_of_oracle"]
        for m, row in finals.get(task, {}).items()
        if m not in (winner, "NONE") and "fraction_of_oracle" in row and row["fraction_of_oracle"]["n_runs"]
    }
    others = {m: est["mean"]["point"] for m, est in measured_rows.items()}
    if not others:
        return {**claim, "measured": "no other method measured", "verdict": "not measured"}
    measured = ", ".join(f"{m} {_fmt(v)}" for m, v in sorted(others.items()))
    if any(v >= SOLVED_FRACTION for v in others.values()):
        verdict = "not"
    else:
        verdict = "reproduced" if main_verdict == "reproduced" else "partly"
    n_seeds = min(est["n_runs"] for est in measured_rows.values())
    return {
        **claim,
        "measured": f"fractions of oracle: {measured}",
        "values": others,
        "verdict": verdict,
        "n_seeds": n_seeds,
    }


def _require_seeds(claim: dict[str, Any], min_seeds: int) -> dict[str, Any]:
    """SPEC §5 asks for >= ``min_seeds`` training seeds: a claim met with fewer is only partly met."""
    n_seeds = claim.get("n_seeds")
    if n_seeds is not None and n_seeds < min_seeds and claim["verdict"] == "reproduced":
        claim["verdict"] = "partly"
        claim["measured"] += f" (met, but with {n_seeds} < {min_seeds} seeds)"
    return claim


def _claims(finals: dict, comm: dict, min_seeds: int = MIN_SEEDS) -> list[dict[str, Any]]:
    bs, gmn = "BlindSoccer-v0", "GuessMyNumber-v0"
    claims = []
    paper = "GSN solves Blind Soccer (Figure 2; maximum about 0.6)"
    c1 = _require_seeds(_solved_claim("C1", bs, "GSN", finals, paper), min_seeds)
    claims.append(c1)
    paper = "only GSN solves Blind Soccer; RIAL and TCG do not (Figure 2)"
    claims.append(_only_claim("C2", bs, "GSN", finals, paper, c1["verdict"]))

    c3 = {
        "id": "C3",
        "task": bs,
        "claim": f"{bs}: zeroing GSN's messages lowers its return",
        "paper": "with communication disabled the blind agent walks straight ahead regardless of the "
        "ball (§7)",
        "rule": "drop = intact - zeroed return, normalised by (oracle - random); reproduced: the drop's 95% "
        "interval is above 0 and the normalised drop >= 0.5; partly: mean drop > 0; not: otherwise",
    }
    row = finals.get(bs, {}).get("GSN")
    if not row or row["zero_drop"]["n_runs"] == 0:
        c3.update(measured="no runs", verdict="not measured")
    else:
        drop = row["zero_drop"]
        normalised = row.get("zero_drop_normalised", {}).get("mean", {}).get("point")
        point, low = drop["mean"]["point"], drop["mean"]["low"]
        strong = low > 0 and normalised is not None and normalised >= 0.5
        c3.update(
            measured=f"intact {_interval_text(row['none'])}, zeroed {_interval_text(row['zero'])}, drop "
            f"{_interval_text(drop)} (normalised {_fmt(normalised)})",
            value=point,
            verdict="reproduced" if strong else ("partly" if point > 0 else "not"),
            n_seeds=drop["n_runs"],
        )
    claims.append(c3)

    c4 = {
        "id": "C4",
        "task": bs,
        "claim": f"{bs}: RIAL's and TCG's returns do not change when their messages are zeroed",
        "paper": "policies learned by RIAL and TCG remain unchanged when communication is disabled (§7)",
        "rule": "normalised drop (intact - zeroed) / (oracle - random): reproduced: |drop| < 0.1 for each "
        "measured method; partly: < 0.25; not: otherwise",
    }
    drop_rows = {
        m: finals[bs][m]["zero_drop_normalised"]
        for m in ("RIAL", "TCG")
        if m in finals.get(bs, {})
        and "zero_drop_normalised" in finals[bs][m]
        and finals[bs][m]["zero_drop_normalised"]["n_runs"]
    }
    drops = {m: est["mean"]["point"] for m, est in drop_rows.items()}
    if not drops:
        c4.update(measured="no runs", verdict="not measured")
    else:
        worst = max(abs(v) for v in drops.values())
        c4.update(
            measured="normalised drops: " + ", ".join(f"{m} {_fmt(v)}" for m, v in drops.items()),
            values=drops,
            verdict="reproduced" if worst < 0.1 else ("partly" if worst < 0.25 else "not"),
            n_seeds=min(est["n_runs"] for est in drop_rows.values()),
        )
    claims.append(c4)

    c5 = {
        "id": "C5",
        "task": bs,
        "claim": f"{bs}: GSN's messages predict the blind agent's next action (dash or turn)",
        "paper": "strong correlation between the message and the teammate's next action (Figure 3)",
        "rule": "linear-probe accuracy (cross-validated) minus the majority rate, mean over seeds: "
        "reproduced: >= 0.05 and > 0 in every seed; partly: mean > 0; not: otherwise",
    }
    direction = comm.get(bs, {}).get("GSN", {}).get("sighted->blind")
    gains = []
    if direction:
        acc, maj = direction["probe_accuracy"]["per_seed"], direction["majority_rate"]["per_seed"]
        gains = [a - b for a, b in zip(acc, maj, strict=True) if math.isfinite(a) and math.isfinite(b)]
    if not gains:
        c5.update(measured="no communication metrics", verdict="not measured")
    else:
        mean_gain = float(np.mean(gains))
        cic = direction["cic"]["mean"]
        c5.update(
            measured=f"probe accuracy {_fmt(direction['probe_accuracy']['mean'])} vs majority "
            f"{_fmt(direction['majority_rate']['mean'])} (gain {_fmt(mean_gain)}; CIC {_fmt(cic)} nats) "
            f"over {len(gains)} seeds",
            value=mean_gain,
            verdict="reproduced"
            if mean_gain >= 0.05 and min(gains) > 0
            else ("partly" if mean_gain > 0 else "not"),
            n_seeds=len(gains),
        )
    claims.append(c5)

    paper = "TCG solves Guess My Number (Figure 4; maximum about 10)"
    c6 = _require_seeds(_solved_claim("C6", gmn, "TCG", finals, paper), min_seeds)
    claims.append(c6)
    claims.append(
        _only_claim(
            "C7",
            gmn,
            "TCG",
            finals,
            "only TCG solves Guess My Number; RIAL and GSN do not (Fig. 4)",
            c6["verdict"],
        )
    )
    return [_require_seeds(claim, min_seeds) for claim in claims]


# ------------------------------------------------------------------------------- markdown --
def _md_table(header: list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    return lines + ["| " + " | ".join(row) + " |" for row in rows]


def _finals_md(finals: dict, references: dict) -> list[str]:
    lines = []
    for task, table in finals.items():
        ref = references.get(task) or {}
        lines += [
            f"### {task}",
            "",
            f"Oracle {_fmt(ref.get('oracle'))}, random {_fmt(ref.get('random'))} "
            f"({ref.get('n_episodes', 'n/a')} episodes). "
            "Mean [95% stratified-bootstrap interval] over seeds.",
            "",
        ]
        rows = []
        for method, row in table.items():
            fraction = row.get("fraction_of_oracle", {})
            iqm = fraction.get("iqm")
            rows.append(
                [
                    method,
                    str(row["none"]["n_runs"]),
                    _interval_text(row["none"]),
                    _interval_text(fraction) if fraction else "n/a",
                    f"{_fmt(iqm['point'])} [{_fmt(iqm['low'])}, {_fmt(iqm['high'])}]"
                    if iqm
                    else "(< 5 seeds)",
                    _interval_text(row["zero"]),
                    _interval_text(row["shuffle"]),
                ]
            )
        header = ["method", "seeds", "return", "fraction of oracle", "IQM fraction", "zeroed", "shuffled"]
        lines += _md_table(header, rows)
        lines.append("")
    return lines


def _comm_md(comm: dict) -> list[str]:
    rows = []
    for task, table in comm.items():
        for method, directions in table.items():
            for key, values in directions.items():
                metrics = [_fmt(values[m]["mean"]) for m in _METRICS]
                rows.append([task, method, key, str(len(values["seeds"])), *metrics])
    if not rows:
        return ["No communication metrics.", ""]
    header = [
        "task",
        "method",
        "direction",
        "seeds",
        "CIC",
        "I(a_s; m)",
        "I(m; a_r')",
        "probe acc.",
        "majority",
    ]
    return [*_md_table(header, rows), "", "Mutual informations and CIC in nats; means over seeds.", ""]


def _claims_md(claims: list[dict]) -> list[str]:
    rows = [[c["id"], c["claim"], c["paper"], c["measured"], f"**{c['verdict']}**"] for c in claims]
    lines = _md_table(["", "claim", "paper", "measured", "verdict"], rows)
    rules = [f"- {c['id']}: {c['rule']}" for c in claims]
    note = "A claim met with fewer training seeds than required (SPEC §5: 3) is marked partly."
    return [*lines, "", "Rules:", "", *rules, "", note, ""]


def _runs_md(runs: list[dict]) -> list[str]:
    skipped = [r for r in runs if not r["used"]]
    partial = [r for r in runs if r["used"] and r["issues"]]
    used = sum(r["used"] for r in runs)
    lines = [f"{used} runs used, {len(skipped)} skipped, {len(partial)} used with missing parts.", ""]
    if skipped:
        rows = [[f"`{r['dir']}`", r["reason"].replace("|", "\\|")] for r in skipped]
        lines += [*_md_table(["run", "reason"], rows), ""]
    if partial:
        rows = [[f"`{r['dir']}`", "; ".join(r["issues"])] for r in partial]
        lines += [*_md_table(["run", "missing"], rows), ""]
    return lines


# ---------------------------------------------------------------------------------- entry --
def _write(path: Path, data: Any) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(_clean(data), indent=2, allow_nan=False) if path.suffix == ".json" else data
    path.write_text(text)
    return path


def _cached_references(out_dir: Path, n_episodes: int) -> dict[str, Any]:
    try:
        cached = json.loads((out_dir / "report.json").read_text()).get("references", {})
    except (OSError, ValueError, AttributeError):
        return {}
    return {
        task: ref
        for task, ref in cached.items()
        if isinstance(ref, dict) and ref.get("n_episodes") == n_episodes and ref.get("seed") == REFERENCE_SEED
    }


def make_report(
    experiment_dir: str | Path,
    out_dir: str | Path | None = None,
    n_reference_episodes: int = 1000,
    reps: int = 10_000,
    seed: int = 0,
    tsne: bool = True,
    min_seeds: int = MIN_SEEDS,
) -> dict[str, Any]:
    """Write the report of an experiment and return it as a dict (the content of ``report.json``).

    :param experiment_dir: the runner's output folder (with ``runs/``).
    :param out_dir: where to write (default ``experiment_dir/report``).
    :param n_reference_episodes: episodes of the oracle and random-policy evaluations (reused from
        an earlier ``report.json`` in ``out_dir`` when it used the same number).
    :param reps: bootstrap replications of the interval estimates.
    :param seed: seed of the bootstrap, the probes and t-SNE.
    :param tsne: draw the t-SNE figures (Blind Soccer only: its receiver's next action is the
        paper's Figure 3; the slowest part of the report).
    :param min_seeds: training seeds a claim needs to count as reproduced; with fewer a met
        claim is marked ``partly``.
    :return: ``runs`` (every run, used or not, with reasons), ``skipped``, ``references``,
        ``final_returns``, ``communication``, ``tsne``, ``claims``, ``figures`` and ``files``.
    """
    root = Path(experiment_dir).resolve()
    out = Path(out_dir) if out_dir is not None else root / "report"
    figures, tables = out / "figures", out / "tables"
    runs = load_runs(root)

    grouped: dict[str, dict[str, list[dict]]] = {}
    for run in runs:
        if run["used"]:
            grouped.setdefault(run["task"], {}).setdefault(run["method"], []).append(run)
    for task in grouped:
        grouped[task] = {
            m: sorted(grouped[task][m], key=lambda r: (r["seed"] is None, r["seed"] or 0))
            for m in _method_order(list(grouped[task]))
        }

    references = _cached_references(out, n_reference_episodes)
    for task in sorted(grouped):
        if task not in references:
            references[task] = reference_returns(task, n_reference_episodes)

    finals, comm, tsne_out, figure_files, errors = {}, {}, {}, {}, []
    for task in sorted(grouped):
        ref = references.get(task) or {}
        finals[task] = _final_table(grouped[task], ref, reps, seed)
        comm[task] = _communication_table(grouped[task])
        lines = {k: ref[k] for k in ("oracle", "random") if ref.get(k) is not None}
        try:
            curves = {m: [_curve(r, root) for r in rs] for m, rs in grouped[task].items()}
            figure_files[f"curves_{task}"] = plot_learning_curves(
                curves, figures / f"curves_{task}", title=f"{task}: learning curves", references=lines
            )
            bars = {m: {a: row[a]["mean"] for a in _ABLATIONS} for m, row in finals[task].items()}
            figure_files[f"ablation_{task}"] = plot_ablation(
                bars, figures / f"ablation_{task}", title=f"{task}: message ablation", references=lines
            )
        except Exception as error:  # a figure must not cost the tables
            errors.append(f"{task} figures: {type(error).__name__}: {error}\n{traceback.format_exc(limit=3)}")
        if tsne and _has_blind_receiver(task, grouped[task]):
            tsne_out[task] = _tsne(task, grouped[task], root, figures, seed)
            for method, entry in tsne_out[task].items():
                if "files" in entry:
                    figure_files[f"tsne_{task}_{method}"] = entry["files"]

    claims = _claims(finals, comm, min_seeds)
    skipped = [{"dir": r["dir"], "reason": r["reason"]} for r in runs if not r["used"]]
    incomplete = [{"dir": r["dir"], "issues": r["issues"]} for r in runs if r["used"] and r["issues"]]
    run_rows = [{k: v for k, v in r.items() if k != "result"} for r in runs]

    provenance = _provenance(root, runs)
    report: dict[str, Any] = {
        "experiment_dir": str(root),
        "provenance": provenance,
        "runs": run_rows,
        "skipped": skipped,
        "incomplete": incomplete,
        "references": references,
        "final_returns": finals,
        "communication": comm,
        "tsne": tsne_out,
        "claims": claims,
        "figures": {k: [str(p) for p in v] for k, v in figure_files.items()},
        "errors": errors,
    }

    finals_md = _finals_md(finals, references)
    files = [
        _write(tables / "final_returns.json", finals),
        _write(tables / "final_returns.md", "\n".join(["# Final returns", "", *finals_md])),
        _write(tables / "communication.json", comm),
        _write(tables / "communication.md", "\n".join(["# Communication metrics", "", *_comm_md(comm)])),
        _write(tables / "claims.json", claims),
        _write(tables / "claims.md", "\n".join(["# Claims of the paper", "", *_claims_md(claims)])),
        _write(tables / "runs.json", {"runs": run_rows, "skipped": skipped, "incomplete": incomplete}),
        _write(tables / "runs.md", "\n".join(["# Runs", "", *_runs_md(runs)])),
    ]
    pngs = [Path(p) for paths in figure_files.values() for p in paths if Path(p).suffix == ".png"]
    figure_lines = [f"- `{p.relative_to(out)}`" for p in pngs]
    markdown = [
        f"# Report of `{root.name}`",
        "",
        *_provenance_md(provenance),
        "## Claims of the paper",
        "",
        *_claims_md(claims),
        "## Final returns",
        "",
        *finals_md,
        "## Communication",
        "",
        *_comm_md(comm),
        "## Figures",
        "",
        *(figure_lines or ["None."]),
        "",
        "## Runs",
        "",
        *_runs_md(runs),
    ]
    if errors:
        markdown += ["## Errors", "", *[f"- {e.splitlines()[0]}" for e in errors], ""]
    files.append(_write(out / "report.md", "\n".join(markdown)))
    report["files"] = [str(p) for p in files] + [str(out / "report.json")]
    _write(out / "report.json", report)
    return _clean(report)
