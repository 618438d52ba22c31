"""Tests of the two-agent communication tasks: batched core and PettingZoo shell."""

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test, parallel_seed_test

from envs import blind_soccer_v0, guess_my_number_v0
from envs.soccer import physics, referee
from envs.soccer.state import SoccerState
from envs.tasks import BlindSoccerTask, GuessMyNumberTask
from envs.tasks.blind_soccer import BLIND, SIGHTED, blind_proximity

MODULES = [blind_soccer_v0, guess_my_number_v0]


def _random_actions(task, rng):
    return rng.uniform(
        task.action_low, task.action_high, size=(task.n_games, task.n_players, task.action_size)
    )


def _turn_actions(task, angle=0.0):
    """Every agent turns by ``angle`` (nothing moves); messages zero."""
    actions = np.zeros((task.n_games, task.n_players, task.action_size))
    actions[..., :3] = [-1.0, 1.0, -1.0]
    actions[..., 5] = angle
    return actions


def _still_state(n_games=1, ball=(30.0, 0.0), players=((10.0, -20.0), (10.0, 20.0)), body=(0.0, 0.0)):
    state = SoccerState.zeros(n_games, len(players))
    state.ball_pos[:] = ball
    state.pos[:] = np.array(players, dtype=float)
    state.body[:] = body
    return state


# ------------------------------------------------------------------------------------------------
# sizes and library checkers
# ------------------------------------------------------------------------------------------------
def test_sizes_and_bounds():
    blind = blind_soccer_v0.batched_env(n_games=3, seed=0)
    assert blind.possible_agents == ("sighted", "blind")
    assert (blind.observation_size, blind.action_size, blind.channel_size) == (70, 12, 4)
    guess = guess_my_number_v0.batched_env(n_games=3, seed=0)
    assert guess.possible_agents == ("agent_0", "agent_1")
    assert (guess.observation_size, guess.action_size, guess.channel_size) == (68, 9, 1)
    for task in (blind, guess):
        assert task.obs.shape == (3, 2, task.observation_size) and task.obs.dtype == np.float32
        assert task.action_low.shape == task.action_high.shape == (task.action_size,)
        np.testing.assert_array_equal(task.action_low[8:], -1.0)
        np.testing.assert_array_equal(task.action_high[8:], 1.0)
        assert task.hybrid_layout["n_actions"] == 3
    assert BlindSoccerTask(channel_size=2).observation_size == 68


@pytest.mark.parametrize("module", MODULES)
def test_pettingzoo_api(module):
    env = module.parallel_env(seed=0)
    parallel_api_test(env, num_cycles=120)
    assert env.metadata["hybrid_action"] == {"n_actions": 3, "parameters": [[3, 4], [5], [6, 7]]}
    assert env.metadata["render_modes"] == ["rgb_array"] and env.metadata["is_parallelizable"]
    assert env.channel_size == env.task.channel_size
    assert env.state().shape == env.state_space.shape


@pytest.mark.parametrize("module", MODULES)
def test_pettingzoo_seed(module):
    parallel_seed_test(lambda: module.parallel_env(), num_cycles=60)


def test_observations_stay_in_bounds():
    for module in MODULES:
        task = module.batched_env(n_games=64, seed=1)
        rng = np.random.default_rng(0)
        for _ in range(60):
            obs, *_ = task.step(_random_actions(task, rng))
            assert np.all(obs >= task.observation_low) and np.all(obs <= task.observation_high)


# ------------------------------------------------------------------------------------------------
# determinism
# ------------------------------------------------------------------------------------------------
def _rollout(task, seed, steps=40):
    rng = np.random.default_rng(123)
    out = [task.reset(seed=seed).copy()]
    for _ in range(steps):
        obs, rew, term, trunc, _ = task.step(_random_actions(task, rng))
        out += [obs.copy(), rew.copy(), term.copy(), trunc.copy()]
    return out


@pytest.mark.parametrize("module", MODULES)
def test_same_seed_same_trajectory_different_seed_differs(module):
    task = module.batched_env(n_games=8)
    first, again, other = _rollout(task, 5), _rollout(task, 5), _rollout(task, 6)
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    assert not np.array_equal(first[0], other[0])
    # the constructor seed acts like reset(seed=...)
    fresh = module.batched_env(n_games=8, seed=5)
    np.testing.assert_array_equal(fresh.obs, first[0])


@pytest.mark.parametrize("module", MODULES)
def test_batched_core_and_parallel_env_agree(module):
    env = module.parallel_env()
    task = module.batched_env(n_games=1, autoreset=False)
    obs_dict, _ = env.reset(seed=11)
    obs = task.reset(seed=11)
    rng = np.random.default_rng(0)
    for _ in range(200):
        for i, agent in enumerate(env.possible_agents):
            np.testing.assert_array_equal(obs_dict[agent], obs[0, i])
        actions = _random_actions(task, rng)
        obs_dict, rew_dict, term_dict, trunc_dict, _ = env.step(
            {agent: actions[0, i].astype(np.float32) for i, agent in enumerate(env.possible_agents)}
        )
        obs, rew, term, trunc, _ = task.step(actions.astype(np.float32))
        assert [rew_dict[a] for a in env.possible_agents] == pytest.approx(rew[0].tolist())
        assert term_dict[env.possible_agents[0]] == term[0] and trunc_dict[env.possible_agents[0]] == trunc[0]
        if term[0] or trunc[0]:
            assert env.agents == []
            break
    else:
        pytest.fail("the episode should have ended within max_steps")


# ------------------------------------------------------------------------------------------------
# the message channel
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("module", MODULES)
def test_message_arrives_exactly_one_step_later(module):
    task = module.batched_env(n_games=2, seed=3)
    c = task.channel_size
    np.testing.assert_array_equal(task.obs[..., -c:], 0.0)  # zeros at the first step
    first = _turn_actions(task)
    first[0, 0, 8:] = 0.25  # agent 0 of game 0 speaks
    first[1, 1, 8:] = -0.5  # agent 1 of game 1 speaks
    obs, *_ = task.step(first)
    np.testing.assert_allclose(obs[0, 1, -c:], 0.25)
    np.testing.assert_allclose(obs[1, 0, -c:], -0.5)
    np.testing.assert_array_equal(obs[0, 0, -c:], 0.0)  # a sender does not hear itself
    np.testing.assert_array_equal(obs[1, 1, -c:], 0.0)
    second = _turn_actions(task)
    second[0, 0, 8:] = 7.0  # clipped to the channel's bound
    obs, *_ = task.step(second)
    np.testing.assert_allclose(obs[0, 1, -c:], 1.0)
    np.testing.assert_array_equal(obs[1, 0, -c:], 0.0)  # the old message is gone
    np.testing.assert_allclose(task.sent_messages[0, 0], 1.0)
    obs = task.reset()
    np.testing.assert_array_equal(obs[..., -c:], 0.0)


def test_messages_reset_with_autoreset():
    task = guess_my_number_v0.batched_env(n_games=2, seed=0, max_steps=2)
    actions = _turn_actions(task)
    actions[:, :, 8] = 0.5
    task.step(actions)
    obs, _, _, truncated, info = task.step(actions)
    assert truncated.all() and info["done"].all()
    np.testing.assert_allclose(info["final_observation"][..., -1], 0.5)
    np.testing.assert_array_equal(obs[..., -1], 0.0)


# ------------------------------------------------------------------------------------------------
# Blind Soccer rules
# ------------------------------------------------------------------------------------------------
def test_blind_agent_sees_only_its_messages():
    task = blind_soccer_v0.batched_env(n_games=16, seed=2)
    rng = np.random.default_rng(1)
    for _ in range(30):
        actions = _random_actions(task, rng)
        obs, *_ = task.step(actions)
        np.testing.assert_array_equal(obs[:, BLIND, :66], 0.0)
        assert np.abs(obs[:, SIGHTED, :66]).sum(axis=1).min() > 0.0
        sent = np.clip(actions[:, SIGHTED, 8:], -1, 1)
        np.testing.assert_allclose(obs[:, BLIND, 66:], sent, rtol=1e-6)


def test_sighted_dash_is_a_noop():
    task = blind_soccer_v0.batched_env(noise=False, autoreset=False)
    task.load_state(_still_state())
    actions = np.zeros((1, 2, 12))
    actions[..., :3] = [1.0, -1.0, -1.0]
    actions[..., 3] = 100.0  # both dash at full power
    task.step(actions)
    np.testing.assert_array_equal(task.state.pos[0, SIGHTED], [10.0, -20.0])
    np.testing.assert_array_equal(task.state.vel[0, SIGHTED], [0.0, 0.0])
    assert task.state.pos[0, BLIND, 0] > 10.5  # the blind agent moved along its body (+x)


def test_blind_reward_is_the_proximity_change():
    task = blind_soccer_v0.batched_env(n_games=32, seed=4)
    rng = np.random.default_rng(2)
    start = blind_proximity(task.state, task.params)
    total = np.zeros(32)
    for _ in range(25):
        actions = _random_actions(task, rng)
        actions[:, BLIND, :3] = [1.0, 0.0, 0.0]  # the blind agent dashes: its distance changes
        _, rewards, _, _, info = task.step(actions)
        expected = blind_proximity(task.state, task.params) - blind_proximity(
            task.previous_state, task.params
        )
        done = info["done"]
        # for games that ended, task.state is already the next episode's: compare the others
        np.testing.assert_allclose(rewards[~done, 0], expected[~done], atol=1e-6)
        np.testing.assert_array_equal(rewards[:, 0], rewards[:, 1])
        total += rewards[:, 0]
        assert not done.any(), "no game should end in this test"
    np.testing.assert_allclose(total, blind_proximity(task.state, task.params) - start, atol=1e-4)
    d = 62.55 / 2 * (1 - blind_proximity(task.state, task.params))  # distance back from proximity
    assert np.all(d > 0)


def test_blind_terminates_when_it_can_kick():
    task = blind_soccer_v0.batched_env(n_games=2, noise=False, autoreset=False)
    state = _still_state(2, ball=(30.0, 0.0), players=((5.0, 5.0), (28.5, 0.0)))
    state.pos[1, BLIND] = (20.0, 0.0)  # game 1: far from the ball
    task.load_state(state)
    actions = np.zeros((2, 2, 12))
    actions[:, BLIND, :3] = [1.0, -1.0, -1.0]
    actions[:, BLIND, 3] = 100.0  # dash towards the ball (+x)
    previous = task.state
    _, rewards, terminated, truncated, info = task.step(actions)
    kickable = physics.kickable(task.state, task.params)[:, BLIND]
    np.testing.assert_array_equal(kickable, [True, False])
    np.testing.assert_array_equal(terminated, [True, False])
    np.testing.assert_array_equal(truncated, [False, False])
    np.testing.assert_array_equal(info["outcome"], [referee.IN_GAME, referee.IN_GAME])
    expected = blind_proximity(task.state, task.params) - blind_proximity(previous, task.params)
    np.testing.assert_allclose(rewards[:, 0], expected, rtol=1e-6)
    assert rewards[0, 0] > 0


def test_blind_truncates_after_max_steps():
    task = blind_soccer_v0.batched_env(n_games=4, seed=0, noise=False, max_steps=7)
    for step in range(1, 8):
        _, _, terminated, truncated, info = task.step(_turn_actions(task))
        assert not terminated.any()
        assert truncated.all() == (step == 7)
    np.testing.assert_array_equal(info["outcome"], referee.OUT_OF_TIME)
    np.testing.assert_array_equal(info["episode_length"], 7)
    np.testing.assert_array_equal(task.episode_steps, 0)


def test_autoreset_semantics_with_mixed_endings():
    task = blind_soccer_v0.batched_env(n_games=3, noise=False)
    state = _still_state(3, ball=(30.0, 0.0), players=((5.0, 5.0), (20.0, 0.0)))
    state.pos[1, BLIND] = (28.5, 0.0)  # game 1 ends at the first step
    task.load_state(state)
    actions = np.zeros((3, 2, 12))
    actions[:, BLIND, :3] = [1.0, -1.0, -1.0]
    actions[:, BLIND, 3] = 100.0
    actions[:, SIGHTED, 8:] = 0.3
    obs, rewards, terminated, _, info = task.step(actions)
    np.testing.assert_array_equal(info["done"], [False, True, False])
    np.testing.assert_array_equal(terminated, [False, True, False])
    final = info["final_observation"]
    np.testing.assert_array_equal(final[[0, 2]], obs[[0, 2]])
    np.testing.assert_allclose(final[1, BLIND, 66:], 0.3)  # the last observation heard the message
    np.testing.assert_array_equal(obs[1, BLIND, 66:], 0.0)  # the new episode starts in silence
    assert not np.array_equal(final[1], obs[1])
    np.testing.assert_allclose(info["episode_return"][1], rewards[1])
    assert info["episode_length"][1] == 1
    np.testing.assert_array_equal(task.episode_steps, [1, 0, 1])
    np.testing.assert_array_equal(task.state.cycle, [1, 0, 1])


@pytest.mark.parametrize("module", MODULES)
def test_autoreset_of_several_games_gives_their_own_first_observations(module):
    """Games reset together are observed in one padded feature pass (3 fresh games padded to 4):
    each gets exactly the first observation a task started in its state gives."""
    task = module.batched_env(n_games=6, seed=3, noise=False, max_steps=2)
    rng = np.random.default_rng(0)
    task.step(_random_actions(task, rng))
    task._steps[[0, 2, 5]] = task.max_steps - 1  # these three reach the time limit now
    obs, _, _, _, info = task.step(_random_actions(task, rng))
    ended = np.flatnonzero(info["done"])
    assert set(ended) >= {0, 2, 5}
    alone = module.batched_env(n_games=ended.size, seed=0, noise=False)
    np.testing.assert_array_equal(obs[ended], alone.load_state(task.state.select(ended)))


def test_reset_games_without_autoreset():
    task = guess_my_number_v0.batched_env(n_games=3, seed=0, autoreset=False, max_steps=2)
    task.step(_turn_actions(task))
    _, _, _, truncated, info = task.step(_turn_actions(task))
    assert truncated.all()
    np.testing.assert_array_equal(info["final_observation"], task.obs)  # nothing was reset
    before = task.obs.copy()
    obs = task.reset_games(np.array([True, False, True]))
    np.testing.assert_array_equal(obs[1], before[1])
    np.testing.assert_array_equal(task.episode_steps, [0, 2, 0])


# ------------------------------------------------------------------------------------------------
# Guess My Number rules
# ------------------------------------------------------------------------------------------------
def test_guess_my_number_reward_by_hand():
    task = guess_my_number_v0.batched_env(n_games=1, seed=0, hidden_numbers=(-0.3, 0.6))
    np.testing.assert_allclose(task.obs[0, :, 66], [-0.3, 0.6], rtol=1e-6)  # each sees its own number
    actions = _turn_actions(task)
    actions[0, :, 8] = [0.5, -0.2]  # agent 0 says 0.5, agent 1 says -0.2
    _, rewards, *_ = task.step(actions)
    # first step: nothing was received yet, the message is 0
    np.testing.assert_allclose(rewards[0], [0.1 * np.exp(-50 * 0.09), 0.1 * np.exp(-50 * 0.36)], rtol=1e-6)
    actions[0, :, 8] = [0.0, 0.0]
    _, rewards, *_ = task.step(actions)
    # agent 0 (h = -0.3) heard -0.2 from agent 1; agent 1 (h = 0.6) heard 0.5 from agent 0
    np.testing.assert_allclose(rewards[0], [0.1 * np.exp(-50 * 0.01), 0.1 * np.exp(-50 * 0.01)], rtol=1e-6)


def test_guess_my_number_runs_exactly_max_steps():
    task = guess_my_number_v0.batched_env(n_games=4, seed=0)
    rng = np.random.default_rng(0)
    for step in range(1, 101):
        _, _, terminated, truncated, info = task.step(_random_actions(task, rng))
        assert not terminated.any()
        assert truncated.all() == (step == 100)
    np.testing.assert_array_equal(info["episode_length"], 100)


def test_guess_my_number_validates_hidden_numbers():
    with pytest.raises(ValueError, match="hidden_numbers"):
        GuessMyNumberTask(hidden_numbers=(0.0, 1.5))
    with pytest.raises(ValueError, match="hidden_numbers"):
        GuessMyNumberTask(hidden_numbers=(0.1, 0.2, 0.3))


# ------------------------------------------------------------------------------------------------
# errors and rendering
# ------------------------------------------------------------------------------------------------
def test_batched_errors_name_agent_and_shape():
    task = blind_soccer_v0.batched_env(n_games=2, seed=0)
    with pytest.raises(ValueError, match=r"\(2, 2, 12\)"):
        task.step(np.zeros((2, 2, 8)))
    with pytest.raises(ValueError, match=r"\(2, 2, 12\)"):
        task.step(np.zeros((2, 12)))  # the (P, A) shortcut is for one game only
    actions = np.zeros((2, 2, 12))
    actions[1, 1, 9] = np.nan
    with pytest.raises(ValueError, match="'blind' in game 1"):
        task.step(actions)
    single = blind_soccer_v0.batched_env(n_games=1, seed=0)
    obs, *_ = single.step(np.zeros((2, 12)))
    assert obs.shape == (1, 2, 70)


def test_parallel_errors_name_agent_and_shape():
    env = guess_my_number_v0.parallel_env(seed=0)
    env.reset()
    good = np.zeros(9, dtype=np.float32)
    with pytest.raises(ValueError, match=r"'agent_1'.*\(9,\)"):
        env.step({"agent_0": good})
    with pytest.raises(ValueError, match=r"'agent_0'.*\(9,\)"):
        env.step({"agent_0": np.zeros(8), "agent_1": good})
    bad = good.copy()
    bad[3] = np.inf
    with pytest.raises(ValueError, match="'agent_1'"):
        env.step({"agent_0": good, "agent_1": bad})


def test_render_and_video(tmp_path):
    from envs.oracles import blind_soccer_oracle
    from envs.video import record_episode

    env = blind_soccer_v0.parallel_env(render_mode="rgb_array", seed=0)
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert blind_soccer_v0.parallel_env().render() is None

    def policy(obs):
        actions = blind_soccer_oracle(env.task)[0]
        return {agent: actions[i] for i, agent in enumerate(env.possible_agents)}

    path = record_episode(env, policy, tmp_path / "blind.gif", max_steps=4, seed=0)
    assert path.exists() and path.stat().st_size > 0
