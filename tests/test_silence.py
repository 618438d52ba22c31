"""Silencing an environment's own channel, and the foreign benchmark mpe2 simple_reference."""

from __future__ import annotations

import sys

import gymnasium as gym
import numpy as np
import pytest
from mpe2 import simple_reference_v3  # the mpe extra, part of dev: these tests are not optional
from stable_baselines3.common.vec_env import DummyVecEnv
from toy_envs import CoinParallelEnv

from sb3_comm import CommDDPG, make_comm_vec_env
from sb3_comm.evaluation import evaluate_team
from sb3_comm.foreign.simple_reference import (
    SIMPLE_REFERENCE_CHANNEL,
    NativeChannelTeam,
    NoCommTeam,
    OracleTeam,
    RandomTeam,
    simple_reference_env,
)
from sb3_comm.wrappers import NativeChannel, SilenceNativeChannel, TwoAgentEnv

GAMES = 40


def _raw() -> object:
    return simple_reference_v3.parallel_env(continuous_actions=True)


def _vec(make, seed: int = 7) -> DummyVecEnv:
    env = DummyVecEnv([make] * GAMES)
    env.seed(seed)
    return env


def _score(team_class, make, seed: int = 7) -> float:
    env = _vec(make, seed)
    return evaluate_team(team_class(env), env).mean


def test_native_channel_oracle_beats_no_comm_only_while_the_channel_is_open() -> None:
    open_rows = lambda: TwoAgentEnv(_raw(), channel_size=4)  # noqa: E731
    closed_rows = lambda: TwoAgentEnv(SilenceNativeChannel(_raw(), SIMPLE_REFERENCE_CHANNEL), channel_size=4)  # noqa: E731
    no_comm = _score(NoCommTeam, open_rows)
    talking = _score(NativeChannelTeam, open_rows)
    silenced = _score(NativeChannelTeam, closed_rows)
    assert talking > no_comm + 4.0  # the native channel carries the target (gap is about 9)
    assert silenced <= no_comm + 0.05  # closed: the same team is no better than no-comm


def test_silenced_rows_drop_the_native_entries_and_the_env_hears_the_fill() -> None:
    env = simple_reference_env(channel_size=4)
    # 21 features - 10 heard entries, role one-hot, our channel; 15 actions - 10 said entries, channel
    assert env.observation_space.shape == (2, 11 + 2 + 4)
    assert env.action_space.shape == (2, 5 + 4)
    assert env.comm_layout.obs_message_slice == slice(13, 17)
    masked = TwoAgentEnv(SilenceNativeChannel(_raw(), SIMPLE_REFERENCE_CHANNEL), channel_size=4)
    obs, _ = env.reset(seed=3)
    full, _ = masked.reset(seed=3)
    keep = [*range(11), 21, 22, 23, 24, 25, 26]
    np.testing.assert_array_equal(obs, full[:, keep])
    rng = np.random.default_rng(0)
    for _ in range(5):
        action = rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32)
        full_action = np.zeros((2, 15 + 4), dtype=np.float32)
        full_action[:, :5], full_action[:, 15:] = action[:, :5], action[:, 5:]
        full_action[:, 5:15] = rng.uniform(0, 1, (2, 10))  # said natively: must not get through
        obs, *_ = env.step(action)
        full, *_ = masked.step(full_action)
        np.testing.assert_allclose(obs, full[:, keep], atol=1e-6)
        np.testing.assert_array_equal(full[:, 11:21], 0.0)
        np.testing.assert_allclose(obs[::-1, 13:], np.clip(action[:, 5:], -1, 1))  # ours: one step later
    world = env.env.env.unwrapped.world  # the native channel the environment itself carries
    for agent in world.agents:
        np.testing.assert_array_equal(agent.state.c, 0.0)


def test_scripted_references_are_ordered_oracle_no_comm_random() -> None:
    make = lambda: simple_reference_env(channel_size=4)  # noqa: E731
    oracle, no_comm, random = (_score(t, make) for t in (OracleTeam, NoCommTeam, RandomTeam))
    assert oracle > no_comm + 4.0 > random + 4.0


def test_gymnasium_id_and_a_short_training_run() -> None:
    env = gym.make("MPESimpleReference-v0", channel_size=2)
    assert env.observation_space.shape == (2, 11 + 2 + 2)
    vec = make_comm_vec_env("MPESimpleReference-v0", n_envs=2, seed=0, env_kwargs={"channel_size": 2})
    model = CommDDPG("GSN", vec, learning_starts=50, batch_size=16, seed=0, device="cpu")
    model.learn(120)
    action, _ = model.predict(vec.reset())
    assert action.shape == (2, 2, 5 + 2) and np.isfinite(action).all()
    assert (action[..., :5] >= 0).all() and (action[..., :5] <= 1).all()  # MPE's [0, 1] movement


def test_simple_reference_options_are_checked() -> None:
    with pytest.raises(TypeError, match="silence must be True or False"):
        simple_reference_env(silence="yes")  # type: ignore[arg-type]
    open_env = simple_reference_env(channel_size=3, silence=False)
    assert open_env.observation_space.shape == (2, 21 + 2 + 3)


def test_missing_mpe2_names_the_extra(monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "mpe2", None)
    with pytest.raises(ImportError, match=r"sb3-comm\[mpe\]"):
        simple_reference_env()


@pytest.mark.parametrize(
    ("silence", "error", "match"),
    [
        (NativeChannel(observation=[7]), ValueError, r"indices \[7\] are outside \[0, 3\)"),
        (NativeChannel(observation=[0, 0]), ValueError, "repeat"),
        (NativeChannel(observation=slice(0, 3)), ValueError, "leaves the agent nothing"),
        (NativeChannel(), ValueError, "names no observation or action entries"),
        (NativeChannel(observation="ab"), TypeError, "a slice or a sequence of ints"),
        (NativeChannel(action=[0]), ValueError, "silencing all 1 entries"),
        ({"listener": NativeChannel(action=[0], action_fill=2.0)}, ValueError, "outside the action space"),
        ({"listener": NativeChannel(action=[0], action_fill=float("nan"))}, ValueError, "finite"),
        ({"nobody": NativeChannel(observation=[0])}, ValueError, "unknown agents"),
        ({"speaker": [0]}, TypeError, "must be a NativeChannel"),
        ([0, 1], TypeError, "NativeChannel or a dict"),
    ],
)
def test_bad_silence_is_a_clear_error(silence, error, match) -> None:
    with pytest.raises(error, match=match):
        TwoAgentEnv(CoinParallelEnv(), channel_size=1, silence=silence)


def test_silence_per_agent_and_refused_for_the_wrappers_own_channel() -> None:
    env = TwoAgentEnv(CoinParallelEnv(), channel_size=1, silence={"speaker": NativeChannel(observation=[1])})
    obs, _ = env.reset(seed=0)
    assert env.codec.feature_sizes == [2, 2]  # the speaker lost one entry, the listener none
    assert obs[0, 0] == pytest.approx(env.env.env.coin)

    class WithChannel(CoinParallelEnv):
        channel_size = 1

    with pytest.raises(ValueError, match="wrapper's message channel"):
        TwoAgentEnv(WithChannel(), silence=NativeChannel(observation=[0]))
