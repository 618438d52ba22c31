"""CommDDPG(shared_reward=...): the team's reward for every agent, or each agent's own."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from stable_baselines3.common.callbacks import BaseCallback

from sb3_comm import OWN_REWARD_METHODS, CommDDPG, make_comm_vec_env
from sb3_comm.comm_ddpg import CommPolicy, TCGPolicy

ZOO = Path(__file__).resolve().parents[1] / "zoo_configs"


def _model(method: Any = "GSN", **kwargs) -> CommDDPG:
    # Guess My Number: the two agents' rewards differ (each hangs on the teammate's message)
    env = make_comm_vec_env("GuessMyNumber-v0", n_envs=4, seed=0)
    return CommDDPG(method, env, learning_starts=1000, batch_size=8, seed=0, device="cpu", **kwargs)


def _stored(model: CommDDPG, steps: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """Rewards the replay stored and the per-agent rewards the environment gave."""
    given: list[np.ndarray] = []

    class Record(BaseCallback):
        def _on_step(self) -> bool:
            given.append(np.stack([info["agent_rewards"] for info in self.locals["infos"]]))
            return True

    model.learn(steps, callback=Record())
    n = model.replay_buffer.size()
    return model.replay_buffer.rewards[:n], np.stack(given)[:n]


def test_default_is_the_team_reward_for_every_agent() -> None:
    model = _model()
    assert model.shared_reward is True and model.replay_buffer.shared_reward is True
    stored, given = _stored(model)
    assert (given[..., 0] != given[..., 1]).any()  # the task gives different rewards...
    np.testing.assert_allclose(stored[..., 0], given.mean(axis=-1), rtol=1e-6)  # ...both learn the mean
    np.testing.assert_array_equal(stored[..., 0], stored[..., 1])


@pytest.mark.parametrize("method", ["NONE", "RIAL", "GSN-MAX"])  # GSN: the test above
def test_default_is_the_team_reward_for_the_other_methods(method: str) -> None:
    assert OWN_REWARD_METHODS == ("TCG",)
    assert _model(method).shared_reward is True


@pytest.mark.parametrize(
    "how",
    [
        dict(method="TCG"),
        dict(method="tcg"),
        dict(method=TCGPolicy),
        dict(method=CommPolicy, policy_kwargs={"method": "TCG"}),
    ],
)
def test_tcg_defaults_to_each_agents_own_reward(how: dict) -> None:
    """TCG, however it is named, learns from its own reward."""
    model = _model(**how)
    assert model.method == "TCG"
    assert model.shared_reward is False and model.replay_buffer.shared_reward is False
    stored, given = _stored(model)
    np.testing.assert_array_equal(stored, given)


def test_an_explicit_value_wins_over_tcgs_default() -> None:
    assert _model("TCG", shared_reward=True).shared_reward is True


def test_false_keeps_each_agents_own_reward() -> None:
    stored, given = _stored(_model(shared_reward=False))
    np.testing.assert_array_equal(stored, given)


@pytest.mark.parametrize("value", [True, False])
def test_save_load_keeps_the_setting_and_the_buffer_follows_the_model(value: bool, tmp_path) -> None:
    model = _model(shared_reward=value)
    model.learn(16)
    model.save(tmp_path / "model.zip")
    model.save_replay_buffer(tmp_path / "replay.pkl")
    loaded = CommDDPG.load(tmp_path / "model.zip", env=model.get_env(), device="cpu")
    assert loaded.shared_reward is value
    loaded.load_replay_buffer(tmp_path / "replay.pkl")
    assert loaded.replay_buffer.shared_reward is value


def test_a_file_from_before_the_option_keeps_its_own_rewards(tmp_path) -> None:
    """A model file without the attribute (as saved before it existed) loads with False."""
    model = _model(shared_reward=True)
    model.shared_reward_backup = model.__dict__.pop("shared_reward")  # not saved under its name
    model.save(tmp_path / "old.zip", exclude=["shared_reward_backup"])
    loaded = CommDDPG.load(tmp_path / "old.zip", device="cpu")
    assert loaded.shared_reward is False and loaded.replay_buffer_kwargs["shared_reward"] is False


def test_bad_value_is_a_clear_error() -> None:
    with pytest.raises(TypeError, match=r"shared_reward must be True or False \(or None: the default"):
        _model(shared_reward="yes")


def test_packaged_configurations_pin_each_agents_own_reward() -> None:
    """The paper's setting, under which the packaged results were measured."""
    for path in sorted(ZOO.glob("*.yml")):
        if path.name == "hybrid_ddpg.yml":  # one agent: nothing to share
            continue
        for task, entry in yaml.safe_load(path.read_text()).items():
            assert entry.get("shared_reward") is False, f"{path.name}: {task}"
