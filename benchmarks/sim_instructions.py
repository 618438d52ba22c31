"""Simulator work per step in CPU instructions (valgrind), for versions of the code side by side.

Wall-clock throughput on a shared VM varies by ±25 % from one minute to the next, more than most
code changes. The number of instructions a step executes does not: this script runs the batched
task for ``--short`` and ``--long`` steps under ``valgrind --tool=cachegrind --cache-sim=no`` and
reports ``(I_long - I_short) / (long - short)`` per step, which cancels start-up and imports.
Instructions are not time (memory traffic is not counted), but for this numpy code they move
with it. Two runs of the same code still differ by 1-2 % (memory layout and alignment change
from one process to the next); differences below that are not resolved. Needs ``valgrind``.

    python benchmarks/sim_instructions.py                       # this checkout
    python benchmarks/sim_instructions.py --code /tmp/old=before # plus an older checkout
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

ROOT = Path(__file__).resolve().parents[1]

_STEPS = """
import sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from envs.registry import TASKS
spec = next(s for s in TASKS.values() if s.key == sys.argv[2])
task = spec.batched_env(n_games=int(sys.argv[4]), seed=0)
rng = np.random.default_rng(0)
shape = (32, task.n_games, task.n_players, task.action_size)
pool = rng.uniform(task.action_low, task.action_high, size=shape).astype(np.float32)
for i in range(int(sys.argv[3])):
    task.step(pool[i % 32])
"""


def instructions(code: Path, task: str, steps: int, n_games: int) -> int:
    """Instructions of a process that builds the task and steps it ``steps`` times."""
    run = subprocess.run(
        ["valgrind", "--tool=cachegrind", "--cache-sim=no", "--cachegrind-out-file=/dev/null",
         sys.executable, "-c", _STEPS, str(code), task, str(steps), str(n_games)],
        capture_output=True, text=True, check=True, env={**os.environ, "PYTHONHASHSEED": "0"},
    )  # fmt: skip
    match = re.search(r"I\s+refs:\s+([\d,]+)", run.stderr)
    if match is None:
        raise RuntimeError(f"no instruction count in valgrind's output:\n{run.stderr[-500:]}")
    return int(match.group(1).replace(",", ""))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--code", nargs="*", default=[], help="other checkouts, as PATH=LABEL")
    parser.add_argument("--n-games", type=int, default=1024)
    parser.add_argument("--short", type=int, default=50)
    parser.add_argument("--long", type=int, default=250)
    parser.add_argument("--name", default="sim_instructions")
    args = parser.parse_args()
    if shutil.which("valgrind") is None:
        raise SystemExit("valgrind is not installed: apt install valgrind")
    versions = [(Path(p), label) for p, _, label in (c.partition("=") for c in args.code)]
    versions.append((ROOT, "this checkout"))
    tasks = ("blind_soccer", "guess_my_number")
    results: dict[str, dict[str, float]] = {}
    for code, label in versions:
        results[label] = {}
        for task in tasks:
            short = instructions(code, task, args.short, args.n_games)
            long = instructions(code, task, args.long, args.n_games)
            per_step = (long - short) / (args.long - args.short)
            results[label][task] = per_step
            print(f"{label:24s} {task:16s} {per_step / 1e6:8.3f} M instructions per step", flush=True)
    base = results[versions[0][1]]
    rows = [
        "| code | " + " | ".join(f"{t}: M instr. per step" for t in tasks) + " |",
        "|---|" + "---:|" * len(tasks),
    ]
    for label, per_task in results.items():
        cells = [f"{per_task[t] / 1e6:.3f} ({per_task[t] / base[t] - 1:+.1%})" for t in tasks]
        rows.append(f"| {label} | " + " | ".join(cells) + " |")
    notes = (
        f"\n\n{args.n_games:,} games, random actions, features computed, autoreset on; "
        f"(I({args.long} steps) − I({args.short} steps)) / {args.long - args.short}; percentages against "
        f"the first row. An agent-step is one agent acting once: a step is {2 * args.n_games:,} agent-steps."
    )
    write_results(args.name, {"args": vars(args), "instructions_per_step": results}, "\n".join(rows) + notes,
                  title="Simulator instructions per step (valgrind)")  # fmt: skip


if __name__ == "__main__":
    main()
