"""Experiment files and the runner: validation, config hash, resume, failures, parallel and Ray runs.

Every run here is tiny (400 env steps, 2 games, [16, 16] networks, 4 evaluation games).
"""

from __future__ import annotations

import json
import os
import sys
import time
import types
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from sb3_comm.cli import main
from sb3_comm.config import RunConfig
from sb3_comm.experiments import (
    ExperimentSpecError,
    RunSpec,
    config_hash,
    load_experiment,
    packaged_experiments,
    parse_experiment,
    run_experiment,
)
from sb3_comm.experiments import spec as spec_module
from sb3_comm.results import RunResult

TINY_HYPERPARAMS = {
    "n_envs": 2,
    "learning_starts": 100,
    "batch_size": 16,
    "buffer_size": 1000,
    "policy_kwargs": {"net_arch": [16, 16]},
}


def tiny(**changes: Any) -> dict[str, Any]:
    """A two-run experiment (NONE and GSN on Guess My Number, seed 0) as a parsed YAML dict."""
    data = {
        "name": "tiny",
        "methods": ["NONE", "GSN"],
        "tasks": ["GuessMyNumber-v0"],
        "seeds": [0],
        "timesteps": 400,
        "eval_freq": 200,
        "eval_episodes": 4,
        "analysis_episodes": 4,
        "hyperparams": {"all": dict(TINY_HYPERPARAMS)},
    }
    data.update(changes)
    return data


def write(path: Path, data: dict[str, Any]) -> Path:
    path.write_text(yaml.safe_dump(data))
    return path


def results(out: Path) -> dict[str, dict[str, Any]]:
    """``METHOD/TASK/SEED`` -> result.json of every finished run under ``out``."""
    found = {}
    for path in sorted((out / "runs").rglob("result.json")):
        result = json.loads(path.read_text())
        found[f"{result['method']}/{result['task']}/{result['seed']}"] = result
    return found


# --------------------------------------------------------------------------- the experiment file


def test_paper_experiment_is_packaged_and_resolves() -> None:
    assert "paper" in packaged_experiments()
    full = load_experiment("paper")
    runs = full.runs()
    assert len(runs) == 5 * 2 * 3
    assert {r.method for r in runs} == {"NONE", "RIAL", "TCG", "GSN", "GSN-MAX"}
    assert {r.task for r in runs} == {"BlindSoccer-v0", "GuessMyNumber-v0"}
    assert {r.seed for r in runs} == {0, 1, 2}
    for run in runs:  # budgets from the packaged zoo configs, 100-game evaluations every 50k steps
        assert run.timesteps == RunConfig.load(run.method, run.task).n_timesteps
        assert (run.eval_freq, run.eval_episodes) == (50_000, 100)
        assert run.hyperparams["n_envs"] == RunConfig.load(run.method, run.task).n_envs
    quick = load_experiment("paper", quick=True)
    assert quick.is_quick and not full.is_quick
    quick_runs = quick.runs()
    assert len(quick_runs) == 10 and {r.seed for r in quick_runs} == {0}
    assert {r.task: r.timesteps for r in quick_runs} == {"BlindSoccer-v0": 30_000, "GuessMyNumber-v0": 20_000}
    assert {r.eval_freq for r in quick_runs} == {10_000}
    # Quick runs never reuse (or overwrite) the folders of full runs.
    assert not {r.relative_dir for r in runs} & {r.relative_dir for r in quick_runs}


def test_paper_fast_is_the_paper_runs_with_32_games_in_bfloat16() -> None:
    """``paper_fast`` (``sb3-comm reproduce --fast``): the packaged experiment's five methods, 5 seeds,
    the packaged configurations but for 32 games, bfloat16 and, on Blind Soccer, batches twice the
    packaged size (as many sampled transitions per environment step); its runs are not the
    packaged experiment's."""
    assert "paper_fast" in packaged_experiments()
    fast = load_experiment("paper_fast")
    paper = load_experiment("paper", overrides={"seeds": [0, 1, 2, 3, 4]})
    assert fast.precision == "bfloat16"
    fast_runs = {run.key: run for run in fast.runs()}
    assert {r.method for r in fast_runs.values()} == {"NONE", "RIAL", "TCG", "GSN", "GSN-MAX"}
    assert {r.seed for r in fast_runs.values()} == {0, 1, 2, 3, 4} and len(fast_runs) == 5 * 2 * 5
    for run in paper.runs():
        twin = fast_runs[run.key]
        assert (twin.timesteps, twin.eval_freq, twin.eval_episodes) == (run.timesteps, run.eval_freq, 100)
        assert twin.hyperparams["n_envs"] == 32 and run.hyperparams["n_envs"] == 16
        kwargs = dict(run.hyperparams["policy_kwargs"], precision="bfloat16")  # the pins kept
        factor = 2 if run.task == "BlindSoccer-v0" else 1
        batch = factor * run.hyperparams["batch_size"]
        assert twin.hyperparams == {
            **run.hyperparams,
            "n_envs": 32,
            "batch_size": batch,
            "policy_kwargs": kwargs,
        }
        assert twin.relative_dir != run.relative_dir
    assert {r.timesteps for r in load_experiment("paper_fast", quick=True).runs()} == {30_000, 20_000}


def test_reproduce_fast_runs_the_paper_fast_experiment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    """``--fast`` picks ``paper_fast``: its folder name, its precision, its report."""
    packaged = tmp_path / "packaged"
    packaged.mkdir()
    write(packaged / "paper.yml", tiny(name="paper"))
    write(packaged / "paper_fast.yml", tiny(name="paper_fast", methods=["NONE"], precision="bfloat16"))
    monkeypatch.setattr(spec_module, "EXPERIMENTS_DIR", packaged)
    monkeypatch.chdir(tmp_path)
    assert main(["reproduce", "--fast", "--workers", "0"]) == 0
    out = tmp_path / "runs" / "experiments" / "paper_fast-bfloat16"
    assert f"Report: {Path('runs/experiments/paper_fast-bfloat16/report')}" in capsys.readouterr().out
    (result,) = results(out).values()
    assert result["method"] == "NONE" and result["hyperparams"]["policy_kwargs"]["precision"] == "bfloat16"
    assert (out / "report" / "report.md").is_file()
    assert not (tmp_path / "runs" / "experiments" / "paper").exists()


BAD_EXPERIMENTS = [
    (
        {"methods": ["GSN", "DIAL"]},
        r"unknown method 'DIAL'; accepted: \['GSN', 'GSN-MAX', 'NONE', 'RIAL', 'TCG'\]",
    ),
    ({"tasks": ["BlindSoccer-v1"]}, r"unknown task 'BlindSoccer-v1'; accepted: \['BlindSoccer-v0'"),
    ({"n_seeds": 3}, r"unknown key\(s\) \['n_seeds'\]; accepted: \['name', 'description', 'methods'"),
    (
        {"hyperparams": {"GSN": {"learning_rat": 0.001}}},
        r"hyperparams\['GSN'\]: unknown key\(s\) \['learning_rat'\]; accepted keys: \[.*'learning_rate'",
    ),
    (
        {"hyperparams": {"DIAL": {"batch_size": 8}}},
        r"unknown hyperparams section 'DIAL'; accepted: \['all', 'NONE', .*'METHOD/TASK",
    ),
    ({"hyperparams": {"all": {"policy": "TCG"}}}, r"may not set 'policy': the method is set by 'methods'"),
    (
        {"hyperparams": {"all": {"learning_rate": "lin_fast"}}},
        r"hyperparams\['all'\]: learning_rate: 'lin_fast' is not a linear schedule",
    ),
    ({"timesteps": {"GuessMyNumbr-v0": 100}}, r"unknown task in 'timesteps' 'GuessMyNumbr-v0'; accepted"),
    ({"timesteps": -5}, r"'timesteps' must be at least 1, got -5"),
    ({"eval_freq": "often"}, r"'eval_freq' must be a whole number, got 'often'"),
    ({"seeds": []}, r"'seeds' must be a non-empty list"),
    ({"quick": {"seed": [0]}}, r"unknown key\(s\) in 'quick' \['seed'\]; accepted: \['methods'"),
    ({"quick": {"methods": ["gsm"]}}, r"\(quick\): unknown method 'GSM'; accepted"),
]


def test_quick_needs_a_quick_section() -> None:
    with pytest.raises(ExperimentSpecError, match=r"--quick: bad.yml has no 'quick' section"):
        parse_experiment(tiny(), quick=True, source="bad.yml")


@pytest.mark.parametrize(("change", "message"), BAD_EXPERIMENTS)
def test_invalid_experiment_names_the_entry_and_what_is_accepted(change: dict, message: str) -> None:
    with pytest.raises(ExperimentSpecError, match=message):
        parse_experiment(tiny(**change), source="bad.yml")


def test_malformed_files(tmp_path: Path) -> None:
    broken = tmp_path / "broken.yml"
    broken.write_text("methods: [GSN\ntasks: BlindSoccer-v0\n")
    with pytest.raises(ExperimentSpecError, match=r"broken.yml is not valid YAML"):
        load_experiment(broken)
    listing = tmp_path / "listing.yml"
    listing.write_text("- GSN\n- NONE\n")
    with pytest.raises(ExperimentSpecError, match=r"must be a mapping of keys \['name'"):
        load_experiment(listing)
    with pytest.raises(
        FileNotFoundError,
        match=r"No experiment file 'papr'.*\(gsn_max, gsn_max_ablation, paper, paper_fast\)",
    ):
        load_experiment("papr")
    with pytest.raises(ExperimentSpecError, match=r"missing key 'seeds'"):
        parse_experiment({"methods": ["GSN"], "tasks": ["BlindSoccer-v0"]})


def test_cli_rejects_a_bad_experiment_before_any_run(tmp_path: Path, capsys) -> None:
    bad = write(tmp_path / "bad.yml", tiny(methods=["NONE", "GSN", "DIAL"]))
    out = tmp_path / "out"
    assert main(["experiment", str(bad), "--out", str(out), "--workers", "0"]) == 2
    assert "unknown method 'DIAL'" in capsys.readouterr().err
    assert not out.exists()
    good = write(tmp_path / "good.yml", tiny())
    assert main(["experiment", str(good), "--out", str(out), "--only", "GSN/BlindSoccer-v0/0"]) == 2
    assert "matches no run of the experiment; its runs: ['NONE/GuessMyNumber-v0/0'" in capsys.readouterr().err
    assert not out.exists()


# --------------------------------------------------------------------------- the config hash


def test_config_hash_is_stable_and_sensitive() -> None:
    # A fixed fingerprint: the same configuration keeps its run folder across versions and machines.
    assert config_hash({"timesteps": 1000, "hyperparams": {"batch_size": 64}}) == "3bacde78"
    assert config_hash({"hyperparams": {"batch_size": 64}, "timesteps": 1000}) == "3bacde78"

    def runs(**changes: Any) -> list[RunSpec]:
        return parse_experiment(tiny(**changes)).runs()

    base = runs()
    assert [r.config_hash for r in base] == [r.config_hash for r in runs()]  # deterministic
    # Seeds share the configuration: same hash, folder told apart by the seed.
    seeded = runs(seeds=[0, 1])
    assert seeded[0].config_hash == seeded[1].config_hash
    assert seeded[0].relative_dir != seeded[1].relative_dir
    # 1e-3 written three ways is one configuration.
    lrs = [runs(hyperparams={"all": {**TINY_HYPERPARAMS, "learning_rate": lr}})[0].config_hash
           for lr in ("lin_1e-3", "lin_0.001", "lin_1.0e-3")]  # fmt: skip
    assert len(set(lrs)) == 1 and lrs[0] == base[0].config_hash  # the packaged rate is lin_1e-3
    changed = [
        runs(timesteps=500),
        runs(eval_freq=100),
        runs(eval_episodes=8),
        runs(analysis_episodes=2),
        runs(hyperparams={"all": {**TINY_HYPERPARAMS, "learning_rate": "lin_3e-4"}}),
        runs(hyperparams={"all": {**TINY_HYPERPARAMS, "policy_kwargs": {"net_arch": [32, 32]}}}),
        runs(hyperparams={"all": TINY_HYPERPARAMS, "NONE": {"batch_size": 32}}),
    ]
    for variant in changed:
        assert variant[0].config_hash != base[0].config_hash
    assert changed[-1][1].config_hash == base[1].config_hash  # the NONE section leaves GSN alone
    assert runs(save_freq=50)[0].config_hash == base[0].config_hash  # checkpoints do not define a run


def test_override_sections_apply_from_general_to_specific() -> None:
    spec = parse_experiment(
        tiny(
            hyperparams={
                "all": {"batch_size": 8, "tau": 0.1, "gamma": 0.5},
                "gsn": {"batch_size": 16, "tau": 0.2},
                "GuessMyNumber-v0": {"tau": 0.3},
                "GSN/GuessMyNumber-v0": {"gamma": 0.9},
            }
        )
    )
    none, gsn = spec.runs()
    assert (none.hyperparams["batch_size"], none.hyperparams["tau"], none.hyperparams["gamma"]) == (
        8,
        0.3,
        0.5,
    )
    assert (gsn.hyperparams["batch_size"], gsn.hyperparams["tau"], gsn.hyperparams["gamma"]) == (16, 0.3, 0.9)
    assert gsn.hyperparams["learning_rate"] == "lin_0.001"  # untouched packaged value


def test_seeds_and_precision_from_the_command_line_replace_the_files() -> None:
    base = {r.key: r for r in load_experiment("paper").runs()}
    five = load_experiment("paper", overrides={"seeds": [0, 1, 2, 3, 4]}).runs()
    assert len(five) == 5 * 2 * 5 and {r.seed for r in five} == {0, 1, 2, 3, 4}
    for run in five:  # more seeds, the same configurations: the finished seeds' folders are reused
        if run.seed <= 2:
            assert run.relative_dir == base[run.key].relative_dir
    quick = load_experiment("paper", quick=True, overrides={"seeds": [3]})
    assert {r.seed for r in quick.runs()} == {3}  # over the quick section's seeds too
    assert {r.timesteps for r in quick.runs() if r.task == "GuessMyNumber-v0"} == {20_000}

    bf16 = load_experiment("paper", overrides={"precision": "bfloat16"})
    assert bf16.precision == "bfloat16" and bf16.to_dict()["precision"] == "bfloat16"
    for run in bf16.runs():  # added to each configuration's policy_kwargs; its pins stay
        kwargs = base[run.key].hyperparams["policy_kwargs"]
        assert run.hyperparams["policy_kwargs"] == {**kwargs, "precision": "bfloat16"}
        assert run.hyperparams["policy_kwargs"].get("averaged_actor") is kwargs["averaged_actor"]
        assert run.config_hash != base[run.key].config_hash
    # float32, the configurations' own, is the same runs; a file may set it too.
    same = load_experiment("paper", overrides={"precision": "float32"}).runs()
    assert [r.config_hash for r in same] == [base[r.key].config_hash for r in same]
    in_file = parse_experiment(tiny(precision="bfloat16")).runs()
    assert {r.hyperparams["policy_kwargs"]["precision"] for r in in_file} == {"bfloat16"}
    assert in_file[0].hyperparams["policy_kwargs"]["net_arch"] == [16, 16]


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"precision": "float16"}, r"'precision' must be one of \['float32', 'bfloat16'\] or null"),
        ({"seeds": [-1]}, r"'seeds' must be at least 0, got -1"),
        ({"seeds": [1, 1]}, r"'seeds' lists a seed twice: \[1, 1\]"),
        ({"seed": [1]}, r"command-line override\(s\) of unknown key\(s\) \['seed'\]; accepted: \['methods'"),
    ],
)
def test_bad_command_line_overrides_are_clear_errors(overrides: dict, message: str) -> None:
    with pytest.raises(ExperimentSpecError, match=message):
        parse_experiment(tiny(), source="exp.yml", overrides=overrides)


def test_cli_seeds_and_precision_train_those_runs_in_their_own_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fake_analysis
) -> None:
    file = write(tmp_path / "exp.yml", tiny())
    monkeypatch.chdir(tmp_path)
    command = ["experiment", str(file), "--workers", "0", "--seeds", "3", "--precision", "bfloat16"]
    assert main([*command, "--only", "NONE/*/*"]) == 0
    out = tmp_path / "runs" / "experiments" / "tiny-bfloat16"  # not the float32 runs' folder
    assert not (tmp_path / "runs" / "experiments" / "tiny").exists()
    (found,) = results(out).items()
    assert found[0] == "NONE/GuessMyNumber-v0/3"
    assert found[1]["hyperparams"]["policy_kwargs"] == {"net_arch": [16, 16], "precision": "bfloat16"}
    assert yaml.safe_load((out / "experiment.yml").read_text())["precision"] == "bfloat16"
    (model_file,) = (out / "runs").rglob("model.zip")
    from sb3_comm import CommDDPG

    assert CommDDPG.load(model_file).policy.precision == "bfloat16"


# --------------------------------------------------------------------------- running


@pytest.fixture
def fake_analysis(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, Any]]:
    """Stand-in ``sb3_comm.analysis`` that records how the runner calls it (runs in this process)."""
    calls: list[tuple[str, Any]] = []

    class Rollout:
        def save(self, path: Path) -> None:
            calls.append(("save", Path(path)))
            np.savez(path, messages=np.zeros((3, 2)))

    def collect_rollout(
        model: Any, env_id: str, n_episodes: int = 10, seed: int = 0, env_kwargs: Any = None
    ) -> Rollout:
        calls.append(("collect_rollout", (model.method, env_id, n_episodes, seed, env_kwargs)))
        return Rollout()

    def analyse_communication(
        model: Any, env_id: str, n_episodes: int = 10, seed: int = 0, rollout=None, env_kwargs: Any = None
    ):
        heard = isinstance(rollout, Rollout)
        calls.append(("analyse_communication", (env_id, n_episodes, heard, env_kwargs)))
        return {"sighted->blind": {"cic": np.float64(0.25), "probe_accuracy": np.array([0.5])[0]}}

    module = types.ModuleType("sb3_comm.analysis")
    module.collect_rollout = collect_rollout
    module.analyse_communication = analyse_communication
    monkeypatch.setitem(sys.modules, "sb3_comm.analysis", module)
    return calls


def test_a_run_writes_model_curve_ablations_and_communication(tmp_path: Path, fake_analysis) -> None:
    spec = parse_experiment(tiny(methods=["GSN"], save_freq=200))
    summary = run_experiment(spec, tmp_path, workers=0, command="test", echo=lambda line: None)
    (row,) = summary["runs"]
    assert row["status"] == "done" and row["timesteps"] == 400
    run_dir = tmp_path / row["dir"]
    assert run_dir.name == f"seed0-{spec.runs()[0].config_hash}"
    result = json.loads((run_dir / "result.json").read_text())
    assert (result["method"], result["task"], result["seed"], result["status"]) == (
        "GSN", "GuessMyNumber-v0", 0, "done"
    )  # fmt: skip
    assert result["config_hash"] == spec.runs()[0].config_hash
    assert result["timesteps"] == 400 and result["hyperparams"]["n_envs"] == 2
    assert 0 < result["train_seconds"] < result["wall_seconds"]
    assert [point["timesteps"] for point in result["curve"]] == [200, 400]
    assert result["curve"] == json.loads((run_dir / "evaluations.json").read_text())
    assert set(result["final"]) == {"none", "zero", "shuffle"}
    assert all(entry["n_episodes"] == 4 for entry in result["final"].values())
    # The analysis is called on the trained model; numpy numbers become JSON numbers.
    assert result["communication"] == {"sighted->blind": {"cic": 0.25, "probe_accuracy": 0.5}}
    assert fake_analysis == [
        ("collect_rollout", ("GSN", "GuessMyNumber-v0", 4, 0, {})),  # the task's options: none
        ("save", run_dir / "messages.npz"),
        ("analyse_communication", ("GuessMyNumber-v0", 4, True, {})),
    ]
    assert (run_dir / "messages.npz").is_file() and (run_dir / "model.zip").is_file()
    # one TensorBoard folder per experiment, a run named by method, task and seed
    assert list((tmp_path / "tb" / "GSN" / "GuessMyNumber-v0" / "seed0").glob("events.out.tfevents.*"))
    assert sorted(p.name for p in (run_dir / "checkpoints").iterdir()) == [
        "model_200_steps.zip", "model_400_steps.zip"
    ]  # fmt: skip
    written = [p.stat().st_mtime_ns for p in run_dir.rglob("*") if p.is_file()]
    assert (run_dir / "result.json").stat().st_mtime_ns == max(written)  # written last
    assert yaml.safe_load((run_dir / "config.yml").read_text())["GuessMyNumber-v0"]["policy"] == "GSN"
    summary_file = json.loads((tmp_path / "summary.json").read_text())
    assert summary_file["command"] == "test" and summary_file["workers"] == 0
    assert summary_file["machine"]["cores"] >= 1 and summary_file["machine"]["cpu_model"]
    assert summary_file["machine"]["speed_reference_us"] > 0  # how fast the machine computed then
    assert summary_file["wall_seconds"] > result["train_seconds"] and summary_file["env_steps"] == 400
    assert (
        yaml.safe_load((tmp_path / "experiment.yml").read_text())["resolved"]["GSN/GuessMyNumber-v0"][
            "config_hash"
        ]
        == result["config_hash"]
    )


def test_a_broken_analysis_is_recorded_not_fatal(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    module = types.ModuleType("sb3_comm.analysis")

    def collect_rollout(*args: Any, **kwargs: Any) -> None:
        raise RuntimeError("no rollout today")

    module.collect_rollout = collect_rollout
    module.analyse_communication = collect_rollout
    monkeypatch.setitem(sys.modules, "sb3_comm.analysis", module)
    lines: list[str] = []
    summary = run_experiment(parse_experiment(tiny(methods=["NONE"])), tmp_path, workers=0, echo=lines.append)
    assert summary["counts"]["done"] == 1
    (result,) = results(tmp_path).values()
    assert (
        result["communication"] is None and "RuntimeError: no rollout today" in result["communication_error"]
    )
    assert any("communication analysis failed: RuntimeError: no rollout today" in line for line in lines)


def test_resume_skips_finished_runs_and_retrains_unfinished_ones(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fake_analysis
) -> None:
    import sb3_comm.training

    trained: list[str] = []
    original = sb3_comm.training.train_run

    def counting(config: RunConfig, *args: Any, **kwargs: Any) -> RunResult:
        trained.append(f"{config.method}/{config.task}/{config.seed}")
        return original(config, *args, **kwargs)

    monkeypatch.setattr(sb3_comm.training, "train_run", counting)
    spec = parse_experiment(tiny())
    quiet = {"workers": 0, "echo": lambda line: None}
    first = run_experiment(spec, tmp_path, **quiet)
    assert trained == ["NONE/GuessMyNumber-v0/0", "GSN/GuessMyNumber-v0/0"]
    assert first["counts"] == {"done": 2, "failed": 0, "skipped": 0, "not selected": 0}
    stamps = {path: path.stat().st_mtime_ns for path in (tmp_path / "runs").rglob("result.json")}

    second = run_experiment(spec, tmp_path, **quiet)
    assert len(trained) == 2  # nothing trained again
    assert second["counts"] == {"done": 0, "failed": 0, "skipped": 2, "not selected": 0}
    assert {path: path.stat().st_mtime_ns for path in stamps} == stamps

    # A run that died before its result.json is trained again; its earlier files are kept aside.
    gsn_dir = tmp_path / first["runs"][1]["dir"]
    (gsn_dir / "result.json").rename(gsn_dir / "result.json.bak")
    third = run_experiment(spec, tmp_path, **quiet)
    assert trained[2:] == ["GSN/GuessMyNumber-v0/0"]
    assert third["counts"]["done"] == 1 and third["counts"]["skipped"] == 1
    assert (gsn_dir / "result.json").is_file()
    assert (gsn_dir / "previous_attempts" / "1" / "result.json.bak").is_file()
    assert (gsn_dir / "previous_attempts" / "1" / "model.zip").is_file()

    # A changed configuration is a new run folder; the old one stays. --only picks one run.
    changed = parse_experiment(tiny(eval_episodes=2))
    fourth = run_experiment(changed, tmp_path, only=["none/*/0"], **quiet)
    assert trained[3:] == ["NONE/GuessMyNumber-v0/0"]
    assert fourth["counts"] == {"done": 1, "failed": 0, "skipped": 0, "not selected": 1}
    none_dirs = sorted((tmp_path / "runs" / "GuessMyNumber-v0" / "NONE").iterdir())
    assert len(none_dirs) == 2 and all((d / "result.json").is_file() for d in none_dirs)
    assert list(tmp_path.glob("experiment.*.yml"))  # the earlier experiment.yml is kept


def test_a_failing_run_is_reported_and_the_others_finish(tmp_path: Path, capsys, fake_analysis) -> None:
    # A policy option that the policy does not take passes the file check but raises when the model is
    # built (values such as a negative layer width are refused by the file check itself).
    broken = {"all": TINY_HYPERPARAMS, "GSN": {"policy_kwargs": {"net_arch": [8], "no_such_option": 1}}}
    file = write(tmp_path / "exp.yml", tiny(hyperparams=broken))
    out = tmp_path / "out"
    assert main(["experiment", str(file), "--out", str(out), "--workers", "0"]) == 1
    stdout = capsys.readouterr().out
    assert "FAILED  GSN/GuessMyNumber-v0/0: TypeError" in stdout
    assert f"--out {out} --only GSN/GuessMyNumber-v0/0" in stdout and "--rerun-failed" in stdout
    assert set(results(out)) == {"NONE/GuessMyNumber-v0/0"}
    (error_file,) = (out / "runs").rglob("error.txt")
    assert "Traceback" in error_file.read_text() and "no_such_option" in error_file.read_text()
    summary = json.loads((out / "summary.json").read_text())
    assert {row["key"]: row["status"] for row in summary["runs"]} == {
        "NONE/GuessMyNumber-v0/0": "done",
        "GSN/GuessMyNumber-v0/0": "failed",
    }
    # --rerun-failed tries only the failed run again (still failing: exit status 1).
    assert main(["experiment", str(file), "--out", str(out), "--workers", "0", "--rerun-failed"]) == 1
    stdout = capsys.readouterr().out
    assert "0 done, 1 failed, 1 skipped" in stdout
    assert (error_file.parent / "previous_attempts" / "1" / "error.txt").is_file()


def test_the_longest_runs_start_first_by_budget_and_method() -> None:
    """Blind Soccer's GSN-MAX runs (twice the time per step), then Blind Soccer's others, then
    Guess My Number's GSN-MAX, then its others; within a group, the experiment's order."""
    from sb3_comm.experiments.runner import longest_first

    runs = load_experiment("paper_fast").runs()
    order = [(run.task, run.method) for run in longest_first(runs)]
    groups = [order[:5], order[5:25], order[25:30], order[30:]]
    assert groups[0] == [("BlindSoccer-v0", "GSN-MAX")] * 5
    assert {task for task, _ in groups[1]} == {"BlindSoccer-v0"}
    assert groups[1][0] == ("BlindSoccer-v0", "NONE")  # then the experiment's order
    assert groups[2] == [("GuessMyNumber-v0", "GSN-MAX")] * 5
    assert {task for task, _ in groups[3]} == {"GuessMyNumber-v0"}
    assert "GSN-MAX" not in {method for _, method in groups[3]}
    assert [run.seed for run in longest_first(runs)][:5] == [0, 1, 2, 3, 4]


def test_runs_start_in_new_processes_that_have_the_trainer_imported_already() -> None:
    """The runs' processes fork from a server that imported the trainer and the analysis once
    (Linux, macOS): a new process per run without the imports (about 3.5 s each), and the worker
    still ends with the runner (tests/test_reliability_files.py)."""
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    from process_probe import loaded

    from sb3_comm.experiments.runner import PRELOADED, pool_context

    context = pool_context()
    if "forkserver" not in mp.get_all_start_methods():
        assert context.get_start_method() == "spawn"
        return
    assert context.get_start_method() == "forkserver"
    with ProcessPoolExecutor(max_workers=1, mp_context=context) as pool:
        first = pool.submit(os.getpid).result()
        assert pool.submit(loaded, list(PRELOADED)).result() == [True] * len(PRELOADED)
    assert first != os.getpid()


def test_ray_missing_is_a_clear_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray raises ImportError
    file = write(tmp_path / "exp.yml", tiny())
    assert main(["experiment", str(file), "--out", str(tmp_path / "out"), "--ray-address", "local"]) == 2
    assert 'pip install "sb3-comm[ray]"' in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_reproduce_quick_end_to_end_in_parallel_processes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    """``sb3-comm reproduce --quick`` with a tiny stand-in for the packaged paper experiment."""
    packaged = tmp_path / "packaged"
    packaged.mkdir()
    full = tiny(
        name="paper",
        seeds=[0, 1, 2],
        timesteps=100_000,
        quick={"seeds": [0], "timesteps": {"GuessMyNumber-v0": 400}, "eval_freq": 200},
    )
    write(packaged / "paper.yml", full)
    monkeypatch.setattr(spec_module, "EXPERIMENTS_DIR", packaged)
    out = tmp_path / "out"
    began = time.perf_counter()
    assert main(["reproduce", "--quick", "--out", str(out), "--workers", "2"]) == 0
    elapsed = time.perf_counter() - began
    stdout = capsys.readouterr().out
    assert f"Report: {out / 'report'}" in stdout
    found = results(out)
    assert set(found) == {"NONE/GuessMyNumber-v0/0", "GSN/GuessMyNumber-v0/0"}  # quick: one seed
    for result in found.values():
        assert result["timesteps"] == 400 and [p["timesteps"] for p in result["curve"]] == [200, 400]
        assert isinstance(result["communication"], dict)
        assert list((out / "runs" / "GuessMyNumber-v0" / result["method"]).rglob("messages.npz"))
    report = json.loads((out / "report" / "report.json").read_text())
    assert not report["skipped"]
    assert (out / "report" / "figures" / "curves_GuessMyNumber-v0.png").exists()
    # `sb3-comm report` rebuilds it from the folder alone, elsewhere.
    assert main(["report", str(out), "--to", str(tmp_path / "again")]) == 0
    assert (tmp_path / "again" / "report.md").read_text() == (out / "report" / "report.md").read_text()
    assert main(["report", str(tmp_path / "packaged")]) == 2
    assert "has no runs/ folder" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["quick"] and summary["workers"] == 2 and summary["backend"] == "processes"
    assert 0 < summary["wall_seconds"] <= elapsed
    assert all(row["timesteps"] == 400 and row["wall_seconds"] > 0 for row in summary["runs"])


def test_runs_on_a_local_ray_instance(tmp_path: Path) -> None:
    pytest.importorskip("ray")
    lines: list[str] = []
    spec = parse_experiment(tiny())
    summary = run_experiment(spec, tmp_path, workers=2, ray_address="local", echo=lines.append)
    assert summary["counts"]["done"] == 2, "\n".join(lines)
    assert summary["backend"] == "Ray (local)" and summary["workers"] == 2
    assert set(results(tmp_path)) == {"NONE/GuessMyNumber-v0/0", "GSN/GuessMyNumber-v0/0"}
    import ray

    assert not ray.is_initialized()  # the instance this run started is shut down
