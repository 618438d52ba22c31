"""Markdown of the report: the tables, claims, runs and provenance drawn as text.

Pure functions from the report's dicts (built by :mod:`~sb3_comm.analysis.tables`,
:mod:`~sb3_comm.analysis.claims` and :mod:`~sb3_comm.analysis.runs`) to lists of lines; nothing
here computes a statistic or reads a file. :func:`report_page` assembles ``report.md``;
:func:`fmt` and :func:`interval_text` are the number formats every part uses.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from sb3_comm.analysis.tables import METRICS

__all__ = [
    "claims_md",
    "communication_md",
    "final_returns_md",
    "fmt",
    "interval_text",
    "md_table",
    "provenance_md",
    "report_page",
    "runs_md",
]

_METRIC_HEADERS = ("CIC", "I(a_s; m)", "I(m; a_r')", "probe acc.", "majority")
"""Column titles of :data:`~sb3_comm.analysis.tables.METRICS`, in that order."""


def fmt(value: float | None, digits: int = 3) -> str:
    """``value`` with ``digits`` decimals, or ``n/a`` when missing or not finite."""
    return "n/a" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def interval_text(est: dict[str, Any]) -> str:
    """``mean [low, high]`` of an interval estimate."""
    mean = est.get("mean", {})
    return f"{fmt(mean.get('point'))} [{fmt(mean.get('low'))}, {fmt(mean.get('high'))}]"


def md_table(header: list[str], rows: list[list[str]]) -> list[str]:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    return lines + ["| " + " | ".join(row) + " |" for row in rows]


def provenance_md(info: dict[str, Any]) -> list[str]:
    """How the runs were made (:func:`~sb3_comm.analysis.runs.provenance`)."""
    machine = info.get("machine") or {}
    wall = info.get("wall_seconds")
    runs = (
        f"sum over the {info['runs_used']} runs used: {info['run_wall_seconds_total']:.0f} s of run time; "
        f"environment steps per run: {', '.join(f'{n:,}' for n in info['run_env_steps'])}"
    )
    if info.get("command") is None:  # a folder put together by hand, or whose summary.json was lost
        return [
            "- No runner summary (`summary.json`) in this folder: each run's `result.json` holds its "
            f"settings, times and seed; {runs}",
            "",
        ]
    return [
        f"- Command (last start of the runner): `{info.get('command')}`, finished {info.get('finished')}",
        f"- Machine: {machine.get('cpu_model', '?')}, {machine.get('usable_cores', '?')} usable cores;"
        f" backend {info.get('backend')}, {info.get('workers')} runs at a time",
        f"- Wall-clock time of that start: {'?' if wall is None else f'{wall:.0f} s'}; {runs}",
        "",
    ]


def final_returns_md(finals: dict[str, Any], references: dict[str, Any]) -> list[str]:
    """One table of final returns per task, headed by its oracle and random returns."""
    lines = []
    for task, table in finals.items():
        ref = references.get(task) or {}
        lines += [
            f"### {task}",
            "",
            f"Oracle {fmt(ref.get('oracle'))}, random {fmt(ref.get('random'))} "
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
                    interval_text(row["none"]),
                    interval_text(fraction) if fraction else "n/a",
                    f"{fmt(iqm['point'])} [{fmt(iqm['low'])}, {fmt(iqm['high'])}]" if iqm else "(< 5 seeds)",
                    interval_text(row["zero"]),
                    interval_text(row["shuffle"]),
                ]
            )
        header = ["method", "seeds", "return", "fraction of oracle", "IQM fraction", "zeroed", "shuffled"]
        lines += md_table(header, rows)
        lines.append("")
    return lines


def communication_md(comm: dict[str, Any]) -> list[str]:
    """One row per task, method and channel direction: the mean of each communication metric."""
    rows = []
    for task, table in comm.items():
        for method, directions in table.items():
            for key, values in directions.items():
                metrics = [fmt(values[m]["mean"]) for m in METRICS]
                rows.append([task, method, key, str(len(values["seeds"])), *metrics])
    if not rows:
        return ["No communication metrics.", ""]
    header = ["task", "method", "direction", "seeds", *_METRIC_HEADERS]
    return [*md_table(header, rows), "", "Mutual informations and CIC in nats; means over seeds.", ""]


def claims_md(claims: list[dict[str, Any]]) -> list[str]:
    """The claims with the paper's words, the measurement and the verdict, then the rules."""
    rows = [[c["id"], c["claim"], c["paper"], c["measured"], f"**{c['verdict']}**"] for c in claims]
    lines = md_table(["", "claim", "paper", "measured", "verdict"], rows)
    rules = [f"- {c['id']}: {c['rule']}" for c in claims]
    note = "A claim met with fewer training seeds than required (SPEC §5: 3) is marked partly."
    return [*lines, "", "Rules:", "", *rules, "", note, ""]


def runs_md(runs: list[dict[str, Any]]) -> list[str]:
    """How many runs were used; the skipped ones with the reason, the incomplete ones with what
    they lack."""
    skipped = [r for r in runs if not r["used"]]
    partial = [r for r in runs if r["used"] and r["issues"]]
    used = sum(r["used"] for r in runs)
    lines = [f"{used} runs used, {len(skipped)} skipped, {len(partial)} used with missing parts.", ""]
    if skipped:
        rows = [[f"`{r['dir']}`", r["reason"].replace("|", "\\|")] for r in skipped]
        lines += [*md_table(["run", "reason"], rows), ""]
    if partial:
        rows = [[f"`{r['dir']}`", "; ".join(r["issues"])] for r in partial]
        lines += [*md_table(["run", "missing"], rows), ""]
    return lines


def report_page(
    name: str,
    provenance: dict[str, Any],
    claims: list[dict[str, Any]],
    finals: dict[str, Any],
    references: dict[str, Any],
    comm: dict[str, Any],
    figures: list[Path],
    runs: list[dict[str, Any]],
    errors: list[str],
    beyond: list[dict[str, Any]] | None = None,
) -> str:
    """``report.md``: provenance, claims (the paper's, then those beyond it), final returns,
    communication, figures, runs, errors.

    :param name: the experiment folder's name (the title).
    :param figures: the PNG files, relative to the report folder.
    """
    figure_lines = [f"- `{p}`" for p in figures]
    markdown = [
        f"# Report of `{name}`",
        "",
        *provenance_md(provenance),
        "## Claims of the paper",
        "",
        *claims_md(claims),
        *(["## Beyond the paper", "", *claims_md(beyond)] if beyond else []),
        "## Final returns",
        "",
        *final_returns_md(finals, references),
        "## Communication",
        "",
        *communication_md(comm),
        "## Figures",
        "",
        *(figure_lines or ["None."]),
        "",
        "## Runs",
        "",
        *runs_md(runs),
    ]
    if errors:
        markdown += ["## Errors", "", *[f"- {e.splitlines()[0]}" for e in errors], ""]
    return "\n".join(markdown)
