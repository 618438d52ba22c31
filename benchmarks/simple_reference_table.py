"""One table over several result files of ``benchmarks/simple_reference.py``.

Each file of that benchmark holds one setting (``--params``, ``--perfect-channel``, steps). This
script puts them side by side: per file and method, the fraction of the communication gap closed
on every seed, its mean, rliable's IQM (5 seeds or more), the worst seed, the machine and the
training time per run. It reads only the JSON files in ``benchmarks/results/``, so the combined
table is remade from the runs' own records, e.g. the perfect-channel screen of session 19::

    python benchmarks/simple_reference_table.py simple_reference_perfect_channel_300k \\
        screen_pc_gamma0.95 screen_pc_td3 screen_pc_batch256 screen_pc_epsgauss screen_pc_tau0.01 \\
        screen_pc_actorlr1e-3 --name screen_simple_reference_perfect_channel_learner \\
        --title "mpe2 simple_reference, perfect channel: which learner setting lifts the ceiling"

writes ``benchmarks/results/<name>.{json,md}``.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import RESULTS_DIR, write_results

from sb3_comm.results import read_json

SCRIPT = "benchmarks/simple_reference_table.py"


def setting(args: dict[str, Any]) -> str:
    """A result file's setting in words: its constructor parameters (or "defaults"), the perfect
    channel where it was on, and the steps per run."""
    params = args.get("params") or []
    text = " ".join(f"`{p}`" for p in params) if params else "defaults"
    if args.get("perfect_channel"):
        text += ", perfect channel"
    return f"{text}, {args['timesteps']:,} steps"


def rows_of(name: str) -> list[dict[str, Any]]:
    """One row per method of the result file ``benchmarks/results/<name>.json``.

    :raises FileNotFoundError: when the file does not exist.
    :raises ValueError: when the file is not a ``simple_reference.py`` result.
    """
    path = RESULTS_DIR / f"{name}.json"
    if not path.is_file():
        raise FileNotFoundError(f"no result file {path} (give a name in {RESULTS_DIR}, without .json)")
    data = read_json(path)
    if "methods" not in data or "args" not in data or "runs" not in data:
        raise ValueError(
            f"{path} is not a result of benchmarks/simple_reference.py (no 'methods', 'args', 'runs')"
        )
    described = setting(data["args"])
    rows = []
    for method, m in data["methods"].items():
        seconds = [r["train_seconds"] for r in data["runs"] if r["method"] == method]
        rows.append(
            {
                "file": name,
                "setting": described,
                "method": method,
                "seeds": m["seeds"],
                "gap_closed": m["gap_closed"],
                "mean": m["gap_closed_estimates"]["mean"],
                "iqm": m["gap_closed_estimates"].get("iqm"),
                "worst": m["worst_gap_closed"],
                "machine": data["machine"]["cpu_model"],
                "date": data["machine"]["date"][:10],
                "train_seconds": [min(seconds), max(seconds)],
            }
        )
    return rows


def markdown(rows: list[dict[str, Any]]) -> str:
    """The table: one row per (file, method)."""
    lines = [
        "| setting (file) | method | gap closed per seed | mean [95 % CI] | IQM [95 % CI] | worst "
        "| machine, date | train s per run |",
        "|---|---|---|---:|---:|---:|---|---:|",
    ]
    for r in rows:
        per_seed = ", ".join(f"{s}: {g:.2f}" for s, g in zip(r["seeds"], r["gap_closed"], strict=True))
        mean = r["mean"]
        iqm = r["iqm"]
        iqm_text = f"{iqm['point']:.2f} [{iqm['low']:.2f}, {iqm['high']:.2f}]" if iqm else "— (< 5 seeds)"
        lines.append(
            f"| {r['setting']} ([`{r['file']}.md`]({r['file']}.md)) | {r['method']} | {per_seed} "
            f"| {mean['point']:.2f} [{mean['low']:.2f}, {mean['high']:.2f}] | {iqm_text} | {r['worst']:.2f} "
            f"| {r['machine']}, {r['date']} | {r['train_seconds'][0]:.0f}–{r['train_seconds'][1]:.0f} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("files", nargs="+", help="result names in benchmarks/results/ (without .json)")
    parser.add_argument("--name", required=True, help="name of the combined table")
    parser.add_argument("--title", default=None, help="heading of the Markdown file")
    parser.add_argument("--note", default="", help="a paragraph after the table")
    args = parser.parse_args()
    try:
        rows = [row for name in args.files for row in rows_of(name)]
    except (FileNotFoundError, ValueError) as error:
        parser.error(str(error))
    body = markdown(rows)
    body += (
        "\n\n*Gap closed* = (return − no-comm) / (oracle − no-comm) on each file's 100 final games. "
        "Each row is one file's runs, made by the command recorded in that file; this table is "
        f"remade from those files by `{shlex.join(['python', SCRIPT, *args.files])} --name …`. "
        "Runs on different processors are not the same models, seed for seed."
    )
    if args.note:
        body += f"\n\n{args.note}"
    write_results(args.name, {"files": args.files, "rows": rows}, body, title=args.title)
    print(body)


if __name__ == "__main__":
    main()
