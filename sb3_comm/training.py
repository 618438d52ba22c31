"""One training run, end to end: the single run path of the project.

``sb3-comm train``, the experiment runner (``sb3-comm experiment`` / ``reproduce``) and
``benchmarks/solve.py`` all call :func:`train_run`; rl-zoo3 builds its models through the same
:class:`~sb3_comm.config.RunConfig` conversion. A run folder receives:

- ``config.yml``: the :class:`~sb3_comm.config.RunConfig` (what ``sb3-comm evaluate`` reads);
- ``tb/`` (TensorBoard), ``checkpoints/`` and ``evaluations.json`` (the learning curve, rewritten
  after every evaluation so that a run that dies keeps it);
- ``model.zip`` (also written when training is interrupted);
- ``messages.npz`` when a communication analysis is asked for;
- ``result.json`` last: the :class:`~sb3_comm.results.RunResult`;
- ``error.txt`` instead of ``result.json`` when the run fails: ``status: failed``, the reason on
  one line, then the traceback.

Every file is written atomically (:func:`sb3_comm.common.files.atomic_path`): a run that dies,
the disk full included, leaves whole files or none, never a truncated ``model.zip`` or checkpoint.

>>> from sb3_comm.config import RunConfig
>>> from sb3_comm.training import train_run
>>> result = train_run(RunConfig.load("GSN", "BlindSoccer-v0"), "runs/gsn0")  # doctest: +SKIP
>>> result.final_return  # doctest: +SKIP
"""

from __future__ import annotations

import contextlib
import datetime as dt
import time
import traceback
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback, CallbackList, CheckpointCallback
from stable_baselines3.common.vec_env import VecEnv

from sb3_comm.callbacks import TeamEvalCallback
from sb3_comm.comm_ddpg import CommDDPG
from sb3_comm.common.files import atomic_path, write_text
from sb3_comm.common.validation import Range
from sb3_comm.config import RunConfig
from sb3_comm.evaluation import ABLATIONS, evaluate_team
from sb3_comm.registration import make_comm_vec_env
from sb3_comm.results import RunResult, to_jsonable

__all__ = [
    "AtomicCheckpointCallback",
    "EvalSettings",
    "build_model",
    "save_model",
    "train_run",
    "write_failure",
]


@dataclass(frozen=True)
class EvalSettings:
    """How a run is evaluated.

    :param freq: a learning-curve evaluation every this many environment steps.
    :param episodes: games per evaluation (deterministic policy, one episode each).
    :param curve_seed: seed of the learning-curve games (the same games at every evaluation).
    :param final_seed: seed of the final evaluation with the message ablations.
    :param ablations: the final evaluations: messages intact, zeroed, shuffled.
    :param analysis_episodes: games recorded for the communication analysis (0: none).
    :param analysis_seed: seed of those games.
    :param target_return: the return that counts as solved (time and steps to it are recorded).
    """

    freq: int = 25_000
    episodes: int = 100
    curve_seed: int = 12_345
    final_seed: int = 20_000
    ablations: tuple[str, ...] = ABLATIONS
    analysis_episodes: int = 0
    analysis_seed: int = 0
    target_return: float | None = None

    def __post_init__(self) -> None:
        for name in ("freq", "episodes"):
            Range(1, whole=True)(name, getattr(self, name))
        Range(0, whole=True)("analysis_episodes", self.analysis_episodes)

    def describe(self) -> dict[str, Any]:
        """The ``eval`` entry of a :class:`~sb3_comm.results.RunResult`."""
        return {
            "freq": self.freq,
            "episodes": self.episodes,
            "analysis_episodes": self.analysis_episodes,
            "seeds": {"curve": self.curve_seed, "final": self.final_seed, "analysis": self.analysis_seed},
        }


class AtomicCheckpointCallback(CheckpointCallback):
    """SB3's :class:`~stable_baselines3.common.callbacks.CheckpointCallback`, each file written
    atomically: a run that dies while saving leaves the earlier checkpoints and no truncated one."""

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq != 0:
            return True
        model_path = self._checkpoint_path(extension="zip")
        save_model(self.model, model_path)
        if self.verbose >= 2:
            print(f"Saving model checkpoint to {model_path}")
        if self.save_replay_buffer and getattr(self.model, "replay_buffer", None) is not None:
            buffer_path = self._checkpoint_path("replay_buffer_", extension="pkl")
            with atomic_path(buffer_path) as tmp:
                self.model.save_replay_buffer(tmp)  # type: ignore[attr-defined]
        vec_normalize = self.model.get_vec_normalize_env()
        if self.save_vecnormalize and vec_normalize is not None:
            with atomic_path(self._checkpoint_path("vecnormalize_", extension="pkl")) as tmp:
                vec_normalize.save(str(tmp))
        return True


def save_model(model: Any, path: str | Path) -> Path:
    """``model.save(path)``, atomically (a temporary ``.zip`` in the same folder, then a rename)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        model.save(tmp)
    return path


def write_failure(run_dir: str | Path, error: BaseException, note: str = "") -> bool:
    """Mark ``run_dir`` failed: ``error.txt`` holds ``status: failed`` (``interrupted`` for Ctrl-C),
    the reason on one line, then ``note`` and the traceback (its last line is the reason again).

    Written atomically and never raises: on a full disk the file may not be written at all
    (then ``False``), but it is never empty or truncated.
    """
    status = "failed" if isinstance(error, Exception) else "interrupted"
    reason = traceback.format_exception_only(type(error), error)[-1].strip()
    text = "".join(traceback.format_exception(type(error), error, error.__traceback__))
    try:
        write_text(Path(run_dir) / "error.txt", f"status: {status}\nreason: {reason}\n\n{note}{text}")
    except OSError:
        return False
    return True


def build_model(config: RunConfig, env: VecEnv | None = None, **kwargs: Any) -> CommDDPG:
    """The :class:`~sb3_comm.CommDDPG` of a configuration.

    :param config: the run configuration.
    :param env: the training environment (default: ``config.n_envs`` batched games of
        ``config.task``, seeded with ``config.seed``).
    :param kwargs: further CommDDPG arguments that are not hyperparameters (``tensorboard_log``,
        ``device``, ``verbose``).
    """
    if env is None:
        env = make_comm_vec_env(config.task, n_envs=config.n_envs, seed=config.seed)
    return CommDDPG(config.method, env, seed=config.seed, **config.algorithm_kwargs(), **kwargs)


def _communication(
    model: CommDDPG, config: RunConfig, run_dir: Path, settings: EvalSettings
) -> tuple[dict[str, Any] | None, str | None]:
    """Messages of ``analysis_episodes`` games to ``messages.npz``, and the communication metrics.

    A failure here does not fail the run (the trained model is worth keeping): it is returned as
    ``(None, traceback)`` and recorded in ``communication_error``.
    """
    try:
        from sb3_comm.analysis import analyse_communication, collect_rollout

        n, seed = settings.analysis_episodes, settings.analysis_seed
        rollout = collect_rollout(model, config.task, n_episodes=n, seed=seed)
        rollout.save(run_dir / "messages.npz")  # atomic
        metrics = analyse_communication(model, config.task, n_episodes=n, seed=seed, rollout=rollout)
        return to_jsonable(metrics), None
    except Exception:
        return None, traceback.format_exc()


def train_run(
    config: RunConfig,
    run_dir: str | Path,
    evaluation: EvalSettings | None = None,
    save_freq: int = 100_000,
    callbacks: Sequence[BaseCallback] = (),
    config_hash: str | None = None,
    device: str = "cpu",
    verbose: int = 0,
    eval_verbose: int = 0,
    progress_bar: bool = False,
) -> RunResult:
    """Train, evaluate (and optionally analyse) one run into ``run_dir``.

    :param config: the run configuration.
    :param run_dir: the run folder (created; see the module docstring for what it receives).
    :param evaluation: how to evaluate (default: :class:`EvalSettings`).
    :param save_freq: a checkpoint every this many environment steps (0: none).
    :param callbacks: further SB3 callbacks (e.g. a time budget).
    :param config_hash: fingerprint recorded in the result (experiment runs).
    :param device: torch device.
    :param verbose: verbosity of the algorithm.
    :param eval_verbose: 1 prints every periodic evaluation.
    :param progress_bar: show SB3's progress bar.
    :return: the :class:`~sb3_comm.results.RunResult`, also written to ``run_dir/result.json``.
    """
    run_dir = Path(run_dir)
    if save_freq < 0:
        raise ValueError(f"save_freq must be a whole number ≥ 0 (0: no checkpoints), got {save_freq}")
    run_dir.mkdir(parents=True, exist_ok=True)
    try:
        return _train_run(
            config, run_dir, evaluation or EvalSettings(), save_freq, callbacks, config_hash, device,
            verbose, eval_verbose, progress_bar,
        )  # fmt: skip
    except BaseException as error:
        write_failure(run_dir, error)
        raise


def _train_run(
    config: RunConfig,
    run_dir: Path,
    settings: EvalSettings,
    save_freq: int,
    callbacks: Sequence[BaseCallback],
    config_hash: str | None,
    device: str,
    verbose: int,
    eval_verbose: int,
    progress_bar: bool,
) -> RunResult:
    began = time.perf_counter()
    started = dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")
    (run_dir / "error.txt").unlink(missing_ok=True)  # this attempt's outcome replaces an earlier one's
    # Built before config.yml is written: a run that cannot start leaves no configuration behind.
    model = build_model(config, tensorboard_log=str(run_dir / "tb"), device=device, verbose=verbose)
    write_text(run_dir / "config.yml", config.to_yaml())
    evaluator = TeamEvalCallback(
        config.task,
        eval_freq=settings.freq,
        n_episodes=settings.episodes,
        target_return=settings.target_return,
        seed=settings.curve_seed,
        log_path=run_dir / "evaluations.json",
        verbose=eval_verbose,
    )
    run_callbacks: list[BaseCallback] = [evaluator]
    if save_freq > 0:
        run_callbacks.append(
            AtomicCheckpointCallback(
                max(save_freq // config.n_envs, 1), str(run_dir / "checkpoints"), name_prefix="model"
            )
        )
    learn_began = time.perf_counter()
    try:
        model.learn(
            config.n_timesteps,
            callback=CallbackList([*run_callbacks, *callbacks]),
            progress_bar=progress_bar,
            log_interval=100 * config.n_envs,
        )
    except BaseException:
        # Saved also when training is interrupted; a failed save must not hide why it stopped.
        with contextlib.suppress(Exception):
            save_model(model, run_dir / "model.zip")
        raise
    save_model(model, run_dir / "model.zip")
    train_seconds = time.perf_counter() - learn_began - evaluator.eval_seconds
    if not evaluator.history or evaluator.history[-1]["timesteps"] != model.num_timesteps:
        evaluator.evaluate()  # the curve ends where training ended
    final = {
        ablation: evaluate_team(
            model, config.task, n_episodes=settings.episodes, seed=settings.final_seed, ablation=ablation
        ).summary()
        for ablation in settings.ablations
    }
    result = RunResult(
        method=config.method,
        task=config.task,
        seed=config.seed,
        config_hash=config_hash,
        timesteps=int(model.num_timesteps),
        budget=config.n_timesteps,
        n_envs=config.n_envs,
        updates=int(model.n_updates),
        train_seconds=train_seconds,
        eval_seconds=evaluator.eval_seconds,
        hyperparams={"n_envs": config.n_envs, **config.hyperparams},
        eval=settings.describe(),
        curve=evaluator.history,
        final=final,
        target_return=settings.target_return,
        time_to_target_seconds=evaluator.time_to_target,
        steps_to_target=evaluator.steps_to_target,
        started=started,
    )
    if settings.analysis_episodes > 0:
        result.communication, result.communication_error = _communication(model, config, run_dir, settings)
    result.wall_seconds = time.perf_counter() - began
    result.finished = dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")
    result.save(run_dir / "result.json")  # last: its presence means the run is done
    return result
