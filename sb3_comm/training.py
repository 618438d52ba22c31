"""One training run, end to end: the single run path of the project.

``sb3-comm train``, the experiment runner (``sb3-comm experiment`` / ``reproduce``) and
``benchmarks/solve.py`` all call :func:`train_run`; rl-zoo3 builds its models through the same
:class:`~sb3_comm.config.RunConfig` conversion. A run folder receives:

- ``config.yml``: the :class:`~sb3_comm.config.RunConfig` (what ``sb3-comm evaluate`` reads);
- ``run_settings.json``: the seed, evaluation and checkpoint settings (what a resume reads);
- ``tb/`` (TensorBoard event files, unless ``tensorboard_dir`` puts them elsewhere: dense
  training curves, every evaluation, message histograms, hyperparameters, the messages in the
  Embedding Projector), ``checkpoints/`` (``model_<steps>_steps.zip``, and
  ``model_replay_buffer_<steps>_steps.pkl`` with ``save_replay_buffer``) and ``evaluations.json``
  (the learning curve, rewritten after every evaluation so that a run that dies keeps it);
- ``model.zip`` (also written when training is interrupted);
- ``messages.npz`` when a communication analysis is asked for;
- ``result.json`` last: the :class:`~sb3_comm.results.RunResult`;
- ``error.txt`` instead of ``result.json`` when the run fails: ``status: failed`` (``interrupted``
  after a signal), the reason on one line, then the traceback.

Every file is written atomically (:func:`sb3_comm.common.files.atomic_path`): a run that dies,
the disk full included, leaves whole files or none, never a truncated ``model.zip`` or checkpoint.
The model is built (or, for a resume, loaded) before anything is written, so a run that cannot
start leaves its folder as it found it.

>>> from sb3_comm.config import RunConfig
>>> from sb3_comm.training import train_run
>>> result = train_run(RunConfig.load("GSN", "BlindSoccer-v0"), "runs/gsn0")  # doctest: +SKIP
>>> result.final_return  # doctest: +SKIP

**Interruption and resume.** SIGINT (Ctrl-C) or SIGTERM during training stops it at the next
environment step, saves ``model.zip`` and a final checkpoint (with the replay buffer when
``save_replay_buffer``), and raises :class:`TrainingInterrupted` (the command line prints where
and how to resume and exits with 130 or 143); a second signal stops at once, without saving.
:func:`resume_run` (``sb3-comm train --resume RUN_DIR``) continues from the last checkpoint, in the
same folder, with the same ``config.yml`` and settings, for the rest of the budget
(``reset_num_timesteps=False``: schedules, exploration and TensorBoard continue); the learning
curve keeps its points up to the checkpoint's step and continues on the same grid.

What a resume does not reproduce exactly: SB3's files hold no random-number state (NumPy, torch,
the games'), so a resumed run is not bit-identical to one that was never interrupted. The
environments restart (episodes in progress are lost, their transitions keep no Monte-Carlo
return), seeded with ``seed + steps`` as are NumPy and torch, so that resuming one checkpoint twice
gives the same run. Without the replay buffer, learning restarts from an empty buffer. The
training time of the earlier session is counted up to its last evaluation.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as dt
import re
import signal
import sys
import threading
import time
import traceback
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from stable_baselines3.common.callbacks import BaseCallback, CallbackList, CheckpointCallback
from stable_baselines3.common.vec_env import VecEnv

from sb3_comm.callbacks import TeamEvalCallback
from sb3_comm.comm_ddpg import CommDDPG
from sb3_comm.common.files import atomic_path, write_text
from sb3_comm.common.validation import Range
from sb3_comm.config import RunConfig
from sb3_comm.evaluation import ABLATIONS, evaluate_team
from sb3_comm.hybrid_ddpg.hybrid_ddpg import default_log_interval
from sb3_comm.registration import make_comm_vec_env
from sb3_comm.results import RunResult, read_json, to_jsonable, write_json
from sb3_comm.tensorboard import event_logger, record_hparams, write_projector

__all__ = [
    "AtomicCheckpointCallback",
    "EvalSettings",
    "TrainingInterrupted",
    "build_model",
    "latest_checkpoint",
    "resume_run",
    "save_model",
    "train_run",
    "write_failure",
]

RUN_SETTINGS = "run_settings.json"
"""The run folder's record of what config.yml does not hold: seed, evaluation, checkpoints."""


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
    :param stop_at_target: end training at the first evaluation that reaches ``target_return``.
    :param video_every: a rendered evaluation episode in TensorBoard every this many evaluations
        (0: none).
    :param projector_episodes: games whose messages go to TensorBoard's Embedding Projector at
        the end of training (0: none; tasks without a channel have none).
    """

    freq: int = 25_000
    episodes: int = 100
    curve_seed: int = 12_345
    final_seed: int = 20_000
    ablations: tuple[str, ...] = ABLATIONS
    analysis_episodes: int = 0
    analysis_seed: int = 0
    target_return: float | None = None
    stop_at_target: bool = False
    video_every: int = 0
    projector_episodes: int = 20

    def __post_init__(self) -> None:
        for name in ("freq", "episodes"):
            Range(1, whole=True)(name, getattr(self, name))
        for name in ("analysis_episodes", "video_every", "projector_episodes"):
            Range(0, whole=True)(name, getattr(self, name))

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
        with_buffer = self.save_replay_buffer and getattr(self.model, "replay_buffer", None) is not None
        model_path = _save_checkpoint(self.model, Path(self.save_path), with_buffer, self.name_prefix)
        if self.verbose >= 2:
            print(f"Saving model checkpoint to {model_path}")
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
    interrupted = isinstance(error, TrainingInterrupted) or not isinstance(error, Exception)
    status = "interrupted" if interrupted else "failed"
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
        env = make_comm_vec_env(
            config.task, n_envs=config.n_envs, seed=config.seed, env_kwargs=config.env_kwargs
        )
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
        options = config.env_kwargs
        rollout = collect_rollout(model, config.task, n_episodes=n, seed=seed, env_kwargs=options)
        rollout.save(run_dir / "messages.npz")
        metrics = analyse_communication(
            model, config.task, n_episodes=n, seed=seed, rollout=rollout, env_kwargs=options
        )
        return to_jsonable(metrics), None
    except Exception:
        return None, traceback.format_exc()


class TrainingInterrupted(Exception):
    """Training was stopped by SIGINT or SIGTERM; ``model.zip`` and a final checkpoint were saved.

    :param signum: the signal.
    :param run_dir: the run folder (``sb3-comm train --resume`` takes it).
    :param checkpoint: the final checkpoint.
    :param timesteps: environment steps trained.
    """

    def __init__(self, signum: int, run_dir: Path, checkpoint: Path, timesteps: int) -> None:
        self.signum, self.run_dir, self.checkpoint, self.timesteps = signum, run_dir, checkpoint, timesteps
        super().__init__(
            f"{signal.Signals(signum).name} at {timesteps} steps: saved {checkpoint}; "
            f"resume with: sb3-comm train --resume {run_dir}"
        )

    @property
    def exit_code(self) -> int:
        """The shell's code of a process ended by the signal: 130 (SIGINT), 143 (SIGTERM)."""
        return 128 + self.signum


class _StopOnSignal(BaseCallback):
    """SIGINT and SIGTERM, while installed, stop ``learn`` at the next step instead of killing it."""

    def __init__(self) -> None:
        super().__init__()
        self.signum: int | None = None
        self._previous: dict[int, Any] = {}

    def install(self) -> None:
        if threading.current_thread() is threading.main_thread():  # signals reach the main thread only
            for signum in (signal.SIGINT, signal.SIGTERM):
                self._previous[signum] = signal.signal(signum, self._handle)

    def restore(self) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        self._previous = {}

    def _handle(self, signum: int, frame: Any) -> None:
        if self.signum is not None:  # the second one: the previous behaviour, nothing saved
            self.restore()
            signal.raise_signal(signum)
            return
        self.signum = signum
        print(
            f"sb3-comm: {signal.Signals(signum).name}: stopping at the next step to save a checkpoint "
            "(send it again to stop without saving)",
            file=sys.stderr,
            flush=True,
        )

    def _on_step(self) -> bool:
        return self.signum is None


_CHECKPOINT = re.compile(r"model_(\d+)_steps\.zip")


def _buffer_of(checkpoint: Path) -> Path:
    """The replay buffer saved with a checkpoint (SB3's CheckpointCallback naming)."""
    steps = _CHECKPOINT.fullmatch(checkpoint.name).group(1)  # type: ignore[union-attr]
    return checkpoint.with_name(f"model_replay_buffer_{steps}_steps.pkl")


def latest_checkpoint(
    folder: str | Path, with_replay_buffer: bool = False
) -> tuple[Path, Path | None] | None:
    """The checkpoint with the most steps in ``folder``, and its replay buffer if saved.

    :param folder: a run's ``checkpoints/``.
    :param with_replay_buffer: prefer the latest checkpoint that has its replay buffer (a run killed
        between the model and the buffer has a newer checkpoint without one).
    :return: ``(model zip, buffer or None)``, or None when there is no checkpoint.
    """
    found = [
        (int(m.group(1)), p)
        for p in Path(folder).glob("model_*_steps.zip")
        if (m := _CHECKPOINT.fullmatch(p.name))
    ]
    found.sort(reverse=True)
    if not found:
        return None
    candidates = [p for _, p in found]
    if with_replay_buffer:
        candidates = [p for p in candidates if _buffer_of(p).exists()] or candidates
    buffer = _buffer_of(candidates[0])
    return candidates[0], buffer if buffer.exists() else None


def _save_checkpoint(model: Any, folder: Path, save_replay_buffer: bool, prefix: str = "model") -> Path:
    """A checkpoint named as SB3's CheckpointCallback names it, written atomically; the buffer
    first, so that a checkpoint's zip means it is complete (the periodic checkpoints of
    :class:`AtomicCheckpointCallback` and the one saved on a signal)."""
    folder.mkdir(parents=True, exist_ok=True)
    steps = model.num_timesteps
    if save_replay_buffer:
        with atomic_path(folder / f"{prefix}_replay_buffer_{steps}_steps.pkl") as tmp:
            model.save_replay_buffer(tmp)
    return save_model(model, folder / f"{prefix}_{steps}_steps.zip")


def _resume_model(
    config: RunConfig, run_dir: Path, save_replay_buffer: bool, device: str, verbose: int
) -> CommDDPG:
    """The model of the run's last checkpoint, with its replay buffer, ready to continue."""
    if (run_dir / "result.json").exists():
        raise ValueError(f"{run_dir} is a finished run (it has result.json): there is nothing to resume")
    stored = (run_dir / "config.yml").read_text()
    if stored != config.to_yaml():
        raise ValueError(
            f"{run_dir / 'config.yml'} differs from the configuration given: a resume keeps the run's"
        )
    found = latest_checkpoint(run_dir / "checkpoints", with_replay_buffer=save_replay_buffer)
    if found is None:
        raise ValueError(
            f"{run_dir} has no checkpoint to resume from (checkpoints/model_<steps>_steps.zip): "
            "it stopped before its first one; train it again"
        )
    checkpoint, buffer = found
    env = make_comm_vec_env(config.task, n_envs=config.n_envs, seed=config.seed, env_kwargs=config.env_kwargs)
    model = CommDDPG.load(checkpoint, env=env, device=device, verbose=verbose)
    # No random state is saved: reseed away from the first session's draws, reproducibly.
    model.set_random_seed(config.seed + model.num_timesteps)
    model._last_obs = None  # the games restart: learn() resets them
    if buffer is not None:
        model.load_replay_buffer(buffer)
    else:
        warnings.warn(
            f"{checkpoint} has no saved replay buffer: training resumes with an empty one "
            "(train with save_replay_buffer / --save-replay-buffer to keep it)",
            stacklevel=3,
        )
    return model


def _remaining_interval(log_interval: int | None, config: RunConfig) -> int:
    """The logging interval of a (resumed) run: the given one, or the default of the whole budget
    (so that a resumed run keeps the grid of points it started on)."""
    return default_log_interval(config.n_timesteps, config.n_envs) if log_interval is None else log_interval


def _finish_tensorboard(
    model: CommDDPG, config: RunConfig, result: RunResult, settings: EvalSettings, tb_dir: Path
) -> None:
    """The run's hyperparameters and final metrics (HPARAMS view), and its messages in the
    Embedding Projector. A failure here is a warning: the run itself is done."""
    metrics: dict[str, float | None] = {
        f"final/mean_return{'' if name == 'none' else '_' + name}": summary["mean_return"]
        for name, summary in result.final.items()
    }
    metrics["final/train_seconds"] = result.train_seconds
    if result.steps_to_target is not None:
        metrics["final/steps_to_target"] = float(result.steps_to_target)
    hparams = {"method": config.method, "task": config.task, "seed": config.seed, **result.hyperparams}
    try:
        # what a default chose by method (absent from the configuration, so from its hyperparameters)
        hparams.setdefault("shared_reward", bool(model.shared_reward))
        sees_teammate = (model.policy_kwargs or {}).get("gsn_reward_sees_teammate")
        if sees_teammate is not None:
            hparams.setdefault("gsn_reward_sees_teammate", bool(sees_teammate))
        hparams.setdefault("averaged_actor", bool(model.policy.averaged_actor))  # what plays
        if model.policy.averaged_actor and model.policy.actor_average_rate is not None:
            hparams.setdefault("actor_average_rate", float(model.policy.actor_average_rate))
        hparams.setdefault("precision", model.policy.precision)  # the hidden layers' arithmetic
        record_hparams(model.logger, hparams, metrics, int(model.num_timesteps))
        # the projector labels messages with the receiver's action type: hybrid actions only
        if settings.projector_episodes > 0 and model.comm_layout.channel_size and model.comm_layout.hybrid:
            write_projector(
                model,
                config.task,
                tb_dir,
                n_episodes=settings.projector_episodes,
                seed=settings.analysis_seed,
                env_kwargs=config.env_kwargs,
            )
    except Exception as error:
        warnings.warn(
            f"TensorBoard hparams/projector not written: {type(error).__name__}: {error}", stacklevel=2
        )
    finally:
        model.logger.close()


def _run_settings(
    settings: EvalSettings,
    seed: int,
    save_freq: int,
    save_replay_buffer: bool,
    log_interval: int | None,
    tensorboard_dir: Path,
) -> dict[str, Any]:
    return {
        "seed": seed,
        "evaluation": dataclasses.asdict(settings),
        "save_freq": save_freq,
        "save_replay_buffer": save_replay_buffer,
        "log_interval": log_interval,
        "tensorboard_dir": str(tensorboard_dir),
    }


def resume_run(
    run_dir: str | Path,
    save_replay_buffer: bool | None = None,
    callbacks: Sequence[BaseCallback] = (),
    device: str = "cpu",
    verbose: int = 0,
    eval_verbose: int = 0,
    progress_bar: bool = False,
) -> RunResult:
    """Continue an interrupted :func:`train_run` from its last checkpoint, in the same folder.

    The configuration is the folder's ``config.yml``; the seed, evaluation and checkpoint settings
    are its ``run_settings.json``. See the module docstring for what is continued and what is not
    reproduced exactly.

    :param run_dir: the run folder.
    :param save_replay_buffer: save the replay buffer with the checkpoints (None: as the run did).
    :param callbacks: further SB3 callbacks.
    :param device: torch device.
    :param verbose: verbosity of the algorithm.
    :param eval_verbose: 1 prints every periodic evaluation.
    :param progress_bar: show SB3's progress bar.
    :raises ValueError: not a resumable run folder (finished, no checkpoint, no settings).
    """
    run_dir = Path(run_dir)
    if not (run_dir / "config.yml").is_file() or not (run_dir / RUN_SETTINGS).is_file():
        raise ValueError(
            f"{run_dir} is not a run folder to resume: it needs config.yml and {RUN_SETTINGS} "
            "(written by sb3-comm train)"
        )
    stored = read_json(run_dir / RUN_SETTINGS)
    entry_map = yaml.safe_load((run_dir / "config.yml").read_text())
    task, entry = next(iter(entry_map.items()))
    config = RunConfig.load(entry["policy"], task, seed=stored["seed"], path=run_dir / "config.yml")
    evaluation = stored["evaluation"]
    settings = EvalSettings(**{**evaluation, "ablations": tuple(evaluation["ablations"])})
    return train_run(
        config,
        run_dir,
        evaluation=settings,
        save_freq=stored["save_freq"],
        callbacks=callbacks,
        device=device,
        verbose=verbose,
        eval_verbose=eval_verbose,
        progress_bar=progress_bar,
        save_replay_buffer=stored["save_replay_buffer"] if save_replay_buffer is None else save_replay_buffer,
        resume=True,
        log_interval=stored.get("log_interval"),
        tensorboard_dir=stored.get("tensorboard_dir"),
    )


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
    save_replay_buffer: bool = False,
    resume: bool = False,
    log_interval: int | None = None,
    tensorboard_dir: str | Path | None = None,
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
    :param save_replay_buffer: save the replay buffer with every checkpoint (SB3's
        ``save_replay_buffer``), so that a resume continues with it.
    :param resume: continue the run in ``run_dir`` from its last checkpoint (``config`` must be its
        ``config.yml``; :func:`resume_run` reads them from the folder).
    :param log_interval: environment steps between two logged training points (None: about
        200 per run; 0: none). Every evaluation is logged at its own step regardless.
    :param tensorboard_dir: where the event files go (default ``run_dir/tb``); an experiment
        gives each run ``<experiment>/tb/<method>/<task>/seed<seed>``.
    :return: the :class:`~sb3_comm.results.RunResult`, also written to ``run_dir/result.json``.
    :raises TrainingInterrupted: SIGINT or SIGTERM stopped training (a checkpoint was saved).
    """
    settings = evaluation or EvalSettings()
    run_dir = Path(run_dir)
    tb_dir = Path(tensorboard_dir) if tensorboard_dir is not None else run_dir / "tb"
    if save_freq < 0:
        raise ValueError(f"save_freq must be a whole number ≥ 0 (0: no checkpoints), got {save_freq}")
    if resume:
        model = _resume_model(config, run_dir, save_replay_buffer, device, verbose)
    else:
        run_dir.mkdir(parents=True, exist_ok=True)
        model = build_model(config, device=device, verbose=verbose)
    model.set_logger(event_logger(tb_dir, verbose))
    try:
        return _train(
            model,
            config,
            run_dir,
            settings,
            save_freq=save_freq,
            callbacks=callbacks,
            config_hash=config_hash,
            eval_verbose=eval_verbose,
            progress_bar=progress_bar,
            save_replay_buffer=save_replay_buffer,
            resume=resume,
            log_interval=log_interval,
            tb_dir=tb_dir,
        )
    except BaseException as error:
        write_failure(run_dir, error)
        raise


def _train(
    model: CommDDPG,
    config: RunConfig,
    run_dir: Path,
    settings: EvalSettings,
    save_freq: int,
    callbacks: Sequence[BaseCallback],
    config_hash: str | None,
    eval_verbose: int,
    progress_bar: bool,
    save_replay_buffer: bool,
    resume: bool,
    log_interval: int | None,
    tb_dir: Path,
) -> RunResult:
    """The body of :func:`train_run`, once the model exists."""
    began = time.perf_counter()
    started = dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")
    (run_dir / "error.txt").unlink(missing_ok=True)  # this attempt's outcome replaces an earlier one's
    history: list[dict[str, Any]] = []
    if resume:
        if (run_dir / "evaluations.json").exists():  # the points after the checkpoint are redone
            history = [
                p for p in read_json(run_dir / "evaluations.json") if p["timesteps"] <= model.num_timesteps
            ]
        write_json(run_dir / "evaluations.json", history)
    else:
        write_text(run_dir / "config.yml", config.to_yaml())
        write_json(
            run_dir / RUN_SETTINGS,
            _run_settings(settings, config.seed, save_freq, save_replay_buffer, log_interval, tb_dir),
        )
    evaluator = TeamEvalCallback(
        config.task,
        eval_freq=settings.freq,
        n_episodes=settings.episodes,
        target_return=settings.target_return,
        stop_at_target=settings.stop_at_target,
        seed=settings.curve_seed,
        log_path=run_dir / "evaluations.json",
        history=history,
        verbose=eval_verbose,
        env_kwargs=config.env_kwargs,
        video_every=settings.video_every,
    )
    run_callbacks: list[BaseCallback] = [evaluator]
    if save_freq > 0:
        run_callbacks.append(
            AtomicCheckpointCallback(
                max(save_freq // config.n_envs, 1),
                str(run_dir / "checkpoints"),
                name_prefix="model",
                save_replay_buffer=save_replay_buffer,
            )
        )
    remaining = config.n_timesteps - model.num_timesteps
    stopper = _StopOnSignal()
    checkpoint: Path | None = None
    stopper.install()
    learn_began = time.perf_counter()
    try:
        if remaining > 0:
            model.learn(
                remaining,
                callback=CallbackList([stopper, *run_callbacks, *callbacks]),
                progress_bar=progress_bar,
                log_interval=_remaining_interval(log_interval, config),
                reset_num_timesteps=not resume,
            )
        else:  # the checkpoint holds the whole budget: the run died in its final evaluation
            evaluator.init_callback(model)
            evaluator.on_training_start({}, {})
    except BaseException:
        # Saved also when training fails; a failed save must not hide why it stopped.
        with contextlib.suppress(Exception):
            save_model(model, run_dir / "model.zip")
        stopper.restore()
        raise
    try:
        save_model(model, run_dir / "model.zip")
        if stopper.signum is not None:
            checkpoint = _save_checkpoint(model, run_dir / "checkpoints", save_replay_buffer)
    finally:
        stopper.restore()
    if stopper.signum is not None:
        if checkpoint is None:  # the signal came while model.zip was being written
            checkpoint = _save_checkpoint(model, run_dir / "checkpoints", save_replay_buffer)
        raise TrainingInterrupted(stopper.signum, run_dir, checkpoint, model.num_timesteps)
    train_seconds = evaluator.seconds_offset + time.perf_counter() - learn_began - evaluator.eval_seconds
    if not evaluator.history or evaluator.history[-1]["timesteps"] != model.num_timesteps:
        evaluator.evaluate()  # the curve ends where training ended
    final = {
        ablation: evaluate_team(
            model,
            config.task,
            n_episodes=settings.episodes,
            seed=settings.final_seed,
            ablation=ablation,
            env_kwargs=config.env_kwargs,
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
        hyperparams={"n_envs": config.n_envs, **config.options_entry(), **config.hyperparams},
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
    _finish_tensorboard(model, config, result, settings, tb_dir)
    result.wall_seconds = time.perf_counter() - began
    result.finished = dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")
    result.save(run_dir / "result.json")  # last: its presence means the run is done
    return result
