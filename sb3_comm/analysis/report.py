"""Turn an experiment folder into figures, tables and the paper's claims next to measured numbers.

:func:`make_report` reads every run under ``experiment_dir/runs/<task>/<method>/<seed dir>/``
(``result.json``, ``messages.npz``, ``evaluations.json``; see the runner) and writes into
``out_dir`` (default ``experiment_dir/report/``)::

    report.json, report.md            everything below in one file each
    tables/{final_returns,communication,claims,beyond,runs}.{json,md}
    figures/curves_<task>.{png,svg}   learning curves, mean and 95% interval over seeds (Figs. 2, 4)
    figures/ablation_<task>.{png,svg} returns with messages intact, zeroed, shuffled
    figures/tsne_<task>_<method>.{png,svg}  the sender's messages coloured by the receiver's next
                                      action (Fig. 3; Blind Soccer, GSN first)

A run that is not done, has a missing or corrupt ``result.json`` or lacks what a part needs
(``messages.npz`` for the t-SNE) is listed with the reason, in the returned dict and in the
Markdown, and never stops the others. Final returns are also given as fractions of the oracle's
return (:func:`~sb3_comm.analysis.references.reference_returns`, cached in ``report.json``), with
stratified-bootstrap intervals over seeds (:func:`~sb3_comm.analysis.stats.interval_estimates`).

:func:`make_report` only orchestrates; each step lives in its own module:

* :mod:`~sb3_comm.analysis.runs`: loading the runs (:func:`load_runs`, the one reader of
  ``result.json``) and the provenance;
* :mod:`~sb3_comm.analysis.references`: oracle and random returns from the task registry;
* :mod:`~sb3_comm.analysis.tables`: the statistics tables;
* :mod:`~sb3_comm.analysis.claims`: the paper's claims as data, judged on the tables;
* :mod:`~sb3_comm.analysis.markdown`: the Markdown pages;
* here: the figures of each task and writing the files.
"""

from __future__ import annotations

import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sb3_comm.analysis import markdown
from sb3_comm.analysis.claims import BEYOND_CLAIMS, MIN_SEEDS, SOLVED_FRACTION, Claim, judge_claims
from sb3_comm.analysis.metrics import linear_probe
from sb3_comm.analysis.plots import plot_ablation, plot_learning_curves, plot_tsne
from sb3_comm.analysis.references import cached_references, reference_returns
from sb3_comm.analysis.rollout import ACTION_NAMES, Rollout, communication_directions
from sb3_comm.analysis.runs import (
    communication_of,
    group_runs,
    learning_curve,
    load_runs,
    method_order,
    provenance,
)
from sb3_comm.analysis.tables import ABLATIONS, communication_table, final_returns_table
from sb3_comm.results import to_jsonable, write_json

__all__ = ["MIN_SEEDS", "SOLVED_FRACTION", "load_runs", "make_report", "reference_returns"]


def _write(path: Path, data: Any) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".json":
        return write_json(path, data)
    path.write_text(data)
    return path


# -------------------------------------------------------------------------------- figures --
def _has_blind_receiver(task: str, runs: dict[str, list[dict]]) -> bool:
    """A task with a ``blind`` agent (Blind Soccer, from the task registry), or any task whose
    measured channel goes to a ``blind`` agent."""
    from envs.registry import TASKS

    if task in TASKS and "blind" in TASKS[task].agents:
        return True
    for method_runs in runs.values():
        for run in method_runs:
            directions = (communication_of(run) or {}).get("directions") or {}
            if any(key.endswith("->blind") for key in directions):
                return True
    return False


def _curves_and_ablation(
    task: str,
    runs: dict[str, list[dict]],
    finals: dict[str, Any],
    lines: dict[str, float],
    root: Path,
    figures: Path,
    files: dict[str, list[Path]],
) -> None:
    """Draw the learning curves (Figs. 2, 4) and the message-ablation bars of one task; add each
    figure's files to ``files`` as soon as it is drawn."""
    curves = {m: [learning_curve(r, root) for r in rs] for m, rs in runs.items()}
    files[f"curves_{task}"] = plot_learning_curves(
        curves, figures / f"curves_{task}", title=f"{task}: learning curves", references=lines
    )
    bars = {m: {a: row[a]["mean"] for a in ABLATIONS} for m, row in finals.items()}
    files[f"ablation_{task}"] = plot_ablation(
        bars, figures / f"ablation_{task}", title=f"{task}: message ablation", references=lines
    )


def _tsne(task: str, runs: dict[str, list[dict]], root: Path, figures: Path, seed: int) -> dict[str, Any]:
    """Figure 3 for every method with a messages.npz (GSN first); its probe accuracy as a number."""
    out: dict[str, Any] = {}
    for method in method_order(list(runs)):
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


# ---------------------------------------------------------------------------------- entry --
def make_report(
    experiment_dir: str | Path,
    out_dir: str | Path | None = None,
    n_reference_episodes: int = 1000,
    reps: int = 10_000,
    seed: int = 0,
    tsne: bool = True,
    min_seeds: int = MIN_SEEDS,
    claims: Sequence[Claim] | None = None,
    beyond: Sequence[Claim] = BEYOND_CLAIMS,
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
    :param claims: the claims to judge (default
        :data:`~sb3_comm.analysis.claims.PAPER_CLAIMS`).
    :param beyond: the claims beyond the paper (default
        :data:`~sb3_comm.analysis.claims.BEYOND_CLAIMS`: GSN-MAX solves both tasks), judged in
        their own section; a claim is shown when one of its methods has runs.
    :return: ``runs`` (every run, used or not, with reasons), ``skipped``, ``references``,
        ``final_returns``, ``communication``, ``tsne``, ``claims``, ``beyond``, ``figures`` and
        ``files``.
    """
    root = Path(experiment_dir).resolve()
    out = Path(out_dir) if out_dir is not None else root / "report"
    figures, tables = out / "figures", out / "tables"
    runs = load_runs(root)
    grouped = group_runs(runs)

    references = cached_references(out, n_reference_episodes)
    for task in sorted(grouped):
        if task not in references:
            references[task] = reference_returns(task, n_reference_episodes)

    finals, comm, tsne_out, figure_files, errors = {}, {}, {}, {}, []
    for task in sorted(grouped):
        ref = references.get(task) or {}
        finals[task] = final_returns_table(grouped[task], ref, reps, seed)
        comm[task] = communication_table(grouped[task])
        lines = {k: ref[k] for k in ("oracle", "random") if ref.get(k) is not None}
        try:
            _curves_and_ablation(task, grouped[task], finals[task], lines, root, figures, figure_files)
        except Exception as error:  # a figure must not cost the tables
            errors.append(f"{task} figures: {type(error).__name__}: {error}\n{traceback.format_exc(limit=3)}")
        if tsne and _has_blind_receiver(task, grouped[task]):
            tsne_out[task] = _tsne(task, grouped[task], root, figures, seed)
            for method, entry in tsne_out[task].items():
                if "files" in entry:
                    figure_files[f"tsne_{task}_{method}"] = entry["files"]

    judged = judge_claims(finals, comm, min_seeds, claims)
    measured = {method for table in finals.values() for method in table}
    shown = [c for c in beyond if set(c.methods) & measured]
    beyond_judged = judge_claims(finals, comm, min_seeds, shown) if shown else []
    skipped = [{"dir": r["dir"], "reason": r["reason"]} for r in runs if not r["used"]]
    incomplete = [{"dir": r["dir"], "issues": r["issues"]} for r in runs if r["used"] and r["issues"]]
    run_rows = [{k: v for k, v in r.items() if k != "result"} for r in runs]
    made = provenance(root, runs)
    report: dict[str, Any] = {
        "experiment_dir": str(root),
        "provenance": made,
        "runs": run_rows,
        "skipped": skipped,
        "incomplete": incomplete,
        "references": references,
        "final_returns": finals,
        "communication": comm,
        "tsne": tsne_out,
        "claims": judged,
        "beyond": beyond_judged,
        "figures": {k: [str(p) for p in v] for k, v in figure_files.items()},
        "errors": errors,
    }

    def page(title: str, lines: list[str]) -> str:
        return "\n".join([f"# {title}", "", *lines])

    pngs = [Path(p) for paths in figure_files.values() for p in paths]
    pngs = [p.relative_to(out) for p in pngs if p.suffix == ".png"]
    finals_md = markdown.final_returns_md(finals, references)
    files = [
        _write(tables / "final_returns.json", finals),
        _write(tables / "final_returns.md", page("Final returns", finals_md)),
        _write(tables / "communication.json", comm),
        _write(tables / "communication.md", page("Communication metrics", markdown.communication_md(comm))),
        _write(tables / "claims.json", judged),
        _write(tables / "claims.md", page("Claims of the paper", markdown.claims_md(judged))),
        _write(tables / "beyond.json", beyond_judged),
        _write(tables / "beyond.md", page("Beyond the paper", markdown.claims_md(beyond_judged))),
        _write(tables / "runs.json", {"runs": run_rows, "skipped": skipped, "incomplete": incomplete}),
        _write(tables / "runs.md", page("Runs", markdown.runs_md(runs))),
        _write(
            out / "report.md",
            markdown.report_page(
                root.name, made, judged, finals, references, comm, pngs, runs, errors, beyond_judged
            ),
        ),
    ]
    report["files"] = [str(p) for p in files] + [str(out / "report.json")]
    _write(out / "report.json", report)
    return to_jsonable(report)
