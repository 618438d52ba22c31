"""The GSN's worker process: where it is used, the state it shares, its errors, its end."""

from __future__ import annotations

import os
import signal

import pytest
import torch as th
from stable_baselines3.common.env_util import make_vec_env
from toy_envs import coin_env

from sb3_comm import CommDDPG
from sb3_comm.comm_ddpg import gsn as gsn_module
from sb3_comm.comm_ddpg.gsn_worker import can_fork

pytestmark = pytest.mark.skipif(not can_fork(), reason="the worker is forked: Linux only")


def _model(method: str = "GSN") -> CommDDPG:
    env = make_vec_env(coin_env, n_envs=2, seed=0)
    return CommDDPG(
        method, env, batch_size=16, learning_starts=20, seed=0,
        policy_kwargs={"net_arch": [16], "gsn_net_arch": [8], "gsn_reward_net_arch": [8]},
    )  # fmt: skip


@pytest.fixture
def spare_core(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(gsn_module, "spare_core", lambda: True)


def _train_in_learn(model: CommDDPG) -> None:
    """One agent update bracketed by the GSN's, as inside ``learn``."""
    model._in_learn = True
    try:
        model.train(gradient_steps=1, batch_size=16)
    finally:
        model._in_learn = False


def test_the_worker_trains_shared_tensors_and_ends_with_learn(spare_core: None) -> None:
    model = _model()
    model.learn(60)
    callback = model.gsn_callback
    assert callback.uses_worker()
    gsn = model.policy.gsn
    before = {name: t.clone() for name, t in gsn.state_dict().items()}
    steps_before = [s["step"].item() for s in gsn.optimizer.state.values()]
    _train_in_learn(model)
    worker = callback._worker
    assert worker is not None and worker.alive
    # the worker's update is seen here: parameters, reward moments and Adam's state moved
    assert all(t.is_shared() for t in gsn.state_dict().values())
    moved = [name for name, t in gsn.state_dict().items() if not th.equal(t, before[name])]
    assert "reward_count" in moved and any(name.startswith("message_extractor") for name in moved)
    assert [s["step"].item() for s in gsn.optimizer.state.values()] == [s + 1 for s in steps_before]
    model.learn(20, reset_num_timesteps=False)  # learn stops every worker of the model
    assert not worker.alive and model.gsn_callback._worker is None


def test_an_error_in_the_worker_is_raised_in_the_trainer(spare_core: None) -> None:
    model = _model()
    model.learn(60)
    callback = model.gsn_callback

    def broken(batches):
        raise ValueError("a broken GSN update")

    callback._updates = broken  # inherited by the forked worker
    with pytest.raises(RuntimeError, match=r"(?s)failed in the worker process.*a broken GSN update"):
        _train_in_learn(model)
    callback.close()


def test_a_dead_worker_is_a_clear_error(spare_core: None) -> None:
    model = _model()
    model.learn(60)
    callback = model.gsn_callback
    _train_in_learn(model)
    worker = callback._worker
    os.kill(worker._process.pid, signal.SIGKILL)
    worker._process.join()
    with pytest.raises(RuntimeError, match="GSN worker process died"):
        _train_in_learn(model)
    callback.close()


def test_no_worker_where_it_cannot_help(spare_core: None, monkeypatch: pytest.MonkeyPatch) -> None:
    gsn_max = _model("GSN-MAX")
    gsn_max.learn(40)
    assert not gsn_max.gsn_callback.uses_worker()  # its update reads the agents' critic
    model = _model()
    model.learn(40)
    assert model.gsn_callback.uses_worker()
    monkeypatch.setattr(gsn_module, "BESIDE_AGENTS", False)  # the experiment runner's switch
    assert not model.gsn_callback.uses_worker()
    monkeypatch.setattr(gsn_module, "BESIDE_AGENTS", True)
    monkeypatch.setattr(gsn_module, "can_fork", lambda: False)  # not Linux, or a daemonic process
    assert not model.gsn_callback.uses_worker()


def test_more_batches_than_slots_go_through_the_pipe(spare_core: None) -> None:
    """A train call with more updates than the first one: same result as the trainer's own."""
    states = {}
    for use_worker in (True, False):
        model = _model()
        model.learn(60)
        model.gsn_callback.beside_agents = use_worker
        for steps in (1, 3):
            model._in_learn = True
            model.train(gradient_steps=steps, batch_size=16)
        model._in_learn = False
        assert (model.gsn_callback._worker is not None) == use_worker
        model.gsn_callback.close()
        states[use_worker] = model.policy.gsn.state_dict()
    for name, tensor in states[True].items():
        assert th.equal(tensor, states[False][name]), name


def test_save_and_load_after_the_worker_trained(spare_core: None, tmp_path) -> None:
    model = _model()
    model.learn(120)
    assert model.gsn_callback.n_updates > 0
    model.save(tmp_path / "model.zip")
    loaded = CommDDPG.load(tmp_path / "model.zip")
    for name, tensor in model.policy.gsn.state_dict().items():
        assert th.equal(tensor, loaded.policy.gsn.state_dict()[name]), name
    ours, theirs = model.policy.gsn.optimizer.state_dict(), loaded.policy.gsn.optimizer.state_dict()
    for key, state in ours["state"].items():
        for field, value in state.items():
            assert th.equal(value, theirs["state"][key][field]), (key, field)
