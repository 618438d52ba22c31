"""Run an experiment: one process per run, in parallel on this machine or on a Ray cluster.

Every run is one call of :func:`sb3_comm.training.train_run` with the run's
:class:`~sb3_comm.config.RunConfig` (the packaged hyperparameters plus the experiment's
overrides), into ``OUT/runs/<task>/<method>/seed<seed>-<hash8>/``: ``checkpoints/``,
``evaluations.json``, ``config.yml``, ``model.zip``, ``messages.npz`` (for the t-SNE of the
messages) and, last, ``result.json`` (a :class:`~sb3_comm.results.RunResult`: curve, final return
with messages intact, zeroed and shuffled, communication metrics and timings). The TensorBoard
event files of every run go to ``OUT/tb/<method>/<task>/seed<seed>/``:
``tensorboard --logdir OUT/tb`` compares every method and seed in one chart.

A run that raises writes ``error.txt`` (``status: failed``, the reason, the traceback) instead;
the other runs go on. A run whose ``result.json`` exists is skipped, so an interrupted experiment
resumes where it stopped; a run folder left without ``result.json`` is trained again, its earlier
files moved aside to ``previous_attempts/<k>/`` (nothing is deleted).

One runner at a time owns an experiment folder (``OUT/.lock``, see
:func:`~sb3_comm.common.files.folder_lock`): a second one stops with a message naming the first.
Worker processes end with the runner, even after ``kill -9``, so that nothing writes into the
folder of a restarted runner. Every file is written atomically, and the Ray address is recorded
with its password masked.

>>> from sb3_comm.experiments import load_experiment, run_experiment
>>> spec = load_experiment("paper", quick=True)
>>> summary = run_experiment(spec, "runs/experiments/paper-quick")  # doctest: +SKIP
"""

from __future__ import annotations

import datetime as dt
import shlex
import shutil
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import ExitStack, contextmanager, suppress
from pathlib import Path
from typing import Any

import yaml

from sb3_comm.common.files import die_with_parent, folder_lock, mask_command, mask_url, write_text
from sb3_comm.experiments.spec import ExperimentSpec, ExperimentSpecError, RunSpec
from sb3_comm.results import RunResult, machine_info, read_json, usable_cores, write_json

__all__ = [
    "default_workers",
    "longest_first",
    "machine_info",
    "run_experiment",
    "run_one",
    "select_runs",
    "start_worker",
]


def start_worker(workers: int) -> None:
    """A worker process of a pool of ``workers``: it ends with its parent, and its GSN updates use a
    second process only where the runs leave cores spare (one core per run otherwise)."""
    from sb3_comm.comm_ddpg import gsn

    die_with_parent()
    gsn.BESIDE_AGENTS = workers < usable_cores()


RAY_MISSING = 'Ray is not installed: pip install "sb3-comm[ray]" (or pip install "ray>=2.9")'


def default_workers() -> int:
    """Number of cores this process may use."""
    return usable_cores()


def _move_aside(run_dir: Path) -> None:
    """Move what an earlier, unfinished attempt left into ``previous_attempts/<k>/``."""
    leftovers = [p for p in run_dir.iterdir() if p.name != "previous_attempts"]
    if not leftovers:
        return
    k = 1
    while (run_dir / "previous_attempts" / str(k)).exists():
        k += 1
    target = run_dir / "previous_attempts" / str(k)
    target.mkdir(parents=True)
    for path in leftovers:
        shutil.move(str(path), str(target / path.name))


def run_one(run: RunSpec, run_dir: str | Path) -> dict[str, Any]:
    """Train, evaluate and analyse one run into ``run_dir`` (:func:`~sb3_comm.training.train_run`);
    never raises.

    :param run: the resolved run.
    :param run_dir: its folder (created; an unfinished earlier attempt there is moved aside).
    :return: the :class:`~sb3_comm.results.RunResult` as JSON (``status`` ``done`` or ``failed``;
        ``skipped`` when another invocation finished it meanwhile).
    """
    began = time.perf_counter()
    run_dir = Path(run_dir)
    import torch as th

    from sb3_comm.training import train_run, write_failure

    threads = th.get_num_threads()
    th.set_num_threads(1)  # one core per run; runs go in parallel
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
        if (run_dir / "result.json").exists():  # finished meanwhile (another invocation)
            return {**read_json(run_dir / "result.json"), "status": "skipped"}
        _move_aside(run_dir)
        experiment_dir = run_dir.parents[len(run.relative_dir.parts) - 1]
        tb_dir = experiment_dir / run.tensorboard_dir
        if tb_dir.is_dir():  # an earlier attempt's curves: kept apart (previous_attempts/<k>)
            _move_aside(tb_dir)
        result = train_run(
            run.config,
            run_dir,
            evaluation=run.eval_settings,
            save_freq=run.save_freq,
            config_hash=run.config_hash,
            tensorboard_dir=tb_dir,
        )
        return result.to_json()
    except BaseException as error:
        write_failure(run_dir, error)  # never raises, never leaves an empty or half file
        if not isinstance(error, Exception):  # KeyboardInterrupt, SystemExit: stop
            raise
        failed = RunResult(
            run.method,
            run.task,
            run.seed,
            status="failed",
            config_hash=run.config_hash,
            error=f"{type(error).__name__}: {error}",
            wall_seconds=time.perf_counter() - began,
        )
        return failed.to_json()
    finally:
        th.set_num_threads(threads)


def _parse_selector(selector: str) -> tuple[str, str, str]:
    parts = selector.split("/")
    if len(parts) != 3 or not all(parts):
        raise ExperimentSpecError(
            f"--only {selector!r} must look like METHOD/TASK/SEED "
            "(e.g. GSN/BlindSoccer-v0/0; '*' matches anything)"
        )
    return parts[0].upper(), parts[1], parts[2]


def select_runs(runs: list[RunSpec], only: Iterable[str] | None) -> list[RunSpec]:
    """The runs that match one of the ``METHOD/TASK/SEED`` selectors (``*`` matches anything).

    :raises ExperimentSpecError: a selector that matches no run of the experiment.
    """
    if not only:
        return list(runs)
    chosen: dict[str, RunSpec] = {}
    for selector in only:
        method, task, seed = _parse_selector(selector)
        matches = [
            run
            for run in runs
            if method in ("*", run.method) and task in ("*", run.task) and seed in ("*", str(run.seed))
        ]
        if not matches:
            raise ExperimentSpecError(
                f"--only {selector!r} matches no run of the experiment; its runs: {[r.key for r in runs]}"
            )
        chosen.update((run.key, run) for run in matches)
    return [run for run in runs if run.key in chosen]


def _failed_before(run: RunSpec, out: Path) -> bool:
    run_dir = out / run.relative_dir
    return (run_dir / "error.txt").exists() and not (run_dir / "result.json").exists()


PRELOADED = ("sb3_comm.training", "sb3_comm.analysis")
"""What the fork server of :func:`pool_context` imports once, so that each run's new process does
not (about 3.5 s of imports, torch, scikit-learn and matplotlib included, per run on a 2-core VM)."""


def pool_context() -> Any:
    """The multiprocessing context of the runs' processes: a fork server that has imported
    :data:`PRELOADED` where the platform has one (Linux, macOS), each run still in a new process
    forked from it; ``spawn`` elsewhere (a new interpreter per run)."""
    import multiprocessing as mp

    if "forkserver" not in mp.get_all_start_methods():
        return mp.get_context("spawn")
    context = mp.get_context("forkserver")
    context.set_forkserver_preload(list(PRELOADED))
    return context


STEP_COST = {"GSN-MAX": 2.0}
"""Training time per environment step of a method's runs relative to the others' (1 where not
listed), for :func:`longest_first`: GSN-MAX's effect search and effect models make its steps about
twice as long (``--fast`` on Blind Soccer, session 35: 426-484 s a run against 178-240 s for the
other methods; session 36, with the faster search, on a slower day: 428-443 s against 211-311 s)."""


def longest_first(runs: Iterable[RunSpec]) -> list[RunSpec]:
    """``runs`` in the order to start them: the longest first (budget times :data:`STEP_COST`),
    so that the last ones to finish are short and the parallel processes end close together."""
    return sorted(runs, key=lambda run: -run.timesteps * STEP_COST.get(run.method, 1.0))


def _local_results(
    jobs: list[tuple[RunSpec, Path]], workers: int
) -> Iterator[tuple[RunSpec, dict[str, Any]]]:
    """Each run in its own new process (:func:`pool_context`), at most ``workers`` at a time (0: in
    this process)."""
    if workers == 0:
        for run, run_dir in jobs:
            yield run, run_one(run, run_dir)
        return
    extra = {"max_tasks_per_child": 1} if sys.version_info >= (3, 11) else {}
    with ProcessPoolExecutor(
        max_workers=workers,
        mp_context=pool_context(),
        initializer=start_worker,
        initargs=(workers,),
        **extra,
    ) as pool:
        futures = {pool.submit(run_one, run, run_dir): run for run, run_dir in jobs}
        for future in as_completed(futures):
            run = futures[future]
            try:
                yield run, future.result()
            except Exception as error:  # the worker process died (out of memory, killed)
                yield run, _crashed(run, jobs, error)


def _crashed(run: RunSpec, jobs: list[tuple[RunSpec, Path]], error: BaseException) -> dict[str, Any]:
    from sb3_comm.training import write_failure

    run_dir = dict((r.key, d) for r, d in jobs)[run.key]
    with suppress(OSError):
        run_dir.mkdir(parents=True, exist_ok=True)
    write_failure(run_dir, error, note="The process of this run ended abnormally:\n")
    return {"status": "failed", "error": f"{type(error).__name__}: {error}"}


def _import_ray() -> Any:
    try:
        import ray
    except ImportError as error:
        raise ImportError(RAY_MISSING) from error
    return ray


@contextmanager
def _ray_session(address: str, workers: int | None) -> Iterator[Any]:
    """Connect to (or start) Ray; shut down on exit what this call started.

    ``address`` is ``auto`` (the running cluster), ``host:port`` or ``ray://host:port``, or
    ``local`` (start a Ray instance in this process with ``workers`` CPUs).
    """
    ray = _import_ray()
    started_here = not ray.is_initialized()
    if started_here:
        options: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
        if address == "local" and workers:
            options["num_cpus"] = workers
        try:
            ray.init(address=address, **options)
        except Exception as error:
            raise ConnectionError(
                f"Cannot connect to Ray at {mask_url(address)!r}: {error}. Give 'auto' (the cluster "
                "started with 'ray start' on this machine), 'host:port' of the head node, or 'local'. "
                "A cluster with token authentication (the default of 'ray start' in recent Ray) also needs "
                "RAY_AUTH_MODE=token in this shell."
            ) from error
    try:
        yield ray
    finally:
        if started_here:
            ray.shutdown()


def _ray_results(ray: Any, jobs: list[tuple[RunSpec, Path]]) -> Iterator[tuple[RunSpec, dict[str, Any]]]:
    """One ``ray.remote(num_cpus=1)`` task per run, as many at a time as the cluster has CPUs.

    The experiment folder must be on a file system that every node sees, and sb3-comm installed
    on every node.
    """
    # max_calls=1: a fresh worker process per run, as in the local pool.
    remote = ray.remote(num_cpus=1, max_calls=1)(run_one)
    pending = {remote.remote(run, str(run_dir)): (run, run_dir) for run, run_dir in jobs}
    while pending:
        ready, _ = ray.wait(list(pending), num_returns=1)
        run, run_dir = pending.pop(ready[0])
        try:
            yield run, ray.get(ready[0])
        except Exception as error:  # the worker died
            yield run, _crashed(run, [(run, run_dir)], error)


def _describe(result: dict[str, Any]) -> str:
    final = result.get("final") or {}
    text = (
        f"{result.get('timesteps', 0):,} steps in {result.get('wall_seconds', 0.0):.0f} s"
        f" (training {result.get('train_seconds', 0.0):.0f} s)"
    )
    if final:
        text += (
            f"; return {final['none']['mean_return']:.3f}, zeroed messages "
            f"{final['zero']['mean_return']:.3f}, shuffled {final['shuffle']['mean_return']:.3f}"
        )
    if result.get("communication") is None:
        error = (result.get("communication_error") or "").strip().splitlines()
        text += f"; communication analysis failed: {error[-1] if error else 'unknown error'}"
    return text


def run_experiment(
    spec: ExperimentSpec,
    out: str | Path,
    workers: int | None = None,
    ray_address: str | None = None,
    only: Iterable[str] | None = None,
    rerun_failed: bool = False,
    command: str | None = None,
    echo: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Run every run of ``spec`` that has no ``result.json`` in ``out`` yet, holding ``out``'s lock.

    :param spec: a checked experiment (:func:`~sb3_comm.experiments.load_experiment`).
    :param out: experiment folder; receives ``experiment.yml``, ``runs/`` and ``summary.json``.
    :param workers: runs at a time on this machine (default: the usable cores); 0 runs them one
        after another in this process (debugging). With ``ray_address``: the CPUs of a ``local``
        Ray instance.
    :param ray_address: run on Ray instead: ``auto``, ``host:port`` or ``local``.
    :param only: ``METHOD/TASK/SEED`` selectors (``*`` matches anything); the rest are not run.
    :param rerun_failed: run only the runs whose last attempt failed (``error.txt``, no result).
    :param command: the command line to record (default: ``sys.argv``).
    :param echo: where progress lines go.
    :return: the summary (also written to ``out/summary.json``): one row per run of the
        experiment with status ``done``, ``failed``, ``skipped`` (finished earlier) or
        ``not selected``, plus timings and the machine.
    :raises FolderLockedError: another live runner holds ``out`` (the message names it); a lock
        left by a runner that is gone is taken over (``echo`` says so).
    """
    if ray_address:
        _import_ray()  # fail before anything is written
    out = Path(out).resolve()
    select_runs(spec.runs(), only)  # a selector that matches nothing fails before the folder is made
    command = command or " ".join(shlex.quote(arg) for arg in mask_command(sys.argv))
    with folder_lock(out, command, echo=echo):
        return _run_locked(spec, out, workers, ray_address, only, rerun_failed, command, echo)


def _run_locked(
    spec: ExperimentSpec,
    out: Path,
    workers: int | None,
    ray_address: str | None,
    only: Iterable[str] | None,
    rerun_failed: bool,
    command: str,
    echo: Callable[[str], None],
) -> dict[str, Any]:
    began = time.perf_counter()
    runs = spec.runs()
    selected = select_runs(runs, only)
    if rerun_failed:
        selected = [run for run in selected if _failed_before(run, out)]
    selected_keys = {run.key for run in selected}
    rows: dict[str, dict[str, Any]] = {}
    todo: list[RunSpec] = []
    for run in runs:
        row = {"key": run.key, "method": run.method, "task": run.task, "seed": run.seed,
               "config_hash": run.config_hash, "dir": str(run.relative_dir)}  # fmt: skip
        result_path = out / run.relative_dir / "result.json"
        if result_path.exists():
            rows[run.key] = {**row, **_timing(read_json(result_path)), "status": "skipped"}
        elif run.key in selected_keys:
            rows[run.key] = {**row, "status": "pending"}
            todo.append(run)
        else:
            rows[run.key] = {**row, "status": "not selected"}
    local = "this process" if workers == 0 else "processes"
    backend = f"Ray ({mask_url(ray_address)})" if ray_address else local
    n_workers = default_workers() if workers is None else workers
    if not ray_address and n_workers:
        n_workers = max(1, min(n_workers, len(todo) or 1))

    with ExitStack() as stack:
        ray = stack.enter_context(_ray_session(ray_address, workers)) if ray_address and todo else None
        if ray is not None:  # as many runs at a time as the cluster has CPUs
            n_workers = int(ray.cluster_resources().get("CPU", 0))
        out.mkdir(parents=True, exist_ok=True)
        _write_spec(spec, out)
        skipped = [key for key, row in rows.items() if row["status"] == "skipped"]
        echo(
            f"Experiment {spec.name!r}{' (quick)' if spec.is_quick else ''}: {len(runs)} runs, "
            f"{len(todo)} to run, {len(skipped)} already done (skipped), in {out}"
        )
        for key in skipped:
            echo(f"  skipped {key}: result.json exists")
        if todo:
            where = "in this process" if workers == 0 else f"in {n_workers} process(es) at a time"
            echo(f"Running {len(todo)} run(s) " + (f"on {backend}, {n_workers} CPUs" if ray else where))
        jobs = [(run, out / run.relative_dir) for run in longest_first(todo)]
        results = _ray_results(ray, jobs) if ray is not None else _local_results(jobs, n_workers)
        for done, (run, result) in enumerate(results, start=1):
            status = "done" if result.get("status") in ("done", "skipped") else "failed"
            rows[run.key].update(status=status, **_timing(result))
            if status == "done":
                echo(f"[{done}/{len(todo)}] done    {run.key}: {_describe(result)}")
            else:
                rows[run.key]["error"] = result.get("error")
                echo(
                    f"[{done}/{len(todo)}] FAILED  {run.key}: {result.get('error')} "
                    f"(traceback: {out / run.relative_dir / 'error.txt'})"
                )
    summary = _summary(spec, out, rows, began, n_workers, backend, command)
    write_json(out / "summary.json", summary)
    _print_summary(summary, spec, out, echo)
    return summary


def _timing(result: dict[str, Any]) -> dict[str, Any]:
    keys = ("timesteps", "train_seconds", "wall_seconds")
    return {key: result[key] for key in keys if key in result}


def _write_spec(spec: ExperimentSpec, out: Path) -> None:
    """``experiment.yml``; a different earlier one is kept as ``experiment.<time>.yml``."""
    text = yaml.safe_dump(spec.to_dict(), sort_keys=False)
    path = out / "experiment.yml"
    if path.exists() and path.read_text() != text:
        stamp = dt.datetime.fromtimestamp(path.stat().st_mtime).strftime("%Y%m%d-%H%M%S")
        target, k = out / f"experiment.{stamp}.yml", 1
        while target.exists():
            target, k = out / f"experiment.{stamp}-{k}.yml", k + 1
        path.rename(target)
    write_text(path, text)


def _summary(
    spec: ExperimentSpec,
    out: Path,
    rows: dict[str, dict[str, Any]],
    began: float,
    workers: int,
    backend: str,
    command: str,
) -> dict[str, Any]:
    table = list(rows.values())
    counts = {status: sum(row["status"] == status for row in table)
              for status in ("done", "failed", "skipped", "not selected")}  # fmt: skip
    return {
        "name": spec.name,
        "quick": spec.is_quick,
        "out": str(out),
        "command": command,
        "finished": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
        "wall_seconds": time.perf_counter() - began,
        "backend": backend,
        "workers": workers,
        "machine": machine_info(speed=True),  # how fast it computed, to compare wall_seconds across days
        "counts": counts,
        "env_steps": sum(row.get("timesteps", 0) for row in table if row["status"] == "done"),
        "runs": table,
    }


def _print_summary(
    summary: dict[str, Any], spec: ExperimentSpec, out: Path, echo: Callable[[str], None]
) -> None:
    counts = summary["counts"]
    echo(
        f"Finished in {summary['wall_seconds']:.0f} s: {counts['done']} done, {counts['failed']} failed, "
        f"{counts['skipped']} skipped"
        + (f", {counts['not selected']} not selected" if counts["not selected"] else "")
    )
    echo(f"Summary: {out / 'summary.json'}")
    failed = [row for row in summary["runs"] if row["status"] == "failed"]
    if failed:
        source = (
            spec.source if spec.source and Path(spec.source).parent != Path(__file__).parent else spec.name
        )
        quick = " --quick" if spec.is_quick else ""
        base = f"sb3-comm experiment {shlex.quote(str(source))}{quick} --out {shlex.quote(str(out))}"
        echo("Failed runs (traceback in error.txt):")
        for row in failed:
            echo(f"  {row['key']}: {out / row['dir'] / 'error.txt'}")
        echo(f"Re-run one alone:     {base} --only {failed[0]['key']}")
        echo(f"Re-run all that failed: {base} --rerun-failed")
