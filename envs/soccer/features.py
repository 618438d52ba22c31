"""HFO low-level state features (2016 layout), computed for every player of a batch of games.

Source: the Half Field Offense simulator's ``LowLevelFeatureExtractor``
(``src/lowlevel_feature_extractor.cpp`` and ``src/feature_extractor.cpp`` of ``LARG/HFO``,
2016 versions), i.e. the 58 + 8·T + 8·O egocentric features the paper's agents saw. SPEC §3
("Observation: HFO low-level features, 2016 layout") is the contract; this module computes
exactly that table from the full simulator state (every valid flag is +1, since the
simulator has no perception noise).

Encoding rules (as in HFO):

- booleans and valid flags are +1 / -1, and a feature whose valid flag is -1 is 0;
- angles are (sin, cos); the angle of a landmark, the ball or a player is its direction from
  the player minus the player's body angle, and a zero-length vector has direction 0
  (``atan2(0, 0)``);
- ``normalize(v, lo, hi) = 2 (v - lo) / (hi - lo) - 1``, clipped to [-1, 1];
- the proximity of an object at distance d is ``1 - 2 clip(d / 62.55, 0, 1)``.

Two points where SPEC §3's table reads differently follow HFO's 2016 code (SPEC §6 items 1, 8):
the edge features 46-49 are HFO's ``addDistFeature``, a proximity ``1 - 2 clip(v, 0, 1)`` of the
normalised distance v (+1 on the edge, -1 across the field), not ``2 v - 1``; and a teammate
whose x <= 0 is skipped (``teammate->pos().x > 0`` in ``ExtractFeatures``): its 8 features are
0, as for a missing player, and the visible teammates fill the blocks nearest first.

Speed: everything is computed for all ``N × P`` players at once, in float32 (which numpy
vectorises best) and feature-major, (F, N·P), so that every operation runs over long contiguous
rows; one transposition at the end gives the (N, P, F) result. Directions use rotation
identities instead of ``arctan2``: the only transcendental calls are one ``sin`` and one
``cos`` of the body angles. Work arrays are reused between calls of the same batch shape.
"""

from __future__ import annotations

import math
import threading

import numpy as np

from envs.soccer import physics
from envs.soccer.params import DEFAULT_PARAMS, ServerParams
from envs.soccer.state import SoccerState

__all__ = [
    "BALL_ANGLE_COS",
    "BALL_ANGLE_SIN",
    "BALL_POS_VALID",
    "BALL_PROXIMITY",
    "BALL_SPEED",
    "BALL_VEL_ANGLE_COS",
    "BALL_VEL_ANGLE_SIN",
    "BALL_VEL_VALID",
    "COLLIDING_BALL",
    "COLLIDING_PLAYER",
    "COLLIDING_POST",
    "EDGE_BOTTOM",
    "EDGE_LEFT",
    "EDGE_RIGHT",
    "EDGE_TOP",
    "FEATURES_PER_PLAYER",
    "FROZEN",
    "KICKABLE",
    "LANDMARK_NAMES",
    "LANDMARK_START",
    "NUM_BASIC_FEATURES",
    "NUM_LANDMARKS",
    "SELF_BODY_COS",
    "SELF_BODY_SIN",
    "SELF_POS_VALID",
    "SELF_SPEED",
    "SELF_VEL_ANGLE_COS",
    "SELF_VEL_ANGLE_SIN",
    "SELF_VEL_VALID",
    "STAMINA",
    "TEAMMATE_START",
    "feature_names",
    "feature_size",
    "landmark_index",
    "landmarks",
    "low_level_features",
    "player_index",
]

# --- indices of the basic features (SPEC §3 table) --------------------------------------------
SELF_POS_VALID = 0
SELF_VEL_VALID = 1
SELF_VEL_ANGLE_SIN = 2
"""sin of (body angle - velocity direction)."""
SELF_VEL_ANGLE_COS = 3
SELF_SPEED = 4
SELF_BODY_SIN = 5
SELF_BODY_COS = 6
STAMINA = 7
FROZEN = 8
COLLIDING_BALL = 9
COLLIDING_PLAYER = 10
COLLIDING_POST = 11
KICKABLE = 12
LANDMARK_START = 13
"""First landmark feature; landmark ``k`` occupies ``13 + 3k`` (sin), ``+1`` (cos), ``+2`` (proximity)."""
NUM_LANDMARKS = 11
EDGE_LEFT = 46
EDGE_RIGHT = 47
EDGE_TOP = 48
EDGE_BOTTOM = 49
BALL_POS_VALID = 50
BALL_ANGLE_SIN = 51
BALL_ANGLE_COS = 52
BALL_PROXIMITY = 53
BALL_VEL_VALID = 54
BALL_SPEED = 55
BALL_VEL_ANGLE_SIN = 56
"""sin of the global ball-velocity direction."""
BALL_VEL_ANGLE_COS = 57
NUM_BASIC_FEATURES = 58
TEAMMATE_START = 58
FEATURES_PER_PLAYER = 8

LANDMARK_NAMES: tuple[str, ...] = (
    "goal_center",
    "goal_post_top",
    "goal_post_bottom",
    "penalty_box_center",
    "penalty_box_top",
    "penalty_box_bottom",
    "center_field",
    "corner_top_left",
    "corner_top_right",
    "corner_bottom_right",
    "corner_bottom_left",
)
"""The 11 landmarks in HFO's order (SPEC §3)."""

_PLAYER_FIELDS = (
    "angle_sin",
    "angle_cos",
    "proximity",
    "body_sin",
    "body_cos",
    "speed",
    "vel_sin",
    "vel_cos",
)
_BASIC_NAMES: tuple[str, ...] = (
    "self_pos_valid",
    "self_vel_valid",
    "self_vel_angle_sin",
    "self_vel_angle_cos",
    "self_speed",
    "self_body_sin",
    "self_body_cos",
    "stamina",
    "frozen",
    "colliding_ball",
    "colliding_player",
    "colliding_post",
    "kickable",
    *(f"{name}_{part}" for name in LANDMARK_NAMES for part in ("sin", "cos", "proximity")),
    "edge_left",
    "edge_right",
    "edge_top",
    "edge_bottom",
    "ball_pos_valid",
    "ball_angle_sin",
    "ball_angle_cos",
    "ball_proximity",
    "ball_vel_valid",
    "ball_speed",
    "ball_vel_angle_sin",
    "ball_vel_angle_cos",
)
assert len(_BASIC_NAMES) == NUM_BASIC_FEATURES


def feature_size(n_teammates: int, n_opponents: int = 0) -> int:
    """Number of low-level features, ``58 + 8 T + 8 O``.

    :param n_teammates: number of teammates ``T`` (players of the game other than oneself).
    :param n_opponents: number of opponents ``O``.
    :return: the feature vector's length.
    """
    if n_teammates < 0 or n_opponents < 0:
        raise ValueError(f"negative player count: n_teammates={n_teammates}, n_opponents={n_opponents}")
    return NUM_BASIC_FEATURES + FEATURES_PER_PLAYER * (n_teammates + n_opponents)


def feature_names(n_teammates: int, n_opponents: int = 0) -> list[str]:
    """Names of the features in order, e.g. ``"ball_proximity"`` or ``"teammate1_speed"``.

    Teammates and opponents are numbered from 0 in increasing distance from the player.

    :param n_teammates: number of teammates ``T``.
    :param n_opponents: number of opponents ``O``.
    :return: a list of ``feature_size(n_teammates, n_opponents)`` names.
    """
    feature_size(n_teammates, n_opponents)  # validates the counts
    names = list(_BASIC_NAMES)
    for kind, count in (("teammate", n_teammates), ("opponent", n_opponents)):
        names += [f"{kind}{k}_{field}" for k in range(count) for field in _PLAYER_FIELDS]
    return names


def landmark_index(name: str) -> int:
    """Index of the first (sin) feature of the named landmark, e.g. ``landmark_index("goal_center") == 13``.

    :param name: one of :data:`LANDMARK_NAMES`.
    """
    return LANDMARK_START + 3 * LANDMARK_NAMES.index(name)


def player_index(k: int, field: str, n_teammates: int, opponent: bool = False) -> int:
    """Index of one field of the ``k``-th nearest teammate (or opponent).

    :param k: rank by distance, 0 = nearest.
    :param field: one of ``angle_sin, angle_cos, proximity, body_sin, body_cos, speed, vel_sin,
        vel_cos``.
    :param n_teammates: number of teammates ``T`` (opponent blocks follow the teammate blocks).
    :param opponent: whether ``k`` counts opponents instead of teammates.
    """
    base = TEAMMATE_START + (FEATURES_PER_PLAYER * n_teammates if opponent else 0)
    return base + FEATURES_PER_PLAYER * k + _PLAYER_FIELDS.index(field)


def landmarks(params: ServerParams = DEFAULT_PARAMS) -> np.ndarray:
    """The 11 landmark positions (HFO order, SPEC §3) as an (11, 2) float64 array.

    :param params: field geometry.
    """
    half_l, half_w = params.half_length, params.half_width
    goal_y = params.goal_width / 2.0
    box_x = half_l - params.penalty_area_length
    box_y = params.penalty_area_width / 2.0
    return np.array(
        [
            (half_l, 0.0),
            (half_l, -goal_y),
            (half_l, goal_y),
            (box_x, 0.0),
            (box_x, -box_y),
            (box_x, box_y),
            (0.0, 0.0),
            (0.0, -half_w),
            (half_l, -half_w),
            (half_l, half_w),
            (0.0, half_w),
        ]
    )


_F32 = np.float32
_DEG2RAD = math.pi / 180.0
_count = np.count_nonzero

_TINY = _F32(1e-30)
"""Added to lengths before dividing, so that a zero vector gets direction 0 without a branch;
it is below half an ulp of any length that matters, so other results are unchanged."""

_BALL_ROW = NUM_LANDMARKS
"""Row of the ball among the targets seen from each player (landmarks, ball, teammates)."""
_SPEED_ROWS = slice(SELF_SPEED, BALL_SPEED + 1, BALL_SPEED - SELF_SPEED)
"""Feature rows 4 and 55, self speed and ball speed, normalised in one step."""


class _Workspace:
    """Reused work arrays of :func:`low_level_features` for one batch shape and one params.

    Fresh large temporaries on every call would cost a page fault per 4 KiB (doubling the
    time of a 1,024-game batch); these are allocated once, with the rows that never change
    (valid flags, frozen, absent opponents, landmark positions) filled at creation.
    """

    def __init__(self, n: int, p: int, n_opponents: int, params: ServerParams) -> None:
        m, t = n * p, p - 1
        n_feat = feature_size(t, n_opponents)
        n_targets = NUM_LANDMARKS + 1 + t
        self.params = params
        self.features = np.empty((n_feat, m), dtype=_F32)
        """(F, m) feature-major: every operation runs over long contiguous rows."""
        self.features[SELF_POS_VALID : SELF_VEL_VALID + 1] = 1.0
        self.features[FROZEN] = -1.0
        self.features[BALL_POS_VALID] = 1.0
        self.features[BALL_VEL_VALID] = 1.0
        self.features[TEAMMATE_START + FEATURES_PER_PLAYER * t :] = 0.0  # absent opponents
        self.pos = np.empty((2, m), dtype=_F32)
        self.vectors = np.empty((2, 2, m), dtype=_F32)
        """(x / y, self velocity / ball velocity, m)."""
        self.ball_vel = self.vectors[:, 1].reshape(2, n, p)
        self.globals = np.empty((7, m), dtype=_F32)
        """sin b, cos b, speed (teammate scale), sin v, cos v of each player, then sin, cos of
        the ball velocity; rows 0-4 are what a teammate sees of this player."""
        self.targets = np.empty((2, n_targets, m), dtype=_F32)
        """(x / y, landmarks + ball + teammates nearest first, m) in world coordinates."""
        self.targets[:, :NUM_LANDMARKS] = landmarks(params).T[:, :, None]
        self.ball_pos = self.targets[:, _BALL_ROW].reshape(2, n, p)
        self.rel = np.empty((2, n_targets, m), dtype=_F32)
        self.dist = np.empty((n_targets, m), dtype=_F32)
        self.tmp = np.empty((n_targets, m), dtype=_F32)
        self.polar = np.empty((3, n_targets, m), dtype=_F32)
        """(sin, cos, proximity) of every target relative to the body."""
        self.mate_rows = (np.arange(m) ^ 1)[None] if p == 2 else None
        """(T, m) row of each player's teammates: fixed when there is one teammate."""
        self.edge_scale = np.array([[2.0 / params.half_length], [1.0 / params.half_width]], dtype=_F32)
        self.speed_scale = np.array(
            [[2.0 / params.observed_self_speed_max], [2.0 / params.observed_ball_speed_max]], dtype=_F32
        )
        self.player_speed_scale = _F32(2.0 / params.observed_player_speed_max)
        self.stamina_scale = 2.0 / params.stamina_max
        self.prox_scale = _F32(-2.0 / params.max_dist)


_LOCAL = threading.local()
_WORKSPACES = 16
"""Workspaces kept per thread, least recently used dropped first (a batched task uses one per
padded batch size: its games, and its games plus a power of two of fresh ones)."""


def _workspace(n: int, p: int, n_opponents: int, params: ServerParams) -> _Workspace:
    """The calling thread's workspace for this shape and params (a few are kept)."""
    cache: dict[tuple[int, int, int, int], _Workspace] | None = getattr(_LOCAL, "cache", None)
    if cache is None:
        cache = _LOCAL.cache = {}
    key = (n, p, n_opponents, id(params))
    ws = cache.pop(key, None)  # re-inserted below: the dict's order is least recently used first
    if ws is None or ws.params is not params:
        if len(cache) >= _WORKSPACES:
            del cache[next(iter(cache))]
        ws = _Workspace(n, p, n_opponents, params)
    cache[key] = ws
    return ws


def _teammate_rows(pos: np.ndarray, visible: np.ndarray, n: int, p: int) -> np.ndarray:
    """Row (game * P + q) of each player's teammates, visible ones (x > 0) nearest first, then
    the hidden ones, ties by index: (T, m)."""
    xy = pos.reshape(2, n, p)
    gap = xy[:, :, :, None] - xy[:, :, None, :]  # (2, N, P, P)
    d2 = gap[0] * gap[0]
    d2 += gap[1] * gap[1]
    d2 = d2.astype(np.float64)
    d2 += np.where(visible.reshape(n, 1, p), 0.0, 1e300)  # hidden teammates after the visible
    diag = np.arange(p)
    d2[:, diag, diag] = np.inf
    order = np.argsort(d2, axis=2, kind="stable")[:, :, : p - 1]  # (N, P, T)
    order += (np.arange(n) * p)[:, None, None]
    return order.reshape(n * p, p - 1).T


def _rows_to_columns(features: np.ndarray, out: np.ndarray) -> None:
    """``out[...] = features.T`` for a (F, m) array.

    numpy's transposed copy of a large array is several times slower than copying a few
    feature rows at a time into strided columns.
    """
    if out.shape[0] < 256:  # measured crossover; below it everything stays in cache
        out[...] = features.T
    else:
        for j in range(0, features.shape[0], 8):
            out[:, j : j + 8] = features[j : j + 8].T


def low_level_features(
    state: SoccerState,
    params: ServerParams = DEFAULT_PARAMS,
    n_opponents: int = 0,
    kickable: np.ndarray | None = None,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """HFO low-level features (2016 layout, SPEC §3) of every player of every game.

    Teammates of a player are the other players of its game at x > 0, sorted by increasing
    distance (ties by player index); a teammate at x <= 0 is not seen (HFO 2016): its block is
    0, HFO's value for a missing player. No opponents are simulated, so opponent blocks, if
    requested, are 0 too. A zero vector (a target at the player's position, a
    player or ball at rest) has direction 0, as ``atan2(0, 0)`` in HFO.

    Computed in float32 and clipped to [-1, 1] (float32 trigonometry can land one ulp outside);
    the result does not depend on the batch size. Thread-safe (work arrays are per thread).

    :param state: the batched games (N games, P players).
    :param params: field geometry and the normalisers (``max_dist``, ``observed_*_speed_max``,
        ``stamina_max``, ``kickable_area``).
    :param n_opponents: number of (absent) opponents to reserve feature blocks for.
    :param kickable: optional (N, P) bool, ``physics.kickable(state, params)`` if the caller
        has it already (the kickable feature is exactly the simulator's test); computed if None.
    :param out: optional float32 (N, P, F) array to write into; it may be a view with strided
        rows, such as the feature part of an observation buffer (saves a copy).
    :return: float32 array of shape (N, P, F), F = 58 + 8 (P - 1) + 8 n_opponents (``out`` if
        given).
    """
    n, p = state.pos.shape[:2]
    m, t = n * p, p - 1
    ws = _workspace(n, p, n_opponents, params)
    ft = ws.features

    # --- per-player globals: body angle, and velocity (with the ball's) as length, direction ---
    pos = ws.pos
    pos[...] = state.pos.reshape(m, 2).T
    glob = ws.globals
    sb, cb, player_speed, sv, cv = glob[:5]
    ang = np.multiply(state.body.reshape(m), _DEG2RAD, dtype=_F32)
    np.sin(ang, out=sb)
    np.cos(ang, out=cb)
    vec = ws.vectors
    vec[:, 0] = state.vel.reshape(m, 2).T
    ws.ball_vel[...] = state.ball_vel.T[:, :, None]
    vx, vy = vec
    speed = vx * vx  # (self, ball)
    speed += vy * vy
    np.sqrt(speed, out=speed)
    # (x + tiny, y) / (|v| + tiny) is the direction of v, and (1, 0) for a zero vector.
    inv = speed + _TINY
    np.divide(1.0, inv, out=inv)
    cos_v = glob[4::2]  # rows cos v (self), cos v (ball)
    np.add(vx, _TINY, out=cos_v)
    cos_v *= inv
    np.multiply(vy, inv, out=glob[3::2])

    # --- self ---
    np.multiply(sb, cv, out=ft[SELF_VEL_ANGLE_SIN])  # sin(body - velocity direction)
    ft[SELF_VEL_ANGLE_SIN] -= cb * sv
    np.multiply(cb, cv, out=ft[SELF_VEL_ANGLE_COS])
    ft[SELF_VEL_ANGLE_COS] += sb * sv
    ft[SELF_BODY_SIN : SELF_BODY_COS + 1] = glob[:2]
    speeds = ft[_SPEED_ROWS]  # self speed over [0, 0.46], ball speed over [0, 5]
    np.multiply(speed, ws.speed_scale, out=speeds)
    speeds -= 1.0
    np.minimum(speeds, 1.0, out=speeds)
    stamina = ft[STAMINA]
    np.multiply(state.stamina.reshape(m), ws.stamina_scale, out=stamina)
    stamina -= 1.0
    np.minimum(stamina, 1.0, out=stamina)
    np.maximum(stamina, -1.0, out=stamina)
    ft[BALL_VEL_ANGLE_SIN : BALL_VEL_ANGLE_COS + 1] = glob[5:7]

    # --- edges: HFO's 1 - 2 v of the distances x / 52.5, (52.5 - x) / 52.5, (34 + y) / 68,
    # (34 - y) / 68. 1 - 2 v of a far edge is 2 v - 1 of the near one; opposite edges are negatives
    far = ft[EDGE_RIGHT : EDGE_BOTTOM + 1 : 2]  # right, bottom
    np.multiply(pos, ws.edge_scale, out=far)
    far[0] -= 1.0
    np.minimum(far, 1.0, out=far)
    np.maximum(far, -1.0, out=far)
    np.negative(far, out=ft[EDGE_LEFT : EDGE_BOTTOM + 1 : 2])

    # --- landmarks, ball and teammates (nearest first) in the body frame, one row each ---
    targets = ws.targets
    ws.ball_pos[...] = state.ball_pos.T[:, :, None]
    if t:
        x = state.pos[..., 0].reshape(m)
        mate_rows = ws.mate_rows if ws.mate_rows is not None else _teammate_rows(pos, x > 0.0, n, p)
        pos.take(mate_rows, axis=1, out=targets[:, _BALL_ROW + 1 :], mode="clip")
    rel = np.subtract(targets, pos[:, None], out=ws.rel)
    dx, dy = rel
    dist, tmp = ws.dist, ws.tmp
    np.multiply(dx, dx, out=dist)
    np.multiply(dy, dy, out=tmp)
    dist += tmp
    np.sqrt(dist, out=dist)
    inv = dist + _TINY
    np.divide(1.0, inv, out=inv)
    dx += _TINY  # a target at the player's position is straight along +x (atan2(0, 0) = 0)
    sin, cos, prox = ws.polar
    np.multiply(dy, cb, out=sin)  # rotate by -body: direction of the target minus body angle
    np.multiply(dx, sb, out=tmp)
    sin -= tmp
    sin *= inv
    np.multiply(dx, cb, out=cos)
    np.multiply(dy, sb, out=tmp)
    cos += tmp
    cos *= inv
    np.multiply(dist, ws.prox_scale, out=prox)
    prox += 1.0
    np.maximum(prox, -1.0, out=prox)  # distances are >= 0: only the far side clips
    landmark_rows = ft[LANDMARK_START : LANDMARK_START + 3 * NUM_LANDMARKS].reshape(NUM_LANDMARKS, 3, m)
    landmark_rows[...] = ws.polar[:, :NUM_LANDMARKS].transpose(1, 0, 2)
    ft[BALL_ANGLE_SIN : BALL_PROXIMITY + 1] = ws.polar[:, _BALL_ROW]

    # --- collisions and kickable ---
    flags = ft[COLLIDING_BALL : KICKABLE + 1]
    flags[0] = state.collided_ball.reshape(m)
    flags[1] = state.collided_player.reshape(m)
    flags[2] = state.collided_post.reshape(m)
    flags[3] = (physics.kickable(state, params) if kickable is None else kickable).reshape(m)
    flags *= 2.0
    flags -= 1.0

    # --- teammates: (sin, cos, proximity) relative to the body, then their global features ---
    if t:
        np.multiply(speed[0], ws.player_speed_scale, out=player_speed)
        player_speed -= 1.0
        np.minimum(player_speed, 1.0, out=player_speed)
        for j in range(t):
            start = TEAMMATE_START + FEATURES_PER_PLAYER * j
            block = ft[start : start + FEATURES_PER_PLAYER]
            block[:3] = ws.polar[:, _BALL_ROW + 1 + j]
            glob[:5].take(mate_rows[j], axis=1, out=block[3:], mode="clip")
            hidden = x.take(mate_rows[j]) <= 0.0  # HFO 2016 skips teammates at x <= 0
            if _count(hidden):
                block *= ~hidden

    np.clip(ft, -1.0, 1.0, out=ft)
    if out is None:
        out = np.empty((n, p, ft.shape[0]), dtype=_F32)
    elif out.shape != (n, p, ft.shape[0]) or out.dtype != _F32:
        shape = (n, p, ft.shape[0])
        raise ValueError(f"out must be a float32 array of shape {shape}, got {out.dtype} {out.shape}.")
    _rows_to_columns(ft, np.reshape(out, (m, ft.shape[0]), copy=False))  # a view, or ValueError
    return out
