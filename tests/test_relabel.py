"""GSN message relabelling (``relabel_messages``): replayed transitions hear what the current
message network sends, and nothing else of a transition changes."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import torch as th

from sb3_comm import CommDDPG, make_comm_vec_env

ENV_ID = "BlindSoccer-v0"  # both agents send different messages, one of them sees nothing


def collected(method: str = "GSN", steps: int = 440, **kwargs) -> CommDDPG:
    """A model whose buffer (50 steps of 4 games) has wrapped (110 steps each), filled by a GSN
    that never trained."""
    env = make_comm_vec_env(ENV_ID, n_envs=4, seed=0)
    kwargs.setdefault("relabel_messages", True)
    model = CommDDPG(
        method, env, learning_starts=10_000, buffer_size=200, seed=0, device="cpu",
        policy_kwargs={"net_arch": [16, 16], "gsn_net_arch": [16], "gsn_reward_net_arch": [16]}, **kwargs,
    )  # fmt: skip
    if steps:
        model.learn(steps)
    return model


def perturb_gsn(model: CommDDPG) -> None:
    """Move the message network away from the one that acted (and sent the stored messages)."""
    with th.no_grad():
        for parameter in model.policy.gsn.message_extractor.parameters():
            parameter.add_(0.3 * th.randn_like(parameter))


def relabelled_and_stored(buffer, seed: int, batch_size: int):
    """The same sample (same random draws) with the buffer's relabeler and without it, which then
    stays detached; the relabelling draws no random numbers of its own."""
    np.random.seed(seed)
    relabelled = buffer.sample(batch_size)
    after = np.random.random()
    buffer.message_relabeler = None
    np.random.seed(seed)
    stored = buffer.sample(batch_size)
    assert np.random.random() == after
    return relabelled, stored


def every_transition(model: CommDDPG):
    buffer = model.replay_buffer
    steps = np.arange(buffer.buffer_size).repeat(buffer.n_envs)
    envs = np.tile(np.arange(buffer.n_envs), buffer.buffer_size)
    previous, has_previous = buffer.previous_observations(steps, envs)
    return (
        buffer._gather(steps, envs),
        buffer.to_torch(previous),
        buffer.to_torch(has_previous.astype(np.float32)),
    )


def test_with_the_acting_gsn_relabelling_gives_the_stored_messages() -> None:
    model = collected()
    buffer = model.replay_buffer
    assert buffer.full and buffer.pos != 0  # the oldest stored step is inside the arrays
    data, previous, has_previous = every_transition(model)
    obs, next_obs = model.relabel_heard_messages(
        data.observations, data.next_observations, previous, has_previous
    )
    th.testing.assert_close(obs, data.observations)
    th.testing.assert_close(next_obs, data.next_observations)
    # No previous step: an episode's first step (one per game here) and the oldest stored step.
    starts = int(buffer.episode_starts.sum())
    assert starts >= buffer.n_envs
    assert int((has_previous == 0).sum()) == starts + buffer.n_envs
    # The heard messages are not trivially equal: the two agents send different ones.
    heard = data.observations[..., model.comm_layout.obs_message_slice]
    assert (heard[:, 0] - heard[:, 1]).abs().max() > 1e-3


def test_a_changed_gsn_changes_only_the_heard_messages() -> None:
    model = collected()
    data, previous, has_previous = every_transition(model)
    perturb_gsn(model)
    obs, next_obs = model.relabel_heard_messages(
        data.observations, data.next_observations, previous, has_previous
    )
    heard = model.comm_layout.obs_message_slice
    rest = slice(0, heard.start)
    th.testing.assert_close(obs[..., rest], data.observations[..., rest])
    th.testing.assert_close(next_obs[..., rest], data.next_observations[..., rest])
    message = model.policy.gsn.message
    with th.no_grad():
        expected_obs = message(previous).flip(1)
        expected_next = message(obs).flip(1)
    valid = has_previous > 0
    th.testing.assert_close(obs[valid][..., heard], expected_obs[valid])
    th.testing.assert_close(obs[~valid][..., heard], data.observations[~valid][..., heard])
    th.testing.assert_close(next_obs[..., heard], expected_next)
    assert (obs[valid][..., heard] - data.observations[valid][..., heard]).abs().max() > 1e-3


def test_samples_are_relabelled_and_the_random_draws_are_unchanged() -> None:
    model = collected()
    buffer = model.replay_buffer
    perturb_gsn(model)
    relabelled, stored = relabelled_and_stored(buffer, seed=5, batch_size=32)
    heard = model.comm_layout.obs_message_slice
    th.testing.assert_close(relabelled.actions, stored.actions)
    th.testing.assert_close(
        relabelled.observations[..., : heard.start], stored.observations[..., : heard.start]
    )
    assert (
        relabelled.next_observations[..., heard] - stored.next_observations[..., heard]
    ).abs().max() > 1e-3


def test_the_states_at_the_time_limits_cuts_are_relabelled_too() -> None:
    """With ``mc_truncated="bootstrap"`` a sample also carries the state at its episode's cut: it
    hears what the current GSN sends for the cut's observations, like ``next_observations``."""
    model = collected(mc_mixing=0.5, replay_buffer_kwargs={"mc_truncated": "bootstrap"})
    buffer = model.replay_buffer
    perturb_gsn(model)
    relabelled, stored = relabelled_and_stored(buffer, seed=3, batch_size=64)
    cut = stored.mc_tail_discount[:, 0] > 0
    assert bool(cut.any())  # Blind Soccer's untrained team is cut by the time limit
    heard = model.comm_layout.obs_message_slice
    rest = slice(0, heard.start)
    tail, stored_tail = relabelled.mc_tail_observations, stored.mc_tail_observations
    th.testing.assert_close(tail[..., rest], stored_tail[..., rest])
    np.random.seed(3)
    batch_inds = np.random.randint(0, buffer.buffer_size, size=64)
    env_inds = np.random.randint(0, buffer.n_envs, size=64)
    tails = buffer.mc_tail_positions[batch_inds, env_inds]  # the cut's transition: its next state
    previous, has_previous = buffer.previous_observations(tails, env_inds)
    _, expected = model.relabel_heard_messages(  # checked against the GSN's messages above
        buffer.to_torch(buffer.observations[tails, env_inds]),
        stored.mc_tail_observations,
        buffer.to_torch(previous),
        buffer.to_torch(has_previous.astype(np.float32)),
    )
    th.testing.assert_close(tail[cut], expected[cut])
    assert (tail[cut][..., heard] - stored_tail[cut][..., heard]).abs().max() > 1e-3


def test_the_option_survives_save_and_load_and_is_not_pickled_with_the_buffer(tmp_path) -> None:
    model = collected(steps=120)
    model.save(tmp_path / "model.zip")
    model.save_replay_buffer(tmp_path / "buffer.pkl")
    loaded = CommDDPG.load(
        tmp_path / "model.zip", env=make_comm_vec_env(ENV_ID, n_envs=4, seed=1), device="cpu"
    )
    assert loaded.relabel_messages is True
    assert loaded.replay_buffer.message_relabeler == loaded.relabel_heard_messages
    loaded.load_replay_buffer(tmp_path / "buffer.pkl")
    assert loaded.replay_buffer.message_relabeler == loaded.relabel_heard_messages
    with open(tmp_path / "buffer.pkl", "rb") as file:
        assert pickle.load(file).message_relabeler is None  # the file holds the data only
    # The loaded buffer's next step begins an episode in every game (the environments restart).
    assert loaded.replay_buffer._next_starts.all()
    off = collected(steps=40, relabel_messages=False)
    assert off.replay_buffer.message_relabeler is None


@pytest.mark.parametrize(
    ("method", "settings"),
    [("NONE", {}), ("RIAL", {}), ("TCG", {}), ("GSN-MAX", {"gsn_max_explore_messages": True})],
)
def test_methods_whose_messages_are_not_m_of_o_refuse_the_option(method: str, settings: dict) -> None:
    with pytest.raises(ValueError, match=r"relabel_messages=True needs messages .* M\(o\)"):
        collected(method, steps=0, **settings)


def test_gsn_max_without_explored_messages_accepts_it_and_a_bad_value_is_a_clear_error() -> None:
    model = collected("GSN-MAX", steps=0, gsn_max_explore_messages=False)
    assert model.replay_buffer.message_relabeler is not None
    default = collected("GSN-MAX", steps=0)  # the effect search: only its explorer games explore
    assert default.replay_buffer.message_relabeler is not None
    with pytest.raises(TypeError, match=r"relabel_messages must be True or False, got 'yes'"):
        collected(steps=0, relabel_messages="yes")
