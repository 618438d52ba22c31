"""Callbacks: periodic team evaluation with a learning-curve record and an optional target, and a
wall-clock time budget."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback

from sb3_comm.common.train_log import dump_only
from sb3_comm.evaluation import evaluate_team
from sb3_comm.results import write_json
from sb3_comm.tensorboard import log_video, tensorboard_video

__all__ = ["TeamEvalCallback", "TimeBudgetCallback"]


class TeamEvalCallback(BaseCallback):
    """Evaluate the team every ``eval_freq`` environment steps on ``n_episodes`` parallel games.

    Writes ``eval/mean_return`` (and ``eval/return_<agent>``, ``eval/std_return``) to the model's
    logger at the step of every evaluation (one logger dump of its own, which leaves the training
    values gathered for the next point alone), keeps the learning curve in :attr:`history`, and
    records when the mean return first reached ``target_return`` (wall-clock seconds and steps).
    With ``stop_at_target`` training stops there. With ``video_every`` K, every K-th evaluation
    also plays one rendered episode into TensorBoard (``eval/video``, messages drawn as bars).

    :param env_id: registered id of the task to evaluate on.
    :param eval_freq: evaluate every this many environment steps (``model.num_timesteps``).
    :param n_episodes: evaluation episodes (one per parallel game), deterministic policy.
    :param target_return: the return that counts as solved (e.g. 0.9 × the oracle's), or None.
    :param stop_at_target: stop training once the target is reached.
    :param seed: seed of the evaluation games (the same games at every evaluation).
    :param env_kwargs: task options.
    :param log_path: if given, the learning curve is rewritten to this JSON file after every
        evaluation (so a run that dies keeps it).
    :param history: the curve of an earlier session of the same run (a resumed run): kept, and
        continued (its last point's ``seconds`` is where the training time resumes counting).
    :param video_every: a video every this many evaluations (0: none).
    :param video_steps: at most this many steps per video.
    """

    def __init__(
        self,
        env_id: str,
        eval_freq: int = 10_000,
        n_episodes: int = 100,
        target_return: float | None = None,
        stop_at_target: bool = False,
        seed: int = 12345,
        env_kwargs: dict[str, Any] | None = None,
        log_path: str | Path | None = None,
        history: list[dict[str, float]] | None = None,
        verbose: int = 0,
        video_every: int = 0,
        video_steps: int = 100,
    ) -> None:
        super().__init__(verbose)
        if isinstance(video_every, bool) or not isinstance(video_every, int) or video_every < 0:
            raise ValueError(
                f"video_every must be a whole number of evaluations ≥ 0 (0: none), got {video_every!r}"
            )
        self.video_every = video_every
        self.video_steps = video_steps
        self.env_id = env_id
        self.eval_freq = eval_freq
        self.n_episodes = n_episodes
        self.target_return = target_return
        self.stop_at_target = stop_at_target
        self.seed = seed
        self.env_kwargs = env_kwargs
        self.log_path = Path(log_path) if log_path is not None else None
        self.history: list[dict[str, float]] = list(history or [])
        self.time_to_target: float | None = None
        self.steps_to_target: int | None = None
        for point in self.history:
            if (
                target_return is not None
                and self.time_to_target is None
                and point["mean_return"] >= target_return
            ):
                self.time_to_target, self.steps_to_target = point["seconds"], int(point["timesteps"])
        self.seconds_offset = float(self.history[-1]["seconds"]) if self.history else 0.0
        """Training seconds of earlier sessions (a resumed run), added to this session's."""
        self._next_eval = 0
        self._start = 0.0
        self.eval_seconds = 0.0
        """Wall-clock seconds spent in evaluations so far (excluded from the training time)."""

    def _on_training_start(self) -> None:
        self._start = time.perf_counter()
        # On the grid of eval_freq steps, so that a resumed run evaluates where it would have.
        self._next_eval = (self.num_timesteps // self.eval_freq + 1) * self.eval_freq

    def evaluate(self) -> dict[str, float]:
        """Run one evaluation now, log it and append it to :attr:`history`."""
        began = time.perf_counter()
        result = evaluate_team(
            self.model, self.env_id, n_episodes=self.n_episodes, seed=self.seed, env_kwargs=self.env_kwargs
        )
        self.eval_seconds += time.perf_counter() - began
        summary = result.summary()
        # Training time excludes the evaluations themselves.
        elapsed = time.perf_counter() - self._start - self.eval_seconds + self.seconds_offset
        point = {"timesteps": self.num_timesteps, "seconds": elapsed, **summary}
        self.history.append(point)
        values: dict[str, Any] = {"eval/mean_return": summary["mean_return"]}
        if "std_return" in summary:
            values["eval/std_return"] = summary["std_return"]
        names = getattr(self.model, "comm_layout", None)
        for i, value in enumerate(summary["agent_mean_returns"]):
            name = names.agent_names[i] if names is not None else str(i)
            values[f"eval/return_{name}"] = value
        dump_only(self.logger, values, self.num_timesteps)
        if self.video_every and len(self.history) % self.video_every == 0:
            began = time.perf_counter()
            frames = tensorboard_video(self.model, self.env_id, self.video_steps, self.seed, self.env_kwargs)
            log_video(self.logger, "eval/video", frames, self.num_timesteps)
            self.eval_seconds += time.perf_counter() - began
        if self.verbose:
            print(f"[eval] steps={self.num_timesteps} mean_return={summary['mean_return']:.4f}")
        if (
            self.target_return is not None
            and self.time_to_target is None
            and summary["mean_return"] >= self.target_return
        ):
            self.time_to_target = elapsed
            self.steps_to_target = self.num_timesteps
        if self.log_path is not None:
            self.log_path.parent.mkdir(parents=True, exist_ok=True)
            write_json(self.log_path, self.history)
        return point

    def _on_step(self) -> bool:
        if self.num_timesteps < self._next_eval:
            return True
        self._next_eval += self.eval_freq
        self.evaluate()
        return not (self.stop_at_target and self.time_to_target is not None)


class TimeBudgetCallback(BaseCallback):
    """Stop training after ``seconds`` of wall-clock time.

    :param seconds: the budget, counted from the start of ``learn``.
    """

    def __init__(self, seconds: float, verbose: int = 0) -> None:
        super().__init__(verbose)
        if not seconds > 0:
            raise ValueError(f"The time budget must be a positive number of seconds, got {seconds}")
        self.seconds = seconds
        self._deadline = 0.0

    def _on_training_start(self) -> None:
        self._deadline = time.perf_counter() + self.seconds

    def _on_step(self) -> bool:
        return time.perf_counter() < self._deadline
