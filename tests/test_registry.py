"""The task registry (envs.registry) and what sb3_comm builds from it."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import envs
from envs.registry import TASKS, TaskSpec, UnknownTaskError, get_task, task_ids
from sb3_comm import TASK_IDS, make_comm_vec_env
from sb3_comm.analysis import reference_returns
from sb3_comm.wrappers import TwoAgentEnv, make_task_env

SPECS = list(TASKS.values())


def test_registry_lists_the_papers_tasks_and_is_reexported() -> None:
    assert task_ids() == ("BlindSoccer-v0", "GuessMyNumber-v0") == TASK_IDS
    assert envs.TASKS is TASKS and envs.get_task is get_task and envs.TaskSpec is TaskSpec
    with pytest.raises(TypeError):
        TASKS["Other-v0"] = SPECS[0]  # type: ignore[index]


@pytest.mark.parametrize("spec", SPECS, ids=lambda s: s.env_id)
def test_every_record_builds_its_batched_and_parallel_env(spec: TaskSpec) -> None:
    task = spec.batched_env(n_games=3, seed=0)
    assert task.n_games == 3 and task.name == spec.name
    assert task.channel_size == spec.channel_size
    assert tuple(task.possible_agents) == spec.agents
    env = spec.parallel_env(seed=0)
    assert env.channel_size == spec.channel_size and tuple(env.possible_agents) == spec.agents
    obs, _ = env.reset(seed=0)
    assert set(obs) == set(spec.agents)
    vec_env = make_comm_vec_env(spec.env_id, n_envs=2, seed=0)
    assert vec_env.num_envs == 2
    # the channel sits at the end of every observation row and every action row
    assert vec_env.observation_space.shape[-1] >= spec.channel_size
    vec_env.close()


@pytest.mark.parametrize("spec", SPECS, ids=lambda s: s.env_id)
def test_reference_policies_give_one_action_per_agent_and_game(spec: TaskSpec) -> None:
    task = spec.batched_env(n_games=4, seed=0)
    task.reset(seed=0)
    policies = spec.reference_policies(np.random.default_rng(0))
    assert list(policies)[:2] == ["oracle", "random"]
    for policy in policies.values():
        actions = policy(task)
        assert actions.shape == (task.n_games, task.n_players, task.action_size)
        assert np.isfinite(actions).all()


@pytest.mark.parametrize("name", ["BlindSoccer-v0", "blind_soccer", "blind_soccer_v0"])
def test_a_task_is_found_by_id_key_or_pettingzoo_name(name: str) -> None:
    assert get_task(name) is TASKS["BlindSoccer-v0"]
    env = make_task_env(name, seed=0)  # the old registrations passed the module name
    assert isinstance(env, TwoAgentEnv) and env.comm_layout.channel_size == 4


def test_an_unknown_task_is_a_clear_error() -> None:
    expected = "unknown task 'Soccer-v9'; accepted: 'BlindSoccer-v0'"
    with pytest.raises(UnknownTaskError, match=expected) as info:
        get_task("Soccer-v9")
    assert isinstance(info.value, KeyError)
    assert "GuessMyNumber-v0" in str(info.value) and "guess_my_number" in str(info.value)
    with pytest.raises(KeyError, match="accepted"):
        make_task_env("Soccer-v9")
    assert reference_returns("Soccer-v9", n_episodes=2) is None


@pytest.mark.parametrize("spec", SPECS, ids=lambda s: s.env_id)
def test_gym_ids_are_registered_from_the_registry(spec: TaskSpec) -> None:
    assert gym.spec(spec.env_id).kwargs == {"task": spec.env_id}
    env = gym.make(spec.env_id, max_steps=5)
    assert env.unwrapped.comm_layout.channel_size == spec.channel_size
    env.close()


def test_reference_returns_come_from_the_registry_records() -> None:
    ref = reference_returns("GuessMyNumber-v0", n_episodes=4)
    assert ref is not None
    assert list(ref) == ["n_episodes", "seed", "oracle", "oracle_ci95", "random", "random_ci95"]
    assert ref["oracle"] == pytest.approx(9.9, abs=1e-6)  # 99 x 0.1: the first step hears 0
    blind = reference_returns("blind_soccer", n_episodes=4)
    assert blind is not None and "blind_dash_forward" in blind
