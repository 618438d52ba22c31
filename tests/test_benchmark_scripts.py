"""The benchmark scripts import (a renamed helper once broke one unnoticed), and the resumable
single-agent benchmark continues a cut run to its end."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.callbacks import BaseCallback

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPTS = sorted(path for path in BENCHMARKS.glob("*.py") if not path.name.startswith("_"))


def _load(path: Path) -> ModuleType:
    sys.path.insert(0, str(BENCHMARKS))
    try:
        spec = importlib.util.spec_from_file_location(f"benchmark_{path.stem}", path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(str(BENCHMARKS))


@pytest.mark.parametrize("path", SCRIPTS, ids=[path.stem for path in SCRIPTS])
def test_every_benchmark_script_imports_and_has_a_main(path):
    assert callable(getattr(_load(path), "main", None)), f"{path.name} has no main()"


def test_hybrid_ddpg_benchmark_rejects_bad_overrides():
    module = _load(BENCHMARKS / "hybrid_ddpg.py")
    assert module.parse_overrides(["tau=0.001", "gradient_steps=2"]) == {"tau": 0.001, "gradient_steps": 2}
    with pytest.raises(ValueError, match="key=value"):
        module.parse_overrides(["tau"])
    with pytest.raises(ValueError, match=r"Unknown --params key\(s\) \['taux'\]; accepted: .*'tau'"):
        module.job_settings("HFOScoreEmptyGoal-v0", {"taux": 0.1})


def test_hybrid_ddpg_benchmark_resumes_a_cut_run_to_its_end(tmp_path):
    module = _load(BENCHMARKS / "hybrid_ddpg.py")
    settings = module.job_settings(
        "HFOMoveToBall-v0",
        {"n_envs": 2, "learning_starts": 8, "buffer_size": 1000, "policy_kwargs": {"net_arch": [8]}},
    )
    key = {"env": "HFOMoveToBall-v0", "seed": 0, "timesteps": 60, "settings": settings,
           "eval_freq": 20, "eval_episodes": 1}  # fmt: skip
    job = {"key": key, "run_dir": str(tmp_path / "run")}

    cut = module.run_one({**job, "time_budget": 1e-9})  # stops after the first step
    assert not cut["done"] and cut["timesteps"] == 2
    assert (tmp_path / "run" / "model.zip").exists() and (tmp_path / "run" / "replay.pkl").exists()

    finished = module.run_one({**job, "time_budget": 600.0})
    assert finished["done"] and finished["timesteps"] == 60
    assert [point["timesteps"] for point in finished["curve"]] == [20, 40, 60]
    assert finished["train_seconds"] >= cut["train_seconds"]
    assert module.run_one({**job, "time_budget": 600.0}) == finished  # read, not trained again

    other = {**key, "seed": 1}
    with pytest.raises(ValueError, match="other settings"):
        module.run_one({"key": other, "run_dir": job["run_dir"], "time_budget": 600.0})
    # the config's n_timesteps only defaults the run's length: a changed one is the same run
    same = {**key, "settings": {**settings, "n_timesteps": 7}}
    assert module.run_one({"key": same, "run_dir": job["run_dir"], "time_budget": 600.0}) == finished


def test_simple_reference_perfect_channel_hears_the_own_target():
    """The diagnostic game: where the teammate's message would be, each agent hears its own target's
    colour, i.e. the colour in its teammate's row (what the oracle reads); the game is the same."""
    module = _load(BENCHMARKS / "simple_reference.py")
    perfect = module._vec_env(50, 3, 4, batched=True, perfect_channel=True)
    plain = module._vec_env(50, 3, 4, batched=True)
    layout = perfect.get_attr("comm_layout")[0]
    heard = layout.obs_message_slice
    rows, plain_rows = perfect.reset(), plain.reset()
    for _ in range(30):  # through an episode's end: the fresh games hear their targets at once
        np.testing.assert_array_equal(rows[:, :, heard.start : heard.start + 3], rows[:, ::-1, 8:11])
        np.testing.assert_array_equal(rows[:, :, : heard.start], plain_rows[:, :, : heard.start])
        action = np.full((50, *perfect.action_space.shape), 0.5, dtype=np.float32)
        rows, *_ = perfect.step(action)
        plain_rows, *_ = plain.step(action)
    with pytest.raises(ValueError, match="needs --channel-size >= 3"):
        module._vec_env(2, 0, 2, batched=True, perfect_channel=True)


def test_simple_reference_params_take_linear_schedules_as_a_config_file_does(tmp_path, monkeypatch, capsys):
    """``--params learning_rate=lin_1e-3`` trains with a schedule (it raised a TypeError before);
    the run's record keeps the text form."""
    module = _load(BENCHMARKS / "simple_reference.py")
    params = {"learning_rate": "lin_1e-3", "actor_learning_rate": "lin_1e-4", "learning_starts": 20}
    job = {
        "method": "NONE", "seed": 0, "channel_size": 4, "batched": True, "n_envs": 2, "timesteps": 40,
        "eval_freq": 10**9, "runs_dir": str(tmp_path), "params": params,
    }  # fmt: skip
    result = module.run_one(job)
    assert result["params"] == params and (tmp_path / "NONE_seed0.json").exists()
    monkeypatch.setattr("sys.argv", ["simple_reference.py", "--params", "learning_rate=lin_x"])
    with pytest.raises(SystemExit):  # a malformed schedule stops the command before any run
        module.main()
    assert "'lin_x' is not a linear schedule" in capsys.readouterr().err


def test_stability_pairs_blind_soccer_runs_with_the_visible_oracle_too():
    """benchmarks/stability.py divides by a reference on the very games of a run's evaluations; the
    visible oracle (the oracle less the games no protocol can be told about) lies below the oracle
    there, and a reference a task does not have is refused by name."""
    module = _load(BENCHMARKS / "stability.py")
    runs = [{"eval": {"seeds": {"curve": 7, "final": 8}, "episodes": 40}}]
    oracle = module.paired_oracles("BlindSoccer-v0", runs)
    visible = module.paired_oracles("BlindSoccer-v0", runs, reference="visible_oracle")
    assert set(oracle) == set(visible) == {"7", "8"}
    assert all(0 < visible[seed] < oracle[seed] for seed in oracle)
    refused = r"GuessMyNumber-v0 has no reference 'visible_oracle'; it has \['oracle'"
    with pytest.raises(KeyError, match=refused):
        module.paired_oracles("GuessMyNumber-v0", runs, reference="visible_oracle")


def test_stability_summary_pools_distinct_seeds_and_refuses_a_seed_twice():
    """benchmarks/stability_summary.py --pool judges the seeds of several solves together: passes
    and failures add up, the worst final is the worst of all, the mean is over every seed; a seed
    found in two solves would count twice and is refused by name."""
    module = _load(BENCHMARKS / "stability_summary.py")

    def judged(seeds, finals, failed):
        return {
            "seeds": seeds,
            "paired": {
                "passed": [s for s in seeds if s not in failed],
                "failed": failed,
                "worst_final": min(finals),
                "finals": finals,
            },
        }

    solves = {"a": judged([0, 1, 2], [0.9, 0.8, 1.0], [1]), "b": judged([5, 6], [0.95, 0.7], [6])}
    pooled = module.pool(solves)
    assert pooled["seeds"] == [0, 1, 2, 5, 6]
    assert pooled["paired"]["passed"] == [0, 2, 5] and pooled["paired"]["failed"] == [1, 6]
    assert pooled["paired"]["worst_final"] == 0.7
    assert pooled["paired"]["final_fraction"]["mean"]["point"] == pytest.approx(0.87)
    assert "visible" not in pooled
    with pytest.raises(SystemExit, match=r"seeds \[2\] are in more than one solve"):
        module.pool({"a": judged([1, 2], [0.9, 0.9], []), "b": judged([2, 3], [0.9, 0.9], [])})


def test_protocol_probe_tells_an_informative_protocol_from_noise_and_a_recoding_from_a_change():
    """benchmarks/protocol_probe.py: messages that encode the ball's bearing give a held-out R² near
    1, messages of pure noise one near 0 or below; a protocol that was only re-coded linearly has a
    linear-map R² of 1 between checkpoints, one that was replaced does not."""
    module = _load(BENCHMARKS / "protocol_probe.py")
    rng = np.random.default_rng(0)
    bearing = rng.uniform(-np.pi, np.pi, 2000)
    kind = rng.integers(0, 3, 2000)
    base = {"bearing": bearing, "kind": kind, "dash_error": np.abs(rng.normal(0.0, 30.0, 2000))}
    telling = np.stack([np.sin(bearing), np.cos(bearing), rng.normal(size=2000), rng.normal(size=2000)], 1)
    told = module.probe({**base, "heard": telling}, seed=0)
    noise = module.probe({**base, "heard": rng.normal(size=(2000, 4))}, seed=0)
    assert told["r2_linear"] > 0.99 and told["r2_knn"] > 0.9
    assert noise["r2_linear"] < 0.05 and noise["r2_knn"] < 0.05
    assert told["dash_share"] == pytest.approx(np.mean(kind == 0))
    recoded = telling @ rng.normal(size=(4, 4)) + 0.3
    assert module.drift(telling, recoded)["r2_linear_map"] == pytest.approx(1.0)
    assert module.drift(telling, rng.normal(size=(2000, 4)))["r2_linear_map"] < 0.05


def test_final_level_divides_by_the_reference_on_the_same_games_and_narrows_with_more_games():
    """benchmarks/final_level.py: the fraction is the team's mean over every game divided by the
    reference's mean over the same game seeds, and its interval shrinks as 1/sqrt(games)."""
    module = _load(BENCHMARKS / "final_level.py")
    rng = np.random.default_rng(0)
    references = [{"oracle": 0.6, "visible_oracle": 0.55}, {"oracle": 0.64, "visible_oracle": 0.57}]
    few = [rng.normal(0.56, 0.27, 100) for _ in references]
    many = [rng.normal(0.56, 0.27, 10_000) for _ in references]
    got = module.level(few, references, "oracle")
    assert got["reference_return"] == pytest.approx(0.62)
    assert got["fraction"] == pytest.approx(np.concatenate(few).mean() / 0.62)
    assert module.level(few, references, "visible_oracle")["fraction"] > got["fraction"]
    narrow = module.level(many, references, "oracle")["ci95"]
    assert narrow == pytest.approx(got["ci95"] / 10.0, rel=0.15)


def test_checkpoints_lists_a_run_folders_checkpoints_by_step_and_skips_other_files(tmp_path):
    """benchmarks/_common.checkpoints (collapse_anatomy.py, protocol_probe.py): the checkpoints of a
    run folder sorted by their step, numerically, from ``min_steps`` on; other files are left out."""
    module = _load(BENCHMARKS / "_common.py")
    folder = tmp_path / "checkpoints"
    folder.mkdir()
    for name in ("model_100000_steps.zip", "model_25000_steps.zip", "model_x_steps.zip", "notes.txt"):
        (folder / name).write_text("")
    assert [step for step, _ in module.checkpoints(tmp_path)] == [25000, 100000]
    assert module.checkpoints(tmp_path, min_steps=50000) == [(100000, folder / "model_100000_steps.zip")]
    assert module.checkpoints(tmp_path / "missing") == []


def test_simple_reference_table_reads_every_seed_and_rejects_other_files(tmp_path, monkeypatch):
    """The combined table of simple_reference result files: one row per method with every seed,
    the setting in words; a missing file or a file of another benchmark is a clear error."""
    import json

    module = _load(BENCHMARKS / "simple_reference_table.py")
    monkeypatch.setattr(module, "RESULTS_DIR", tmp_path)
    estimate = {"point": 0.5, "low": 0.4, "high": 0.6}
    result = {
        "args": {"params": ["gamma=0.95"], "perfect_channel": True, "timesteps": 300000},
        "machine": {"cpu_model": "cpu", "date": "2026-12-05T00:00:00"},
        "methods": {
            "GSN": {
                "seeds": [0, 1],
                "gap_closed": [0.25, 0.75],
                "gap_closed_estimates": {"mean": estimate},
                "worst_gap_closed": 0.25,
            }
        },
        "runs": [{"method": "GSN", "train_seconds": 10.0}, {"method": "GSN", "train_seconds": 12.0}],
    }
    (tmp_path / "a.json").write_text(json.dumps(result))
    (tmp_path / "other.json").write_text(json.dumps({"name": "other"}))
    (row,) = module.rows_of("a")
    assert (
        row["seeds"] == [0, 1] and row["gap_closed"] == [0.25, 0.75] and row["train_seconds"] == [10.0, 12.0]
    )
    assert row["setting"] == "`gamma=0.95`, perfect channel, 300,000 steps"
    table = module.markdown([row])
    assert "0: 0.25, 1: 0.75" in table and "— (< 5 seeds)" in table
    with pytest.raises(FileNotFoundError, match="no result file"):
        module.rows_of("missing")
    with pytest.raises(ValueError, match=r"not a result of benchmarks/simple_reference\.py"):
        module.rows_of("other")


def test_checkpoint_level_judges_a_curve_by_stability_rule_and_pairs_blocks_with_their_oracle():
    module = _load(BENCHMARKS / "checkpoint_level.py")
    # reaches 0.9 at the second reading, then one reading under the floor: fails
    assert module.judge([0.5, 0.91, 0.79, 0.95], 0.93, reach=0.9, floor=0.8) == {
        "first_index": 1,
        "lowest_after": 0.79,
        "passes": False,
    }
    assert module.judge([0.5, 0.91, 0.85, 0.95], 0.93, reach=0.9, floor=0.8)["passes"]
    assert not module.judge([0.5, 0.91, 0.85, 0.95], 0.89, reach=0.9, floor=0.8)["passes"]  # ends under
    assert not module.judge([0.5, 0.7], 0.95, reach=0.9, floor=0.8)["passes"]  # never a reading at the bar

    class Team:  # returns 0.5 on the games of seed 1, 0.3 on those of seed 2, 0.6 on the curve's
        pass

    module.team_returns = lambda model, seed: np.full(100, {1: 0.5, 2: 0.3, 10: 0.6}[seed])
    row = module.measure(Team(), 10, [1, 2], {1: 0.5, 2: 0.6, 10: 0.6}, {1: 0.4, 2: 0.4, 10: 0.5})
    assert row["block_fractions"] == [1.0, 0.5]  # each block by its own oracle
    assert row["curve_fraction"] == pytest.approx(1.0)
    assert row["level"] == pytest.approx(0.4 / 0.55)  # all games by the oracle's mean on them
    assert row["visible_level"] == pytest.approx(0.4 / 0.4)
    assert row["block_sd"] == pytest.approx(np.std([1.0, 0.5], ddof=1))

    def run(curve: bool, level: bool, final: float) -> dict:
        return {
            "judged": {
                "curve": {"passes": curve},
                "level": {"passes": level},
                "saved_curve": {"passes": True},
            },
            "final": {"final_fraction": final, "level": final - 0.05},
            "falls": {"curve": 1.0 - final, "level": 0.5 - final / 2, "saved_curve": 0.0},
        }

    results = {"a": run(True, True, 0.95), "b": run(False, True, 0.91), "c": run(False, False, 0.85)}
    results["final only"] = {"judged": {}, "final": {"final_fraction": 0.1, "level": 0.1}, "falls": {}}
    pooled = module.summary(results)
    assert pooled["runs"] == 3
    assert pooled["curve"] == {"passed": ["a"], "failed": ["b", "c"]}
    assert pooled["level"] == {"passed": ["a", "b"], "failed": ["c"]}
    assert pooled["saved_curve"] == {"passed": ["a", "b", "c"], "failed": []}
    assert pooled["final_fraction"]["mean"]["point"] == pytest.approx(0.9033333, abs=1e-6)
    assert pooled["final_level"]["mean"]["point"] == pytest.approx(0.8533333, abs=1e-6)
    assert pooled["falls"]["curve"] == pytest.approx([0.05, 0.09, 0.15])


def test_checkpoint_level_pairs_the_readings_as_saved_and_as_played_from_a_step_on():
    module = _load(BENCHMARKS / "checkpoint_level.py")

    def run(*readings: tuple[int, float, float]) -> dict:
        return {
            "checkpoints": [
                {"step": t, "saved_curve_fraction": a, "curve_fraction": b} for t, a, b in readings
            ]
        }

    results = {
        "a": run((100, 0.1, 0.9), (200, 0.7, 0.85), (300, 0.9, 0.88)),
        "b": run((200, 0.95, 0.75), (300, 0.6, 0.9)),
        "c": run((100, 0.2, 0.3)),  # nothing from step 200 on: not counted
    }
    paired = module.paired_readings(results, since=200, floor=0.8)
    assert paired["readings"] == 4
    assert paired["saved"] == {
        "below_floor": 2,
        "lowest_mean": pytest.approx(0.65),
        "four_lowest": [0.6, 0.7],
    }
    assert paired["played"] == {
        "below_floor": 1,
        "lowest_mean": pytest.approx(0.8),
        "four_lowest": [0.75, 0.85],
    }
    assert (paired["higher"], paired["lower"]) == (2, 2)
    assert paired["mean_difference"] == pytest.approx((0.15 - 0.02 - 0.2 + 0.3) / 4)
    assert module.paired_readings(results, since=400, floor=0.8) == {"since": 400, "readings": 0}


def test_a_fall_is_counted_below_the_best_reading_once_the_curve_has_learned():
    module = _load(BENCHMARKS / "stability_variants.py")
    assert module.drawdown([-0.5, 0.3, -0.2, 0.6, 0.9, 0.7, 0.95, 0.4, 0.9]) == pytest.approx(0.55)
    assert module.drawdown([-0.5, 0.4, -0.6, 0.3]) == 0.0  # never at 0.5: early swings are not falls
    assert module.drawdown([0.5, 0.6, 0.7]) == 0.0


def test_averaged_actor_pairs_the_two_players_game_by_game():
    module = _load(BENCHMARKS / "averaged_actor.py")
    actor = np.array([1.0, 2.0, 3.0, 4.0])
    row = module.paired_difference(actor, actor + np.array([0.5, 0.5, 1.5, 1.5]))
    assert row["actor"] == pytest.approx(2.5) and row["average"] == pytest.approx(3.5)
    assert row["difference"] == pytest.approx(1.0)
    assert row["difference_ci95"] == pytest.approx(1.96 * np.std([0.5, 0.5, 1.5, 1.5], ddof=1) / 2)
    with pytest.raises(ValueError, match="same games"):
        module.paired_difference(actor, actor[:3])


class _ParametersAtSaves(BaseCallback):
    """Copies of one of the policy's networks (``module``) every 10 calls, by step: what a
    checkpoint or the actor-averages file saved at that step is compared with."""

    def __init__(self, module: str) -> None:
        super().__init__()
        self.module = module
        self.saved: dict[int, list[th.Tensor]] = {}

    def _on_step(self) -> bool:
        if self.n_calls % 10 == 0:
            network = getattr(self.model.policy, self.module)
            self.saved[self.num_timesteps] = [p.clone() for p in network.parameters()]
        return True


def test_actor_averages_at_ddpgs_rate_equal_the_target_actor_and_leave_training_unchanged(tmp_path):
    """``solve.py --actor-averages``: an average kept at DDPG's own rate ``tau`` is the target actor
    of the checkpoint saved at the same step, bit for bit; a slower one lags it; training with the
    callback gives the same actor as without; a rate the file lacks is a clear error."""
    from sb3_comm import CommDDPG, make_comm_vec_env

    module = _load(BENCHMARKS / "_actor_averages.py")

    def team() -> CommDDPG:
        env = make_comm_vec_env("BlindSoccer-v0", n_envs=2, seed=0)
        return CommDDPG("GSN", env, learning_starts=10, batch_size=8, seed=0, device="cpu",
                        policy_kwargs={"net_arch": [8, 8]})  # fmt: skip

    with pytest.raises(ValueError, match=r"rates must be in \(0, 1\]"):
        module.ActorAveragesCallback([0.0], 20, tmp_path)
    with pytest.raises(ValueError, match="save_freq > 0"):
        module.ActorAveragesCallback([0.01], 0, tmp_path)

    model, targets = team(), _ParametersAtSaves("actor_target")  # what a checkpoint then holds
    model.learn(60, callback=[targets, module.ActorAveragesCallback([model.tau, 0.001], 20, tmp_path)])
    assert sorted(targets.saved) == [20, 40, 60]
    for step, saved in targets.saved.items():
        path = module.average_path(tmp_path, step)
        averages = th.load(path, weights_only=True)["averages"]
        for average, target in zip(averages[model.tau], saved, strict=True):
            assert th.equal(average, target), f"the average at rate tau is not the target actor at {step}"
    assert module.average_path(tmp_path, None).exists()

    plain = team()
    plain.learn(60)
    pairs = zip(model.policy.actor.parameters(), plain.policy.actor.parameters(), strict=True)
    assert all(th.equal(a, b) for a, b in pairs), "keeping averages changed training"

    module.load_actor_average(plain, module.average_path(tmp_path, 60), 0.001)
    slow = th.load(module.average_path(tmp_path, 60), weights_only=True)["averages"][0.001]
    for target, average in zip(plain.policy.actor_target.parameters(), slow, strict=True):
        assert th.equal(target, average)
    assert not all(th.equal(a, b) for a, b in zip(slow, model.policy.actor.parameters(), strict=True)), (
        "a slow average lags the actor"
    )
    with pytest.raises(ValueError, match=r"no actor average at rate 0\.5; it has \[0\.001, 0\.005\]"):
        module.load_actor_average(plain, module.average_path(tmp_path, 60), 0.5)


def test_the_benchmarks_actor_averages_are_the_policys_actor_average(tmp_path):
    """What ``solve.py --actor-averages TAU`` measured is what ``policy_kwargs={"actor_average_tau":
    TAU}`` plays: the callback's average at a save is the policy's ``actor_average``, bit for bit."""
    from sb3_comm import CommDDPG, make_comm_vec_env

    module = _load(BENCHMARKS / "_actor_averages.py")
    env = make_comm_vec_env("BlindSoccer-v0", n_envs=2, seed=0)
    model = CommDDPG("GSN", env, learning_starts=10, batch_size=8, seed=0, device="cpu",
                     policy_kwargs={"net_arch": [8, 8], "actor_average_tau": 0.01})  # fmt: skip

    policy_averages = _ParametersAtSaves("actor_average")
    model.learn(60, callback=[policy_averages, module.ActorAveragesCallback([0.01], 20, tmp_path)])
    assert sorted(policy_averages.saved) == [20, 40, 60]
    for step, saved in policy_averages.saved.items():
        kept = th.load(module.average_path(tmp_path, step), weights_only=True)["averages"][0.01]
        assert all(th.equal(a, b) for a, b in zip(kept, saved, strict=True)), step


def test_checkout_speed_refuses_a_folder_that_is_not_a_checkout(tmp_path, monkeypatch, capsys):
    module = _load(BENCHMARKS / "checkout_speed.py")
    monkeypatch.setattr(sys, "argv", ["checkout_speed.py", str(tmp_path), str(BENCHMARKS.parent)])
    with pytest.raises(SystemExit) as stop:
        module.main()
    assert stop.value.code == 2
    assert f"{tmp_path} is not a checkout of sb3-comm" in capsys.readouterr().err


def test_experiment_overheads_refuses_a_report_folder_without_runs(tmp_path, monkeypatch, capsys):
    module = _load(BENCHMARKS / "experiment_overheads.py")
    monkeypatch.setattr(sys, "argv", ["experiment_overheads.py", "--report-of", str(tmp_path)])
    with pytest.raises(SystemExit) as stop:
        module.main()
    assert stop.value.code == 2
    assert f"{tmp_path} is not an experiment folder" in capsys.readouterr().err


def _experiment_folder(folder, runs):
    """An experiment folder whose ``result.json`` files hold only what compare_experiments reads."""
    for (task, method, seed), (seconds, final) in runs.items():
        run_dir = folder / "runs" / task / method / f"seed{seed}-abc"
        run_dir.mkdir(parents=True)
        final_returns = {kind: {"mean_return": final} for kind in ("none", "zero", "shuffle")}
        result = {"task": task, "method": method, "seed": seed, "status": "done", "wall_seconds": seconds}
        result.update({"curve": [{"mean_return": 0.0}], "final": final_returns})
        (run_dir / "result.json").write_text(json.dumps(result))
    return folder


def test_compare_experiments_takes_the_drift_from_runs_that_trained_the_same_model(tmp_path):
    module = _load(BENCHMARKS / "compare_experiments.py")
    before = _experiment_folder(
        tmp_path / "a", {("T", "NONE", 0): (100.0, 1.0), ("T", "GSN-MAX", 0): (200.0, 2.0)}
    )
    after = _experiment_folder(
        tmp_path / "b", {("T", "NONE", 0): (130.0, 1.0), ("T", "GSN-MAX", 0): (210.0, 2.5)}
    )
    data = module.compare(before, after, {"T/NONE/0": 10.0}, {"GSN-MAX/T": 2.0})
    assert data["unchanged_runs"] == 1 and data["changed_runs"] == ["T/GSN-MAX/0"]
    assert data["drift"] == pytest.approx(1.2)  # (130 - 10 paused) / 100
    assert data["estimate_by_drift"] == pytest.approx((120.0 + 210.0) / 1.2)
    assert data["estimate_by_speedup"] == pytest.approx(100.0 + 200.0 / 2.0)
    with pytest.raises(SystemExit, match="not in"):
        module.compare(before, after, {"T/RIAL/0": 1.0}, {})
    retrained = _experiment_folder(  # every run ends elsewhere: no drift can be measured
        tmp_path / "c", {("T", "NONE", 0): (130.0, 9.0), ("T", "GSN-MAX", 0): (210.0, 9.0)}
    )
    with pytest.raises(SystemExit, match="no run trained the same model"):
        module.compare(before, retrained, {}, {})
    (tmp_path / "b" / "runs" / "T" / "NONE" / "seed0-abc" / "result.json").unlink()
    with pytest.raises(SystemExit, match="different runs"):
        module.compare(before, after, {}, {})


def test_result_files_record_the_machine_speed(tmp_path, monkeypatch):
    """benchmarks/_common.write_results: both files carry the speed reference, a positive time per
    update, in the JSON's machine record and on the Markdown's machine line."""
    module = _load(BENCHMARKS / "_common.py")
    monkeypatch.setattr(module, "RESULTS_DIR", tmp_path)
    json_path, md_path = module.write_results("speed_check", {"x": 1}, "| a |\n|---|")
    machine = json.loads(json_path.read_text())["machine"]
    assert machine["speed_reference_us"] > 0
    assert machine["speed_reference"] == module.SPEED_REFERENCE
    assert f"speed reference {machine['speed_reference_us']:,.0f} µs per update" in md_path.read_text()
