"""Statistics tables of an experiment: final returns and communication metrics over seeds.

Both tables are plain dicts (JSON-ready after :func:`~sb3_comm.analysis.markdown.clean`), keyed
task -> method, built from the runs :func:`~sb3_comm.analysis.runs.group_runs` returns; their
Markdown is drawn by :mod:`~sb3_comm.analysis.markdown`, and :mod:`~sb3_comm.analysis.claims`
judges the paper's claims on them.

* :func:`final_returns_table`: per method, the final return with messages intact, zeroed and
  shuffled, the drop when zeroed (also normalised by oracle - random) and the fraction of the
  oracle's return, each per seed and as stratified-bootstrap interval estimates
  (:func:`~sb3_comm.analysis.stats.interval_estimates`).
* :func:`communication_table`: per method and channel direction, the communication metrics per
  seed and their mean.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sb3_comm.analysis.runs import communication_of, final_return
from sb3_comm.analysis.stats import interval_estimates
from sb3_comm.evaluation import ABLATIONS

__all__ = ["ABLATIONS", "METRICS", "communication_table", "final_returns_table"]

METRICS = ("cic", "speaker_consistency", "instantaneous_coordination", "probe_accuracy", "majority_rate")
"""Communication metrics per channel direction, as ``result.json`` names them."""


def _estimate(values: list[float], reps: int, seed: int) -> dict[str, Any]:
    return interval_estimates(np.asarray(values, dtype=np.float64), reps=reps, seed=seed)


def final_returns_table(
    runs: dict[str, list[dict[str, Any]]], ref: dict[str, Any] | None, reps: int, seed: int
) -> dict[str, Any]:
    """Final returns of one task's methods.

    :param runs: the task's runs by method (:func:`~sb3_comm.analysis.runs.group_runs`).
    :param ref: the task's reference returns (``oracle``, ``random``; see
        :func:`~sb3_comm.analysis.references.reference_returns`), or None.
    :param reps: bootstrap replications.
    :param seed: bootstrap seed.
    :return: per method ``seeds``, ``none``/``zero``/``shuffle``, ``zero_drop`` and, with an
        oracle, ``fraction_of_oracle`` and ``zero_drop_normalised``: each ``per_seed`` values plus
        the interval estimates.
    """
    oracle = ref.get("oracle") if ref else None
    random_return = ref.get("random") if ref else None
    table: dict[str, Any] = {}
    for method, method_runs in runs.items():
        row: dict[str, Any] = {"seeds": [r["seed"] for r in method_runs]}
        for ablation in ABLATIONS:
            values = [final_return(r, ablation) for r in method_runs]
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


def communication_table(runs: dict[str, list[dict[str, Any]]]) -> dict[str, Any]:
    """Communication metrics of one task's methods: per method and direction (e.g.
    ``"sighted->blind"``) the ``seeds`` and, per metric of :data:`METRICS`, ``per_seed`` values
    (NaN where a run lacks it) and their ``mean`` (None when no seed has it)."""
    table: dict[str, Any] = {}
    for method, method_runs in runs.items():
        per_direction: dict[str, dict[str, list]] = {}
        for run in method_runs:
            comm = communication_of(run)
            if comm is None:
                continue
            for key, values in (comm.get("directions") or {}).items():
                bucket = per_direction.setdefault(key, {name: [] for name in METRICS} | {"seeds": []})
                bucket["seeds"].append(run["seed"])
                for name in METRICS:
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
                    for name in METRICS
                },
            }
            for key, bucket in per_direction.items()
        }
    return table
