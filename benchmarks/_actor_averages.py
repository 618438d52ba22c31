"""Slower averages of the actor, kept beside a run's checkpoints (a diagnostic of issue 12).

``policy_kwargs={"averaged_actor": True}`` plays the target actor, the actor's Polyak average at
DDPG's rate ``tau`` (0.005: about the last 200 updates, 3,200 steps of 16 games). It has none of
the deepest Blind Soccer dips, which last a few thousand steps, but keeps the slower ones
(``benchmarks/results/checkpoint_level_defaults_bs_gsn_20seeds_averaged_actor.md``). This module
keeps other averages of the actor during a run, at slower rates, without touching training:

* :class:`ActorAveragesCallback`, given to ``benchmarks/solve.py`` by ``--actor-averages TAU …``:
  after every environment step (one update of the actor with ``train_freq=1`` and
  ``gradient_steps=1``, the constructor's defaults) each average moves towards the actor,
  ``θ̄ ← θ̄ + τ (θ − θ̄)``, as the target actor does; every ``save_freq`` steps, at the
  checkpoints' steps, all averages are written to ``checkpoints/actor_averages_<steps>_steps.pt``,
  and at the end of training to ``actor_averages_final.pt`` beside ``model.zip``.
* :func:`load_actor_average` puts one of them into a loaded model's target actor, so that
  ``model.policy.averaged_actor = True`` plays it (``benchmarks/checkpoint_level.py
  --actor-average TAU``).

The callback reads the actor and writes its own tensors only: the run's updates, exploration and
evaluations are the same as without it, bit for bit.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import torch as th
from stable_baselines3.common.callbacks import BaseCallback

from sb3_comm.common.files import atomic_path

__all__ = ["ActorAveragesCallback", "average_path", "load_actor_average"]


def average_path(run_dir: str | Path, step: int | None) -> Path:
    """The file of a run's averages at ``step`` (None: at the end of training)."""
    if step is None:
        return Path(run_dir) / "actor_averages_final.pt"
    return Path(run_dir) / "checkpoints" / f"actor_averages_{step}_steps.pt"


class ActorAveragesCallback(BaseCallback):
    """Polyak averages of the actor at the rates ``taus``, saved beside the checkpoints.

    :param taus: the rates, each in (0, 1].
    :param save_freq: write them every this many environment steps (as ``solve.py --save-freq``).
    :param run_dir: the run folder.
    """

    def __init__(self, taus: list[float], save_freq: int, run_dir: str | Path) -> None:
        super().__init__()
        if not taus or not all(0.0 < tau <= 1.0 for tau in taus):
            raise ValueError(f"actor average rates must be in (0, 1]; got {taus}")
        if save_freq <= 0:
            raise ValueError(f"the averages are saved with the checkpoints: save_freq > 0, got {save_freq}")
        self.taus = [float(tau) for tau in taus]
        self.save_freq = save_freq
        self.run_dir = Path(run_dir)
        self.sources: list[th.Tensor] = []
        self.averages: dict[float, list[th.Tensor]] = {}
        self.every = 1  # calls between saves, from save_freq and the number of games at the start

    def _on_training_start(self) -> None:
        self.sources = [p.detach() for p in self.model.policy.actor.parameters()]
        self.averages = {tau: [p.clone() for p in self.sources] for tau in self.taus}
        self.every = max(self.save_freq // self.model.n_envs, 1)  # as the checkpoint callback

    def _on_step(self) -> bool:
        with th.no_grad():
            for tau, average in self.averages.items():
                th._foreach_lerp_(average, self.sources, tau)
        if self.n_calls % self.every == 0:
            self._save(average_path(self.run_dir, self.num_timesteps))
        return True

    def _on_training_end(self) -> None:
        self._save(average_path(self.run_dir, None))

    def _save(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:  # th.save writes the tensors' values: no copy needed
            th.save({"step": self.num_timesteps, "averages": self.averages}, tmp)


def load_actor_average(model: Any, path: str | Path, tau: float) -> None:
    """Copy the average at rate ``tau`` saved in ``path`` into ``model``'s target actor.

    :raises ValueError: the file has no average at that rate.
    """
    state = th.load(path, map_location="cpu", weights_only=True)
    averages = state["averages"]
    match = [saved for saved in averages if abs(saved - tau) <= 1e-12]
    if not match:
        raise ValueError(f"{path} has no actor average at rate {tau}; it has {sorted(averages)}")
    with th.no_grad():
        for target, value in zip(model.policy.actor_target.parameters(), averages[match[0]], strict=True):
            target.copy_(value)
