"""Figures of the report: learning curves (paper Figures 2, 4), message ablation, t-SNE (Figure 3).

Every figure is drawn on a bare :class:`matplotlib.figure.Figure` (no ``pyplot``, so no GUI
backend and no global state) and written as PNG and SVG next to each other.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from scipy import stats

__all__ = [
    "METHOD_COLORS",
    "mean_and_interval",
    "plot_ablation",
    "plot_learning_curves",
    "plot_tsne",
    "save_figure",
    "tsne_embedding",
]

METHOD_COLORS = {
    "GSN": "tab:blue",
    "TCG": "tab:orange",
    "RIAL": "tab:green",
    "NONE": "tab:gray",
    "GSN-MAX": "tab:purple",
}
"""One colour per method in every figure."""


def save_figure(fig: Figure, stem: str | Path) -> list[Path]:
    """Write ``stem.png`` and ``stem.svg`` and return both paths."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [stem.with_suffix(".png"), stem.with_suffix(".svg")]
    for path in paths:
        fig.savefig(path, dpi=120, bbox_inches="tight")
    return paths


def mean_and_interval(
    values: np.ndarray, confidence: float = 0.95
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean over seeds (axis 0) and its Student-t ``confidence`` interval (the mean itself for one seed)."""
    values = np.asarray(values, dtype=np.float64)
    mean = values.mean(axis=0)
    n = values.shape[0]
    if n < 2:
        return mean, mean.copy(), mean.copy()
    half = stats.t.ppf(0.5 + confidence / 2.0, n - 1) * values.std(axis=0, ddof=1) / np.sqrt(n)
    return mean, mean - half, mean + half


def _align(curves: Sequence[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Seeds' curves on one grid: the longest run's timesteps up to where every run has data."""
    end = min(float(np.max(x)) for x, _ in curves)
    grid = max((np.asarray(x, dtype=np.float64) for x, _ in curves), key=len)
    grid = grid[grid <= end]
    return grid, np.stack([np.interp(grid, x, y) for x, y in curves])


def worst_seed(values: np.ndarray) -> int:
    """Index of the worst seed of ``(n_seeds, n_points)`` curves: the lowest last value, ties
    broken by the lowest mean over the curve."""
    values = np.asarray(values, dtype=np.float64)
    return int(np.lexsort((values.mean(axis=1), values[:, -1]))[0])


def plot_learning_curves(
    curves: Mapping[str, Sequence[tuple[np.ndarray, np.ndarray]]],
    stem: str | Path,
    title: str = "",
    references: Mapping[str, float] | None = None,
    ylabel: str = "mean team return",
) -> list[Path]:
    """Mean return over seeds against environment steps, with a 95% interval band per method and,
    with two or more seeds, the worst seed's own curve (dotted; :func:`worst_seed`).

    :param curves: per method, one ``(timesteps, returns)`` pair per seed.
    :param stem: output path without suffix.
    :param title: figure title.
    :param references: horizontal lines, e.g. ``{"oracle": 0.61, "random": 0.0}``.
    :param ylabel: y-axis label.
    """
    fig = Figure(figsize=(6.4, 4.2))
    ax = fig.add_subplot()
    for method, runs in curves.items():
        runs = [(np.asarray(x, float), np.asarray(y, float)) for x, y in runs if len(x)]
        if not runs:
            continue
        grid, values = _align(runs)
        mean, low, high = mean_and_interval(values)
        color = METHOD_COLORS.get(method)
        ax.plot(grid, mean, color=color, label=f"{method} ({len(runs)} seeds)")
        ax.fill_between(grid, low, high, color=color, alpha=0.25, linewidth=0)
        if len(runs) > 1:
            worst = values[worst_seed(values)]
            ax.plot(grid, worst, color=color, linestyle=":", label=f"{method} worst seed")
    styles = {"oracle": ("black", "--"), "random": ("gray", ":")}
    for name, value in (references or {}).items():
        if value is None:
            continue
        color, style = styles.get(name, ("tab:red", "-."))
        ax.axhline(value, color=color, linestyle=style, linewidth=1, label=f"{name} ({value:.3g})")
    ax.set_xlabel("environment steps")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    return save_figure(fig, stem)


def plot_ablation(
    table: Mapping[str, Mapping[str, Mapping[str, Any]]],
    stem: str | Path,
    title: str = "",
    references: Mapping[str, float] | None = None,
) -> list[Path]:
    """Grouped bars: per method, the return with messages intact, zeroed and shuffled.

    :param table: ``table[method][ablation] = {"point", "low", "high"}`` (None values are skipped).
    :param stem: output path without suffix.
    :param title: figure title.
    :param references: horizontal lines, e.g. the oracle's return.
    """
    methods = list(table)
    ablations = ["none", "zero", "shuffle"]
    labels = {"none": "intact", "zero": "zeroed", "shuffle": "shuffled"}
    fig = Figure(figsize=(1.6 + 1.4 * max(len(methods), 1), 4.0))
    ax = fig.add_subplot()
    width = 0.8 / len(ablations)
    for k, ablation in enumerate(ablations):
        xs, heights, errors = [], [], []
        for m, method in enumerate(methods):
            cell = table[method].get(ablation) or {}
            if cell.get("point") is None:
                continue
            xs.append(m + (k - 1) * width)
            heights.append(cell["point"])
            low, high = cell.get("low", cell["point"]), cell.get("high", cell["point"])
            errors.append((cell["point"] - low, high - cell["point"]))
        if xs:
            err = np.asarray(errors, dtype=np.float64).T
            ax.bar(xs, heights, width, yerr=err, capsize=3, label=labels[ablation], alpha=0.85)
    for name, value in (references or {}).items():
        if value is not None:
            color = "black" if name == "oracle" else "gray"
            ax.axhline(value, color=color, linestyle="--", linewidth=1, label=f"{name} ({value:.3g})")
    ax.set_xticks(range(len(methods)), methods)
    ax.set_ylabel("mean team return")
    ax.set_title(title)
    ax.axhline(0.0, color="black", linewidth=0.5)
    ax.legend(fontsize="small")
    return save_figure(fig, stem)


def tsne_embedding(
    messages: np.ndarray, seed: int = 0, max_points: int = 2000
) -> tuple[np.ndarray, np.ndarray]:
    """2-D t-SNE of messages ``(N, n)`` (at most ``max_points``, drawn at random).

    :return: the embedding ``(M, 2)`` and the indices of the messages it shows.
    """
    from sklearn.manifold import TSNE
    from threadpoolctl import threadpool_limits

    x = np.asarray(messages, dtype=np.float64).reshape(len(messages), -1)
    rng = np.random.default_rng(seed)
    index = np.arange(x.shape[0])
    if x.shape[0] > max_points:
        index = np.sort(rng.choice(x.shape[0], size=max_points, replace=False))
    x = x[index]
    if x.shape[0] < 5:
        raise ValueError(f"t-SNE needs at least 5 messages, got {x.shape[0]}")
    # Tiny jitter: identical messages (a saturated channel) make t-SNE's distances degenerate.
    x = x + rng.normal(scale=1e-6, size=x.shape)
    perplexity = float(min(30.0, (x.shape[0] - 1) / 3.0))
    # One OpenMP thread: on a busy machine the spinning threads of the Barnes-Hut gradient make
    # t-SNE 10-20 times slower than a single thread.
    with threadpool_limits(limits=1, user_api="openmp"):
        tsne = TSNE(n_components=2, perplexity=perplexity, init="pca", random_state=seed)
        embedding = tsne.fit_transform(x)
    return embedding, index


def plot_tsne(
    messages: np.ndarray,
    labels: np.ndarray,
    stem: str | Path,
    label_names: Sequence[str] | None = None,
    title: str = "",
    seed: int = 0,
) -> list[Path]:
    """Scatter of the t-SNE of ``messages`` coloured by ``labels`` (paper Figure 3).

    :param messages: ``(N, n)`` messages of the sender.
    :param labels: ``(N,)`` integer label per message, e.g. the receiver's next action type.
    :param stem: output path without suffix.
    :param label_names: name of each label value.
    :param title: figure title.
    :param seed: seed of t-SNE and of the subsampling.
    """
    embedding, index = tsne_embedding(messages, seed=seed)
    labels = np.asarray(labels)[index]
    fig = Figure(figsize=(5.0, 4.6))
    ax = fig.add_subplot()
    colors = ["black", "tab:orange", "tab:red", "tab:blue"]
    for value in np.unique(labels):
        known = label_names is not None and int(value) < len(label_names)
        name = label_names[int(value)] if known else str(value)  # type: ignore[index]
        keep = labels == value
        ax.scatter(
            embedding[keep, 0],
            embedding[keep, 1],
            s=8,
            color=colors[int(value) % len(colors)],
            label=f"{name} ({int(keep.sum())})",
            alpha=0.7,
        )
    ax.set_title(title)
    ax.set_xticks([])
    ax.set_yticks([])
    ax.legend(fontsize="small", title="receiver's next action")
    return save_figure(fig, stem)
