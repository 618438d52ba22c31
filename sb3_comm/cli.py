"""The ``sb3-comm`` command line: train, evaluate, record-video, zoo, experiment, reproduce, report.

    sb3-comm train --env BlindSoccer-v0 --method GSN [--save-replay-buffer]
    sb3-comm train --resume runs/BlindSoccer-v0/GSN_seed0          # continue an interrupted run
    sb3-comm evaluate runs/BlindSoccer-v0/GSN_seed0/model.zip --ablation zero
    sb3-comm record-video runs/BlindSoccer-v0/GSN_seed0/model.zip -o gsn.gif [--no-comm]
    sb3-comm zoo train --env BlindSoccer-v0 --method GSN -f logs   # rl-zoo3, every flag
    sb3-comm experiment paper --quick --workers 2                  # many runs from a YAML file
    sb3-comm reproduce                                             # the paper's runs, then the report
    sb3-comm reproduce --fast                                      # the same, 32 games, bfloat16: faster
    sb3-comm report runs/experiments/paper                         # the report of an experiment folder

``train`` reads the packaged hyperparameters of the method (``zoo_configs/<method>.yml``; for a
registered two-agent task that no packaged file configures, such as ``MPESimpleReference-v0``, the
constructor's defaults with 8 games and 300,000 steps, and it says so), trains
with a progress bar, evaluates periodically, and writes TensorBoard logs, the learning curve, the
model and the run's record (``result.json``) into a fresh run folder (an existing folder is never
overwritten); it is a thin caller of :func:`sb3_comm.training.train_run`. Ctrl-C or SIGTERM saves a
checkpoint and prints how to resume (exit 130 / 143); ``--resume RUN_DIR`` continues that run
(:func:`sb3_comm.training.resume_run`).
"""

from __future__ import annotations

import argparse
import json
import sys
import traceback
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from sb3_comm.common.hyperparams import canonical_value
from sb3_comm.common.networks import PRECISIONS

if TYPE_CHECKING:
    from sb3_comm.comm_ddpg import CommDDPG

__all__ = ["main", "parse_overrides"]


def parse_overrides(items: list[str] | None) -> dict[str, Any]:
    """``key=value`` pairs to a dict of text-form values (parsed as YAML: numbers, lists, mappings;
    see :mod:`sb3_comm.common.hyperparams`)."""
    result: dict[str, Any] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"Hyperparameter override {item!r} must look like key=value")
        try:
            parsed = yaml.safe_load(value)
        except yaml.YAMLError as error:
            problem = getattr(error, "problem", None) or "cannot be parsed"
            raise ValueError(
                f"Hyperparameter override {item!r}: the value {value!r} is not valid YAML ({problem}); "
                "e.g. batch_size=64, learning_rate=lin_1e-3, 'policy_kwargs={net_arch: [64, 64]}'"
            ) from error
        result[key.strip()] = canonical_value(key.strip(), parsed)
    return result


def parse_env_kwargs(items: list[str] | None) -> dict[str, Any]:
    """rl-zoo3's ``--env-kwargs key:value ...`` to a dict (values parsed as YAML: ``true``, numbers)."""
    result: dict[str, Any] = {}
    for item in items or []:
        key, sep, value = item.partition(":")
        if not sep or not key.strip():
            raise ValueError(f"--env-kwargs {item!r} must look like key:value (e.g. time_feature:true)")
        try:
            result[key.strip()] = yaml.safe_load(value)
        except yaml.YAMLError as error:
            raise ValueError(f"--env-kwargs {item!r}: the value {value!r} is not valid YAML") from error
    return result


def _fresh_dir(base: Path, option: str) -> Path:
    """Create and return ``base`` or, if it exists, ``base_1``, ``base_2``, ... (never reuse a folder)."""
    candidate, k = base, 1
    while candidate.exists():
        candidate = base.with_name(f"{base.name}_{k}")
        k += 1
    try:
        candidate.mkdir(parents=True)
    except OSError as error:
        raise ValueError(f"{option}: cannot create the run folder {candidate} ({error.strerror})") from error
    return candidate


def _count(minimum: int, meaning: str = "") -> Callable[[str], int]:
    """An argparse type: a whole number ≥ ``minimum`` (a mistake exits 2 with argparse's usage line)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number ≥ {minimum}, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be ≥ {minimum}{meaning}, got {value}")
        return value

    parse.__name__ = f"whole number ≥ {minimum}"
    return parse


def _device(text: str) -> str:
    """An argparse type: a torch device this machine has (``auto``, ``cpu``, ``cuda``, ``cuda:1``, ...);
    a GPU torch cannot see exits 2 here, before a run folder exists."""
    from sb3_comm.common.validation import Device

    try:
        Device()("--device", text)
    except (TypeError, ValueError) as error:
        raise argparse.ArgumentTypeError(
            str(error).removeprefix("--device=").removeprefix("--device ")
        ) from None
    return text


_device.__name__ = "device"


def _add_device_argument(parser: argparse.ArgumentParser) -> None:
    """``--device``, checked at parse time (:func:`_device`); default the CPU."""
    parser.add_argument(
        "--device", type=_device, default="cpu", help="torch device: cpu, cuda, cuda:<index> or auto"
    )


def _check_env_id(env_id: str) -> str:
    """A Gymnasium id that is registered (the packaged tasks are, by ``import sb3_comm``)."""
    import gymnasium as gym

    import sb3_comm  # noqa: F401  (registers the task ids)
    from sb3_comm.registration import TASK_IDS

    if env_id not in gym.registry:
        raise ValueError(f"Unknown environment {env_id!r}: not a registered id; the tasks: {list(TASK_IDS)}")
    return env_id


def _packaged(method: str, env_id: str) -> bool:
    """Whether the packaged file of ``method`` has an entry for ``env_id``."""
    from sb3_comm.config import config_path, read_entry

    try:
        read_entry(config_path(method), env_id)
    except ValueError:
        return False
    return True


def _check_two_agent_task(env_id: str) -> None:
    """A registered id that builds a two-agent task (a single-agent HFO task does not)."""
    from sb3_comm import make_comm_vec_env

    try:
        env = make_comm_vec_env(env_id, n_envs=1, seed=0)
    except Exception as error:
        raise ValueError(f"{env_id!r} could not be built ({type(error).__name__}: {error})") from None
    try:
        env.get_attr("comm_layout")
    except AttributeError:
        raise ValueError(
            f"{env_id!r} is not a two-agent task that CommDDPG can train (its environment has no "
            "'comm_layout'); for a single-agent HFO task use HybridDDPG (see the README)"
        ) from None
    finally:
        env.close()


def _model_file(path_text: str) -> Path:
    """The model file a user named, checked without unpickling anything: it exists, is a zip archive
    and its JSON ``data`` entry says CommDDPG saved it (a folder, a missing file, a corrupted
    archive or another algorithm's model are named as such)."""
    path = Path(path_text)
    if not path.exists() and path.suffix != ".zip" and path.with_name(f"{path.name}.zip").is_file():
        path = path.with_name(f"{path.name}.zip")  # SB3's convention: the .zip may be left out
    if not path.exists():
        raise FileNotFoundError(f"Model file {path} does not exist")
    if path.is_dir():
        hint = f"; did you mean {path / 'model.zip'}?" if (path / "model.zip").is_file() else ""
        raise ValueError(f"{path} is a folder, not a model file (the model.zip of a run){hint}")
    if not zipfile.is_zipfile(path):
        raise ValueError(f"{path} is not a model file: not a zip archive (truncated or corrupted?)")
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data")) if "data" in archive.namelist() else None
    except (OSError, ValueError, zipfile.BadZipFile) as error:
        raise ValueError(f"{path} is a corrupted model file: its 'data' entry is unreadable") from error
    if not isinstance(data, dict):
        raise ValueError(f"{path} is not a model file of Stable-Baselines3: the archive has no 'data' entry")
    policy = data.get("policy_class")
    module = policy.get("__module__", "") if isinstance(policy, dict) else ""
    if not module.startswith("sb3_comm.comm_ddpg"):
        raise ValueError(
            f"{path} is not a CommDDPG team model (its policy comes from {module or 'an unknown module'}); "
            "evaluate and record-video take the model.zip of an sb3-comm train run"
        )
    return path


def _load_model(path: Path, device: str) -> CommDDPG:
    """``CommDDPG.load`` of a file checked by :func:`_model_file`; a failure names the file."""
    from sb3_comm import CommDDPG

    try:
        return CommDDPG.load(path, device=device)
    except Exception as error:  # a corrupted policy.pth or optimizer, a bad pickle, ...
        text = str(error).strip()
        reason = text.splitlines()[0].split(". ")[0] if text else ""
        raise ValueError(
            f"{path} cannot be loaded as a CommDDPG model: corrupted or incompatible contents "
            f"({type(error).__name__}{': ' + reason if reason else ''})"
        ) from error


_RUN_FLAGS = {
    "env": "--env",
    "method": "--method",
    "timesteps": "--timesteps",
    "n_envs": "--n-envs",
    "seed": "--seed",
    "conf": "--conf",
    "params": "--params",
    "env_kwargs": "--env-kwargs",
    "eval_freq": "--eval-freq",
    "eval_episodes": "--eval-episodes",
    "save_freq": "--save-freq",
    "log_interval": "--log-interval",
    "precision": "--precision",
    "video_every": "--video-every",
}
"""Flags that define a run: a resume takes them from the run folder instead."""


_ABLATION_WORDS = {"none": "with messages intact", "zero": "zeroed", "shuffle": "shuffled"}


def _train(args: argparse.Namespace) -> int:
    from sb3_comm.training import TrainingInterrupted

    try:
        result, run_dir = _resume(args) if args.resume else _new_run(args)
    except TrainingInterrupted as stopped:
        print(f"sb3-comm: interrupted by {stopped}", file=sys.stderr)
        return stopped.exit_code
    print(
        f"Done in {result.wall_seconds:.0f} s. Last periodic evaluation: mean return "
        f"{result.curve[-1]['mean_return']:.4f}; final evaluation ({result.eval['episodes']} other games): "
        + ", ".join(
            f"{summary['mean_return']:.4f} {_ABLATION_WORDS.get(name, name)}"
            for name, summary in result.final.items()
        )
    )
    print(f"Model:       {run_dir / 'model.zip'}")
    print(f"Curve:       {run_dir / 'evaluations.json'}")
    print(f"Result:      {run_dir / 'result.json'}")
    print(f"TensorBoard: tensorboard --logdir {_tensorboard_dir(run_dir)}")
    return 0


def _tensorboard_dir(run_dir: Path) -> Path:
    """The run's TensorBoard folder, as its run_settings.json records it."""
    from sb3_comm.results import read_json
    from sb3_comm.training import RUN_SETTINGS

    try:
        return Path(read_json(run_dir / RUN_SETTINGS).get("tensorboard_dir") or run_dir / "tb")
    except (OSError, ValueError):
        return run_dir / "tb"


def _resume(args: argparse.Namespace) -> tuple[Any, Path]:
    from sb3_comm.training import resume_run

    given = [flag for name, flag in _RUN_FLAGS.items() if getattr(args, name) is not None]
    if given:
        raise ValueError(f"--resume continues the run with its own settings; drop {', '.join(given)}")
    run_dir = Path(args.resume)
    print(f"Resuming {run_dir} from its last checkpoint (its config.yml and run_settings.json)")
    result = resume_run(
        run_dir,
        save_replay_buffer=True if args.save_replay_buffer else None,
        device=args.device,
        verbose=args.verbose,
        eval_verbose=1,
        progress_bar=not args.no_progress_bar,
    )
    return result, run_dir


def _new_run(args: argparse.Namespace) -> tuple[Any, Path]:
    from sb3_comm.config import RunConfig
    from sb3_comm.training import EvalSettings, train_run

    if args.env is None or args.method is None:
        raise ValueError("train needs --env and --method (or --resume RUN_DIR)")
    overrides = parse_overrides(args.params)
    if args.n_envs is not None:
        overrides["n_envs"] = args.n_envs
    if args.timesteps is not None:
        overrides["n_timesteps"] = args.timesteps
    seed = 0 if args.seed is None else args.seed
    # Checked in full (every value, RunConfig) before the run folder exists.
    env_id = _check_env_id(args.env)
    if args.conf is None and not _packaged(args.method, env_id):
        _check_two_agent_task(env_id)
        config = RunConfig.constructor_defaults(args.method, env_id, seed=seed).with_overrides(overrides)
        averaged = (config.hyperparams.get("policy_kwargs") or {}).get("averaged_actor", True)
        print(
            f"No packaged configuration of {config.method} for {env_id}: CommDDPG's constructor defaults, "
            f"{config.n_envs} games, {config.n_timesteps} steps (--params, --n-envs, --timesteps or "
            "--conf to change them); "
            + (
                "the team plays its actor's average over the run's last tenth "
                "(-params 'policy_kwargs={averaged_actor: false}' plays the actor)"
                if averaged
                else "the team plays its actor"
            )
        )
    else:
        config = RunConfig.load(args.method, env_id, seed=seed, path=args.conf, overrides=overrides)
    if args.precision is not None:  # added to (and over) the file's policy_kwargs, which stay
        config = config.with_precision(args.precision)
    if args.env_kwargs:  # added to (and over) the file's task options
        options = {**config.env_kwargs, **parse_env_kwargs(args.env_kwargs)}
        config = config.with_overrides({"env_kwargs": options})
    run_name = f"{config.method}_seed{config.seed}"
    run_dir = _fresh_dir(Path(args.log_folder) / args.env / run_name, "--log-folder")
    print(
        f"Training CommDDPG {config.method} on {args.env}: {config.n_timesteps} steps, "
        f"{config.n_envs} parallel games, seed {config.seed}"
        + (f", hidden layers in {config.precision}" if config.precision != "float32" else "")
    )
    print(f"Run folder: {run_dir}")
    evaluation = EvalSettings(
        freq=25_000 if args.eval_freq is None else args.eval_freq,
        episodes=100 if args.eval_episodes is None else args.eval_episodes,
        video_every=args.video_every or 0,
    )
    try:
        result = train_run(
            config,
            run_dir,
            evaluation=evaluation,
            save_freq=100_000 if args.save_freq is None else args.save_freq,
            device=args.device,
            verbose=args.verbose,
            eval_verbose=1,
            progress_bar=not args.no_progress_bar,
            save_replay_buffer=args.save_replay_buffer,
            log_interval=args.log_interval,
        )
    except BaseException:
        if not any(run_dir.iterdir()):  # failed before writing anything: leave no empty run folder
            run_dir.rmdir()
        raise
    return result, run_dir


def _evaluate(args: argparse.Namespace) -> int:
    from sb3_comm.evaluation import evaluate_team

    path = _model_file(args.model)
    env_id = _check_env_id(args.env or _env_of(path))
    model = _load_model(path, args.device)
    if args.averaged_actor is not None:  # the actor's Polyak average, or the actor (default: as saved)
        model.policy.averaged_actor = args.averaged_actor
    options = _env_kwargs_of(path, env_id)
    result = evaluate_team(
        model, env_id, n_episodes=args.episodes, seed=args.seed, ablation=args.ablation, env_kwargs=options
    )
    report = {
        "env": env_id,
        "method": model.method,
        "ablation": args.ablation,
        "averaged_actor": bool(model.policy.averaged_actor),
        "actor_average_tau": model.policy.actor_average_tau,
        **result.summary(),
    }
    print(json.dumps(report, indent=2))
    if args.projector is not None:
        from sb3_comm.tensorboard import write_projector

        folder = write_projector(
            model, env_id, args.projector, n_episodes=args.episodes, seed=args.seed, env_kwargs=options
        )
        print(f"Projector: tensorboard --logdir {folder}  (PROJECTOR tab)")
    return 0


def _record_video(args: argparse.Namespace) -> int:
    import gymnasium as gym
    import numpy as np

    from envs.video import record_episode

    model_path = _model_file(args.model)
    suffix = "_nocomm" if args.no_comm else ""
    out = Path(args.output) if args.output else model_path.with_name(f"{model_path.stem}{suffix}.gif")
    if not out.parent.is_dir():
        raise ValueError(f"--output {out}: the folder {out.parent} does not exist (or is not a folder)")
    env_id = _check_env_id(args.env or _env_of(model_path))
    model = _load_model(model_path, args.device)
    env = gym.make(env_id, render_mode="rgb_array", **_env_kwargs_of(model_path, env_id))
    layout = model.comm_layout

    def policy(obs: np.ndarray) -> np.ndarray:
        if args.no_comm and layout.channel_size:
            obs = obs.copy()
            obs[..., layout.obs_message_slice] = 0.0  # the receivers hear nothing
        action, _ = model.predict(obs, deterministic=True)
        return action

    for episode in range(args.episodes):
        path = out if args.episodes == 1 else out.with_name(f"{out.stem}_{episode}{out.suffix}")
        record_episode(env, policy, path, fps=args.fps, seed=args.seed + episode)
        print(f"wrote {path}")
    return 0


def _zoo(args: argparse.Namespace) -> int:
    from sb3_comm.zoo import run

    return run(args.zoo_command, args.zoo_args)


def _run_experiment(args: argparse.Namespace, file_or_name: str) -> tuple[int, Path]:
    from sb3_comm.experiments import load_experiment, run_experiment

    if args.workers is not None and args.workers < 0:
        raise ValueError(f"--workers must be 0 (in this process) or more, got {args.workers}")
    overrides = {"seeds": args.seeds, "precision": args.precision}
    spec = load_experiment(file_or_name, quick=args.quick, overrides=overrides)
    # Runs in another arithmetic go to their own folder: a report groups a folder's runs by method
    # and task, whatever their configuration.
    suffix = ("-quick" if spec.is_quick else "") + (
        f"-{spec.precision}" if spec.precision not in (None, "float32") else ""
    )
    default = Path("runs/experiments") / f"{spec.name}{suffix}"
    out = Path(args.out) if args.out else default
    summary = run_experiment(
        spec,
        out,
        workers=args.workers,
        ray_address=args.ray_address,
        only=getattr(args, "only", None),
        rerun_failed=getattr(args, "rerun_failed", False),
    )
    return (1 if summary["counts"]["failed"] else 0), out


def _experiment(args: argparse.Namespace) -> int:
    try:
        return _run_experiment(args, args.experiment)[0]
    except (ImportError, ConnectionError) as error:  # Ray missing or unreachable
        print(f"sb3-comm: error: {error}", file=sys.stderr)
        return 2


def _reproduce(args: argparse.Namespace) -> int:
    try:
        status, out = _run_experiment(args, "paper_fast" if args.fast else "paper")
        from sb3_comm.analysis import make_report
    except (ImportError, ConnectionError) as error:
        print(f"sb3-comm: error: {error}", file=sys.stderr)
        return 2
    print(f"Writing the report of {out} ...")
    make_report(out)
    print(f"Report: {out / 'report'}")
    for page in sorted((out / "report").glob("*.md")):
        print(f"  {page}")
    if status:
        print("Some runs failed: the report covers the finished runs only (see above to re-run them).")
    return status


def _report(args: argparse.Namespace) -> int:
    from sb3_comm.analysis import make_report

    folder = Path(args.experiment_dir)
    if not (folder / "runs").is_dir():
        raise FileNotFoundError(f"{folder} is not an experiment folder (it has no runs/ folder)")
    out = Path(args.to) if args.to else folder / "report"
    report = make_report(folder, out)
    print(f"Report: {out}")
    for page in sorted(out.glob("*.md")):
        print(f"  {page}")
    for skipped in report.get("skipped", []):
        print(f"  not used: {skipped['dir']}: {skipped['reason']}")
    return 0


def _run_entries(model_path: Path) -> dict[str, Any] | None:
    """The ``{task: entry}`` of the run's ``config.yml`` beside ``model_path`` (None: no run config).

    :raises ValueError: the file is not valid YAML.
    """
    config = model_path.parent / "config.yml"
    if not config.is_file():
        return None
    try:
        entries = yaml.safe_load(config.read_text())
    except yaml.YAMLError as error:
        raise ValueError(f"{config} is not valid YAML; pass --env") from error
    return entries if isinstance(entries, dict) else None


def _env_of(model_path: Path) -> str:
    entries = _run_entries(model_path)
    if entries:
        return str(next(iter(entries)))
    raise ValueError(f"Cannot tell the environment of {model_path} (no run config.yml beside it): pass --env")


def _env_kwargs_of(model_path: Path, env_id: str) -> dict[str, Any]:
    """The task options the run beside ``model_path`` trained with on ``env_id`` (its config.yml's
    ``env_kwargs``), so that a model is evaluated on the task it learned; {} without a run config."""
    entry = (_run_entries(model_path) or {}).get(env_id)
    options = entry.get("env_kwargs") if isinstance(entry, dict) else None
    return dict(options) if isinstance(options, dict) else {}


def build_parser() -> argparse.ArgumentParser:
    """The ``sb3-comm`` argument parser."""
    from sb3_comm.comm_ddpg import METHODS
    from sb3_comm.evaluation import ABLATIONS
    from sb3_comm.registration import TASK_IDS

    parser = argparse.ArgumentParser(prog="sb3-comm", description="Agents that learn to communicate (SB3).")
    parser.add_argument(
        "-v",
        "--verbose",
        dest="traceback",
        action="store_true",
        help="on an error, print the full traceback (before the command: sb3-comm -v train ...)",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    train = sub.add_parser("train", help="train a method on a task with the packaged configuration")
    train.add_argument(
        "--env",
        help=f"task id (required unless --resume): {', '.join(sorted(TASK_IDS))} (packaged configurations), "
        "or any registered two-agent task, which trains with the constructor's defaults",
    )
    train.add_argument(
        "--method", type=str.upper, choices=METHODS, help="communication method (required unless --resume)"
    )
    train.add_argument("--timesteps", "-n", type=_count(1), default=None, help="override n_timesteps")
    train.add_argument("--n-envs", type=_count(1), default=None, help="override n_envs (parallel games)")
    train.add_argument("--seed", type=int, default=None, help="training seed (default 0)")
    train.add_argument("--conf", "-conf", default=None, help="hyperparameter YAML (default: packaged)")
    train.add_argument("--params", "-params", nargs="*", help="overrides key=value")
    train.add_argument(
        "--env-kwargs",
        nargs="*",
        default=None,
        help="task options key:value, as rl-zoo3 (e.g. time_feature:true); added to the file's env_kwargs",
    )
    train.add_argument("--log-folder", "-f", default="runs", help="where run folders go")
    train.add_argument(
        "--eval-freq", type=_count(1), default=None, help="evaluate every N env steps (default 25000)"
    )
    train.add_argument("--eval-episodes", type=_count(1), default=None, help="games per evaluation (100)")
    train.add_argument(
        "--save-freq",
        type=_count(0, " (0: no checkpoints)"),
        default=None,
        help="checkpoint every N env steps (default 100000; 0: no checkpoints)",
    )
    train.add_argument(
        "--log-interval",
        type=_count(0, " (0: no training points)"),
        default=None,
        help="TensorBoard training point every N env steps (default: about 200 per run; 0: none)",
    )
    train.add_argument(
        "--video-every",
        type=_count(0, " (0: no videos)"),
        default=None,
        help="a rendered evaluation episode in TensorBoard every K evaluations (default 0: none)",
    )
    train.add_argument(
        "--save-replay-buffer",
        action="store_true",
        help="save the replay buffer with every checkpoint, so that --resume continues with it",
    )
    train.add_argument(
        "--resume",
        metavar="RUN_DIR",
        default=None,
        help="continue an interrupted run from its last checkpoint, with its own settings",
    )
    train.add_argument(
        "--precision",
        choices=list(PRECISIONS),
        default=None,
        help="arithmetic of the networks' hidden layers (policy_kwargs precision, added to the "
        "configuration's policy_kwargs; default: the configuration's, float32). bfloat16 trains faster "
        "where the processor has bfloat16 arithmetic; it is not the same numbers (README)",
    )
    _add_device_argument(train)
    train.add_argument("--no-progress-bar", action="store_true")
    train.add_argument("--verbose", type=int, default=0, help="verbosity of the algorithm (0, 1, 2)")
    train.set_defaults(func=_train)

    evaluate = sub.add_parser("evaluate", help="evaluate a saved model, optionally with ablated messages")
    evaluate.add_argument("model", help="path of a saved model.zip")
    evaluate.add_argument("--env", default=None, help="task id (default: from the run's config.yml)")
    evaluate.add_argument("--episodes", type=_count(1), default=100)
    evaluate.add_argument("--seed", type=int, default=12345)
    evaluate.add_argument("--ablation", choices=ABLATIONS, default="none")
    evaluate.add_argument(
        "--averaged-actor",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="play the actor's Polyak average (policy_kwargs averaged_actor): the model's actor_average "
        "where it keeps one (actor_average_tau), else its target actor; --no-averaged-actor plays the "
        "actor itself (default: what the model was saved to play, for a new CommDDPG the average)",
    )
    evaluate.add_argument(
        "--projector",
        metavar="TB_DIR",
        default=None,
        help="also write the messages of --episodes games to TensorBoard's Embedding Projector in TB_DIR",
    )
    _add_device_argument(evaluate)
    evaluate.set_defaults(func=_evaluate)

    video = sub.add_parser("record-video", help="write a GIF or MP4 of a saved model, messages shown as bars")
    video.add_argument("model", help="path of a saved model.zip")
    video.add_argument("--env", default=None, help="task id (default: from the run's config.yml)")
    video.add_argument("--output", "-o", default=None, help="file .gif or .mp4 (default: next to the model)")
    video.add_argument("--episodes", type=_count(1), default=1)
    video.add_argument("--seed", type=int, default=0)
    video.add_argument("--fps", type=_count(1), default=10)
    video.add_argument("--no-comm", action="store_true", help="receivers hear zeros (the paper's ablation)")
    _add_device_argument(video)
    video.set_defaults(func=_record_video)

    zoo = sub.add_parser(
        "zoo", help="rl-zoo3's train/enjoy/record_video with CommDDPG (see python -m sb3_comm.zoo)"
    )
    zoo.add_argument("zoo_command", choices=("train", "enjoy", "record_video"))
    zoo.add_argument("zoo_args", nargs=argparse.REMAINDER, help="rl-zoo3 flags")
    zoo.set_defaults(func=_zoo)

    def experiment_options(command: argparse.ArgumentParser) -> None:
        command.add_argument(
            "--quick", action="store_true", help="the file's quick settings: 1 seed, short runs"
        )
        command.add_argument(
            "--out",
            default=None,
            help="experiment folder (default: runs/experiments/<name>[-quick][-bfloat16])",
        )
        command.add_argument(
            "--seeds",
            type=int,
            nargs="+",
            default=None,
            metavar="SEED",
            help="train these seeds instead of the file's (e.g. --seeds 0 1 2 3 4); a run already "
            "finished in the folder is not trained again",
        )
        command.add_argument(
            "--precision",
            choices=list(PRECISIONS),
            default=None,
            help="arithmetic of every run's hidden layers, added to each configuration's policy_kwargs "
            "(default: the configurations', float32); not float32: its own default folder",
        )
        command.add_argument(
            "--workers",
            type=int,
            default=None,
            help="runs at a time, one process each (default: usable cores; 0: one after another in this "
            "process); with --ray-address local: the CPUs of the Ray instance",
        )
        command.add_argument(
            "--ray-address",
            default=None,
            help="run on Ray: 'auto' (running cluster), 'host:port', or 'local' (start one here)",
        )

    experiment = sub.add_parser(
        "experiment", help="train every method/task/seed of an experiment YAML file, resuming finished runs"
    )
    experiment.add_argument("experiment", help="experiment YAML file or packaged name (paper)")
    experiment_options(experiment)
    experiment.add_argument(
        "--only", nargs="+", metavar="METHOD/TASK/SEED", help="run only these ('*' matches anything)"
    )
    experiment.add_argument(
        "--rerun-failed", action="store_true", help="run only the runs that failed last time"
    )
    experiment.set_defaults(func=_experiment)

    reproduce = sub.add_parser(
        "reproduce",
        help="the paper's experiment (NONE/RIAL/TCG/GSN and, beyond it, GSN-MAX x both tasks x 3 seeds, "
        "or --seeds), then the report",
    )
    experiment_options(reproduce)
    reproduce.add_argument(
        "--fast",
        action="store_true",
        help="the same methods and tasks, 5 seeds, with 32 games (batches twice the packaged size on "
        "Blind Soccer) and bfloat16 (sb3_comm/experiments/paper_fast.yml): about an hour of runs on "
        "two cores instead of 107 minutes",
    )
    reproduce.set_defaults(func=_reproduce)

    report = sub.add_parser(
        "report", help="figures and tables (curves, ablation, t-SNE, CIC, rliable) of an experiment folder"
    )
    report.add_argument("experiment_dir", help="the folder of `sb3-comm experiment` (holds runs/)")
    report.add_argument("--to", default=None, help="output folder (default: EXPERIMENT_DIR/report)")
    report.set_defaults(func=_report)
    return parser


_USER_FILE_ERRORS = (
    FileNotFoundError,
    FileExistsError,
    NotADirectoryError,
    IsADirectoryError,
    PermissionError,
)
"""File errors that follow from what the user gave (a path), not from the machine."""


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``sb3-comm``.

    A user's mistake (a ``ValueError``, an experiment folder held by another runner, or a file
    error such as a missing file or a folder that cannot be written) prints one line
    ``sb3-comm: error: ...`` and returns 2, as argparse does. Any other ``OSError`` (a full disk,
    a lost mount) prints one line and returns 1; the files already written are whole.
    ``sb3-comm -v ...`` prints the traceback too. Other exceptions are bugs and propagate.
    """
    from sb3_comm.common.files import FolderLockedError, describe_os_error

    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except (ValueError, FolderLockedError, *_USER_FILE_ERRORS) as error:
        if args.traceback:
            traceback.print_exc()
        message = " ".join(line.strip() for line in str(error).splitlines() if line.strip())
        print(f"sb3-comm: error: {message or type(error).__name__}", file=sys.stderr)
        return 2
    except OSError as error:
        if args.traceback:
            traceback.print_exc()
        print(f"sb3-comm: error: {describe_os_error(error)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # Ctrl-C outside training (which saves and resumes, see train)
        print("sb3-comm: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
