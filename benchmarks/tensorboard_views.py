"""What TensorBoard shows of a run, drawn from its event files: the README's pictures.

This machine has no browser to take a screenshot of TensorBoard itself, so the two views are
drawn from exactly the data TensorBoard serves: the SCALARS of a few tags (read with
TensorBoard's own ``EventAccumulator``) and the PROJECTOR's messages (its ``tensors.tsv`` and
``metadata.tsv``), projected on their first two principal components as the projector's PCA
view does, coloured by a metadata column.

    python benchmarks/tensorboard_views.py runs/BlindSoccer-v0/GSN_seed0/tb
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import RESULTS_DIR, write_results

SCALARS = (
    ("eval/mean_return", "every evaluation"),
    ("train/critic_loss", "critic loss (mean between points)"),
    ("gsn/prediction_rmse", "GSN prediction error (reward units)"),
    ("train/q_mean", "Q mean"),
    ("rollout/exploration_rate", "exploration ε"),
    ("time/agent_update_ms", "ms per agent update"),
)


def scalars_view(tb_dir: Path, path: Path) -> dict[str, int]:
    """A grid of the :data:`SCALARS` tags; returns the number of points of each."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(str(tb_dir), size_guidance={"scalars": 0})
    events.Reload()
    available = set(events.Tags()["scalars"])
    tags = [(tag, title) for tag, title in SCALARS if tag in available]
    fig, axes = plt.subplots(2, 3, figsize=(13, 6.5))
    counts = {}
    for ax, (tag, title) in zip(axes.flat, tags, strict=False):
        points = events.Scalars(tag)
        counts[tag] = len(points)
        ax.plot([p.step for p in points], [p.value for p in points], lw=1.2, color="#1f77b4")
        ax.set_title(f"{tag}\n{title}, {len(points)} points", fontsize=9)
        ax.tick_params(labelsize=8)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(tags) :]:
        ax.axis("off")
    fig.suptitle(f"TensorBoard SCALARS of {tb_dir} (drawn from its event files)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return counts


def projector_view(tb_dir: Path, path: Path) -> int:
    """The projector's messages on their first two principal components, coloured by the
    receiver's next action and by the ball's bearing; returns the number of messages."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folders = sorted(p.parent for p in tb_dir.glob("*/messages/tensors.tsv"))
    if not folders:
        raise SystemExit(f"{tb_dir} has no projector data (*/messages/tensors.tsv)")
    folder = folders[-1]
    vectors = np.loadtxt(folder / "tensors.tsv", ndmin=2)
    lines = (folder / "metadata.tsv").read_text().splitlines()
    header, rows = lines[0].split("\t"), [line.split("\t") for line in lines[1:]]
    column = {name: [row[i] for row in rows] for i, name in enumerate(header)}
    centred = vectors - vectors.mean(axis=0)
    _, _, components = np.linalg.svd(centred, full_matrices=False)
    xy = centred @ components[:2].T
    if xy.shape[1] == 1:  # a one-entry channel: the message itself, on a line
        xy = np.column_stack([xy[:, 0], np.zeros(len(xy))])
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    actions = np.array(column["receiver_next_action"])
    for action, colour in (("dash", "#1f77b4"), ("turn", "#ff7f0e"), ("kick", "#2ca02c")):
        mask = actions == action
        axes[0].scatter(
            xy[mask, 0], xy[mask, 1], s=6, alpha=0.6, color=colour, label=f"{action} ({mask.sum()})"
        )
    axes[0].legend(fontsize=8, title="receiver's next action", title_fontsize=8)
    axes[0].set_title("coloured by receiver_next_action", fontsize=9)
    bearings = np.array([float(b) if b else np.nan for b in column["ball_bearing_deg"]])
    if np.isfinite(bearings).any():
        points = axes[1].scatter(xy[:, 0], xy[:, 1], s=6, c=bearings, cmap="twilight", vmin=-180, vmax=180)
        fig.colorbar(points, ax=axes[1], label="ball bearing from the sender (degrees)")
        axes[1].set_title("coloured by ball_bearing_deg", fontsize=9)
    else:
        axes[1].axis("off")
    for ax in axes:
        ax.set_xlabel("PCA 1")
        ax.set_ylabel("PCA 2")
        ax.tick_params(labelsize=8)
    fig.suptitle(
        f"TensorBoard PROJECTOR: {len(rows)} messages of {folder.relative_to(tb_dir)} "
        "(PCA, as the projector shows it)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return len(rows)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("tb_dir", type=Path, help="a run's TensorBoard folder")
    parser.add_argument("--name", default="tensorboard_views", help="result file stem")
    args = parser.parse_args()
    scalars_png = RESULTS_DIR / f"{args.name}_scalars.png"
    projector_png = RESULTS_DIR / f"{args.name}_projector.png"
    counts = scalars_view(args.tb_dir, scalars_png)
    n_messages = projector_view(args.tb_dir, projector_png)
    table = "\n".join(
        [
            f"Drawn from the event files of `{args.tb_dir}` (no browser here for a screenshot of "
            "TensorBoard itself; the data are what TensorBoard serves).",
            "",
            f"![scalars]({scalars_png.name})",
            "",
            f"![projector]({projector_png.name})",
            "",
            "| tag | points |",
            "|---|---:|",
            *[f"| {tag} | {n} |" for tag, n in counts.items()],
            "",
            f"Projector: {n_messages} messages.",
        ]
    )
    write_results(
        args.name,
        {"tb_dir": str(args.tb_dir), "points": counts, "projector_messages": n_messages},
        table,
        title="TensorBoard views of a real run",
    )


if __name__ == "__main__":
    main()
