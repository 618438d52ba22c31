"""Tests of HFO's referee (envs/soccer/referee.py) and episode reset (envs/soccer/reset.py)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from envs.soccer import referee
from envs.soccer.params import DEFAULT_PARAMS
from envs.soccer.referee import GOAL, IN_GAME, OUT_OF_BOUNDS, OUT_OF_TIME, judge
from envs.soccer.reset import HFO_OFFSETS, reset_state
from envs.soccer.state import SoccerState

P = DEFAULT_PARAMS


def balls(*positions: tuple[float, float], cycle: int = 0, touched: int = -1) -> SoccerState:
    s = SoccerState.zeros(len(positions), 2)
    s.ball_pos[:] = positions
    s.cycle[:] = cycle
    s.ball_touched[:] = touched
    return s


# ------------------------------------------------------------------------------------------------
# referee
# ------------------------------------------------------------------------------------------------
def test_status_values_and_names():
    assert (IN_GAME, GOAL, OUT_OF_BOUNDS, OUT_OF_TIME) == (0, 1, 2, 3)
    assert referee.STATUS_NAMES[GOAL] == "GOAL"


def test_goal_inside_the_posts_and_not_outside():
    """``Referee::crossGoalLine``: previous x <= 52.5 + ball_size < current x, and the line through
    both positions crosses x = 52.585 at |y| <= goal_width / 2 + goal_post_radius = 7.07."""
    before = balls((52.0, 0.0), (52.0, 7.0), (52.0, -7.07), (52.0, 7.08), (52.0, -7.5), (52.0, 0.0))
    after = balls((52.6, 0.0), (52.6, 7.0), (52.6, -7.07), (52.6, 7.08), (53.0, -7.5), (52.58, 0.0))
    np.testing.assert_array_equal(
        judge(after, P, max_cycles=100, previous=before), [GOAL, GOAL, GOAL, IN_GAME, IN_GAME, IN_GAME]
    )
    # one cycle later the balls beside the goal are out (judged on the previous position)
    later = balls((53.0, 7.08), (53.5, -7.5))
    np.testing.assert_array_equal(judge(later, P, 100, previous=after.select([3, 4])), [OUT_OF_BOUNDS] * 2)


def test_ball_crossing_between_the_posts_between_two_cycles_scores():
    """The server judges the path, not the end point (``Referee::crossGoalLine``: ``y_intercept =
    gradient * x + offset`` at x = 52.585, goal if ``|y_intercept| <= 7.07``):

    * (51.5, 9.0) -> (53.5, 6.0) ends in front of the goal but crosses at 9 - 1.085 * 1.5 =
      7.3725: no goal;
    * (51.5, 6.5) -> (53.5, 7.0) crosses at 6.5 + 1.085 * 0.25 = 6.77125: goal;
    * (51.5, 5.0) -> (53.5, 8.0) ends beside the post but crosses at 5 + 1.085 * 1.5 = 6.6275:
      goal. None of the three paths comes within 0.145 of a post centre (52.44, +-7.07).
    """
    before = balls((51.5, 9.0), (51.5, 6.5), (51.5, 5.0))
    after = balls((53.5, 6.0), (53.5, 7.0), (53.5, 8.0))
    np.testing.assert_array_equal(judge(after, P, 100, previous=before), [IN_GAME, GOAL, GOAL])
    # the same moves through the physics, one cycle each
    from envs.soccer import physics
    from envs.soccer.state import Commands

    s = before.copy()
    s.pos[:] = (10.0, 0.0)
    s.ball_vel[:] = ((2.0, -3.0), (2.0, 0.5), (2.0, 3.0))
    nxt = physics.step(s, Commands.noop(3, 2), P.without_noise(), np.random.default_rng(0))
    np.testing.assert_allclose(nxt.ball_pos, after.ball_pos, atol=1e-12)
    np.testing.assert_array_equal(judge(nxt, P, 100, previous=s), [IN_GAME, GOAL, GOAL])


def test_ball_rolling_into_a_post_does_not_score():
    """A ball rolling along y = 7.07 hits the post circle (52.44, 7.07), radius 0.06 + 0.085, and
    comes back: it never crosses the goal line and stays in play."""
    from envs.soccer import physics
    from envs.soccer.state import Commands

    s = balls((50.0, 7.07))
    s.pos[:] = (10.0, 0.0)
    s.ball_vel[:] = (2.0, 0.0)
    outcomes = []
    for _ in range(5):
        nxt = physics.step(s, Commands.noop(1, 2), P.without_noise(), np.random.default_rng(0))
        outcomes.append(int(judge(nxt, P, 100, previous=s)[0]))
        assert nxt.ball_pos[0, 0] < 52.44 - 0.145 + 1e-9
        s = nxt
    assert outcomes == [IN_GAME] * 5
    assert s.ball_vel[0, 0] < 0.0


def test_out_of_bounds_is_judged_on_the_previous_position():
    """``HFORef::analyse``: ``else if ( ! inHFOArea( M_prev_ball_pos ) )``, with inHFOArea
    0 <= x <= 52.5, |y| <= 34: a ball is declared out one cycle after it left."""
    before = balls((-0.01, 0.0), (0.0, 0.0), (30.0, 34.0), (30.0, -34.01), (52.5, 20.0), (52.51, 20.0))
    after = balls((-0.5, 0.0), (-0.5, 0.0), (30.0, 35.0), (30.0, -34.5), (52.9, 20.0), (52.9, 20.0))
    np.testing.assert_array_equal(
        judge(after, P, 100, previous=before),
        [OUT_OF_BOUNDS, IN_GAME, IN_GAME, OUT_OF_BOUNDS, IN_GAME, OUT_OF_BOUNDS],
    )
    # without a previous state the ball is taken not to have moved
    np.testing.assert_array_equal(judge(before, P, 100)[[0, 1]], [OUT_OF_BOUNDS, IN_GAME])


def test_goal_mouth_strip_stays_in_play():
    """A ball resting between the goal line and x = 52.585 is outside the HFO area: out next cycle
    unless it crosses the line; beside the posts it is out too."""
    s = balls((52.55, 3.0), (52.55, 10.0))
    np.testing.assert_array_equal(judge(s, P, 100, previous=s), [OUT_OF_BOUNDS, OUT_OF_BOUNDS])
    inside = balls((52.0, 3.0), (52.0, 10.0))
    np.testing.assert_array_equal(judge(s, P, 100, previous=inside), [IN_GAME, IN_GAME])
    goal = balls((52.7, 3.0), (52.7, 10.0))
    np.testing.assert_array_equal(judge(goal, P, 100, previous=s), [GOAL, OUT_OF_BOUNDS])


def test_out_of_time_and_priorities():
    prev = balls((20.0, 0.0), (20.0, 0.0), (60.0, 20.0), (52.0, 1.0))
    s = balls((20.0, 0.0), (20.0, 0.0), (60.0, 20.0), (52.7, 1.0))
    s.cycle[:] = [99, 100, 100, 100]
    np.testing.assert_array_equal(
        judge(s, P, 100, previous=prev), [IN_GAME, OUT_OF_TIME, OUT_OF_BOUNDS, GOAL]
    )


def test_untouched_time():
    """``if ( M_untouched_time > hfoMaxUntouchedTime() )`` is tested before the cycle is counted,
    so with a limit of 10 and the last touch at cycle t the game ends at cycle t + 12."""
    s = balls((20.0, 0.0), (20.0, 0.0), (20.0, 0.0), (20.0, 0.0))
    s.cycle[:] = [11, 12, 16, 17]
    s.ball_touched[:] = [-1, -1, 5, 5]
    np.testing.assert_array_equal(
        judge(s, P, 100, untouched_cycles=10), [IN_GAME, OUT_OF_TIME, IN_GAME, OUT_OF_TIME]
    )
    np.testing.assert_array_equal(judge(s, P, 100), [IN_GAME] * 4)


def test_judge_shape_and_dtype():
    out = judge(balls((10.0, 0.0), (10.0, 0.0), (10.0, 0.0)), P, 100)
    assert out.shape == (3,) and out.dtype == np.int64


# ------------------------------------------------------------------------------------------------
# reset
# ------------------------------------------------------------------------------------------------
def test_reset_placement_bounds():
    n = 3000
    s = reset_state(np.random.default_rng(0), n, 2, P)
    bx, by = s.ball_pos[:, 0], s.ball_pos[:, 1]
    assert bx.min() >= 0.0 and bx.max() <= 0.8 * 52.5
    assert bx.min() < 1.0 and bx.max() > 0.8 * 52.5 - 1.0  # the whole range is used
    assert np.abs(by).max() <= 27.2 and np.abs(by).max() > 27.0
    px, py = s.pos[..., 0], s.pos[..., 1]
    assert px.min() >= -0.1 and px.max() <= 52.5
    assert np.abs(py).max() <= 27.2
    assert (px == -0.1).any() and (np.abs(py) == 27.2).any()  # clipping happens
    np.testing.assert_array_equal(s.vel, 0.0)
    np.testing.assert_array_equal(s.ball_vel, 0.0)
    assert s.body.min() >= -180.0 and s.body.max() < 180.0 and s.body.std() > 90.0
    np.testing.assert_array_equal(s.stamina, 8000.0)
    np.testing.assert_array_equal(s.effort, 1.0)
    np.testing.assert_array_equal(s.recovery, 1.0)
    np.testing.assert_array_equal(s.cycle, 0)
    np.testing.assert_array_equal(s.ball_touched, -1)
    assert not (s.collided_ball.any() or s.collided_player.any() or s.collided_post.any())


def recovered_offsets(s: SoccerState) -> tuple[np.ndarray, np.ndarray]:
    """Offsets of the players whose position was not clipped, and which those are."""
    rel = (s.pos - s.ball_pos[:, None, :]) / P.reset_player_spread
    off = np.floor(rel)
    x, y = s.pos[..., 0], s.pos[..., 1]
    free = (x > -0.1) & (x < 52.5) & (np.abs(y) < 27.2)
    return off, free


def test_reset_offsets_are_a_shuffled_distinct_subset():
    n = 4000
    s = reset_state(np.random.default_rng(1), n, 2, P)
    off, free = recovered_offsets(s)
    both = free.all(axis=1)
    assert both.sum() > n / 4
    known = {tuple(o) for o in HFO_OFFSETS.tolist()}
    pairs = off[both]
    assert {tuple(o) for o in pairs.reshape(-1, 2).tolist()} == known  # every offset is used
    assert not np.all(pairs[:, 0] == pairs[:, 1], axis=1).any()  # distinct within a game
    # each player index takes each offset about equally often (a shuffle, not a fixed order)
    for i in range(2):
        counts = np.array([np.all(off[free[:, i], i] == o, axis=1).sum() for o in HFO_OFFSETS])
        assert counts.min() > 0.3 * counts.mean()


def test_reset_ten_players_use_every_offset():
    s = reset_state(np.random.default_rng(2), 50, 10, P)
    off, free = recovered_offsets(s)
    for g in np.flatnonzero(free.all(axis=1)):
        assert len({tuple(o) for o in off[g].tolist()}) == 10
    with pytest.raises(ValueError):
        reset_state(np.random.default_rng(2), 5, 11, P)


def test_reset_ball_x_range():
    s = reset_state(np.random.default_rng(3), 500, 2, P, ball_x_range=(0.5, 0.5))
    np.testing.assert_allclose(s.ball_pos[:, 0], 26.25)
    s = reset_state(np.random.default_rng(3), 500, 2, P, ball_x_range=(0.2, 0.4))
    assert s.ball_pos[:, 0].min() >= 0.2 * 52.5 and s.ball_pos[:, 0].max() <= 0.4 * 52.5


def test_reset_is_seeded():
    a = reset_state(np.random.default_rng(7), 20, 2, P)
    b = reset_state(np.random.default_rng(7), 20, 2, P)
    c = reset_state(np.random.default_rng(8), 20, 2, P)
    for f in dataclasses.fields(SoccerState):
        np.testing.assert_array_equal(getattr(a, f.name), getattr(b, f.name))
    assert not np.array_equal(a.pos, c.pos)
