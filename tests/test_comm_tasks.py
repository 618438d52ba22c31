"""CommDDPG and the wrappers on the real soccer tasks: registration, VecEnvs, learn, evaluate."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.env_checker import check_env
from stable_baselines3.common.env_util import make_vec_env

import sb3_comm
from sb3_comm import METHODS, TASK_IDS, CommDDPG, make_comm_vec_env
from sb3_comm.evaluation import evaluate_team

TINY = {"net_arch": [16, 16]}


@pytest.mark.parametrize("env_id", sorted(TASK_IDS))
def test_registered_ids_make_checked_envs(env_id: str) -> None:
    env = gym.make(env_id)
    check_env(env.unwrapped, warn=False)
    layout = env.unwrapped.comm_layout
    assert layout.n_agents == 2
    assert layout.channel_size == (4 if env_id == "BlindSoccer-v0" else 1)
    assert layout.hybrid is not None and layout.hybrid.n_actions == 3
    vec = make_vec_env(env_id, n_envs=3, seed=0)
    obs = vec.reset()
    assert obs.shape == (3, 2, layout.obs_dim)


def test_blind_soccer_message_reaches_the_blind_agent_next_step() -> None:
    env = gym.make("BlindSoccer-v0").unwrapped
    layout = env.comm_layout
    obs, _ = env.reset(seed=4)
    blind = layout.agent_names.index("blind")
    sighted = 1 - blind
    # The blind agent's own features are all zero; it has its role and (zero) message only.
    assert np.count_nonzero(obs[blind, : layout.obs_dim - layout.n_agents - layout.channel_size]) == 0
    action = np.zeros(env.action_space.shape, dtype=np.float32)
    action[:, 1] = 1.0  # both agents pick "turn" (score index 1) with a zero angle
    action[sighted, layout.action_message_slice] = [0.1, -0.2, 0.3, -0.4]
    obs1, *_ = env.step(action)
    np.testing.assert_allclose(obs1[blind, layout.obs_message_slice], [0.1, -0.2, 0.3, -0.4], rtol=1e-6)
    np.testing.assert_array_equal(obs1[sighted, layout.obs_message_slice], 0.0)
    action[sighted, layout.action_message_slice] = 0.0
    obs2, *_ = env.step(action)
    np.testing.assert_array_equal(obs2[blind, layout.obs_message_slice], 0.0)


def test_batched_vec_env_matches_the_single_game_env() -> None:
    single = gym.make("GuessMyNumber-v0").unwrapped
    batched = make_comm_vec_env("GuessMyNumber-v0", n_envs=1, seed=7)
    obs_a, _ = single.reset(seed=7)
    obs_b = batched.reset()
    np.testing.assert_allclose(obs_a, obs_b[0], rtol=1e-6)
    rng = np.random.default_rng(0)
    for _ in range(5):
        action = rng.uniform(single.action_space.low, single.action_space.high).astype(np.float32)
        obs_a, reward_a, *_, info_a = single.step(action)
        obs_b, reward_b, _, info_b = batched.step(action[None])
        np.testing.assert_allclose(obs_a, obs_b[0], rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(info_a["agent_rewards"], info_b[0]["agent_rewards"], rtol=1e-5)
        assert reward_a == pytest.approx(float(reward_b[0]), rel=1e-5)


def test_batched_vec_env_reports_finished_episodes() -> None:
    vec = make_comm_vec_env("GuessMyNumber-v0", n_envs=3, seed=0, env_kwargs={"max_steps": 4})
    vec.reset()
    zeros = np.zeros((3, *vec.action_space.shape), dtype=np.float32)
    for _ in range(3):
        _, _, dones, _ = vec.step(zeros)
        assert not dones.any()
    _, _, dones, infos = vec.step(zeros)
    assert dones.all()
    for info in infos:
        assert info["TimeLimit.truncated"] is True
        assert info["terminal_observation"].shape == vec.observation_space.shape
        assert info["episode"]["l"] == 4
        np.testing.assert_allclose(info["episode"]["r"], np.mean(info["agent_returns"]), rtol=1e-6)


def test_bad_actions_in_batched_vec_env_name_the_agent() -> None:
    vec = make_comm_vec_env("BlindSoccer-v0", n_envs=2, seed=0)
    vec.reset()
    actions = np.zeros((2, *vec.action_space.shape), dtype=np.float32)
    actions[1, 1, 3] = np.nan
    with pytest.raises(ValueError, match="blind"):
        vec.step(actions)
    with pytest.raises(ValueError, match="expected"):
        vec.step(np.zeros((2, 3), dtype=np.float32))


@pytest.mark.parametrize("env_id", sorted(TASK_IDS))
@pytest.mark.parametrize("method", METHODS)
def test_learn_300_steps_every_method_and_task(method: str, env_id: str) -> None:
    env = make_comm_vec_env(env_id, n_envs=2, seed=0)
    model = CommDDPG(
        method, env, learning_starts=100, batch_size=16, policy_kwargs=TINY, seed=0, device="cpu"
    )
    model.learn(300)
    assert model.num_timesteps == 300
    assert model.n_updates > 0
    if method == "GSN":
        assert model.gsn_callback.n_updates == model.n_updates
    result = evaluate_team(model, env_id, n_episodes=3, seed=1, env_kwargs={"max_steps": 10})
    assert result.team_returns.shape == (3,) and np.isfinite(result.team_returns).all()


def test_ablations_change_what_the_receiver_hears() -> None:
    model = CommDDPG(
        "RIAL", make_comm_vec_env("GuessMyNumber-v0", n_envs=2), policy_kwargs=TINY, device="cpu"
    )
    kwargs = {"n_episodes": 6, "seed": 3, "env_kwargs": {"max_steps": 5}}
    intact = evaluate_team(model, "GuessMyNumber-v0", **kwargs)
    again = evaluate_team(model, "GuessMyNumber-v0", **kwargs)
    np.testing.assert_array_equal(intact.team_returns, again.team_returns)  # deterministic
    zeroed = evaluate_team(model, "GuessMyNumber-v0", ablation="zero", **kwargs)
    assert zeroed.team_returns.shape == intact.team_returns.shape
    with pytest.raises(ValueError, match="accepted"):
        evaluate_team(model, "GuessMyNumber-v0", ablation="mute", **kwargs)


def test_share_parameters_false_gives_each_agent_its_networks() -> None:
    env = make_comm_vec_env("BlindSoccer-v0", n_envs=2, seed=0)
    shared = CommDDPG("GSN", env, policy_kwargs=TINY, device="cpu")
    separate = CommDDPG("GSN", env, policy_kwargs=TINY, share_parameters=False, device="cpu")
    assert len(shared.actor.nets) == 1 and len(separate.actor.nets) == 2
    assert len(separate.policy.gsn.message_extractor.nets) == 2
    n_shared = sum(p.numel() for p in shared.actor.parameters())
    assert sum(p.numel() for p in separate.actor.parameters()) == 2 * n_shared


def test_import_registers_ids() -> None:
    assert set(TASK_IDS) <= set(gym.registry)
    sb3_comm.register_envs()  # idempotent


def _scalar_tags(log_dir) -> set[str]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    tags: set[str] = set()
    for event_file in log_dir.rglob("events.out.tfevents.*"):
        accumulator = EventAccumulator(str(event_file))
        accumulator.Reload()
        tags |= set(accumulator.Tags()["scalars"])
    return tags


def test_tensorboard_logs_hold_the_communication_scalars(tmp_path) -> None:
    for method in ("GSN", "TCG"):
        env = make_comm_vec_env("GuessMyNumber-v0", n_envs=2, seed=0, env_kwargs={"max_steps": 20})
        model = CommDDPG(
            method,
            env,
            learning_starts=40,
            batch_size=16,
            policy_kwargs=TINY,
            tensorboard_log=str(tmp_path / method),
            device="cpu",
        )
        model.learn(200, log_interval=1)
        tags = _scalar_tags(tmp_path / method)
        expected = {
            "train/actor_loss",
            "train/critic_loss",
            "comm/message_mean",
            "comm/message_std",
            "rollout/ep_return_agent_0",
            "rollout/ep_return_agent_1",
        }
        expected.add("gsn/loss" if method == "GSN" else "tcg/grad_norm")
        assert expected <= tags, expected - tags


def test_learn_with_progress_bar_and_callbacks() -> None:
    env = make_comm_vec_env("GuessMyNumber-v0", n_envs=2, seed=0)
    model = CommDDPG("TCG", env, learning_starts=20, batch_size=8, policy_kwargs=TINY, device="cpu")
    calls: list[int] = []
    model.learn(60, progress_bar=True, callback=lambda _l, _g: calls.append(1) or True)
    assert len(calls) == 30  # one call per VecEnv step of 2 games
