"""Files, folders and secrets (issue 10, part B): atomic writes under a full disk, one runner per
experiment folder, workers that die with their runner, masked passwords, confined names.

A full disk is faked by patching the low-level write to raise ``OSError(ENOSPC)``; the runs are
tiny (a few hundred steps, [8] networks, 2 games).
"""

from __future__ import annotations

import errno
import json
import os
import pickle
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from sb3_comm.cli import main
from sb3_comm.common.files import (
    FolderLockedError,
    atomic_path,
    folder_lock,
    mask_command,
    mask_url,
    write_text,
)
from sb3_comm.experiments import ExperimentSpecError, parse_experiment, run_experiment, runner
from sb3_comm.results import write_json

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
TINY = {
    "n_envs": 2,
    "learning_starts": 100_000,  # no gradient step: these tests are about files
    "batch_size": 16,
    "buffer_size": 1000,
    "policy_kwargs": {"net_arch": [8]},
}
TRAIN = [
    "train", "--env", "GuessMyNumber-v0", "--method", "NONE", "--n-envs", "2", "--eval-freq", "100000",
    "--eval-episodes", "2", "--no-progress-bar", "--params", "learning_starts=100000", "batch_size=16",
    "buffer_size=1000", "policy_kwargs={net_arch: [8]}",
]  # fmt: skip


def full_disk() -> OSError:
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def experiment_file(path: Path, timesteps: int = 200, **changes: Any) -> Path:
    data = {
        "name": "tiny",
        "methods": ["NONE"],
        "tasks": ["GuessMyNumber-v0"],
        "seeds": [0],
        "timesteps": timesteps,
        "eval_freq": 100_000,
        "eval_episodes": 2,
        "analysis_episodes": 2,
        "save_freq": 100,
        "hyperparams": {"all": dict(TINY)},
        **changes,
    }
    path.write_text(yaml.safe_dump(data))
    return path


def temporary_files(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if ".tmp" in p.name]


def fail_zip_writes_after(monkeypatch: pytest.MonkeyPatch, n_good: int) -> None:
    """Zip archives (models, checkpoints) get half written, then the disk is full, from the
    ``n_good + 1``-th archive on."""
    original = zipfile.ZipFile.writestr
    opened = [0]  # archives numbered on their first write; not id(), which a new archive may reuse

    def writestr(self: zipfile.ZipFile, name: Any, data: Any, *args: Any, **kwargs: Any) -> None:
        if not hasattr(self, "_test_archive_number"):
            opened[0] += 1
            self._test_archive_number = opened[0]  # type: ignore[attr-defined]
        if self._test_archive_number > n_good:  # type: ignore[attr-defined]
            original(self, name, data[: len(data) // 2], *args, **kwargs)
            raise full_disk()
        original(self, name, data, *args, **kwargs)

    monkeypatch.setattr(zipfile.ZipFile, "writestr", writestr)


# --------------------------------------------------------------------------- atomic writes


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path: Path) -> None:
    target = tmp_path / "result.json"
    write_json(target, {"old": 1})
    with pytest.raises(OSError) as caught, atomic_path(target) as tmp:
        tmp.write_text('{"new": ')  # half written, then the disk is full
        raise full_disk()
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(target)  # names the real file
    assert json.loads(target.read_text()) == {"old": 1}
    assert temporary_files(tmp_path) == []


def test_a_failed_rename_leaves_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def replace(*args: Any) -> None:
        raise full_disk()

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(OSError, match="No space left"):
        write_text(tmp_path / "config.yml", "a: 1\n")
    assert list(tmp_path.iterdir()) == []


def test_a_video_on_a_full_disk_is_not_left_truncated(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from PIL import Image

    from envs.soccer.render import save_video

    frames = [np.full((8, 8, 3), k * 40, dtype=np.uint8) for k in range(4)]
    assert save_video(frames, tmp_path / "ok.gif").stat().st_size > 0  # the temporary file keeps .gif
    original = Image.Image.save

    def save(self: Image.Image, fp: Any, *args: Any, **kwargs: Any) -> None:
        original(self, fp, *args, **kwargs)  # the whole GIF, then the disk is full on closing
        raise full_disk()

    monkeypatch.setattr(Image.Image, "save", save)
    with pytest.raises(OSError) as caught:
        save_video(frames, tmp_path / "episode.gif")
    assert caught.value.filename == str(tmp_path / "episode.gif")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ok.gif"]


def test_train_on_a_full_disk_marks_the_run_failed_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # The first checkpoint is written, the second hits the full disk; so does model.zip after it.
    fail_zip_writes_after(monkeypatch, n_good=1)
    argv = [*TRAIN, "--timesteps", "200", "--save-freq", "50", "--log-folder", str(tmp_path)]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no space left on device" in err[0] and "Traceback" not in err[0], err
    (run_dir,) = (tmp_path / "GuessMyNumber-v0").iterdir()
    (checkpoint,) = (run_dir / "checkpoints").iterdir()  # the good one; no truncated second
    with zipfile.ZipFile(checkpoint) as archive:
        assert archive.testzip() is None
    assert not (run_dir / "model.zip").exists() and not (run_dir / "result.json").exists()
    error = (run_dir / "error.txt").read_text().splitlines()
    assert error[0] == "status: failed" and "No space left on device" in error[1]
    assert (run_dir / "config.yml").read_text().strip()  # whole, not empty
    assert temporary_files(run_dir) == []


def test_experiment_on_a_full_disk_leaves_no_empty_or_truncated_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    fail_zip_writes_after(monkeypatch, n_good=0)
    out = tmp_path / "out"
    assert (
        main(["experiment", str(experiment_file(tmp_path / "x.yml")), "--out", str(out), "--workers", "0"])
        == 1
    )
    assert "FAILED  NONE/GuessMyNumber-v0/0: OSError" in capsys.readouterr().out
    (error_file,) = (out / "runs").rglob("error.txt")
    run_dir = error_file.parent
    assert error_file.read_text().startswith("status: failed\nreason: OSError: [Errno 28]")
    assert (run_dir / "config.yml").read_text().strip()
    assert not (run_dir / "checkpoints").exists() or not list((run_dir / "checkpoints").iterdir())
    assert temporary_files(out) == []
    summary = json.loads((out / "summary.json").read_text())
    assert summary["counts"]["failed"] == 1


def test_a_run_whose_every_write_fails_returns_failed_and_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    spec = parse_experiment(yaml.safe_load(experiment_file(tmp_path / "x.yml").read_text()))
    (run,) = spec.runs()

    def replace(*args: Any) -> None:
        raise full_disk()

    monkeypatch.setattr(os, "replace", replace)
    result = runner.run_one(run, tmp_path / "run")  # the error.txt it tries cannot be written either
    assert result["status"] == "failed" and "No space left" in result["error"]
    crashed = runner._crashed(run, [(run, tmp_path / "run")], RuntimeError("worker died"))
    assert crashed["status"] == "failed"  # no exception out of the runner
    assert [p for p in (tmp_path / "run").rglob("*") if p.is_file()] == []  # no empty files


# --------------------------------------------------------------------------- one runner per folder


def _children(pid: int) -> list[int]:
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            found.append(int(stat.parent.name))
    return found


def _descendants(pid: int) -> list[int]:
    found, todo = [], [pid]
    while todo:
        children = _children(todo.pop())
        found += children
        todo += children
    return found


def _running(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")  # a zombie no longer runs


def _wait_for(condition: Any, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.2)


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_second_runner_is_refused_and_workers_die_with_a_killed_runner(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    file = experiment_file(tmp_path / "x.yml", timesteps=1_000_000, save_freq=1_000_000)
    out = tmp_path / "out"
    command = [
        sys.executable,
        "-m",
        "sb3_comm.cli",
        "experiment",
        str(file),
        "--out",
        str(out),
        "--workers",
        "1",
    ]
    first = subprocess.Popen(command, env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        _wait_for(lambda: list((out / "runs").rglob("config.yml")), 60, "the first runner's worker to train")
        # A second runner on the same folder names the first and touches nothing.
        assert main(["experiment", str(file), "--out", str(out), "--workers", "0"]) == 2
        err = capsys.readouterr().err
        assert f"pid {first.pid}" in err and "in use by another runner" in err and "experiment" in err
        assert not list((out / "runs").rglob("previous_attempts"))
        # kill -9 of the runner: its worker stops too.
        workers = _descendants(first.pid)  # the fork server and the runs it forked
        assert workers
        first.send_signal(signal.SIGKILL)
        first.wait(10)
        _wait_for(lambda: not any(_running(pid) for pid in workers), 10, f"workers {workers} to stop")
    finally:
        if first.poll() is None:
            first.kill()
            first.wait()
    # Its lock is stale now: the next runner takes it over and says so.
    notices: list[str] = []
    with folder_lock(out, "next", echo=notices.append):
        pass
    assert len(notices) == 1 and "stale" in notices[0] and f"pid {first.pid}" in notices[0]


def test_a_lock_held_in_another_process_is_refused_with_its_holder(tmp_path: Path) -> None:
    holder = subprocess.Popen(
        [sys.executable, "-c",
         "import sys, time\nfrom sb3_comm.common.files import folder_lock\n"
         f"with folder_lock({str(tmp_path)!r}, 'sb3-comm experiment paper'):\n"
         "    print('held', flush=True); time.sleep(60)"],
        env=ENV, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        with pytest.raises(
            FolderLockedError, match=f"pid {holder.pid} on .* since .*sb3-comm experiment paper"
        ):
            with folder_lock(tmp_path, "second"):
                pass
    finally:
        holder.kill()
        holder.wait()
    with folder_lock(tmp_path, "third", echo=lambda line: None):  # free again (kill -9 released it)
        pass
    assert (tmp_path / ".lock").read_text() == ""  # a clean release leaves nothing stale


# --------------------------------------------------------------------------- secrets and paths


@pytest.mark.parametrize(
    ("url", "masked"),
    [
        (
            "postgresql://user:s3cret@db.example.org:5432/optuna",
            "postgresql://user:***@db.example.org:5432/optuna",
        ),
        ("mysql+pymysql://root:p%40ss@localhost/study", "mysql+pymysql://root:***@localhost/study"),
        ("ray://admin:hunter2@head:10001", "ray://admin:***@head:10001"),
        ("user:pw@head:6379", "user:***@head:6379"),
        ("postgresql://host/db?user=u&password=pw", "postgresql://host/db?user=u&password=***"),
        ("sqlite:///study.db", "sqlite:///study.db"),
        ("auto", "auto"),
        ("10.0.0.1:6379", "10.0.0.1:6379"),
        ("postgresql://user@host/db", "postgresql://user@host/db"),
    ],
)
def test_mask_url(url: str, masked: str) -> None:
    assert mask_url(url) == masked


def test_summary_records_the_ray_address_without_its_password(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(runner, "_import_ray", lambda: None)
    address = "ray://admin:hunter2@head:10001"
    monkeypatch.setattr(sys, "argv", ["sb3-comm", "experiment", "x.yml", "--ray-address", address])
    spec = parse_experiment(yaml.safe_load(experiment_file(tmp_path / "x.yml").read_text()))
    # Nothing failed before, so nothing runs (and Ray is not contacted); the summary is written.
    summary = run_experiment(
        spec, tmp_path / "out", ray_address=address, rerun_failed=True, echo=lambda s: None
    )
    text = (tmp_path / "out" / "summary.json").read_text()
    assert "hunter2" not in text and "hunter2" not in (tmp_path / "out" / ".lock").read_text()
    assert summary["backend"] == "Ray (ray://admin:***@head:10001)" and "admin:***@head" in summary["command"]
    assert mask_command(["--storage", "postgresql://u:pw@h/db"]) == ["--storage", "postgresql://u:***@h/db"]


def test_rl_zoo_report_and_args_hold_no_storage_password(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    optuna = pytest.importorskip("optuna")
    pytest.importorskip("rl_zoo3")
    import argparse

    from rl_zoo3.exp_manager import ExperimentManager

    from sb3_comm.zoo import storage_masked

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    database = tmp_path / "secret-database-name.db"
    study = optuna.create_study(study_name="s", storage=f"sqlite:///{database}")
    study.optimize(lambda trial: trial.suggest_float("x", 0, 1), n_trials=2)
    url = "postgresql://user:s3cret@db/optuna"
    monkeypatch.setattr(sys, "orig_argv", ["python", "-m", "sb3_comm.zoo", "train", "--storage", url])
    manager = argparse.Namespace(
        args=argparse.Namespace(storage=url, command=None), params_path=str(tmp_path), save_path=str(tmp_path)
    )
    import rl_zoo3.exp_manager as exp_manager

    with storage_masked():
        ExperimentManager._save_config(manager, {"x": 1})  # type: ignore[arg-type]
        with open(tmp_path / "report.pkl", "wb") as f:
            exp_manager.pkl.dump(study, f)  # what rl-zoo3 does with its report
    assert manager.args.storage == url  # the run itself still uses the real URL
    for name in ("args.yml", "command.txt"):
        text = (tmp_path / name).read_text()
        assert "s3cret" not in text and "user:***@db" in text, name
    raw = (tmp_path / "report.pkl").read_bytes()
    assert database.name.encode() not in raw  # no storage in the pickled report
    loaded = pickle.loads(raw)
    assert loaded.study_name == "s" and len(loaded.trials) == 2 and loaded.best_value == study.best_value
    assert exp_manager.pkl is pickle  # restored


@pytest.mark.parametrize("name", ["../../../x", "a/b", "..", "/tmp/x"])
def test_experiment_names_stay_inside_the_output_folder(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    with pytest.raises(ExperimentSpecError, match="plain folder name"):
        parse_experiment(yaml.safe_load(experiment_file(tmp_path / "x.yml", name=name).read_text()))
    monkeypatch.chdir(tmp_path)
    assert main(["experiment", str(tmp_path / "x.yml"), "--workers", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "plain folder name" in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.yml"]
