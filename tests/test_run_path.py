"""The single run path: RunConfig (parsed and checked once), train_run, RunResult (one JSON policy)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from sb3_comm.config import RunConfig
from sb3_comm.results import (
    SPEED_REFERENCE,
    RunResult,
    machine_info,
    speed_reference,
    to_jsonable,
    write_json,
)
from sb3_comm.training import EvalSettings, build_model, train_run

PAPER_RUNS = Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "paper" / "runs"

TINY = {
    "learning_starts": 50,
    "batch_size": 8,
    "buffer_size": 1000,
    "policy_kwargs": {"net_arch": [8]},
    "n_envs": 2,
    "n_timesteps": 120,
}


def test_run_config_keeps_text_form_and_converts_once() -> None:
    config = RunConfig.load("gsn", "BlindSoccer-v0", seed=3, overrides={"gsn_learning_rate": "lin_1e-4"})
    assert (config.method, config.task, config.seed) == ("GSN", "BlindSoccer-v0", 3)
    assert config.hyperparams["gsn_learning_rate"] == "lin_0.0001"  # text form, canonical
    kwargs = config.algorithm_kwargs()
    assert callable(kwargs["gsn_learning_rate"]) and kwargs["gsn_learning_rate"](0.5) == pytest.approx(5e-5)
    assert "n_envs" not in kwargs and "n_timesteps" not in kwargs and "policy" not in kwargs
    # config.yml reads back as the same configuration.
    entry = yaml.safe_load(config.to_yaml())["BlindSoccer-v0"]
    again = RunConfig.from_entry(entry, "GSN", "BlindSoccer-v0", seed=3)
    assert again.hyperparams == config.hyperparams
    assert (again.n_envs, again.n_timesteps) == (config.n_envs, config.n_timesteps)


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"lr": 3}, r"unknown key\(s\) \['lr'\]; accepted keys"),
        ({"n_timesteps": 0}, r"n_timesteps must be a whole number ≥ 1, got 0"),
        ({"n_envs": 2.5}, r"n_envs must be a whole number ≥ 1"),
        ({"policy": "TCG"}, "configured for method TCG, but GSN was requested"),
        ({"policy_kwargs": "net_arch=[8]"}, "write policy_kwargs as a YAML mapping"),
        ({"learning_rate": "lin_fast"}, "not a linear schedule"),
    ],
)
def test_run_config_rejects_bad_settings(overrides: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        RunConfig.load("GSN", "BlindSoccer-v0", overrides=overrides)


def test_json_policy_nan_is_null_and_numpy_is_python(tmp_path: Path) -> None:
    data = {"a": np.float32(1.5), "b": [float("nan"), np.inf], "c": np.arange(2), "d": tmp_path}
    assert to_jsonable(data) == {"a": 1.5, "b": [None, None], "c": [0, 1], "d": str(tmp_path)}
    path = write_json(tmp_path / "x.json", data)
    assert json.loads(path.read_text())["b"] == [None, None]
    assert [p.name for p in tmp_path.iterdir()] == ["x.json"]  # no temporary file left


def test_speed_reference_times_one_thread_and_restores_the_callers_threads(monkeypatch) -> None:
    """The machine's speed now (:func:`speed_reference`, recorded with timings): timed with one torch
    thread whatever the caller set, which it gets back with its random stream untouched;
    ``machine_info(speed=True)`` adds it."""
    import torch as th

    seen: list[int] = []
    real_adam = th.optim.Adam

    class Watching(real_adam):  # type: ignore[misc, valid-type]
        def step(self, *args, **kwargs):
            seen.append(th.get_num_threads())
            return super().step(*args, **kwargs)

    monkeypatch.setattr(th.optim, "Adam", Watching)
    threads = th.get_num_threads()
    th.set_num_threads(2)
    th.manual_seed(123)
    expected = th.rand(3)
    th.manual_seed(123)
    try:
        assert speed_reference(updates=2, repeats=3) > 0
        assert th.get_num_threads() == 2
        assert th.equal(th.rand(3), expected)  # the caller's random stream is untouched
    finally:
        th.set_num_threads(threads)
    assert len(seen) == 5 + 2 * 3 and set(seen) == {1}  # warm-up, then the timed updates
    assert "speed_reference_us" not in machine_info()
    info = machine_info(speed=True)
    assert info["speed_reference_us"] > 0 and info["speed_reference"] == SPEED_REFERENCE


def test_run_result_reads_the_stored_paper_results() -> None:
    files = sorted(PAPER_RUNS.glob("*/*/*/result.json"))
    spec = yaml.safe_load((PAPER_RUNS.parent / "experiment.yml").read_text())
    assert len(files) == len(spec["methods"]) * len(spec["tasks"]) * len(spec["seeds"])  # every run kept
    for file in files:
        result = RunResult.load(file)
        assert result.status == "done" and result.curve and math.isfinite(result.final_return)
        # Round trip: what to_json writes reads back equal.
        assert RunResult.from_json(json.loads(json.dumps(result.to_json()))) == result


def test_run_result_rejects_what_is_not_a_result(tmp_path: Path) -> None:
    (tmp_path / "result.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match=r"result.json: a run result must be a JSON object"):
        RunResult.load(tmp_path / "result.json")
    (tmp_path / "result.json").write_text('{"method": "GSN"}')
    with pytest.raises(ValueError, match=r"needs \['task', 'seed'\]"):
        RunResult.load(tmp_path / "result.json")


def test_train_run_writes_one_record(tmp_path: Path) -> None:
    config = RunConfig.load("TCG", "GuessMyNumber-v0", seed=1, overrides=TINY)
    settings = EvalSettings(freq=100, episodes=3, target_return=-1.0)
    result = train_run(config, tmp_path / "run", evaluation=settings, save_freq=0)
    run = tmp_path / "run"
    assert {p.name for p in run.iterdir()} >= {
        "config.yml",
        "tb",
        "evaluations.json",
        "model.zip",
        "result.json",
    }
    assert RunResult.load(run / "result.json") == result
    assert (result.method, result.task, result.seed, result.status) == ("TCG", "GuessMyNumber-v0", 1, "done")
    assert result.timesteps == result.budget == 120 and result.n_envs == 2
    assert result.updates > 0
    # The curve ends where training ended; the final evaluation has every ablation.
    assert [p["timesteps"] for p in result.curve] == [100, 120]
    assert set(result.final) == {"none", "zero", "shuffle"} and result.final["none"]["n_episodes"] == 3
    assert result.steps_to_target == 100  # any return reaches -1
    assert result.hyperparams["n_envs"] == 2 and result.eval["seeds"]["curve"] == settings.curve_seed
    assert (
        RunConfig.load("TCG", "GuessMyNumber-v0", path=run / "config.yml").hyperparams == config.hyperparams
    )


def test_build_model_takes_plain_values_from_the_config() -> None:
    config = RunConfig.load("GSN", "GuessMyNumber-v0", overrides=TINY)
    model = build_model(config, device="cpu")
    assert model.method == "GSN" and model.n_envs == 2
    assert callable(model.actor_learning_rate) and model.actor_learning_rate(1.0) == pytest.approx(1e-4)


def test_a_run_can_stop_at_its_target(tmp_path: Path) -> None:
    """EvalSettings.stop_at_target ends training at the first evaluation that reaches the target."""
    config = RunConfig.load("NONE", "GuessMyNumber-v0", overrides={**TINY, "n_timesteps": 300})
    settings = EvalSettings(
        freq=100, episodes=2, target_return=-1e9, stop_at_target=True, projector_episodes=0
    )
    result = train_run(config, tmp_path / "run", evaluation=settings, save_freq=0)
    assert result.steps_to_target == 100 and result.timesteps == 100
    assert [point["timesteps"] for point in result.curve] == [100]


def test_the_number_of_evaluation_games_leaves_the_training_as_it_is(tmp_path: Path) -> None:
    """More games per evaluation measure a team more exactly (``benchmarks/solve.py
    --eval-episodes``); the periodic evaluations must not draw on the training's random numbers."""
    import torch as th

    from sb3_comm import CommDDPG

    config = RunConfig.load("TCG", "GuessMyNumber-v0", seed=3, overrides={**TINY, "n_timesteps": 300})
    states = []
    for episodes in (2, 7):
        settings = EvalSettings(freq=100, episodes=episodes, ablations=("none",))
        result = train_run(config, tmp_path / f"run{episodes}", evaluation=settings, save_freq=0)
        assert len(result.curve) == 3 and all(point["n_episodes"] == episodes for point in result.curve)
        model = CommDDPG.load(tmp_path / f"run{episodes}" / "model.zip", device="cpu")
        states.append(model.policy.state_dict())
    assert states[0].keys() == states[1].keys()
    for key in states[0]:
        assert th.equal(states[0][key], states[1][key]), key
