"""Tests of the rcssserver physics (envs/soccer/physics.py): each server formula with noise off,
then noise, purity and batching."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from envs.soccer import physics
from envs.soccer.params import DEFAULT_PARAMS, ServerParams
from envs.soccer.state import DASH, KICK, NOOP, TURN, Commands, SoccerState

EXACT = DEFAULT_PARAMS.without_noise()
FAR = (-20.0, -20.0)  # where the idle second player stands


def game(
    ball: tuple[float, float] = (10.0, 10.0),
    players: tuple[tuple[float, float], ...] = ((0.0, 0.0), FAR),
    body: tuple[float, ...] | None = None,
    ball_vel: tuple[float, float] = (0.0, 0.0),
    vel: tuple[tuple[float, float], ...] | None = None,
) -> SoccerState:
    """One game, everything at rest unless given."""
    s = SoccerState.zeros(1, len(players))
    s.ball_pos[0] = ball
    s.ball_vel[0] = ball_vel
    s.pos[0] = players
    if vel is not None:
        s.vel[0] = vel
    if body is not None:
        s.body[0] = body
    return s


def command(kind: int, power: float = 0.0, direction: float = 0.0, n_players: int = 2) -> Commands:
    """Player 0 sends one command, the others nothing."""
    c = Commands.noop(1, n_players)
    c.kind[0, 0] = kind
    c.power[0, 0] = power
    c.direction[0, 0] = direction
    return c


def run(state: SoccerState, commands: Commands, params: ServerParams = EXACT, seed: int = 0) -> SoccerState:
    return physics.step(state, commands, params, np.random.default_rng(seed))


def idle(state: SoccerState, cycles: int, params: ServerParams = EXACT) -> SoccerState:
    for _ in range(cycles):
        state = run(state, Commands.noop(state.n_games, state.n_players), params)
    return state


# ------------------------------------------------------------------------------------------------
# dash
# ------------------------------------------------------------------------------------------------
def test_full_power_dash_from_rest_moves_0_6_then_settles_at_1_0():
    s = game()
    steps = []
    for _ in range(40):
        nxt = run(s, command(DASH, 100.0, 0.0))
        steps.append(nxt.pos[0, 0] - s.pos[0, 0])
        s = nxt
    assert steps[0][0] == pytest.approx(0.6, abs=1e-12)
    assert steps[1][0] == pytest.approx(0.4 * 0.6 + 0.6, abs=1e-12)
    assert steps[-1][0] == pytest.approx(1.0, abs=1e-9)
    assert s.vel[0, 0, 0] / EXACT.player_decay == pytest.approx(1.0, abs=1e-9)  # velocity before decay
    assert np.allclose([d[1] for d in steps], 0.0)


@pytest.mark.parametrize(
    ("direction", "rate", "unit"),
    [
        (0.0, 1.0, (1.0, 0.0)),
        (45.0, 0.7, (np.sqrt(0.5), np.sqrt(0.5))),
        (90.0, 0.4, (0.0, 1.0)),  # side dash: y points down
        (-90.0, 0.4, (0.0, -1.0)),
        (135.0, 0.5, (-np.sqrt(0.5), np.sqrt(0.5))),
        (180.0, 0.6, (-1.0, 0.0)),  # back dash
    ],
)
def test_dash_direction_rates_give_the_acceleration(direction, rate, unit):
    nxt = run(game(), command(DASH, 100.0, direction))
    accel = nxt.pos[0, 0]  # from rest the first displacement is the acceleration
    np.testing.assert_allclose(accel, rate * 0.6 * np.array(unit), atol=1e-12)


def test_direction_rate_formula_hits_the_server_constants():
    d = np.array([0.0, 45.0, 90.0, 135.0, 180.0, -45.0, -180.0])
    r = physics.dash_direction_rate(d, EXACT)
    np.testing.assert_allclose(r, [1.0, 0.7, 0.4, 0.5, 0.6, 0.7, 0.6], atol=1e-15)
    assert r[2] == pytest.approx(EXACT.side_dash_rate)
    assert r[4] == pytest.approx(EXACT.back_dash_rate)
    other = EXACT.replace(side_dash_rate=0.2, back_dash_rate=0.9)
    np.testing.assert_allclose(physics.dash_direction_rate(d, other)[[2, 3, 4]], [0.2, 0.55, 0.9])


def test_dash_direction_snaps_to_the_45_degree_grid():
    d = physics.dash_direction(np.array([20.0, 25.0, -112.0, 22.5, 67.5, 200.0, -200.0, 179.0]), EXACT)
    np.testing.assert_array_equal(d, [0.0, 45.0, -90.0, 0.0, 90.0, 180.0, -180.0, 180.0])
    nxt = run(game(), command(DASH, 100.0, 20.0))  # executed as a straight dash
    np.testing.assert_allclose(nxt.pos[0, 0], [0.6, 0.0], atol=1e-12)


def test_dash_follows_the_body_angle():
    nxt = run(game(body=(-90.0, 0.0)), command(DASH, 100.0, 0.0))
    np.testing.assert_allclose(nxt.pos[0, 0], [0.0, -0.6], atol=1e-12)


def test_negative_power_dashes_backwards_and_costs_twice():
    back = run(game(), command(DASH, -50.0, 0.0))
    np.testing.assert_allclose(back.pos[0, 0], [-50 * 0.006, 0.0], atol=1e-12)
    assert back.stamina[0, 0] == pytest.approx(8000 - 100 + 45)
    fwd = run(game(), command(DASH, 50.0, 0.0))
    assert fwd.stamina[0, 0] == pytest.approx(8000 - 50 + 45)
    assert back.stamina[0, 1] == 8000.0  # the idle player pays nothing


def test_dash_power_is_limited_by_stamina():
    s = game()
    s.stamina[0, 0] = 30.0
    nxt = run(s, command(DASH, 100.0, 0.0))
    assert nxt.pos[0, 0, 0] == pytest.approx(30 * 0.006)
    # stamina hit 0 (<= 30%): recovery and effort drop before the recovery is added
    assert nxt.recovery[0, 0] == pytest.approx(1.0 - 0.002)
    assert nxt.effort[0, 0] == pytest.approx(1.0 - 0.005)
    assert nxt.stamina[0, 0] == pytest.approx(0.998 * 45)


def test_dash_power_is_clipped_and_effort_scales_it():
    nxt = run(game(), command(DASH, 250.0, 0.0))
    assert nxt.pos[0, 0, 0] == pytest.approx(0.6)
    s = game()
    s.effort[0, 0] = 0.8
    assert run(s, command(DASH, 100.0, 0.0)).pos[0, 0, 0] == pytest.approx(0.48)


# ------------------------------------------------------------------------------------------------
# turn
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("speed", [0.0, 0.1, 0.3])
def test_turn_is_damped_by_speed(speed):
    s = game(vel=((speed, 0.0), (0.0, 0.0)), body=(10.0, 0.0))
    nxt = run(s, command(TURN, 0.0, 90.0))
    assert nxt.body[0, 0] == pytest.approx(10.0 + 90.0 / (1.0 + 5.0 * speed), abs=1e-12)
    assert nxt.body[0, 1] == 0.0


def test_turn_moment_is_clipped_and_body_wraps():
    nxt = run(game(body=(170.0, 0.0)), command(TURN, 0.0, 300.0))
    assert nxt.body[0, 0] == pytest.approx(170.0 + 180.0 - 360.0)
    nxt = run(game(body=(-170.0, 0.0)), command(TURN, 0.0, -30.0))
    assert nxt.body[0, 0] == pytest.approx(160.0)
    nxt = run(game(body=(90.0, 0.0)), command(TURN, 0.0, 90.0))
    assert nxt.body[0, 0] == -180.0  # [-180, 180)


@pytest.mark.parametrize(("angle", "speed"), [(30.0, 0.2), (-12.5, 0.5), (5.0, 0.0), (60.0, 0.4)])
def test_hfo_turn_pre_scaling_turns_the_agent_by_what_it_asked(angle, speed):
    moment = physics.hfo_turn_moment(np.array([[angle, 0.0]]), np.array([[speed, 0.0]]), EXACT)
    assert moment[0, 0] == pytest.approx(angle * (1 + 5 * speed))
    s = game(vel=((speed, 0.0), (0.0, 0.0)))
    nxt = run(s, command(TURN, 0.0, moment[0, 0]))
    assert nxt.body[0, 0] == pytest.approx(angle, abs=1e-12)


def test_hfo_turn_pre_scaling_is_clipped_for_large_angles():
    moment = physics.hfo_turn_moment(np.array([120.0]), np.array([0.2]), EXACT)
    assert moment[0] == 180.0
    nxt = run(game(vel=((0.2, 0.0), (0.0, 0.0))), command(TURN, 0.0, moment[0]))
    assert nxt.body[0, 0] == pytest.approx(90.0)


# ------------------------------------------------------------------------------------------------
# kick
# ------------------------------------------------------------------------------------------------
def test_full_power_kick_leaves_at_2_7_and_rolls_45_m():
    s = run(game(ball=(0.385, 0.0)), command(KICK, 100.0, 0.0))
    assert s.ball_pos[0, 0] - 0.385 == pytest.approx(2.7, abs=1e-12)
    assert s.ball_vel[0, 0] == pytest.approx(2.7 * 0.94, abs=1e-12)
    # HFO's referee counts a touch by proximity at the end of a cycle, not by kicks:
    # "if ( ppos.distance2( ball.pos() ) < pow( kickableArea(), 2 ) ) M_untouched_time = 0"
    assert s.ball_touched[0] == -1 and s.cycle[0] == 1
    s = idle(s, 300)
    assert abs(s.ball_pos[0, 0] - 0.385 - 45.0) < 0.5
    assert s.ball_pos[0, 1] == 0.0


def kick_accel(ball: tuple[float, float], power: float = 100.0, direction: float = 0.0, body: float = 0.0):
    """Ball displacement in the first cycle after a kick from rest (its acceleration)."""
    nxt = run(game(ball=ball, body=(body, 0.0)), command(KICK, power, direction))
    return nxt.ball_pos[0] - np.asarray(ball)


def test_kick_power_drops_with_ball_angle_and_distance():
    # ball at 90 degrees from the body, at the feet: 1 - 0.25 * 90 / 180
    np.testing.assert_allclose(kick_accel((0.0, 0.385)), [2.7 * 0.875, 0.0], atol=1e-12)
    # ball straight ahead at 1.0: 1 - 0.25 * (1.0 - 0.385) / 0.7
    np.testing.assert_allclose(kick_accel((1.0, 0.0)), [2.7 * (1 - 0.25 * 0.615 / 0.7), 0.0], atol=1e-12)
    # both, behind-left at 135 degrees and 0.8 m, half power, kicked towards -90
    b = 0.8 * np.array([np.cos(np.radians(135)), np.sin(np.radians(135))])
    rate = 1 - 0.25 * 135 / 180 - 0.25 * (0.8 - 0.385) / 0.7
    np.testing.assert_allclose(kick_accel(tuple(b), 50.0, -90.0), [0.0, -50 * 0.027 * rate], atol=1e-12)
    # relative to the body: body 90, ball at +y is straight ahead
    np.testing.assert_allclose(kick_accel((0.0, 0.385), body=90.0), [0.0, 2.7], atol=1e-12)


def test_kick_effective_power_formula():
    eff = physics.kick_effective_power(np.array([80.0]), np.array([45.0]), np.array([0.35]), EXACT)
    assert eff[0] == pytest.approx(80 * 0.027 * (1 - 0.0625 - 0.125))


def test_no_kick_outside_the_kickable_area():
    nxt = run(game(ball=(1.09, 0.0)), command(KICK, 100.0, 0.0))
    np.testing.assert_array_equal(nxt.ball_pos[0], [1.09, 0.0])
    assert nxt.ball_touched[0] == -1
    assert kick_accel((1.029, 0.0))[0] > 2.0


def test_kick_at_1_05_m_is_refused():
    """librcsc ``PlayerAgent::doKick`` sends nothing unless ``world().self().isKickable()``, and
    ``isKickable`` is ``ball.distFromSelf() <= kickableArea() - 0.055`` (ball seen this cycle):
    1.03. The server alone (``Player::kick``, 1.085) would have accepted a kick at 1.05."""
    np.testing.assert_array_equal(kick_accel((1.05, 0.0)), [0.0, 0.0])
    server_only = EXACT.replace(kickable_buffer=0.0)
    rate = 1 - 0.25 * (1.05 - 0.385) / 0.7
    nxt = run(game(ball=(1.05, 0.0)), command(KICK, 100.0, 0.0), server_only)
    np.testing.assert_allclose(nxt.ball_pos[0], [1.05 + 2.7 * rate, 0.0], atol=1e-12)


def test_negative_kick_power_becomes_zero():
    """librcsc ``Effector::setKick``: ``if ( command_power < 0.0 ) command_power = 0.0``."""
    np.testing.assert_array_equal(kick_accel((0.385, 0.0), power=-100.0), [0.0, 0.0])


def test_kickable_boundaries_client_1_03_server_1_085():
    assert EXACT.kickable_area == pytest.approx(1.085)
    assert EXACT.client_kickable_area == pytest.approx(1.03)
    s = game(ball=(0.0, 0.0), players=((1.0299, 0.0), (0.0, -1.0301)))
    np.testing.assert_array_equal(physics.kickable(s, EXACT), [[True, False]])
    np.testing.assert_array_equal(physics.server_kickable(s, EXACT), [[True, True]])
    s = game(ball=(0.0, 0.0), players=((1.0849, 0.0), (0.0, -1.0851)))
    np.testing.assert_array_equal(physics.server_kickable(s, EXACT), [[True, False]])


def test_kick_accel_is_capped_at_ball_accel_max():
    # ball inside the player (dist 0.2 < 0.385) makes the rate above 1: 2.7 * 1.066 is capped
    np.testing.assert_allclose(kick_accel((0.2, 0.0)), [2.7, 0.0], atol=1e-12)


def test_two_kicks_add_up():
    s = game(ball=(0.0, 0.0), players=((-0.385, 0.0), (0.0, 0.385)), body=(0.0, -90.0))
    c = Commands(np.array([[KICK, KICK]]), np.array([[50.0, 50.0]]), np.array([[0.0, 0.0]]))
    nxt = run(s, c)
    np.testing.assert_allclose(nxt.ball_pos[0], [1.35, -1.35], atol=1e-12)


# ------------------------------------------------------------------------------------------------
# movement
# ------------------------------------------------------------------------------------------------
def test_speed_caps():
    s = game(vel=((1.0, 0.0), (0.0, 0.0)))
    nxt = run(s, command(DASH, 100.0, 0.0))
    assert nxt.pos[0, 0, 0] == pytest.approx(1.05)
    assert nxt.vel[0, 0, 0] == pytest.approx(1.05 * 0.4)
    s = game(ball=(0.385, 0.0), ball_vel=(2.9, 0.0))
    nxt = run(s, command(KICK, 100.0, 0.0))
    assert nxt.ball_pos[0, 0] - 0.385 == pytest.approx(3.0)
    assert nxt.ball_vel[0, 0] == pytest.approx(3.0 * 0.94)


def test_player_accel_cap():
    params = EXACT.replace(player_accel_max=0.3)
    nxt = run(game(), command(DASH, 100.0, 0.0), params)
    assert nxt.pos[0, 0, 0] == pytest.approx(0.3)


def test_decays():
    nxt = run(game(), command(DASH, 100.0, 0.0))
    assert nxt.vel[0, 0, 0] == pytest.approx(0.6 * 0.4)
    s = game(ball=(10.0, 10.0), ball_vel=(1.0, -0.5), vel=((0.2, 0.1), (0.0, 0.0)))
    nxt = run(s, Commands.noop(1, 2))
    np.testing.assert_allclose(nxt.ball_pos[0], [11.0, 9.5])
    np.testing.assert_allclose(nxt.ball_vel[0], [0.94, -0.47])
    np.testing.assert_allclose(nxt.pos[0, 0], [0.2, 0.1])
    np.testing.assert_allclose(nxt.vel[0, 0], [0.08, 0.04])


def test_players_stay_within_the_pitch_margin():
    s = game(players=((57.3, -38.9), FAR), vel=((0.4, -0.4), (0.0, 0.0)))
    nxt = run(s, command(DASH, 100.0, 0.0))
    np.testing.assert_allclose(nxt.pos[0, 0], [57.5, -39.0])


# ------------------------------------------------------------------------------------------------
# collisions
# ------------------------------------------------------------------------------------------------
def test_ball_player_collision_moves_both_apart_and_reflects():
    """``Stadium::calcCollisionPos`` (play on): ``mid = (a + b) / 2; mid2a.normalize((a->size() +
    b->size()) / 2.0 + EPS); apos = mid + mid2a; bpos = mid + mid2b``, then
    ``updateCollisionVel``: ``M_vel *= -0.1`` for both (SPEC §6 item 5)."""
    s = game(ball=(1.0, 0.0), ball_vel=(-0.7, 0.0), vel=((0.05, 0.0), (0.0, 0.0)))
    nxt = run(s, Commands.noop(1, 2))
    # after the move: player at 0.05, ball at 0.3; midpoint 0.175, each 0.1925 from it
    assert nxt.pos[0, 0, 0] == pytest.approx(0.175 - 0.1925, abs=1e-9)
    assert nxt.ball_pos[0, 0] == pytest.approx(0.175 + 0.1925, abs=1e-9)
    assert nxt.ball_pos[0, 0] - nxt.pos[0, 0, 0] == pytest.approx(0.385)  # touching distance
    assert nxt.ball_vel[0, 0] == pytest.approx(-0.7 * 0.94 * -0.1)
    assert nxt.vel[0, 0, 0] == pytest.approx(0.05 * 0.4 * -0.1)
    np.testing.assert_array_equal(nxt.collided_ball, [[True, False]])
    assert not nxt.collided_player.any() and not nxt.collided_post.any()
    after = idle(nxt, 1)
    assert not after.collided_ball.any()  # flags describe the last cycle only


def test_coincident_ball_and_player_separate_along_x():
    """The server separates coincident objects at a random angle; here along x (player +x)."""
    nxt = run(game(ball=(3.0, 4.0), players=((3.0, 4.0), FAR)), Commands.noop(1, 2))
    np.testing.assert_allclose(nxt.ball_pos[0], [3.0 - 0.1925, 4.0], atol=1e-9)
    np.testing.assert_allclose(nxt.pos[0, 0], [3.0 + 0.1925, 4.0], atol=1e-9)


def test_dash_into_a_resting_ball_moves_both():
    """Player at 0 dashes at full power (0.6 m), the ball rests at 0.8: after the move they are
    0.2 apart, so each goes 0.1925 (+ EPS) from the midpoint 0.7; ball velocity 0 * -0.1 = 0,
    player 0.6 * 0.4 * -0.1."""
    nxt = run(game(ball=(0.8, 0.0)), command(DASH, 100.0, 0.0))
    assert nxt.pos[0, 0, 0] == pytest.approx(0.7 - 0.1925, abs=1e-9)
    assert nxt.ball_pos[0, 0] == pytest.approx(0.7 + 0.1925, abs=1e-9)
    assert nxt.vel[0, 0, 0] == pytest.approx(0.6 * 0.4 * -0.1)
    np.testing.assert_array_equal(nxt.ball_vel[0], [0.0, 0.0])
    np.testing.assert_array_equal(nxt.collided_ball, [[True, False]])


def test_collision_passes_repeat_until_nothing_overlaps():
    """``Stadium::collisions``: ``do { ... } while ( col && max_loop > 0 )`` with max_loop = 10.
    The ball squeezed between two overlapping players: each pass averages the targets of an
    object's pairs, so the overlaps shrink pass after pass, and after the tenth the server stops
    with a small overlap left. Every collided object's velocity is reflected once."""
    s = game(ball=(10.3, 0.0), players=((10.0, 0.0), (10.45, 0.0)))
    s.ball_vel[0] = (0.01, 0.0)
    nxt = run(s, Commands.noop(1, 2))
    gap = np.abs(nxt.pos[0, :, 0] - nxt.ball_pos[0, 0])
    assert 0.38 < gap.min() < 0.385  # from 0.15: nine more passes did most, not all, of the work
    one_pass = physics.COLLISION_PASSES
    try:
        physics.COLLISION_PASSES = 1
        after_one = run(s, Commands.noop(1, 2))
    finally:
        physics.COLLISION_PASSES = one_pass
    assert np.abs(after_one.pos[0, :, 0] - after_one.ball_pos[0, 0]).min() < 0.3
    assert nxt.ball_vel[0, 0] == pytest.approx(0.01 * 0.94 * -0.1)
    np.testing.assert_array_equal(nxt.collided_ball, [[True, True]])
    np.testing.assert_array_equal(nxt.collided_player, [[True, True]])


def test_player_player_collision_splits_the_correction():
    s = game(players=((0.0, 0.0), (0.4, 0.0)), vel=((0.1, 0.0), (0.0, 0.0)))
    nxt = run(s, Commands.noop(1, 2))
    np.testing.assert_allclose(nxt.pos[0, :, 0], [-0.05, 0.55], atol=1e-9)  # + EPS each
    np.testing.assert_allclose(nxt.pos[0, :, 1], [0.0, 0.0], atol=1e-12)
    assert nxt.vel[0, 0, 0] == pytest.approx(0.1 * 0.4 * -0.1)
    np.testing.assert_array_equal(nxt.collided_player, [[True, True]])


def test_coincident_players_separate_along_x():
    nxt = run(game(players=((5.0, 5.0), (5.0, 5.0))), Commands.noop(1, 2))
    np.testing.assert_allclose(nxt.pos[0], [[4.7, 5.0], [5.3, 5.0]], atol=1e-9)


POST = (52.5 - 0.06, 7.01 + 0.06)
"""``nearestPost``: ``PVector( PITCH_LENGTH*0.5 - goalPostRadius(), goalWidth()*0.5 +
goalPostRadius() )``, a circle of radius ``goalPostRadius() + size`` for an object of ``size``."""


def test_player_inside_a_post_is_put_on_its_circle():
    """``MPObject::_inc``: ``while ( ( pos() - post.center() ).r() < post.radius() ) { diff.normalize(
    post.radius() ); M_pos = post.center() + diff; ... }`` with radius 0.06 + 0.3."""
    s = game(players=((52.3, 7.01), (52.5, -7.2)))
    nxt = run(s, Commands.noop(1, 2))
    touch = 0.3 + 0.06
    for i, (x, y) in enumerate(((52.3, 7.01), (52.5, -7.2))):
        cx, cy = POST[0], np.sign(y) * POST[1]
        d = np.hypot(x - cx, y - cy)
        want = [cx + (x - cx) * touch / d, cy + (y - cy) * touch / d]
        np.testing.assert_allclose(nxt.pos[0, i], want, atol=1e-12)
    np.testing.assert_array_equal(nxt.collided_post, [[True, True]])


def test_ball_rolling_into_a_post_bounces():
    """Ball at (50, 7.07) rolling +x at 2.0 (then 1.88): the second move (52 -> 53.88) meets the
    circle x = 52.44 - (0.06 + 0.085) = 52.295 after 0.295 m; ``rem.x = -rem.x`` sends the
    remaining 1.585 m back, and the speed is kept (``M_vel = fromPolar( M_vel.r(), rem.th() )``)."""
    s = game(ball=(50.0, POST[1]), ball_vel=(2.0, 0.0))
    s = run(s, Commands.noop(1, 2))
    np.testing.assert_allclose(s.ball_pos[0], [52.0, POST[1]], atol=1e-12)
    s = run(s, Commands.noop(1, 2))
    assert s.ball_pos[0, 0] == pytest.approx(52.295 - (1.88 - 0.295), abs=1e-9)
    assert s.ball_pos[0, 1] == pytest.approx(POST[1], abs=1e-9)
    assert s.ball_vel[0, 0] == pytest.approx(-1.88 * 0.94, abs=1e-9)


@pytest.mark.parametrize(("gap", "bounces"), [(2.8, True), (2.9, False)])
def test_fast_ball_bounces_only_when_its_move_enters_the_post(gap, bounces):
    """A ball moving at 2.7 straight at a post from ``gap`` metres: from 2.8 m its move enters
    the circle of radius 0.06 + 0.085 after 2.655 m and the last 0.045 m go back; from 2.9 m it
    stops 0.2 m from the centre, outside the circle, and nothing happens (the far-off objects
    the simulator skips before testing posts must not include it)."""
    r = 0.06 + 0.085
    s = game(ball=(POST[0] - gap, POST[1]), ball_vel=(2.7, 0.0))
    nxt = run(s, Commands.noop(1, 2))
    if bounces:
        assert nxt.ball_pos[0, 0] == pytest.approx(POST[0] - r - (2.7 - (gap - r)), abs=1e-9)
        assert nxt.ball_vel[0, 0] == pytest.approx(-2.7 * 0.94, abs=1e-9)
    else:
        assert nxt.ball_pos[0, 0] == pytest.approx(POST[0] - gap + 2.7, abs=1e-12)
        assert nxt.ball_vel[0, 0] == pytest.approx(2.7 * 0.94, abs=1e-12)
    assert nxt.ball_pos[0, 1] == pytest.approx(POST[1], abs=1e-9)


def test_ball_glancing_off_a_post_is_mirrored_about_the_centre_line():
    """A move that enters the post circle off-centre: the rest of the move is mirrored about the
    line from the entry point to the post centre; the object ends outside the circle."""
    start = np.array([51.0, POST[1] - 0.1])
    s = game(ball=tuple(start), ball_vel=(2.0, 0.0))
    nxt = run(s, Commands.noop(1, 2))
    r = 0.06 + 0.085
    ex = POST[0] - np.sqrt(r * r - 0.1 * 0.1)  # entry point on the circle
    entry = np.array([ex, start[1]])
    u = (np.array(POST) - entry) / r
    rest = np.array([start[0] + 2.0 - ex, 0.0])
    rest -= 2 * rest.dot(u) * u
    np.testing.assert_allclose(nxt.ball_pos[0], entry + rest, atol=1e-9)
    np.testing.assert_allclose(nxt.ball_vel[0], rest / np.linalg.norm(rest) * 2.0 * 0.94, atol=1e-9)
    assert np.hypot(*(nxt.ball_pos[0] - POST)) > r


# ------------------------------------------------------------------------------------------------
# stamina
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("stamina", "effort", "recovery", "want_effort", "want_recovery"),
    [
        (2400.0, 1.0, 1.0, 0.995, 0.998),  # <= 30%: both drop
        (2401.0, 0.9, 0.9, 0.9, 0.9),  # between the thresholds: nothing
        (4800.0, 0.9, 0.9, 0.91, 0.9),  # >= 60%: effort recovers
        (4799.0, 0.9, 0.9, 0.9, 0.9),
        (100.0, 0.6, 0.5, 0.6, 0.5),  # minimums
        (8000.0, 0.995, 1.0, 1.0, 1.0),  # maximum
    ],
)
def test_stamina_thresholds(stamina, effort, recovery, want_effort, want_recovery):
    st, ef, rc = physics.update_stamina(np.array([stamina]), np.array([effort]), np.array([recovery]), EXACT)
    assert ef[0] == pytest.approx(want_effort)
    assert rc[0] == pytest.approx(want_recovery)
    assert st[0] == pytest.approx(min(stamina + want_recovery * 45.0, 8000.0))


def test_stamina_update_mixed_batch_matches_single_values():
    stamina = np.array([[2400.0, 8000.0], [4800.0, 3000.0]])
    effort = np.full((2, 2), 0.9)
    recovery = np.full((2, 2), 0.9)
    st, ef, rc = physics.update_stamina(stamina, effort, recovery, EXACT)
    np.testing.assert_allclose(ef, [[0.895, 0.91], [0.91, 0.9]])
    np.testing.assert_allclose(rc, [[0.898, 0.9], [0.9, 0.9]])
    np.testing.assert_allclose(st, [[2400 + 0.898 * 45, 8000.0], [4800 + 0.9 * 45, 3000 + 0.9 * 45]])


# ------------------------------------------------------------------------------------------------
# noise
# ------------------------------------------------------------------------------------------------
def random_batch(n: int, seed: int = 0, spread: float = 2.0) -> tuple[SoccerState, Commands]:
    """n games with players near the ball (so kicks and collisions happen) and random commands."""
    rng = np.random.default_rng(seed)
    s = SoccerState.zeros(n, 2)
    s.ball_pos[:] = rng.uniform([5.0, -20.0], [45.0, 20.0], (n, 2))
    s.ball_vel[:] = rng.uniform(-1.0, 1.0, (n, 2))
    s.pos[:] = s.ball_pos[:, None, :] + rng.uniform(-spread, spread, (n, 2, 2))
    s.vel[:] = rng.uniform(-0.3, 0.3, (n, 2, 2))
    s.body[:] = rng.uniform(-180.0, 180.0, (n, 2))
    s.stamina[:] = rng.uniform(0.0, 8000.0, (n, 2))
    s.effort[:] = rng.uniform(0.6, 1.0, (n, 2))
    s.recovery[:] = rng.uniform(0.5, 1.0, (n, 2))
    s.cycle[:] = rng.integers(0, 50, n)
    c = Commands(
        rng.integers(0, 4, (n, 2)), rng.uniform(-120.0, 120.0, (n, 2)), rng.uniform(-200.0, 200.0, (n, 2))
    )
    return s, c


def assert_states_equal(a: SoccerState, b: SoccerState) -> None:
    for f in dataclasses.fields(SoccerState):
        np.testing.assert_array_equal(getattr(a, f.name), getattr(b, f.name), err_msg=f.name)


def test_same_seed_same_states_different_seed_different():
    s, c = random_batch(32)
    a = run(s, c, DEFAULT_PARAMS, seed=5)
    b = run(s, c, DEFAULT_PARAMS, seed=5)
    assert_states_equal(a, b)
    d = run(s, c, DEFAULT_PARAMS, seed=6)
    assert not np.array_equal(a.pos, d.pos)
    assert not np.array_equal(a.ball_pos, d.ball_pos)
    exact = run(s, c, EXACT)
    assert not np.allclose(a.pos, exact.pos)


def test_kick_noise_is_bounded_by_the_formula():
    n = 4000
    params = EXACT.replace(kick_rand=0.1, ball_accel_max=10.0)  # only kick noise, no cap
    s = SoccerState.zeros(n, 2)
    s.ball_pos[:] = (0.385, 0.0)
    s.pos[:, 1] = FAR
    c = Commands.noop(n, 2)
    c.kind[:, 0] = KICK
    c.power[:, 0] = 100.0
    nxt = physics.step(s, c, params, np.random.default_rng(1))
    noise = nxt.ball_pos - (0.385 + 2.7, 0.0)
    mag = np.sqrt((noise**2).sum(axis=1))
    max_rand = 0.1 * 1.0 * ((0.5 + 0.0) + (0.5 + 0.0))  # pos_rate + speed_rate at the feet, at rest
    assert mag.max() <= max_rand + 1e-12
    assert mag.max() > 0.95 * max_rand  # the bound is reached: U(0, max_rand)
    assert mag.mean() == pytest.approx(max_rand / 2, rel=0.05)
    angles = np.arctan2(noise[:, 1], noise[:, 0])
    assert np.histogram(angles, bins=4, range=(-np.pi, np.pi))[0].min() > n / 4 * 0.85


def test_kick_noise_function_at_the_top_draw():
    nx, ny = physics.kick_noise(
        np.array([50.0]),
        np.array([90.0]),
        np.array([0.35]),
        np.array([1.41]),
        np.array([1.0]),
        np.array([0.75]),  # direction U(-pi, pi) = pi / 2
        DEFAULT_PARAMS,
    )
    pos_rate = 0.5 + 0.25 * (90 / 180 + 0.35 / 0.7)
    speed_rate = 0.5 + 0.5 * 1.41 / (3.0 * 0.94)
    assert np.hypot(nx[0], ny[0]) == pytest.approx(0.1 * 0.5 * (pos_rate + speed_rate))
    assert nx[0] == pytest.approx(0.0, abs=1e-12) and ny[0] > 0


def test_movement_and_turn_noise_are_bounded():
    n = 2000
    params = DEFAULT_PARAMS.replace(kick_rand=0.0)
    s = SoccerState.zeros(n, 2)
    s.ball_pos[:] = (20.0, 0.0)
    s.ball_vel[:] = (1.0, 0.0)
    s.pos[:, 1] = FAR
    c = Commands.noop(n, 2)
    c.kind[:, 0] = TURN
    c.direction[:, 0] = 90.0
    nxt = physics.step(s, c, params, np.random.default_rng(2))
    dev = nxt.ball_pos - (21.0, 0.0)
    dev = np.sqrt((dev**2).sum(axis=1))
    assert dev.max() <= 0.05 + 1e-12 and dev.max() > 0.045
    assert nxt.body[:, 0].min() >= 81.0 - 1e-9 and nxt.body[:, 0].max() <= 99.0 + 1e-9
    assert nxt.body[:, 0].std() > 3.0


# ------------------------------------------------------------------------------------------------
# purity and batching
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("params", [EXACT, DEFAULT_PARAMS])
def test_step_does_not_mutate_its_input(params):
    s, c = random_batch(64, spread=0.6)
    s_before, c_before = s.copy(), Commands(c.kind.copy(), c.power.copy(), c.direction.copy())
    nxt = physics.step(s, c, params, np.random.default_rng(0))
    assert_states_equal(s, s_before)
    np.testing.assert_array_equal(c.kind, c_before.kind)
    np.testing.assert_array_equal(c.power, c_before.power)
    np.testing.assert_array_equal(c.direction, c_before.direction)
    for f in dataclasses.fields(SoccerState):
        assert not np.shares_memory(getattr(nxt, f.name), getattr(s, f.name)), f.name
    assert nxt.collided_ball.any() and nxt.collided_player.any()  # the batch exercised collisions


def test_batched_step_equals_games_one_at_a_time():
    n = 48
    s, c = random_batch(n, seed=3, spread=1.0)
    s.pos[0] = ((52.4, 6.9), (52.6, -7.2))  # posts
    s.ball_pos[1] = s.pos[1, 0]  # coincident ball
    kinds_seen = set()
    for _ in range(4):
        batched = run(s, c)
        for i in range(n):
            single = run(s.select([i]), Commands(c.kind[[i]], c.power[[i]], c.direction[[i]]))
            assert_states_equal(single, batched.select([i]))
        kinds_seen |= set(np.unique(c.kind).tolist())
        s = batched
    assert kinds_seen == {DASH, TURN, KICK, NOOP}
    assert batched.cycle.min() >= 4


# ------------------------------------------------------------------------------------------------
# an independent scalar transcription of SPEC §3 (noise off), one game and one object at a time
# ------------------------------------------------------------------------------------------------
EPS = 1e-10  # rcssserver utility.h


def reference_step(s: SoccerState, c: Commands, p: ServerParams) -> SoccerState:
    """Plain-Python rcssserver cycle for noise-free params, written from the SPEC formulas."""
    import math

    out = s.copy()
    n, n_players = s.body.shape
    for g in range(n):
        bax = bay = 0.0
        pacc = [(0.0, 0.0)] * n_players
        for i in range(n_players):
            kind, power, direction = int(c.kind[g, i]), float(c.power[g, i]), float(c.direction[g, i])
            body = float(s.body[g, i])
            px, py = s.pos[g, i]
            if kind == DASH:
                power = min(max(power, p.minpower), p.maxpower)
                d = min(max(direction, p.min_dash_angle), p.max_dash_angle)
                d = 45.0 * round(d / 45.0)  # Python rounds halves to even, like rint
                need = power if power >= 0 else -2.0 * power
                need = min(need, float(s.stamina[g, i]))
                out.stamina[g, i] = max(0.0, s.stamina[g, i] - need)
                used = need if power >= 0 else -need / 2.0
                a = abs(d)
                rate = 0.4 + 0.6 * (1 - a / 90) if a <= 90 else 0.6 - 0.2 * (1 - (a - 90) / 90)
                mag = abs(s.effort[g, i] * used * rate * p.dash_power_rate)
                ang = math.radians(body + d + (180.0 if used < 0 else 0.0))
                pacc[i] = (mag * math.cos(ang), mag * math.sin(ang))
            elif kind == TURN:
                m = min(max(direction, p.minmoment), p.maxmoment)
                speed = math.hypot(*s.vel[g, i])
                b = body + m / (1 + p.inertia_moment * speed)
                while b >= 180:
                    b -= 360
                while b < -180:
                    b += 360
                out.body[g, i] = b
            elif kind == KICK:
                rx, ry = s.ball_pos[g, 0] - px, s.ball_pos[g, 1] - py
                dist = math.hypot(rx, ry)
                if dist <= p.kickable_area - 0.055:  # librcsc's kickable test
                    power = min(max(power, 0.0), p.maxpower)  # librcsc: negative power -> 0
                    dir_diff = abs((math.degrees(math.atan2(ry, rx)) - body + 180) % 360 - 180)
                    gap = dist - p.player_size - p.ball_size
                    eff = (
                        power
                        * p.kick_power_rate
                        * (1 - 0.25 * dir_diff / 180 - 0.25 * gap / p.kickable_margin)
                    )
                    ang = math.radians(body + min(max(direction, p.minmoment), p.maxmoment))
                    bax += eff * math.cos(ang)
                    bay += eff * math.sin(ang)

        def nearest(q):  # rcssserver nearestPost
            post_x, post_y = p.half_length - p.goal_post_radius, p.goal_width / 2 + p.goal_post_radius
            return (post_x if q[0] > 0 else -post_x, post_y if q[1] > 0 else -post_y)

        def entry(b, e, c, r):  # rcssserver intersect: fraction of the move b -> e entering (c, r)
            sx, sy, ox, oy = e[0] - b[0], e[1] - b[1], b[0] - c[0], b[1] - c[1]
            a = sx * sx + sy * sy
            if a == 0.0:
                return None
            hb = ox * sx + oy * sy
            disc = hb * hb - a * (ox * ox + oy * oy - r * r)
            if disc <= 0.0:
                return None
            t1, t2 = (-hb - math.sqrt(disc)) / a, (-hb + math.sqrt(disc)) / a
            in1, in2 = 0.0 <= t1 <= 1.0, 0.0 <= t2 <= 1.0
            if not (in1 or in2):
                return None
            t = t1 if in1 else t2
            if t == 0.0 and not (in1 and in2):
                return None
            return t

        def move(pos, vel, acc, amax, smax, decay, size):
            ax, ay = acc
            a = math.hypot(ax, ay)
            if a > amax:
                ax, ay = ax * amax / a, ay * amax / a
            vx, vy = vel[0] + ax, vel[1] + ay
            v = math.hypot(vx, vy)
            if v > smax:
                vx, vy = vx * smax / v, vy * smax / v
            r = p.goal_post_radius + size
            bx, by = float(pos[0]), float(pos[1])
            hit = False
            c = nearest((bx, by))
            if math.hypot(bx - c[0], by - c[1]) < r:  # inside a post: out, velocity mirrored
                bx, by = out_to(c, (bx, by), r)
                while math.hypot(bx - c[0], by - c[1]) < r:
                    bx, by = c[0] + (bx - c[0]) * 1.01, c[1] + (by - c[1]) * 1.01
                nx, ny = c[0] - bx, c[1] - by
                k = 2 * (vx * nx + vy * ny) / (nx * nx + ny * ny)
                vx, vy = vx - k * nx, vy - k * ny
                hit = True
            ex, ey = bx + vx, by + vy
            for _ in range(4):
                c1, c2 = nearest((bx, by)), nearest((ex, ey))
                t = entry((bx, by), (ex, ey), c1, r)
                c = c1
                if t is None and c2 != c1:
                    t, c = entry((bx, by), (ex, ey), c2, r), c2
                if t is None:
                    break
                ix, iy = bx + t * (ex - bx), by + t * (ey - by)
                ux, uy = c[0] - ix, c[1] - iy
                un = math.hypot(ux, uy)
                ux, uy = ux / un, uy / un
                rx, ry = ex - ix, ey - iy
                k = 2 * (rx * ux + ry * uy)
                rx, ry = rx - k * ux, ry - k * uy
                bx, by = ix - EPS * ux, iy - EPS * uy
                ex, ey = bx + rx, by + ry
                speed, rest = math.hypot(vx, vy), math.hypot(rx, ry)
                vx, vy = speed * rx / rest, speed * ry / rest
                hit = True
            return [ex, ey], [vx * decay, vy * decay], hit

        def out_to(anchor, point, touch):
            dx, dy = point[0] - anchor[0], point[1] - anchor[1]
            d = math.hypot(dx, dy)
            if d == 0:
                return [anchor[0] + touch, anchor[1]]
            return [anchor[0] + dx * touch / d, anchor[1] + dy * touch / d]

        lim_x, lim_y = p.half_length + p.pitch_margin, p.half_width + p.pitch_margin
        pos, vel, cpost = [], [], []
        for i in range(n_players):
            q, v, h = move(
                s.pos[g, i],
                s.vel[g, i],
                pacc[i],
                p.player_accel_max,
                p.player_speed_max,
                p.player_decay,
                p.player_size,
            )
            pos.append([min(max(q[0], -lim_x), lim_x), min(max(q[1], -lim_y), lim_y)])
            vel.append(v)
            cpost.append(h)
        ball, bvel, _ = move(
            s.ball_pos[g],
            s.ball_vel[g],
            (bax, bay),
            p.ball_accel_max,
            p.ball_speed_max,
            p.ball_decay,
            p.ball_size,
        )

        def separate(a, b, size_sum):  # calcCollisionPos: both to (size_a + size_b) / 2 + EPS from the mid
            mid = [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2]
            dx, dy = a[0] - mid[0], a[1] - mid[1]
            d = math.hypot(dx, dy)
            if d < EPS:
                dx, dy, d = -1.0, 0.0, 1.0
            h = size_sum / 2 + EPS
            return [mid[0] + dx * h / d, mid[1] + dy * h / d], [mid[0] - dx * h / d, mid[1] - dy * h / d]

        cb, cp = [False] * n_players, [False] * n_players
        for _ in range(10):  # Stadium::collisions: up to ten passes while something overlaps
            targets = {k: [] for k in range(-1, n_players)}  # -1: the ball
            for i in range(n_players):
                if math.hypot(ball[0] - pos[i][0], ball[1] - pos[i][1]) < p.ball_size + p.player_size:
                    a, b = separate(ball, pos[i], p.ball_size + p.player_size)
                    targets[-1].append(a)
                    targets[i].append(b)
                    cb[i] = True
            for i in range(n_players):
                for j in range(i + 1, n_players):
                    if math.hypot(pos[j][0] - pos[i][0], pos[j][1] - pos[i][1]) < 2 * p.player_size:
                        a, b = separate(pos[i], pos[j], 2 * p.player_size)
                        targets[i].append(a)
                        targets[j].append(b)
                        cp[i] = cp[j] = True
            if not any(targets.values()):
                break
            for k, ts in targets.items():
                if ts:
                    mean = [sum(t[0] for t in ts) / len(ts), sum(t[1] for t in ts) / len(ts)]
                    if k < 0:
                        ball = mean
                    else:
                        pos[k] = mean
        for i in range(n_players):
            if cb[i] or cp[i]:
                vel[i] = [-0.1 * vel[i][0], -0.1 * vel[i][1]]
        if any(cb):
            bvel = [-0.1 * bvel[0], -0.1 * bvel[1]]
        out.pos[g], out.vel[g], out.ball_pos[g], out.ball_vel[g] = pos, vel, ball, bvel
        out.collided_ball[g], out.collided_player[g], out.collided_post[g] = cb, cp, cpost
        out.cycle[g] = s.cycle[g] + 1
        if any(math.hypot(ball[0] - q[0], ball[1] - q[1]) < p.kickable_area for q in pos):
            out.ball_touched[g] = out.cycle[g]  # HFORef: a player within kickable_area touches it
        for i in range(n_players):  # stamina model, on the stamina after the dash
            st, ef, rc = out.stamina[g, i], out.effort[g, i], out.recovery[g, i]
            if st <= 0.3 * 8000:
                rc = max(rc - 0.002, 0.5)
                ef = max(ef - 0.005, 0.6)
            if st >= 0.6 * 8000:
                ef = min(ef + 0.01, 1.0)
            out.stamina[g, i], out.effort[g, i], out.recovery[g, i] = min(st + rc * 45, 8000), ef, rc
    return out


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_step_matches_a_scalar_transcription_of_the_spec(seed):
    s, c = random_batch(200, seed=seed, spread=1.2)
    s.pos[:4] = ((52.4, 6.9), (52.7, -7.2))  # goal posts
    s.pos[4:8, 1] = s.pos[4:8, 0] + 0.1  # overlapping players
    s.ball_pos[8:12] = s.pos[8:12, 0] + 0.2  # ball inside a player
    s.ball_pos[12:16] = s.pos[12:16].mean(axis=1)  # ball between both players
    s.ball_pos[16:24] = ((50.5, 7.0), (50.5, -7.1), (51.0, 6.9), (51.0, -7.2)) * 2  # at the posts
    s.ball_vel[16:24] = (2.5, 0.05)
    seen = np.zeros(3, dtype=bool)
    bounced = np.zeros(8, dtype=bool)
    for _ in range(3):
        got = run(s, c)
        want = reference_step(s, c, EXACT)
        for f in dataclasses.fields(SoccerState):
            np.testing.assert_allclose(
                getattr(got, f.name), getattr(want, f.name), rtol=0, atol=1e-9, err_msg=f.name
            )
        seen |= [got.collided_ball.any(), got.collided_player.any(), got.collided_post.any()]
        bounced |= (got.ball_vel[16:24, 0] < 0) & (s.ball_vel[16:24, 0] > 0)
        s = got
    assert seen.all()
    assert bounced.sum() >= 4  # balls came off the posts


def test_three_players_match_the_scalar_transcription():
    rng = np.random.default_rng(9)
    n = 100
    s = SoccerState.zeros(n, 3)
    s.ball_pos[:] = rng.uniform(10.0, 30.0, (n, 2))
    s.pos[:] = s.ball_pos[:, None, :] + rng.uniform(-0.7, 0.7, (n, 3, 2))
    s.vel[:] = rng.uniform(-0.2, 0.2, (n, 3, 2))
    s.body[:] = rng.uniform(-180.0, 180.0, (n, 3))
    c = Commands(
        rng.integers(0, 4, (n, 3)), rng.uniform(-100.0, 100.0, (n, 3)), rng.uniform(-180, 180, (n, 3))
    )
    got = run(s, c)
    want = reference_step(s, c, EXACT)
    for f in dataclasses.fields(SoccerState):
        np.testing.assert_allclose(
            getattr(got, f.name), getattr(want, f.name), rtol=0, atol=1e-9, err_msg=f.name
        )
    assert (got.collided_ball.sum(axis=1) >= 2).any()


def test_float32_commands_give_the_float64_result():
    s, c = random_batch(32, seed=5, spread=1.0)
    c.power = c.power.astype(np.float32).astype(np.float64)
    c.direction = c.direction.astype(np.float32).astype(np.float64)
    c32 = Commands(c.kind.astype(np.int32), c.power.astype(np.float32), c.direction.astype(np.float32))
    assert_states_equal(run(s, c32), run(s, c))


@pytest.mark.parametrize("bit_generator", [np.random.PCG64, np.random.MT19937])
def test_uniform_draws_are_generator_random_bit_for_bit(bit_generator) -> None:
    """The fast uniform draw gives Generator.random's numbers and leaves the same state behind."""
    fast, slow = np.random.Generator(bit_generator(7)), np.random.Generator(bit_generator(7))
    for shape in ((3, 12), (1024, 12), (1, 1)):
        np.testing.assert_array_equal(physics.uniform(fast, shape), slow.random(shape))
    assert fast.random() == slow.random()
