"""Tests of the HFO low-level features (SPEC §3), index by index on hand-placed scenes, and
against a direct per-player transcription of HFO's feature extractor on random scenes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from envs.soccer import features as F
from envs.soccer import physics
from envs.soccer.params import DEFAULT_PARAMS
from envs.soccer.state import SoccerState

PARAMS = DEFAULT_PARAMS
MAX_DIST = 62.55
ATOL = 1e-5

# SPEC §3, written out independently of the module under test.
SPEC_LANDMARKS = [
    (52.5, 0.0),
    (52.5, -7.01),
    (52.5, 7.01),
    (36.0, 0.0),
    (36.0, -20.16),
    (36.0, 20.16),
    (0.0, 0.0),
    (0.0, -34.0),
    (52.5, -34.0),
    (52.5, 34.0),
    (0.0, 34.0),
]


def prox(d: float) -> float:
    return 1.0 - 2.0 * min(max(d / MAX_DIST, 0.0), 1.0)


def normalize(v: float, lo: float, hi: float) -> float:
    return min(max(2.0 * (v - lo) / (hi - lo) - 1.0, -1.0), 1.0)


def reference(state: SoccerState, g: int, i: int, n_opponents: int = 0) -> np.ndarray:
    """Features of player i of game g, transcribed from HFO's LowLevelFeatureExtractor with atan2."""
    x, y = state.pos[g, i]
    body = math.radians(state.body[g, i])

    def landmark(tx: float, ty: float) -> list[float]:
        dx, dy = tx - x, ty - y
        a = math.atan2(dy, dx) - body
        return [math.sin(a), math.cos(a), prox(math.hypot(dx, dy))]

    vx, vy = state.vel[g, i]
    f = [1.0, 1.0]
    a = body - math.atan2(vy, vx)
    f += [math.sin(a), math.cos(a), normalize(math.hypot(vx, vy), 0, 0.46)]
    f += [math.sin(body), math.cos(body), normalize(state.stamina[g, i], 0, 8000), -1.0]
    f += [1.0 if c else -1.0 for c in (state.collided_ball[g, i], state.collided_player[g, i])]
    f += [1.0 if state.collided_post[g, i] else -1.0]
    bx, by = state.ball_pos[g]
    f += [1.0 if math.hypot(bx - x, by - y) <= 1.03 else -1.0]  # librcsc: 1.085 - 0.055
    for lx, ly in SPEC_LANDMARKS:
        f += landmark(lx, ly)
    for v in (x / 52.5, (52.5 - x) / 52.5, (34 + y) / 68, (34 - y) / 68):
        f += [normalize(1.0 - min(max(v, 0.0), 1.0), 0, 1)]  # HFO addDistFeature: a proximity
    f += [1.0, *landmark(bx, by), 1.0]
    bvx, bvy = state.ball_vel[g]
    bdir = math.atan2(bvy, bvx)
    f += [normalize(math.hypot(bvx, bvy), 0, 5.0), math.sin(bdir), math.cos(bdir)]
    others = [j for j in range(state.n_players) if j != i]
    others.sort(key=lambda j: math.hypot(*(state.pos[g, j] - state.pos[g, i])))
    seen = [j for j in others if state.pos[g, j, 0] > 0]  # HFO 2016: teammate->pos().x > 0
    for j in seen:
        f += landmark(*state.pos[g, j])
        bj = math.radians(state.body[g, j])
        vj = state.vel[g, j]
        dj = math.atan2(vj[1], vj[0])
        f += [math.sin(bj), math.cos(bj), normalize(math.hypot(*vj), 0, 0.75), math.sin(dj), math.cos(dj)]
    f += [0.0] * (8 * (len(others) - len(seen)))  # unseen teammates: zero blocks at the end
    f += [0.0] * (8 * n_opponents)
    return np.array(f)


def scene(n_players: int = 1, pos=(20.0, 0.0), body: float = 0.0, ball=(30.0, 0.0)) -> SoccerState:
    """One game with player 0 at ``pos`` facing ``body``, the ball at ``ball``, all at rest."""
    s = SoccerState.zeros(1, n_players)
    s.pos[0, 0] = pos
    s.body[0, 0] = body
    s.ball_pos[0] = ball
    return s


def feats(state: SoccerState, player: int = 0, game: int = 0, n_opponents: int = 0) -> np.ndarray:
    return F.low_level_features(state, PARAMS, n_opponents)[game, player]


def random_state(rng: np.random.Generator, n: int, p: int) -> SoccerState:
    s = SoccerState.zeros(n, p)
    s.pos[:] = rng.uniform([-2, -36], [54, 36], size=(n, p, 2))
    s.vel[:] = rng.normal(0, 0.3, size=(n, p, 2))
    s.body[:] = rng.uniform(-180, 180, size=(n, p))
    s.stamina[:] = rng.uniform(0, 8000, size=(n, p))
    s.ball_pos[:] = rng.uniform([0, -34], [52.5, 34], size=(n, 2))
    # Put some balls near a player so that both kickable outcomes occur.
    s.ball_pos[::3] = s.pos[::3, 0] + rng.uniform(-1.3, 1.3, size=s.ball_pos[::3].shape)
    s.ball_vel[:] = rng.normal(0, 1.5, size=(n, 2))
    s.collided_ball[:] = rng.random((n, p)) < 0.5
    s.collided_player[:] = rng.random((n, p)) < 0.5
    s.collided_post[:] = rng.random((n, p)) < 0.5
    return s


# --- sizes and names ---------------------------------------------------------------------------


@pytest.mark.parametrize(("t", "o", "size"), [(0, 0, 58), (1, 0, 66), (1, 1, 74), (3, 2, 98)])
def test_feature_size(t: int, o: int, size: int) -> None:
    assert F.feature_size(t, o) == size
    assert len(F.feature_names(t, o)) == size


def test_feature_names_match_index_constants() -> None:
    names = F.feature_names(1, 1)
    assert len(set(names)) == len(names)
    assert names[F.BALL_ANGLE_SIN] == "ball_angle_sin"
    assert names[F.BALL_PROXIMITY] == "ball_proximity"
    assert names[F.KICKABLE] == "kickable"
    assert names[F.SELF_BODY_SIN] == "self_body_sin"
    assert names[F.EDGE_BOTTOM] == "edge_bottom"
    assert names[F.landmark_index("goal_center")] == "goal_center_sin"
    assert F.landmark_index("corner_bottom_left") == 43
    assert names[F.player_index(0, "speed", 1)] == "teammate0_speed"
    assert F.player_index(0, "angle_sin", 1, opponent=True) == 66
    assert names[-1] == "opponent0_vel_cos"
    assert (F.BALL_ANGLE_SIN, F.BALL_ANGLE_COS, F.BALL_PROXIMITY, F.KICKABLE, F.SELF_BODY_SIN) == (
        51,
        52,
        53,
        12,
        5,
    )


def test_negative_counts_raise() -> None:
    with pytest.raises(ValueError, match="negative"):
        F.feature_size(-1)


def test_landmarks_follow_spec() -> None:
    np.testing.assert_allclose(F.landmarks(PARAMS), SPEC_LANDMARKS)


@pytest.mark.parametrize(("n", "p", "o"), [(1, 1, 0), (3, 2, 0), (2, 2, 1), (2, 4, 3)])
def test_shape_dtype_and_opponent_zeros(n: int, p: int, o: int) -> None:
    s = random_state(np.random.default_rng(0), n, p)
    out = F.low_level_features(s, PARAMS, n_opponents=o)
    assert out.shape == (n, p, 58 + 8 * (p - 1) + 8 * o)
    assert out.dtype == np.float32
    assert out.flags.c_contiguous
    assert np.all(out[..., 58 + 8 * (p - 1) :] == 0.0)
    assert np.all(np.abs(out) <= 1.0)


# --- hand-placed scenes ------------------------------------------------------------------------


def test_ball_straight_ahead() -> None:
    f = feats(scene(pos=(20, 0), body=0, ball=(30, 0)))
    assert f[F.BALL_POS_VALID] == 1.0
    assert f[F.BALL_ANGLE_SIN] == pytest.approx(0.0, abs=ATOL)
    assert f[F.BALL_ANGLE_COS] == pytest.approx(1.0, abs=ATOL)
    assert f[F.BALL_PROXIMITY] == pytest.approx(1 - 2 * 10 / 62.55, abs=ATOL)


def test_ball_to_the_right_is_positive_angle() -> None:
    # y points down, so +y is to the right of a player facing +x.
    f = feats(scene(pos=(20, 0), body=0, ball=(20, 10)))
    assert f[F.BALL_ANGLE_SIN] == pytest.approx(1.0, abs=ATOL)
    assert f[F.BALL_ANGLE_COS] == pytest.approx(0.0, abs=ATOL)
    f = feats(scene(pos=(20, 0), body=0, ball=(20, -10)))
    assert f[F.BALL_ANGLE_SIN] == pytest.approx(-1.0, abs=ATOL)


def test_ball_behind() -> None:
    f = feats(scene(pos=(20, 0), body=0, ball=(5, 0)))
    assert f[F.BALL_ANGLE_SIN] == pytest.approx(0.0, abs=ATOL)
    assert f[F.BALL_ANGLE_COS] == pytest.approx(-1.0, abs=ATOL)


def test_far_ball_proximity_clips_to_minus_one() -> None:
    f = feats(scene(pos=(-10, -40), body=0, ball=(52.5, 34)))  # about 97 m away
    assert f[F.BALL_PROXIMITY] == -1.0


def test_body_angle_rotates_landmark_angles() -> None:
    gc = F.landmark_index("goal_center")
    # Facing the goal (body 0) from (20, 0): goal centre straight ahead, 32.5 m away.
    f = feats(scene(pos=(20, 0), body=0))
    np.testing.assert_allclose(f[gc : gc + 3], [0, 1, 1 - 2 * 32.5 / 62.55], atol=ATOL)
    # Body 90 (facing down, +y): the goal, at +x, is 90 degrees to the left: angle -90.
    f = feats(scene(pos=(20, 0), body=90))
    np.testing.assert_allclose(f[gc : gc + 3], [-1, 0, 1 - 2 * 32.5 / 62.55], atol=ATOL)
    assert f[F.SELF_BODY_SIN] == pytest.approx(1.0, abs=ATOL)
    assert f[F.SELF_BODY_COS] == pytest.approx(0.0, abs=ATOL)
    # Body -90 (facing up): goal to the right.
    f = feats(scene(pos=(20, 0), body=-90))
    np.testing.assert_allclose(f[gc : gc + 2], [1, 0], atol=ATOL)
    assert f[F.SELF_BODY_SIN] == pytest.approx(-1.0, abs=ATOL)


def test_landmarks_from_the_penalty_spot() -> None:
    f = feats(scene(pos=(41.5, 0), body=0))
    top_post = F.landmark_index("goal_post_top")
    d = math.hypot(11, 7.01)
    np.testing.assert_allclose(f[top_post : top_post + 3], [-7.01 / d, 11 / d, prox(d)], atol=ATOL)
    box = F.landmark_index("penalty_box_center")
    np.testing.assert_allclose(f[box : box + 3], [0, -1, prox(5.5)], atol=ATOL)
    corner = F.landmark_index("corner_bottom_right")
    d = math.hypot(11, 34)
    np.testing.assert_allclose(f[corner : corner + 3], [34 / d, 11 / d, prox(d)], atol=ATOL)


def test_player_on_a_landmark_has_direction_zero() -> None:
    # atan2(0, 0) = 0, so the angle is minus the body angle.
    f = feats(scene(pos=(0, 0), body=30))
    cf = F.landmark_index("center_field")
    np.testing.assert_allclose(f[cf : cf + 3], [-0.5, math.sqrt(3) / 2, 1.0], atol=ATOL)


@pytest.mark.parametrize(
    ("pos", "edges"),
    [
        ((0, -34), [1, -1, 1, -1]),
        ((52.5, 34), [-1, 1, -1, 1]),
        ((26.25, 0), [0, 0, 0, 0]),
        ((13.125, 17), [0.5, -0.5, -0.5, 0.5]),
        ((-5, 40), [1, -1, -1, 1]),  # out of the field: clipped
    ],
)
def test_edge_distances(pos: tuple[float, float], edges: list[float]) -> None:
    """HFO 2016 ``addDistFeature(dist, maxDist)``: ``proximity = 1 - max(0, min(1, dist/maxDist));
    addNormFeature(proximity, 0., 1.)``, i.e. 1 - 2 v: +1 standing on the edge (SPEC §6 item 8)."""
    f = feats(scene(pos=pos))
    np.testing.assert_allclose(f[F.EDGE_LEFT : F.EDGE_BOTTOM + 1], edges, atol=ATOL)


@pytest.mark.parametrize(
    ("dist", "expected"),
    [(0.5, 1.0), (1.0, 1.0), (1.029, 1.0), (1.05, -1.0), (1.08, -1.0), (1.2, -1.0), (5.0, -1.0)],
)
def test_kickable(dist: float, expected: float) -> None:
    """HFO's feature is librcsc's ``isKickable()``: ``ball.distFromSelf() <= kickableArea() - buf``
    with ``buf = 0.055`` for a ball seen this cycle, so 1.03, not the server's 1.085."""
    f = feats(scene(pos=(20, 0), body=45, ball=(20 - dist * 0.6, dist * 0.8)))
    assert f[F.KICKABLE] == expected


@pytest.mark.parametrize(
    ("stamina", "expected"), [(8000, 1.0), (4000, 0.0), (2000, -0.5), (0, -1.0), (9000, 1.0)]
)
def test_stamina(stamina: float, expected: float) -> None:
    s = scene()
    s.stamina[0, 0] = stamina
    assert feats(s)[F.STAMINA] == pytest.approx(expected, abs=ATOL)


@pytest.mark.parametrize(
    ("speed", "expected"), [(0.0, -1.0), (0.23, 0.0), (0.345, 0.5), (0.46, 1.0), (1.0, 1.0)]
)
def test_self_speed_normalised_and_clipped(speed: float, expected: float) -> None:
    s = scene(body=0)
    s.vel[0, 0] = (0.6 * speed, -0.8 * speed)
    assert feats(s)[F.SELF_SPEED] == pytest.approx(expected, abs=ATOL)


def test_self_velocity_angle_is_body_minus_velocity_direction() -> None:
    s = scene(body=0)
    s.vel[0, 0] = (0.0, 0.3)  # moving down (+y, direction +90) while facing +x
    f = feats(s)
    assert f[F.SELF_VEL_ANGLE_SIN] == pytest.approx(-1.0, abs=ATOL)  # sin(0 - 90)
    assert f[F.SELF_VEL_ANGLE_COS] == pytest.approx(0.0, abs=ATOL)
    s = scene(body=60)  # at rest: velocity direction 0, so the angle is the body angle
    f = feats(s)
    np.testing.assert_allclose(
        f[F.SELF_VEL_ANGLE_SIN : F.SELF_VEL_ANGLE_COS + 1], [math.sqrt(3) / 2, 0.5], atol=ATOL
    )


def test_kickable_agrees_with_the_simulator() -> None:
    s = random_state(np.random.default_rng(11), 300, 2)
    # Some balls right at the kickable distance, where float rounding decides.
    angle = np.linspace(0, 2 * np.pi, 100)
    ring = PARAMS.client_kickable_area * np.stack([np.cos(angle), np.sin(angle)], 1)
    s.ball_pos[:100] = s.pos[:100, 0] + ring
    kick = F.low_level_features(s, PARAMS)[..., F.KICKABLE]
    np.testing.assert_array_equal(kick == 1.0, physics.kickable(s, PARAMS))
    # A caller that has the test's result already can pass it in.
    given = np.zeros((300, 2), dtype=bool)
    given[5, 1] = True
    kick = F.low_level_features(s, PARAMS, kickable=given)[..., F.KICKABLE]
    np.testing.assert_array_equal(kick == 1.0, given)


def test_constant_and_flag_features() -> None:
    s = scene(ball=(40, 0))
    s.collided_player[0, 0] = True
    f = feats(s)
    assert (f[F.SELF_POS_VALID], f[F.SELF_VEL_VALID], f[F.BALL_POS_VALID], f[F.BALL_VEL_VALID]) == (
        1,
        1,
        1,
        1,
    )
    assert f[F.FROZEN] == -1.0
    assert (f[F.COLLIDING_BALL], f[F.COLLIDING_PLAYER], f[F.COLLIDING_POST]) == (-1.0, 1.0, -1.0)
    assert f[F.KICKABLE] == -1.0


def test_ball_velocity() -> None:
    s = scene()
    s.ball_vel[0] = (-1.5, 2.0)  # speed 2.5: normalised over [0, 5] to 0
    f = feats(s)
    assert f[F.BALL_SPEED] == pytest.approx(0.0, abs=ATOL)
    assert f[F.BALL_VEL_ANGLE_SIN] == pytest.approx(0.8, abs=ATOL)  # global, not body-relative
    assert f[F.BALL_VEL_ANGLE_COS] == pytest.approx(-0.6, abs=ATOL)
    s.ball_vel[0] = (7.0, 0.0)
    assert feats(s)[F.BALL_SPEED] == 1.0
    s.ball_vel[0] = (0.0, 0.0)
    f = feats(s)
    assert (f[F.BALL_SPEED], f[F.BALL_VEL_ANGLE_SIN], f[F.BALL_VEL_ANGLE_COS]) == (-1.0, 0.0, 1.0)


def test_teammates_sorted_by_distance() -> None:
    s = scene(n_players=3, pos=(20, 0), body=0)
    s.pos[0, 1] = (20, 10)  # 10 m, to the right
    s.pos[0, 2] = (25, 0)  # 5 m, ahead
    s.body[0, 1] = -90.0
    s.vel[0, 1] = (0.0, -0.375)  # speed 0.375: 0 over [0, 0.75]; moving up
    s.body[0, 2] = 180.0
    f = feats(s)
    assert f.shape == (58 + 16,)
    near, far = F.TEAMMATE_START, F.TEAMMATE_START + 8
    np.testing.assert_allclose(f[near : near + 8], [0, 1, prox(5), 0, -1, -1, 0, 1], atol=ATOL)
    np.testing.assert_allclose(f[far : far + 8], [1, 0, prox(10), -1, 0, 0, -1, 0], atol=ATOL)
    # Player 2 (at (25, 0), facing 180) sees player 0 first (5 m, ahead of it).
    f2 = feats(s, player=2)
    np.testing.assert_allclose(f2[near : near + 3], [0, 1, prox(5)], atol=ATOL)
    d = math.hypot(5, 10)  # player 1 is behind-right of it, facing left: relative (5, -10)
    np.testing.assert_allclose(f2[far : far + 3], [-10 / d, 5 / d, prox(d)], atol=ATOL)


def test_teammate_speed_clips() -> None:
    s = scene(n_players=2)
    s.pos[0, 1] = (10, 10)
    s.vel[0, 1] = (1.0, 0.0)
    assert feats(s)[F.player_index(0, "speed", 1)] == 1.0


def test_two_players_see_each_other() -> None:
    s = scene(n_players=2, pos=(10, 0), body=0)
    s.pos[0, 1] = (20, 0)
    s.body[0, 1] = 0
    out = F.low_level_features(s, PARAMS)
    np.testing.assert_allclose(out[0, 0, 58:61], [0, 1, prox(10)], atol=ATOL)
    np.testing.assert_allclose(out[0, 1, 58:61], [0, -1, prox(10)], atol=ATOL)


def test_players_on_top_of_each_other_do_not_produce_nan() -> None:
    s = SoccerState.zeros(2, 3)
    s.pos[:] = 1.0  # everything at (1, 1): x > 0, so the teammates are seen
    s.ball_pos[:] = 1.0
    out = F.low_level_features(s, PARAMS)
    assert np.isfinite(out).all()
    np.testing.assert_allclose(out[0, 0, 58:61], [0, 1, 1], atol=ATOL)
    assert out[0, 0, F.KICKABLE] == 1.0


# --- against the reference transcription ---------------------------------------------------


@pytest.mark.parametrize(("n", "p", "o"), [(50, 1, 0), (60, 2, 0), (40, 3, 1), (20, 5, 0)])
def test_matches_reference(n: int, p: int, o: int) -> None:
    s = random_state(np.random.default_rng(p), n, p)
    out = F.low_level_features(s, PARAMS, n_opponents=o)
    ref = np.array([[reference(s, g, i, o) for i in range(p)] for g in range(n)])
    np.testing.assert_allclose(out, ref, atol=2e-5)
    assert (out[..., F.KICKABLE] == 1).any() and (out[..., F.KICKABLE] == -1).any()


@pytest.mark.parametrize("p", [1, 2, 3])
def test_batched_equals_per_game(p: int) -> None:
    # 100 games take the large-batch path; the result must not depend on the batch.
    s = random_state(np.random.default_rng(7), 100, p)
    batched = F.low_level_features(s, PARAMS)
    for g in (0, 1, 57, 99):
        np.testing.assert_array_equal(batched[g], F.low_level_features(s.select([g]), PARAMS)[0])


def test_does_not_modify_state_and_repeats() -> None:
    s = random_state(np.random.default_rng(3), 10, 2)
    before = s.copy()
    a = F.low_level_features(s, PARAMS)
    b = F.low_level_features(s, PARAMS)
    assert a is not b
    np.testing.assert_array_equal(a, b)
    for name in ("pos", "vel", "body", "ball_pos", "ball_vel", "stamina"):
        np.testing.assert_array_equal(getattr(s, name), getattr(before, name))


def test_other_params_change_normalisers() -> None:
    s = scene()
    s.vel[0, 0] = (0.3, 0.0)
    f = F.low_level_features(s, PARAMS.replace(observed_self_speed_max=0.6))[0, 0]
    assert f[F.SELF_SPEED] == pytest.approx(0.0, abs=ATOL)
    f = F.low_level_features(s, PARAMS)[0, 0]
    assert f[F.SELF_SPEED] == pytest.approx(normalize(0.3, 0, 0.46), abs=ATOL)


def test_teammate_at_negative_x_gives_eight_zeros() -> None:
    """HFO 2016 ``ExtractFeatures``: ``if (teammate->pos().x > 0 && ...) addPlayerFeatures(...)``,
    then ``addFeature(0)`` for every missing teammate (SPEC §6 item 1)."""
    s = scene(n_players=2, pos=(10.0, 5.0))
    s.pos[0, 1] = (-1.0, 3.0)
    s.body[0, 1] = 30.0
    s.vel[0, 1] = (0.2, 0.1)
    f = F.low_level_features(s, PARAMS)
    np.testing.assert_array_equal(f[0, 0, F.TEAMMATE_START : F.TEAMMATE_START + 8], np.zeros(8))
    assert np.abs(f[0, 1, F.TEAMMATE_START : F.TEAMMATE_START + 8]).sum() > 0  # x = 10 is seen
    s.pos[0, 1] = (0.0, 3.0)  # x <= 0: still skipped
    f = F.low_level_features(s, PARAMS)
    np.testing.assert_array_equal(f[0, 0, F.TEAMMATE_START : F.TEAMMATE_START + 8], np.zeros(8))
    s.pos[0, 1] = (0.5, 3.0)
    f = F.low_level_features(s, PARAMS)
    np.testing.assert_allclose(f[0, 0], reference(s, 0, 0), atol=ATOL)
    assert f[0, 0, F.player_index(0, "proximity", 1)] != 0.0


def test_hidden_teammates_are_skipped_among_three() -> None:
    """With two teammates, the visible one fills the first block even when the hidden one is nearer."""
    s = scene(n_players=3, pos=(2.0, 0.0))
    s.pos[0, 1] = (-0.5, 0.0)  # nearest, but at x <= 0
    s.pos[0, 2] = (20.0, 0.0)
    f = F.low_level_features(s, PARAMS)[0, 0]
    np.testing.assert_allclose(f, reference(s, 0, 0), atol=ATOL)
    np.testing.assert_array_equal(f[F.TEAMMATE_START + 8 : F.TEAMMATE_START + 16], np.zeros(8))
    assert f[F.TEAMMATE_START + 2] == pytest.approx(1 - 2 * 18.0 / MAX_DIST, abs=ATOL)


def test_features_written_into_a_strided_view_match_and_stay_in_bounds() -> None:
    """``out=`` takes the feature part of an observation buffer (rows longer than the features):
    same values as a fresh array, the rest of each row untouched, every value in [-1, 1]."""
    rng = np.random.default_rng(5)
    s = SoccerState.zeros(300, 2)
    s.pos[:] = rng.uniform(-50, 50, size=s.pos.shape)
    s.ball_pos[:] = rng.uniform(-50, 50, size=s.ball_pos.shape)
    s.vel[:] = rng.uniform(-1, 1, size=s.vel.shape)
    s.body[:] = rng.uniform(-180, 180, size=s.body.shape)
    fresh = F.low_level_features(s)
    buffer = np.full((300, 2, fresh.shape[-1] + 4), 7.0, dtype=np.float32)
    returned = F.low_level_features(s, out=buffer[..., : fresh.shape[-1]])
    assert np.shares_memory(returned, buffer)
    np.testing.assert_array_equal(buffer[..., : fresh.shape[-1]], fresh)
    np.testing.assert_array_equal(buffer[..., fresh.shape[-1] :], 7.0)
    assert fresh.min() >= -1.0 and fresh.max() <= 1.0
    with pytest.raises(ValueError, match="out must be a float32 array of shape"):
        F.low_level_features(s, out=np.empty((300, 2, 3), dtype=np.float32))
