"""Interval estimates of aggregate scores over training seeds (Agarwal et al. 2021, rliable).

:func:`interval_estimates` gives the mean (always) and the interquartile mean (IQM, only with at
least :data:`IQM_MIN_RUNS` runs: with fewer, a 25% trimmed mean discards whole seeds) of a score
matrix ``(n_runs, n_tasks)``, each with a percentile stratified-bootstrap confidence interval
(runs resampled with replacement within each task). It calls
``rliable.library.get_interval_estimates``; where rliable cannot be imported (rliable 1.2 needs
``arch`` < 7.3 with pandas < 3, or it fails at import) the same stratified percentile bootstrap
runs in NumPy, and the result says which one ran in ``backend``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.stats import trim_mean

__all__ = ["IQM_MIN_RUNS", "interval_estimates", "rliable_available"]

IQM_MIN_RUNS = 5
"""Fewest runs for which the IQM is reported."""

_RLIABLE: tuple[Any, Any] | bool | None = None  # (library, metrics) once imported; False if it fails


def _rliable() -> tuple[Any, Any] | None:
    global _RLIABLE
    if _RLIABLE is None:
        try:
            from rliable import library, metrics
        except Exception:  # rliable's dependency arch breaks at import with some pandas versions
            _RLIABLE = False
        else:
            _RLIABLE = (library, metrics)
    return _RLIABLE or None


def rliable_available() -> bool:
    """Whether ``rliable`` imports in this environment."""
    return _rliable() is not None


def _mean(scores: np.ndarray) -> np.ndarray:
    """Mean of the per-task means of ``(..., n_runs, n_tasks)`` (rliable's ``aggregate_mean``)."""
    return scores.mean(axis=-2).mean(axis=-1)


def _iqm(scores: np.ndarray) -> np.ndarray:
    """25% trimmed mean over runs and tasks of ``(..., n_runs, n_tasks)`` (``aggregate_iqm``)."""
    return trim_mean(scores.reshape(*scores.shape[:-2], -1), proportiontocut=0.25, axis=-1)


_AGGREGATES: dict[str, Callable[[np.ndarray], np.ndarray]] = {"mean": _mean, "iqm": _iqm}


def _numpy_bootstrap(
    scores: np.ndarray, names: list[str], reps: int, confidence: float, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    n_runs, n_tasks = scores.shape
    # Stratified: each task's runs are resampled among that task's runs.
    resampled = scores[rng.integers(0, n_runs, size=(reps, n_runs, n_tasks)), np.arange(n_tasks)]
    tail = 100.0 * (1.0 - confidence) / 2.0
    points = np.array([_AGGREGATES[name](scores) for name in names])
    stats = np.stack([_AGGREGATES[name](resampled) for name in names], axis=-1)
    return points, np.percentile(stats, [tail, 100.0 - tail], axis=0)


def replicate_iqm(scores: np.ndarray) -> float:
    """rliable's ``aggregate_iqm`` of one ``(n_runs, n_tasks)`` matrix, the same number to the bit:
    ``scipy.stats.trim_mean(scores, 0.25, axis=None)``'s own operations (a partition, then the mean
    of the middle), without its argument-checking wrapper, which costs about 15 times the
    arithmetic on a bootstrap replicate of a few dozen scores (10,000 replicates per interval)."""
    flat = np.ravel(scores)
    low = int(0.25 * flat.shape[0])
    high = flat.shape[0] - low
    return np.mean(np.partition(flat, (low, high - 1))[low:high], axis=0)


def _rliable_bootstrap(
    scores: np.ndarray, names: list[str], reps: int, confidence: float, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    library, metrics = _rliable()  # type: ignore[misc]
    # rliable's stratified bootstrap and its aggregate_mean; its aggregate_iqm's value, made faster
    functions = {"mean": metrics.aggregate_mean, "iqm": replicate_iqm}

    def func(x: np.ndarray) -> np.ndarray:
        return np.array([functions[name](x) for name in names])

    # rliable 1.2 draws its resamples from NumPy's global generator: seed it, then restore it.
    state = np.random.get_state()
    np.random.seed(seed)
    try:
        points, intervals = library.get_interval_estimates(
            {"scores": scores}, func, reps=reps, confidence_interval_size=confidence
        )
    finally:
        np.random.set_state(state)
    return np.asarray(points["scores"]), np.asarray(intervals["scores"])


def interval_estimates(
    scores: np.ndarray | list[float],
    reps: int = 10_000,
    confidence: float = 0.95,
    seed: int = 0,
    backend: str = "auto",
) -> dict[str, Any]:
    """Point estimates and stratified-bootstrap confidence intervals of aggregate scores.

    :param scores: ``(n_runs,)`` (one task) or ``(n_runs, n_tasks)``; runs with a non-finite
        score are dropped.
    :param reps: bootstrap replications.
    :param confidence: coverage of the intervals.
    :param seed: seed of the bootstrap.
    :param backend: ``"auto"`` (rliable when it imports, else NumPy), ``"rliable"`` or ``"numpy"``.
    :return: ``{"n_runs", "confidence", "reps", "backend", "mean": {"point", "low", "high"}}``
        plus ``"iqm"`` of the same form when ``n_runs >= IQM_MIN_RUNS``. With no runs the
        estimates are None; with one run the interval is the point.
    """
    x = np.asarray(scores, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2:
        raise ValueError(f"scores must be (n_runs,) or (n_runs, n_tasks), got shape {x.shape}")
    x = x[np.isfinite(x).all(axis=1)]
    n_runs = int(x.shape[0])
    names = ["mean", "iqm"] if n_runs >= IQM_MIN_RUNS else ["mean"]
    if backend == "auto":
        backend = "rliable" if rliable_available() else "numpy"
    if backend not in ("rliable", "numpy"):
        raise ValueError(f"Unknown backend {backend!r}; accepted: 'auto', 'rliable', 'numpy'")
    if backend == "rliable" and not rliable_available():
        raise ImportError("rliable cannot be imported in this environment; use backend='numpy'")
    out: dict[str, Any] = {"n_runs": n_runs, "confidence": confidence, "reps": reps, "backend": backend}
    if n_runs == 0:
        out.update({name: {"point": None, "low": None, "high": None} for name in names})
        return out
    bootstrap = _rliable_bootstrap if backend == "rliable" else _numpy_bootstrap
    points, intervals = bootstrap(x, names, reps, confidence, seed)
    for k, name in enumerate(names):
        out[name] = {"point": float(points[k]), "low": float(intervals[0][k]), "high": float(intervals[1][k])}
    return out
