"""Training speed of one run configuration in two checkouts of this repository, side by side.

On this shared 2-core VM the speed drifts by 10-20 % between minutes and between days, so two
versions of the code are compared in the same minutes: each round trains the same configuration
(a run of a packaged experiment, e.g. ``paper_fast``'s GSN-MAX on Blind Soccer) in both checkouts
for ``--steps`` environment steps after a warm-up. With ``--together`` (the default) the two
processes run at the same time, one core each, as the experiment runner's two runs do; otherwise
one after the other, their order swapped every round. Each process imports the package from its
checkout (``PYTHONPATH``)::

    git worktree add /tmp/before 067f871
    python benchmarks/checkout_speed.py /tmp/before . --experiment paper_fast \\
        --method GSN-MAX --task BlindSoccer-v0 --rounds 3 --name checkout_speed_gsn_max_search

writes ``benchmarks/results/<name>.{json,md}``: environment steps per second of each checkout in
every round, and the ratio of their medians.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results

from sb3_comm.results import git_commit

CHILD = """
import json, sys, time
import torch as th
th.set_num_threads(1)
from sb3_comm.experiments.spec import load_experiment
from sb3_comm.training import build_model
experiment, method, task, steps, warmup = sys.argv[1:6]
runs = [r for r in load_experiment(experiment).runs() if r.method == method and r.task == task]
model = build_model(runs[0].config)
model.learn(int(warmup))
began = time.perf_counter()
model.learn(int(steps), reset_num_timesteps=False)
print(json.dumps({"rate": int(steps) / (time.perf_counter() - began)}))
"""


def _start(checkout: Path, args: argparse.Namespace) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": str(checkout.resolve())}
    command = [sys.executable, "-W", "ignore", "-c", CHILD, args.experiment, args.method, args.task]
    command += [str(args.steps), str(args.warmup)]
    return subprocess.Popen(command, env=env, stdout=subprocess.PIPE, text=True, cwd=checkout)


def _rate(process: subprocess.Popen[str]) -> float:
    out, _ = process.communicate()
    if process.returncode != 0:
        raise RuntimeError(f"the timed training failed (exit {process.returncode})")
    return float(json.loads(out.strip().splitlines()[-1])["rate"])


def _commit(checkout: Path) -> str:
    """The checkout's commit (:func:`sb3_comm.results.git_commit`), with ``+dirty`` where its tracked
    files differ from it, or ``"n/a"``."""
    head = git_commit(checkout)
    if head is None:
        return "n/a"
    dirty = subprocess.run(["git", "-C", str(checkout), "diff", "--quiet", "HEAD"]).returncode != 0
    return head + ("+dirty" if dirty else "")


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("before", type=Path, help="the first checkout (the code before a change)")
    parser.add_argument("after", type=Path, help="the second checkout (the code after it)")
    parser.add_argument("--experiment", default="paper_fast", help="packaged experiment or file")
    parser.add_argument("--method", default="GSN-MAX")
    parser.add_argument("--task", default="BlindSoccer-v0")
    parser.add_argument("--steps", type=int, default=10_000, help="timed environment steps")
    parser.add_argument("--warmup", type=int, default=4_000, help="environment steps before timing")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--one-after-the-other", dest="together", action="store_false")
    parser.add_argument("--name", default="checkout_speed")
    args = parser.parse_args()
    for checkout in (args.before, args.after):
        if not (checkout / "sb3_comm" / "__init__.py").is_file():
            parser.error(f"{checkout} is not a checkout of sb3-comm (no sb3_comm/__init__.py)")
    commits = {name: _commit(path) for name, path in (("before", args.before), ("after", args.after))}
    rates: dict[str, list[float]] = {"before": [], "after": []}
    began = time.perf_counter()
    for k in range(args.rounds):
        order = [("before", args.before), ("after", args.after)][:: 1 if k % 2 == 0 else -1]
        if args.together:
            processes = [(name, _start(path, args)) for name, path in order]
            for name, process in processes:
                rates[name].append(_rate(process))
        else:
            for name, path in order:
                rates[name].append(_rate(_start(path, args)))
        print(f"round {k + 1}: " + ", ".join(f"{n} {rates[n][-1]:,.0f}" for n in rates), flush=True)
    medians = {name: statistics.median(values) for name, values in rates.items()}
    ratio = medians["after"] / medians["before"]
    how = "at the same time, one core each" if args.together else "one after the other"
    rows = []
    for name, path in (("before", args.before), ("after", args.after)):
        per_round = ", ".join(f"{rate:,.0f}" for rate in rates[name])
        rows.append(f"| {name} (`{path}`, {commits[name][:7]}) | {per_round} | {medians[name]:,.0f} |")
    table = [
        "| checkout | env steps/s per round | median |",
        "|---|---|---:|",
        *rows,
        "",
        f"`{args.experiment}`'s {args.method} on {args.task} (its first seed's run configuration), "
        f"{args.warmup:,} warm-up steps, then "
        f"{args.steps:,} timed steps, one torch thread; the two checkouts {how}, "
        f"{args.rounds} rounds. **After / before: {ratio:.2f}×** the environment steps per second.",
    ]
    data = {
        "experiment": args.experiment,
        "method": args.method,
        "task": args.task,
        "steps": args.steps,
        "warmup": args.warmup,
        "together": args.together,
        "checkouts": {"before": str(args.before), "after": str(args.after)},
        "commits": commits,
        "rates": rates,
        "medians": medians,
        "ratio_after_before": ratio,
        "seconds": time.perf_counter() - began,
    }
    title = f"Training speed of two checkouts: {args.method} on {args.task} ({args.experiment})"
    for path in write_results(args.name, data, "\n".join(table), title):
        print(path)


if __name__ == "__main__":
    main()
