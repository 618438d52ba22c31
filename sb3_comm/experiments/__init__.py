"""Experiments: train many (method, task, seed) runs from one YAML file, in parallel, resumably.

    sb3-comm experiment paper --quick          # or any experiment YAML file
    sb3-comm reproduce                         # the paper's experiment, then the report

>>> from sb3_comm.experiments import load_experiment, run_experiment
>>> spec = load_experiment("paper", quick=True)
>>> summary = run_experiment(spec, "runs/experiments/paper-quick", workers=2)  # doctest: +SKIP

See :mod:`sb3_comm.experiments.spec` for the file format and :mod:`sb3_comm.experiments.runner`
for what each run writes.
"""

from sb3_comm.experiments.runner import default_workers, machine_info, run_experiment, run_one, select_runs
from sb3_comm.experiments.spec import (
    EXPERIMENTS_DIR,
    ExperimentSpec,
    ExperimentSpecError,
    RunSpec,
    config_hash,
    load_experiment,
    packaged_experiments,
    parse_experiment,
)

__all__ = [
    "EXPERIMENTS_DIR",
    "ExperimentSpec",
    "ExperimentSpecError",
    "RunSpec",
    "config_hash",
    "default_workers",
    "load_experiment",
    "machine_info",
    "packaged_experiments",
    "parse_experiment",
    "run_experiment",
    "run_one",
    "select_runs",
]
