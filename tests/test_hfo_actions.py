"""Tests of the HFO action vector and its decoding into server commands."""

import numpy as np
import pytest

from envs.soccer import physics
from envs.soccer.params import DEFAULT_PARAMS
from envs.soccer.state import DASH, KICK, NOOP, TURN, SoccerState
from envs.tasks.hfo_actions import ACTION_HIGH, ACTION_LOW, HYBRID_LAYOUT, decode_actions


def _actions(rows):
    return np.array(rows, dtype=np.float64)[None]  # (1, P, 8)


def test_bounds_and_layout():
    np.testing.assert_array_equal(ACTION_LOW, [-1, -1, -1, 0, -180, -180, 0, -180])
    np.testing.assert_array_equal(ACTION_HIGH, [1, 1, 1, 100, 180, 180, 100, 180])
    assert ACTION_LOW.dtype == np.float32
    assert HYBRID_LAYOUT == {"n_actions": 3, "parameters": [[3, 4], [5], [6, 7]]}
    params = sorted(i for group in HYBRID_LAYOUT["parameters"] for i in group)
    assert params == list(range(HYBRID_LAYOUT["n_actions"], 8))


def test_argmax_picks_the_command_and_its_parameters():
    state = SoccerState.zeros(1, 3)
    actions = _actions(
        [
            [0.9, 0.1, -0.5, 70.0, 45.0, 10.0, 20.0, -30.0],  # dash
            [-1.0, 0.2, 0.1, 70.0, 45.0, 33.0, 20.0, -30.0],  # turn
            [-1.0, -1.0, 0.0, 70.0, 45.0, 10.0, 20.0, -30.0],  # kick
        ]
    )
    cmd = decode_actions(actions, state, DEFAULT_PARAMS)
    np.testing.assert_array_equal(cmd.kind[0], [DASH, TURN, KICK])
    assert cmd.power[0, 0] == 70.0 and cmd.direction[0, 0] == 45.0
    assert cmd.direction[0, 1] == 33.0  # at rest the pre-scaling is the identity
    assert cmd.power[0, 2] == 20.0 and cmd.direction[0, 2] == -30.0


def test_ties_go_to_the_lowest_index():
    state = SoccerState.zeros(1, 3)
    actions = np.zeros((1, 3, 8))
    actions[0, 0, :3] = [0.5, 0.5, 0.5]
    actions[0, 1, :3] = [-1.0, 0.3, 0.3]
    actions[0, 2, :3] = [0.2, -1.0, 0.2]
    cmd = decode_actions(actions, state, DEFAULT_PARAMS)
    np.testing.assert_array_equal(cmd.kind[0], [DASH, TURN, DASH])


def test_turn_is_prescaled_with_the_current_speed():
    state = SoccerState.zeros(2, 1)
    state.vel[0, 0] = [0.12, 0.16]  # speed 0.2 -> factor 1 + 5 * 0.2 = 2
    state.vel[1, 0] = [0.6, 0.0]  # factor 4: 60 degrees asks for 240, clipped to 180
    actions = np.zeros((2, 1, 8))
    actions[:, 0, 1] = 1.0
    actions[:, 0, 5] = 60.0
    cmd = decode_actions(actions, state, DEFAULT_PARAMS)
    assert cmd.kind[0, 0] == TURN
    np.testing.assert_allclose(cmd.direction[:, 0], [120.0, 180.0])
    np.testing.assert_allclose(
        cmd.direction[:, 0], physics.hfo_turn_moment(np.array([60.0, 60.0]), [0.2, 0.6], DEFAULT_PARAMS)
    )


def test_player_that_cannot_dash_gets_a_noop():
    state = SoccerState.zeros(1, 2)
    actions = np.zeros((1, 2, 8))
    actions[0, :, 0] = 1.0  # both pick dash
    cmd = decode_actions(actions, state, DEFAULT_PARAMS, can_dash=np.array([False, True]))
    np.testing.assert_array_equal(cmd.kind[0], [NOOP, DASH])
    actions[0, 0, :3] = [0.0, 1.0, 0.0]  # turning is still allowed
    cmd = decode_actions(actions, state, DEFAULT_PARAMS, can_dash=np.array([False, True]))
    np.testing.assert_array_equal(cmd.kind[0], [TURN, DASH])
    with pytest.raises(ValueError, match="can_dash"):
        decode_actions(actions, state, DEFAULT_PARAMS, can_dash=np.array([True]))


def test_out_of_range_values_are_left_for_the_server():
    state = SoccerState.zeros(1, 2)
    actions = _actions([[1, 0, 0, 250.0, 400.0, 0, 0, 0], [0, 0, 1, 0, 0, 0, -50.0, -700.0]])
    cmd = decode_actions(actions, state, DEFAULT_PARAMS)
    assert cmd.power[0, 0] == 250.0 and cmd.direction[0, 0] == 400.0
    assert cmd.power[0, 1] == -50.0 and cmd.direction[0, 1] == -700.0


def test_message_entries_are_ignored():
    state = SoccerState.zeros(1, 1)
    actions = np.zeros((1, 1, 12))
    actions[0, 0, :3] = [0, 0, 1]
    actions[0, 0, 8:] = 5.0
    assert decode_actions(actions, state, DEFAULT_PARAMS).kind[0, 0] == KICK


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_values_name_the_player(bad):
    state = SoccerState.zeros(2, 2)
    actions = np.zeros((2, 2, 8))
    actions[1, 1, 6] = bad
    with pytest.raises(ValueError, match="player 1 in game 1"):
        decode_actions(actions, state, DEFAULT_PARAMS)


def test_wrong_shape_raises():
    with pytest.raises(ValueError, match=r"\(N, P, 8\)"):
        decode_actions(np.zeros((2, 5)), SoccerState.zeros(1, 2), DEFAULT_PARAMS)
