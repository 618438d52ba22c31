"""Vectorised rcssserver physics of half-field soccer (HFO), one cycle at a time.

Every formula is the RoboCup soccer server's (``rcssserver``, the v15-era code that HFO's
server fork builds), in one named function each, so that a reader can check it against SPEC §3
and the server sources:

* ``Player::dash`` (``src/player.cpp``): :func:`dash_direction`, :func:`dash_direction_rate`,
  :func:`dash_power_and_stamina`, :func:`dash_acceleration`;
* ``Player::turn``: :func:`turn_moment_effect`, :func:`turn_body`; HFO's client library
  (librcsc ``PlayerAgent::doTurn``) pre-scales the requested angle: :func:`hfo_turn_moment`;
* ``Player::kick`` and ``Player::ballKickable``: :func:`kickable`, :func:`kick_effective_power`,
  :func:`kick_noise`;
* ``MPObject::_inc`` and ``MPObject::noise`` (``src/object.cpp``): :func:`move_objects`, with
  the goal posts of ``_inc`` (``nearestPost``, ``intersect``): :func:`bounce_off_posts`;
* ``Stadium::collisions`` and ``Stadium::calcCollisionPos`` (``src/stadium.cpp``):
  :func:`resolve_collisions`;
* ``Player::updateStamina``: :func:`update_stamina`.

:func:`step` chains them. All functions are pure functions of batched arrays whose first axis is
the game (unless a docstring says "in place"); the only Python loops run over the players
(P is 2), pairs of players, or the server's bounded repetitions (collision passes, post bounces),
each on the games that still need one. Every random draw comes from the generator passed in;
with ``params.without_noise()`` a step is exactly deterministic, and a batch of games gives bit
for bit the results of the same games stepped one at a time.

What HFO's client library adds (librcsc, the agents' side): a kick is sent only when the ball is
within ``client_kickable_area`` (1.03, :func:`kickable`), and a negative kick power becomes 0.

Simplifications against the server: coincident centres separate along x instead of at a random
angle (the server draws one); the server's 0.01 % widening loop after a separation (which only
acts on rounding errors) is left out; no wind, no heterogeneous players, no ``extra_stamina`` and
no ``stamina_capacity``.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from envs.soccer.params import ServerParams
from envs.soccer.state import DASH, KICK, TURN, Commands, SoccerState

__all__ = [
    "COLLISION_PASSES",
    "COLLISION_VELOCITY_FACTOR",
    "bounce_off_posts",
    "dash_acceleration",
    "dash_direction",
    "dash_direction_rate",
    "dash_power_and_stamina",
    "hfo_turn_moment",
    "kick_effective_power",
    "kick_noise",
    "kickable",
    "move_objects",
    "nearest_post",
    "resolve_collisions",
    "server_kickable",
    "step",
    "turn_body",
    "turn_moment_effect",
    "uniform",
    "update_stamina",
    "wrap_degrees",
]

COLLISION_VELOCITY_FACTOR = -0.1
"""Velocities of colliding objects are multiplied by this (rcssserver ``updateCollisionVel``)."""

COLLISION_PASSES = 10
"""Most collision passes per cycle (``Stadium::collisions``: ``max_loop = 10``)."""

POST_BOUNCES = 4
"""Most post bounces of one object in one cycle (the server loops until none; two posts 14 m
apart allow one bounce in practice)."""

_EPS = 1.0e-10
"""rcssserver's ``EPS`` (``utility.h``): added to separation distances and post bounces."""

_HALF_DEG2RAD = math.pi / 360.0  # degrees -> half the angle in radians
_RAD2DEG = 180.0 / math.pi

_count = np.count_nonzero  # the cheapest "any" numpy has (ndarray.any goes through Python)

_SMALL_BATCH = 16
"""Up to this many games a plain broadcast is cheaper than column copies (fewer numpy calls)."""


# ------------------------------------------------------------------------------------------------
# vector helpers
#
# Speed note: numpy runs an operation whose arrays cannot be flattened into one 1-D loop (a
# broadcast of (N,) against (N, P), or a product with v[..., None] on (N, P, 2)) as N inner loops
# of length 2, several times slower than the same work on whole arrays. Vectors are therefore
# handled as separate x and y components, and per-game values are spread over the players by
# column copies.
# ------------------------------------------------------------------------------------------------
def _polar(magnitude: np.ndarray, half_angle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Components (m cos a, m sin a) of vectors of magnitude m at angle a, given a/2 in radians.

    Uses t = tan(a/2): cos a = (1 - t^2) / (1 + t^2), sin a = 2t / (1 + t^2). numpy evaluates a
    float64 tan with SIMD but cos and sin without, so this is several times faster on a batch;
    it gives the same bits whatever the batch size.
    """
    t = np.tan(half_angle)
    t2 = t * t
    scale = t2 + 1.0
    np.divide(magnitude, scale, out=scale)
    x = np.subtract(1.0, t2, out=t2)
    x *= scale
    t *= scale
    t += t
    return x, t


def _random_direction(magnitude: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Components of vectors of the given magnitude in the direction U(-pi, pi) = (2u - 1) pi.

    Small batches take cos and sin directly (fewer numpy calls), large ones :func:`_polar`
    (SIMD). The draws already depend on the batch size, so the two need not agree bit for bit.
    """
    if u.size <= 2 * _SMALL_BATCH:
        ang = u * (2.0 * math.pi)
        ang -= math.pi
        return magnitude * np.cos(ang), magnitude * np.sin(ang)
    half = u * math.pi
    half -= 0.5 * math.pi
    return _polar(magnitude, half)


def _length(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """sqrt(x^2 + y^2) as a new array (np.hypot is not SIMD, np.linalg.norm is slow)."""
    out = x * x
    out += y * y
    return np.sqrt(out, out=out)


def _spread(values: np.ndarray, n_players: int) -> np.ndarray:
    """(N,) per-game values made broadcastable against (N, P): (N, 1) for small batches, an (N, P)
    array of column copies for large ones."""
    if values.shape[0] <= _SMALL_BATCH:
        return values[:, None]
    out = np.empty((values.shape[0], n_players))
    for i in range(n_players):
        out[:, i] = values
    return out


def _relative(ball: np.ndarray, players: np.ndarray) -> np.ndarray:
    """(N, P) ball coordinate minus player coordinates, ``ball`` (N,), ``players`` (N, P)."""
    if ball.shape[0] <= _SMALL_BATCH:
        return ball[:, None] - players
    out = _spread(ball, players.shape[1])
    out -= players
    return out


def uniform(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """``rng.random(shape)``, bit for bit, and the generator left in the same state.

    For numpy's default bit generator (PCG64) a double is ``(next_uint64 >> 11) * 2**-53``; drawing
    the raw integers in one call and converting them with two array operations takes a third less
    time than ``Generator.random``'s per-element loop. Other bit generators use ``rng.random``.
    """
    bit_generator = rng.bit_generator
    if type(bit_generator) is not np.random.PCG64:
        return rng.random(shape)
    raw = bit_generator.random_raw(math.prod(shape))
    raw >>= np.uint64(11)
    return np.multiply(raw, 2.0**-53).reshape(shape)


def wrap_degrees(angle: np.ndarray) -> np.ndarray:
    """Angle folded once into [-180, 180): a - 360 if a >= 180, a + 360 if a < -180.

    One fold is enough for every angle this module produces (|a| < 540); values already in the
    range come back bit for bit (a modulo would round them).
    """
    out = angle - 360.0 * (angle >= 180.0)
    out += 360.0 * (out < -180.0)
    return out


# ------------------------------------------------------------------------------------------------
# dash (Player::dash)
# ------------------------------------------------------------------------------------------------
def dash_direction(direction: np.ndarray, params: ServerParams) -> np.ndarray:
    """Dash direction as the server executes it, relative to the body, in degrees.

    d = clip(d, min_dash_angle, max_dash_angle); d = dash_angle_step * rint(d / dash_angle_step)
    (``rint`` rounds halves to even, like C's); no snapping when dash_angle_step is 0.
    """
    d = np.minimum(np.maximum(direction, params.min_dash_angle), params.max_dash_angle)
    grid = params.dash_angle_step
    if grid > 1e-10:
        d /= grid
        np.rint(d, out=d)
        d *= grid
    return d


def dash_direction_rate(direction: np.ndarray, params: ServerParams) -> np.ndarray:
    """Power rate of a (snapped) dash direction d, in degrees, clipped to [0, 1].

    |d| <= 90: r = side_dash_rate + (1 - side_dash_rate) * (1 - |d| / 90)
    |d| >  90: r = back_dash_rate - (back_dash_rate - side_dash_rate) * (1 - (|d| - 90) / 90)

    With side 0.4 and back 0.6: r(0) = 1, r(45) = 0.7, r(90) = 0.4, r(135) = 0.5, r(180) = 0.6.
    """
    side, back = params.side_dash_rate, params.back_dash_rate
    t = np.abs(direction)
    rear = t > 90.0
    t /= 90.0
    rate = np.subtract(1.0, t)
    rate *= 1.0 - side
    rate += side
    if _count(rear):
        t -= 1.0
        np.subtract(1.0, t, out=t)
        t *= back - side
        np.subtract(back, t, out=t)
        rate = np.where(rear, t, rate)
    np.minimum(rate, 1.0, out=rate)
    np.maximum(rate, 0.0, out=rate)
    return rate


@functools.lru_cache(maxsize=8)
def _dash_rate_table(grid: float, side: float, back: float, lo: float, hi: float) -> np.ndarray:
    """:func:`dash_direction_rate` of the snapped directions grid * k, k = 0, 1, ..., as a table."""
    k_max = math.ceil(max(abs(lo), abs(hi)) / grid) + 1
    params = ServerParams(side_dash_rate=side, back_dash_rate=back)
    table = dash_direction_rate(np.arange(k_max + 1) * grid, params)
    table.flags.writeable = False
    return table


def dash_power_and_stamina(
    power: np.ndarray, stamina: np.ndarray, dashing: np.ndarray, params: ServerParams
) -> tuple[np.ndarray, np.ndarray]:
    """Dash power the stamina allows, and the stamina left after paying for it.

    p = clip(p, minpower, maxpower); need = p if p >= 0 else -2p; need = min(need, stamina);
    stamina' = max(0, stamina - need); p' = need if p >= 0 else -need / 2. Players that do not
    dash (``dashing`` False) pay nothing and get p' = 0.

    :param power: (N, P) requested power.
    :param stamina: (N, P) stamina before the dash.
    :param dashing: (N, P) bool, the player sent a dash.
    :return: (p', stamina'), new (N, P) arrays.
    """
    p = np.minimum(np.maximum(power, params.minpower), params.maxpower)
    p *= dashing
    back = p < 0.0
    has_back = _count(back)
    if has_back:
        p -= 3.0 * p * back  # need = -2p for a backward dash
    np.minimum(p, stamina, out=p)
    stamina_left = stamina - p
    np.maximum(stamina_left, 0.0, out=stamina_left)
    if has_back:
        p *= 1.0 - 1.5 * back  # p' = -need / 2
    return p, stamina_left


def dash_acceleration(
    power: np.ndarray,
    direction: np.ndarray,
    body: np.ndarray,
    effort: np.ndarray,
    params: ServerParams,
) -> tuple[np.ndarray, np.ndarray]:
    """Acceleration of a dash: |effort * p * r(d) * dash_power_rate| along body + d (+180 if p < 0).

    :param power: (N, P) power after the stamina limit (:func:`dash_power_and_stamina`).
    :param direction: (N, P) snapped dash direction (:func:`dash_direction`), degrees.
    :param body: (N, P) body angle, degrees.
    :param effort: (N, P) effort.
    :return: (ax, ay), each (N, P).
    """
    mag = effort * power
    grid = params.dash_angle_step
    if grid > 1e-10:  # d is on the grid: look the rate up (same formula, same bits)
        table = _dash_rate_table(
            grid, params.side_dash_rate, params.back_dash_rate, params.min_dash_angle, params.max_dash_angle
        )
        k = np.abs(direction)
        k /= grid
        np.rint(k, out=k)
        mag *= table.take(k.astype(np.intp))
    else:
        mag *= dash_direction_rate(direction, params)
    mag *= params.dash_power_rate
    half = body + direction
    back = power < 0.0
    if _count(back):
        np.abs(mag, out=mag)
        half += 180.0 * back
    half *= _HALF_DEG2RAD
    return _polar(mag, half)


# ------------------------------------------------------------------------------------------------
# turn (Player::turn, HFO's client pre-scaling)
# ------------------------------------------------------------------------------------------------
def hfo_turn_moment(angle: np.ndarray, speed: np.ndarray, params: ServerParams) -> np.ndarray:
    """Moment HFO's client sends for a requested turn angle (librcsc ``PlayerAgent::doTurn``).

    moment = clip(angle * (1 + inertia_moment * speed), minmoment, maxmoment), with ``speed`` the
    player's current speed |v|, so that the server's division by (1 + inertia_moment * |v|)
    turns the player by ``angle`` (up to turn noise) whenever the moment is not clipped.
    """
    moment = np.multiply(angle, np.multiply(speed, params.inertia_moment) + 1.0)
    return np.minimum(np.maximum(moment, params.minmoment), params.maxmoment)


def turn_moment_effect(
    moment: np.ndarray, speed: np.ndarray, noise: np.ndarray | None, params: ServerParams
) -> np.ndarray:
    """Change of body angle a turn command causes, in degrees.

    delta = (1 + U(-player_rand, player_rand)) * clip(m, minmoment, maxmoment)
    / (1 + inertia_moment * |v|).

    :param moment: (N, P) moment sent, degrees.
    :param speed: (N, P) player speed |v| at the start of the cycle.
    :param noise: (N, P) uniform draws in [0, 1) that make U(-player_rand, player_rand), or None
        (no noise).
    """
    m = np.minimum(np.maximum(moment, params.minmoment), params.maxmoment)
    if noise is not None and params.player_rand > 0.0:
        m *= noise * (2.0 * params.player_rand) + (1.0 - params.player_rand)
    m /= np.multiply(speed, params.inertia_moment) + 1.0
    return m


def turn_body(body: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """New body angle: body + delta, wrapped into [-180, 180)."""
    return wrap_degrees(body + delta)


# ------------------------------------------------------------------------------------------------
# kick (Player::kick)
# ------------------------------------------------------------------------------------------------
def _ball_distance2(state: SoccerState) -> np.ndarray:
    """(N, P) squared centre distance between the ball and every player."""
    return _distance2(state.ball_pos, state.pos)


def _distance2(ball_pos: np.ndarray, pos: np.ndarray) -> np.ndarray:
    """(N, P) squared distance between ``ball_pos`` (N, 2) and ``pos`` (N, P, 2)."""
    dx = _relative(ball_pos[:, 0], pos[..., 0])
    dy = _relative(ball_pos[:, 1], pos[..., 1])
    dx *= dx
    dy *= dy
    dx += dy
    return dx


def kickable(state: SoccerState, params: ServerParams) -> np.ndarray:
    """(N, P) bool: an HFO agent can kick the ball, i.e. librcsc's kickable test passes.

    librcsc (``SelfObject::updateBallInfo``, ball seen this cycle, which full state always is):
    ``dist <= kickable_area - 0.055`` = ``client_kickable_area`` (1.03). This is the agents'
    kickable feature, and librcsc refuses to send a kick otherwise, so it is also the test
    :func:`step` applies to kicks. ``params.kickable_buffer = 0`` gives :func:`server_kickable`.
    """
    return _ball_distance2(state) <= params.client_kickable_area**2


def server_kickable(state: SoccerState, params: ServerParams) -> np.ndarray:
    """(N, P) bool: the server's own test, ``distance2(player, ball) <= kickable_area ** 2``
    (``Player::ballKickable``, 1.085). HFO's referee counts a player within it (strictly) as
    touching the ball (:func:`step` keeps ``ball_touched`` with it)."""
    return _ball_distance2(state) <= params.kickable_area**2


def kick_effective_power(
    power: np.ndarray, dir_diff: np.ndarray, dist_ball: np.ndarray, params: ServerParams
) -> np.ndarray:
    """Ball acceleration of a kick:
    p * kick_power_rate * (1 - 0.25 * |dir_diff| / 180 - 0.25 * dist_ball / kickable_margin).

    :param power: (N, P) kick power, already clipped to [minpower, maxpower].
    :param dir_diff: (N, P) |direction of the ball relative to the body|, degrees in [0, 180].
    :param dist_ball: (N, P) gap between player and ball: dist - player_size - ball_size.
    """
    rate = dir_diff * (-0.25 / 180.0)
    rate -= dist_ball * (0.25 / params.kickable_margin)
    rate += 1.0
    rate *= power
    rate *= params.kick_power_rate
    return rate


def kick_noise(
    power: np.ndarray,
    dir_diff: np.ndarray,
    dist_ball: np.ndarray,
    ball_speed: np.ndarray,
    u_magnitude: np.ndarray,
    u_direction: np.ndarray,
    params: ServerParams,
) -> tuple[np.ndarray, np.ndarray]:
    """Kick noise added to the ball acceleration: magnitude U(0, max_rand), direction U(-pi, pi).

    pos_rate = 0.5 + 0.25 * (|dir_diff| / 180 + dist_ball / kickable_margin);
    speed_rate = 0.5 + 0.5 * |v_ball| / (ball_speed_max * ball_decay);
    max_rand = kick_rand * (|p| / maxpower) * (pos_rate + speed_rate).

    The server draws U(0, max_rand) with the signed power; a negative radius in a uniform
    direction has the distribution of a positive one, so |p| is used.

    :param power: (N, P) kick power (0 for players that do not kick).
    :param dir_diff: (N, P) as in :func:`kick_effective_power`.
    :param dist_ball: (N, P) as in :func:`kick_effective_power`.
    :param ball_speed: (N, P) ball speed at the start of the cycle (same for every player).
    :param u_magnitude: (N, P) uniform draws in [0, 1).
    :param u_direction: (N, P) uniform draws in [0, 1).
    :return: (nx, ny), each (N, P).
    """
    rate = dir_diff * (0.25 / 180.0)
    rate += dist_ball * (0.25 / params.kickable_margin)
    rate += ball_speed * (0.5 / (params.ball_speed_max * params.ball_decay))
    rate += 1.0  # 0.5 + 0.5
    rate *= np.abs(power)
    rate *= params.kick_rand / params.maxpower
    rate *= u_magnitude
    return _random_direction(rate, u_direction)


# ------------------------------------------------------------------------------------------------
# movement (MPObject::_inc)
# ------------------------------------------------------------------------------------------------
def move_objects(
    pos: np.ndarray,
    vel: np.ndarray,
    accel: tuple[np.ndarray, np.ndarray] | None,
    accel_max: float,
    speed_max: float,
    rand: float,
    decay: float,
    u_magnitude: np.ndarray | None = None,
    u_direction: np.ndarray | None = None,
    posts: tuple[float, float, float] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """One cycle of motion for a batch of objects of one kind (players or the ball).

    a <- a * min(1, accel_max / |a|); v <- v + a; v <- v * min(1, speed_max / |v|);
    v <- v + noise, noise of magnitude U(0, rand * |v|) in a uniform direction U(-pi, pi);
    the goal posts (:func:`bounce_off_posts`); pos <- pos + v; v <- v * decay.

    As in the server, the two caps apply only to accelerated objects: with ``accel`` None they
    are skipped (in a batch with an acceleration, objects with a zero one are capped too, which
    changes nothing: without acceleration a velocity only shrinks).

    :param pos: (..., 2) positions (not modified).
    :param vel: (..., 2) velocities after the last decay (not modified).
    :param accel: (ax, ay), each shaped like ``pos[..., 0]`` (may be modified), or None for no
        acceleration. ``accel_max = inf`` skips the accel cap (for callers that know it cannot
        bind).
    :param u_magnitude: uniform draws in [0, 1) shaped like ``pos[..., 0]``, or None (no noise).
    :param u_direction: uniform draws in [0, 1) shaped like ``pos[..., 0]``.
    :param posts: (post x, post |y|, post radius + object size), or None for no posts.
    :return: new (pos, vel, post_hit), ``post_hit`` shaped like ``pos[..., 0]`` (None without
        posts): the object touched a post during the move.
    """
    noisy = u_magnitude is not None and rand > 0.0
    if accel is not None:
        ax, ay = accel
        if accel_max != math.inf:
            a = _length(ax, ay)
            np.maximum(a, accel_max, out=a)
            np.divide(accel_max, a, out=a)
            ax *= a
            ay *= a
        v = np.empty(vel.shape)
        vx = np.add(vel[..., 0], ax, out=v[..., 0])
        vy = np.add(vel[..., 1], ay, out=v[..., 1])
        speed = _length(vx, vy)
        if noisy:
            mag = np.minimum(speed, speed_max)  # |v| after the cap
        np.maximum(speed, speed_max, out=speed)
        cap = np.divide(speed_max, speed, out=speed)
        vx *= cap
        vy *= cap
    else:
        v = vel.copy()
        vx = v[..., 0]
        vy = v[..., 1]
        if noisy:
            mag = _length(vx, vy)
    if noisy:
        mag *= u_magnitude
        mag *= rand
        nx, ny = _random_direction(mag, u_direction)
        vx += nx
        vy += ny
    new_pos = pos + v
    hit = None
    if posts is not None:
        hit = bounce_off_posts(pos, new_pos, v, *posts)
    v *= decay
    return new_pos, v, hit


# ------------------------------------------------------------------------------------------------
# goal posts (MPObject::_inc: nearestPost, intersect)
# ------------------------------------------------------------------------------------------------
def nearest_post(x: np.ndarray, y: np.ndarray, post_x: float, post_y: float) -> tuple[np.ndarray, np.ndarray]:
    """Centre of the post the server tests an object at (x, y) against (``nearestPost``): the
    one in the same quadrant, (+-post_x, +-post_y), with x > 0 and y > 0 choosing the plus signs."""
    return np.where(x > 0.0, post_x, -post_x), np.where(y > 0.0, post_y, -post_y)


def _segment_hits_circle(
    bx: np.ndarray, by: np.ndarray, ex: np.ndarray, ey: np.ndarray, cx: np.ndarray, cy: np.ndarray, r: float
) -> tuple[np.ndarray, np.ndarray]:
    """Where the move from b to e first enters the circle (c, r) (rcssserver ``intersect``).

    :return: (hit, t): hit (k,) bool, t (k,) the fraction of the move at the entry point.
        No hit when the move is zero, when the line only touches the circle, when neither
        crossing lies on the move, or when the object starts on the circle moving away.
    """
    sx = ex - bx
    sy = ey - by
    ox = bx - cx
    oy = by - cy
    a = sx * sx + sy * sy
    half_b = ox * sx + oy * sy
    c = ox * ox + oy * oy - r * r
    disc = half_b * half_b - a * c
    moving = a > 0.0
    hit = moving & (disc > 0.0)
    if not _count(hit):  # the usual case: the line passes the circle by
        return hit, disc
    root = np.sqrt(np.where(hit, disc, 0.0))
    safe_a = np.where(moving, a, 1.0)
    t1 = (-half_b - root) / safe_a
    t2 = (-half_b + root) / safe_a
    in1 = (t1 >= 0.0) & (t1 <= 1.0)
    in2 = (t2 >= 0.0) & (t2 <= 1.0)
    t = np.where(in1, t1, t2)
    hit &= in1 | in2
    hit &= ~((t == 0.0) & ~(in1 & in2))  # tangent at the start and moving away: no collision
    return hit, t


def bounce_off_posts(
    start: np.ndarray, end: np.ndarray, vel: np.ndarray, post_x: float, post_y: float, radius: float
) -> np.ndarray:
    """The goal posts of ``MPObject::_inc``, in place on ``end`` and ``vel``.

    Posts are circles at (+-post_x, +-post_y) (52.44, 7.07: 52.5 - 0.06, 7.01 + 0.06), and an
    object collides with one when its centre comes within ``radius`` = post radius + its own
    size. As in the server, for an object at ``start`` moving by ``vel`` (before decay):

    1. an object already inside its nearest post is put on the circle (along the centre line,
       +x if it is at the centre) and its velocity mirrored about that line;
    2. while the move crosses the circle of the post nearest its start or its end, the object
       goes to the entry point (nudged ``EPS`` outwards), the rest of the move is mirrored
       about the line to the post centre, and the velocity keeps its speed along the mirrored
       rest (an elastic bounce, not the -0.1 of object collisions);
    3. ``end`` becomes the final position.

    Only objects whose move comes near a post are computed, gathered by index.

    :param start: (..., 2) positions before the move (not modified).
    :param end: (..., 2) start + vel, modified in place.
    :param vel: (..., 2) velocity of the move, modified in place.
    :return: bool array shaped like ``start[..., 0]``: the object touched a post.
    """
    hit_all = np.zeros(start.shape[:-1], dtype=bool)
    x0 = start[..., 0]
    x1 = end[..., 0]
    reach = post_x - radius
    near = np.abs(x0) > reach
    near |= np.abs(x1) > reach
    if not _count(near):
        return hit_all
    flat = np.flatnonzero(near)
    s2 = start.reshape(-1, 2)
    e2 = end.reshape(-1, 2)
    v2 = vel.reshape(-1, 2)
    y0 = s2[flat, 1]
    y1 = e2[flat, 1]
    lo = np.minimum(y0, y1)
    hi = np.maximum(y0, y1)
    near = (hi > post_y - radius) & (lo < post_y + radius)
    near |= (hi > -post_y - radius) & (lo < -post_y + radius)
    if not _count(near):
        return hit_all
    flat = flat[near]
    bx, by = s2[flat, 0], s2[flat, 1]
    vx, vy = v2[flat, 0], v2[flat, 1]
    hit = np.zeros(flat.shape[0], dtype=bool)

    # 1. inside a post already: out to the circle, velocity mirrored about the centre line
    cx, cy = nearest_post(bx, by, post_x, post_y)
    dx, dy = bx - cx, by - cy
    d = np.sqrt(dx * dx + dy * dy)
    inside = d < radius
    if _count(inside):
        centre = d == 0.0
        dx = np.where(centre, radius, dx)
        d = np.where(centre, 1.0, d)
        scale = np.where(inside, radius / np.where(inside, d, 1.0), 1.0)
        dx, dy = dx * scale, dy * scale
        for _ in range(8):  # rounding may leave it a hair inside: the server widens by 1 %
            short = inside & (dx * dx + dy * dy < radius * radius)
            if not _count(short):
                break
            dx = np.where(short, dx * 1.01, dx)
            dy = np.where(short, dy * 1.01, dy)
        bx = np.where(inside, cx + dx, bx)
        by = np.where(inside, cy + dy, by)
        nx, ny = cx - bx, cy - by
        n2 = nx * nx + ny * ny
        dot = np.where(inside & (n2 > 0.0), 2.0 * (vx * nx + vy * ny) / np.where(n2 > 0.0, n2, 1.0), 0.0)
        vx = vx - dot * nx
        vy = vy - dot * ny
        hit |= inside
    ex, ey = bx + vx, by + vy

    # 2. the move crosses a post: bounce, as often as it takes
    active = np.ones(flat.shape[0], dtype=bool)
    for _ in range(POST_BOUNCES):
        c1x, c1y = nearest_post(bx, by, post_x, post_y)
        c2x, c2y = nearest_post(ex, ey, post_x, post_y)
        hit1, t1 = _segment_hits_circle(bx, by, ex, ey, c1x, c1y, radius)
        other = (c1x != c2x) | (c1y != c2y)
        if _count(other):  # the move ends in another quadrant: test that post too
            hit2, t2 = _segment_hits_circle(bx, by, ex, ey, c2x, c2y, radius)
            hit2 &= other & ~hit1
        else:
            hit2, t2 = other, t1
        now = (hit1 | hit2) & active
        if not _count(now):
            break
        t = np.where(hit1, t1, t2)
        cx = np.where(hit1, c1x, c2x)
        cy = np.where(hit1, c1y, c2y)
        ix = bx + t * (ex - bx)
        iy = by + t * (ey - by)
        rx, ry = ex - ix, ey - iy  # rest of the move
        ux, uy = cx - ix, cy - iy
        u = np.sqrt(ux * ux + uy * uy)
        u = np.where(u > 0.0, u, 1.0)
        ux /= u
        uy /= u
        dot = 2.0 * (rx * ux + ry * uy)
        rx -= dot * ux
        ry -= dot * uy
        nbx = ix - _EPS * ux
        nby = iy - _EPS * uy
        speed = np.sqrt(vx * vx + vy * vy)
        rest = np.sqrt(rx * rx + ry * ry)
        along = np.where(rest > 0.0, speed / np.where(rest > 0.0, rest, 1.0), 0.0)
        vx = np.where(now, np.where(rest > 0.0, rx * along, speed), vx)
        vy = np.where(now, ry * along, vy)
        bx = np.where(now, nbx, bx)
        by = np.where(now, nby, by)
        ex = np.where(now, nbx + rx, ex)
        ey = np.where(now, nby + ry, ey)
        hit |= now
        active = now
    if not _count(hit):
        return hit_all
    rows = flat[hit]
    e2[rows, 0] = ex[hit]
    e2[rows, 1] = ey[hit]
    v2[rows, 0] = vx[hit]
    v2[rows, 1] = vy[hit]
    hit_all.reshape(-1)[rows] = True
    return hit_all


# ------------------------------------------------------------------------------------------------
# collisions (Stadium::collisions)
# ------------------------------------------------------------------------------------------------
def _separate(
    ax: np.ndarray, ay: np.ndarray, bx: np.ndarray, by: np.ndarray, half: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where ``Stadium::calcCollisionPos`` puts two overlapping objects a and b: both at
    ``half`` = (size_a + size_b) / 2 + EPS from their midpoint, along the line between them
    (each moves half the overlap); coincident centres (both within EPS of the midpoint)
    separate along x, b on the +x side.

    :return: (ax', ay', bx', by').
    """
    mx = (ax + bx) * 0.5
    my = (ay + by) * 0.5
    dx = ax - mx
    dy = ay - my
    d = np.sqrt(dx * dx + dy * dy)
    same = d < _EPS
    if _count(same):
        dx = np.where(same, -1.0, dx)
        dy = np.where(same, 0.0, dy)
        d = np.where(same, 1.0, d)
    scale = half / d
    dx *= scale
    dy *= scale
    return mx + dx, my + dy, mx - dx, my - dy


def resolve_collisions(
    ball_pos: np.ndarray,
    ball_vel: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    params: ServerParams,
) -> tuple[np.ndarray, np.ndarray]:
    """``Stadium::collisions``: separate overlapping objects, then reflect them, in place.

    Each pass tests every ball-player pair (|ball - player| < ball_size + player_size) and
    every player pair (|p_i - p_j| < 2 player_size) on the positions at the start of the pass;
    each overlapping pair gets target positions from :func:`_separate` (both objects move
    apart, each by half the overlap), and an object in several pairs goes to the mean of its
    targets. Passes repeat, up to :data:`COLLISION_PASSES` (10), in the games where something
    overlapped, until nothing does. Afterwards every object that collided in any pass gets
    v <- -0.1 v, once. (Goal posts are part of the movement: :func:`bounce_off_posts`.)

    :param ball_pos: (N, 2), modified in place.
    :param ball_vel: (N, 2), modified in place.
    :param pos: (N, P, 2), modified in place.
    :param vel: (N, P, 2), modified in place.
    :return: (collided_ball, collided_player), each (N, P) bool.
    """
    n, n_players = pos.shape[:2]
    col_ball = np.zeros((n, n_players), dtype=bool)
    col_player = np.zeros((n, n_players), dtype=bool)
    pairs = [(i, j) for i in range(n_players - 1) for j in range(i + 1, n_players)]
    touch_bp = params.ball_size + params.player_size
    touch_pp = 2.0 * params.player_size
    half_bp = 0.5 * touch_bp + _EPS
    half_pp = 0.5 * touch_pp + _EPS

    # first pass test over the whole batch (overlaps are rare); later passes on the games hit
    dx = _relative(ball_pos[:, 0], pos[..., 0])
    dy = _relative(ball_pos[:, 1], pos[..., 1])
    dx *= dx
    dy *= dy
    dx += dy
    hit_bp = dx < touch_bp * touch_bp
    hit_pp = []
    for i, j in pairs:
        gx = pos[:, j, 0] - pos[:, i, 0]
        gy = pos[:, j, 1] - pos[:, i, 1]
        gx *= gx
        gy *= gy
        gx += gy
        hit_pp.append(gx < touch_pp * touch_pp)
    any_hit = hit_bp.any(axis=1) if _count(hit_bp) else np.zeros(n, dtype=bool)
    for h in hit_pp:
        any_hit |= h
    if not _count(any_hit):
        return col_ball, col_player

    rows = np.flatnonzero(any_hit)
    bx, by = ball_pos[rows, 0], ball_pos[rows, 1]
    px, py = pos[rows, :, 0], pos[rows, :, 1]
    hbp = hit_bp[rows]
    hpp = [h[rows] for h in hit_pp]
    live = np.arange(rows.shape[0])  # games of ``rows`` still in the loop
    ball_hit = np.zeros((rows.shape[0], n_players), dtype=bool)
    pair_hit = np.zeros((rows.shape[0], n_players), dtype=bool)
    for pass_ in range(COLLISION_PASSES):
        if pass_:  # re-test the games that moved in the last pass
            gx = px[live] - bx[live, None]
            gy = py[live] - by[live, None]
            hbp = gx * gx + gy * gy < touch_bp * touch_bp
            hpp = []
            for i, j in pairs:
                gx = px[live, j] - px[live, i]
                gy = py[live, j] - py[live, i]
                hpp.append(gx * gx + gy * gy < touch_pp * touch_pp)
            moved = hbp.any(axis=1)
            for h in hpp:
                moved |= h
            if not _count(moved):
                break
            live, hbp, hpp = live[moved], hbp[moved], [h[moved] for h in hpp]
        k = live.shape[0]
        lbx, lby = bx[live], by[live]
        lpx, lpy = px[live], py[live]
        bsx, bsy, bn = np.zeros(k), np.zeros(k), np.zeros(k)
        psx, psy, pn = np.zeros((k, n_players)), np.zeros((k, n_players)), np.zeros((k, n_players))
        for i in range(n_players):
            h = hbp[:, i]
            if not _count(h):
                continue
            ax, ay, qx, qy = _separate(lbx, lby, lpx[:, i], lpy[:, i], half_bp)
            bsx += np.where(h, ax, 0.0)
            bsy += np.where(h, ay, 0.0)
            bn += h
            psx[:, i] += np.where(h, qx, 0.0)
            psy[:, i] += np.where(h, qy, 0.0)
            pn[:, i] += h
        for (i, j), h in zip(pairs, hpp, strict=True):
            if not _count(h):
                continue
            ax, ay, qx, qy = _separate(lpx[:, i], lpy[:, i], lpx[:, j], lpy[:, j], half_pp)
            psx[:, i] += np.where(h, ax, 0.0)
            psy[:, i] += np.where(h, ay, 0.0)
            pn[:, i] += h
            psx[:, j] += np.where(h, qx, 0.0)
            psy[:, j] += np.where(h, qy, 0.0)
            pn[:, j] += h
            pair_hit[live, i] |= h
            pair_hit[live, j] |= h
        ball_hit[live] |= hbp
        moved_ball = bn > 0.0
        bx[live] = np.where(moved_ball, bsx / np.where(moved_ball, bn, 1.0), lbx)
        by[live] = np.where(moved_ball, bsy / np.where(moved_ball, bn, 1.0), lby)
        moved_player = pn > 0.0
        px[live] = np.where(moved_player, psx / np.where(moved_player, pn, 1.0), lpx)
        py[live] = np.where(moved_player, psy / np.where(moved_player, pn, 1.0), lpy)

    ball_pos[rows, 0] = bx
    ball_pos[rows, 1] = by
    pos[rows, :, 0] = px
    pos[rows, :, 1] = py
    col_ball[rows] = ball_hit
    col_player[rows] = pair_hit
    players = ball_hit | pair_hit
    vel[rows] = np.where(players[..., None], vel[rows] * COLLISION_VELOCITY_FACTOR, vel[rows])
    ball_moved = ball_hit.any(axis=1)
    ball_vel[rows] = np.where(ball_moved[:, None], ball_vel[rows] * COLLISION_VELOCITY_FACTOR, ball_vel[rows])
    return col_ball, col_player


# ------------------------------------------------------------------------------------------------
# stamina (Player::updateStamina)
# ------------------------------------------------------------------------------------------------
def update_stamina(
    stamina: np.ndarray, effort: np.ndarray, recovery: np.ndarray, params: ServerParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """End-of-cycle stamina model; returns new arrays (stamina, effort, recovery).

    stamina <= recover_dec_thr * stamina_max: recovery <- max(recovery - recover_dec, recover_min);
    stamina <= effort_dec_thr * stamina_max:  effort <- max(effort - effort_dec, effort_min);
    stamina >= effort_inc_thr * stamina_max:  effort <- min(effort + effort_inc, effort_max);
    then stamina <- min(stamina + recovery * stamina_inc_max, stamina_max).
    """
    smax = params.stamina_max
    high = stamina >= params.effort_inc_thr * smax
    rested = _count(high) == high.size and params.effort_inc_thr > max(
        params.effort_dec_thr, params.recover_dec_thr
    )
    if rested:  # the common case: only the effort increase can apply
        effort = np.minimum(effort + params.effort_inc, params.effort_max)
        recovery = recovery.copy()
    else:
        low_rec = stamina <= params.recover_dec_thr * smax
        recovery = np.where(low_rec, np.maximum(recovery - params.recover_dec, params.recover_min), recovery)
        low_eff = stamina <= params.effort_dec_thr * smax
        effort = np.where(high, np.minimum(effort + params.effort_inc, params.effort_max), effort)
        effort = np.where(low_eff, np.maximum(effort - params.effort_dec, params.effort_min), effort)
    new_stamina = recovery * params.stamina_inc_max
    new_stamina += stamina
    np.minimum(new_stamina, smax, out=new_stamina)
    return new_stamina, effort, recovery


# ------------------------------------------------------------------------------------------------
# one cycle
# ------------------------------------------------------------------------------------------------
def step(
    state: SoccerState, commands: Commands, params: ServerParams, rng: np.random.Generator
) -> SoccerState:
    """The state one server cycle later; the input state is not modified.

    Order, as in rcssserver: execute every player's command from the start-of-cycle state (dash,
    turn, or kick when the ball is kickable: :func:`kickable`), move every object
    (:func:`move_objects`), clip players into the pitch plus ``pitch_margin``, resolve
    collisions (:func:`resolve_collisions`), update stamina (:func:`update_stamina`), advance
    the cycle. ``ball_touched`` becomes the new cycle in games where a player ends the cycle
    strictly within ``kickable_area`` of the ball (HFO's referee: that player "touches" it).

    Random draws: whenever any of ``player_rand``, ``ball_rand``, ``kick_rand`` is positive, one
    block ``rng.random((N, 5P + 2))`` per step (columns: turn noise [0, P), kick noise magnitude
    [P, 2P) and direction [2P, 3P), player motion noise magnitude [3P, 4P) and direction
    [4P, 5P), ball motion noise magnitude 5P and direction 5P + 1), so the stream consumed
    does not depend on the commands.

    :param state: start-of-cycle state of N games with P players.
    :param commands: one command per player.
    :param params: server constants.
    :param rng: the source of every random draw.
    """
    p = params
    body = state.body
    n, n_players = body.shape
    kind = commands.kind
    power = np.asarray(commands.power, dtype=np.float64)  # actions often arrive as float32
    direction = np.asarray(commands.direction, dtype=np.float64)
    noisy = p.player_rand > 0.0 or p.ball_rand > 0.0 or p.kick_rand > 0.0
    u = uniform(rng, (n, 5 * n_players + 2)) if noisy else None

    # --- dash ---
    player_accel = None
    is_dash = kind == DASH
    if _count(is_dash):
        used, stamina = dash_power_and_stamina(power, state.stamina, is_dash, p)
        player_accel = dash_acceleration(used, dash_direction(direction, p), body, state.effort, p)
    else:
        stamina = state.stamina

    # --- turn ---
    is_turn = kind == TURN
    if _count(is_turn):
        speed = _length(state.vel[..., 0], state.vel[..., 1])
        delta = turn_moment_effect(direction, speed, None if u is None else u[:, :n_players], p)
        delta *= is_turn
        new_body = turn_body(body, delta)
    else:
        new_body = body.copy()

    # --- kick ---
    ball_accel = None
    is_kick = kind == KICK
    if _count(is_kick):
        ball_pos = state.ball_pos
        dx = _relative(ball_pos[:, 0], state.pos[..., 0])
        dy = _relative(ball_pos[:, 1], state.pos[..., 1])
        dist = dx * dx
        dist += dy * dy
        kicking = dist <= p.client_kickable_area**2  # librcsc sends no kick otherwise: kickable()
        kicking &= is_kick
        if _count(kicking):
            np.sqrt(dist, out=dist)
            dist -= p.player_size + p.ball_size
            dir_diff = np.arctan2(dy, dx)
            dir_diff *= _RAD2DEG
            dir_diff -= body
            np.abs(dir_diff, out=dir_diff)  # in [0, 360]: fold into [0, 180]
            np.minimum(dir_diff, 360.0 - dir_diff, out=dir_diff)
            # librcsc turns a negative power into 0, then the server clips to [minpower, maxpower]
            kick_power = np.minimum(np.maximum(power, max(p.minpower, 0.0)), p.maxpower)
            kick_power *= kicking
            half = np.minimum(np.maximum(direction, p.minmoment), p.maxmoment)
            half += body
            half *= _HALF_DEG2RAD
            ax, ay = _polar(kick_effective_power(kick_power, dir_diff, dist, p), half)
            if u is not None and p.kick_rand > 0.0:
                ball_speed = _spread(_length(state.ball_vel[:, 0], state.ball_vel[:, 1]), n_players)
                u_mag = u[:, n_players : 2 * n_players]
                u_dir = u[:, 2 * n_players : 3 * n_players]
                nx, ny = kick_noise(kick_power, dir_diff, dist, ball_speed, u_mag, u_dir, p)
                ax += nx
                ay += ny
            bax = ax[:, 0].copy()
            bay = ay[:, 0].copy()
            for i in range(1, n_players):
                bax += ax[:, i]
                bay += ay[:, i]
            ball_accel = (bax, bay)

    # --- movement ---
    if u is None:
        u_pm = u_pd = u_bm = u_bd = None
    else:
        u_pm = u[:, 3 * n_players : 4 * n_players]
        u_pd = u[:, 4 * n_players : 5 * n_players]
        u_bm = u[:, 5 * n_players]
        u_bd = u[:, 5 * n_players + 1]
    # a dash can never exceed the accel cap with the default constants: skip the test then
    dash_max = p.dash_power_rate * max(p.maxpower, -p.minpower) * max(p.effort_max, 1.0)
    player_accel_max = math.inf if dash_max <= p.player_accel_max else p.player_accel_max
    pos, vel, col_post = move_objects(
        state.pos,
        state.vel,
        player_accel,
        player_accel_max,
        p.player_speed_max,
        p.player_rand,
        p.player_decay,
        u_pm,
        u_pd,
        (p.goal_post_x, p.goal_post_y, p.goal_post_radius + p.player_size),
    )
    ball_pos, ball_vel, _ = move_objects(
        state.ball_pos,
        state.ball_vel,
        ball_accel,
        p.ball_accel_max,
        p.ball_speed_max,
        p.ball_rand,
        p.ball_decay,
        u_bm,
        u_bd,
        (p.goal_post_x, p.goal_post_y, p.goal_post_radius + p.ball_size),
    )

    # --- players stay within the pitch plus its margin ---
    x_lim = p.half_length + p.pitch_margin
    y_lim = p.half_width + p.pitch_margin
    coord = pos[..., 0]
    np.minimum(np.maximum(coord, -x_lim, out=coord), x_lim, out=coord)
    coord = pos[..., 1]
    np.minimum(np.maximum(coord, -y_lim, out=coord), y_lim, out=coord)

    col_ball, col_player = resolve_collisions(ball_pos, ball_vel, pos, vel, p)
    stamina, effort, recovery = update_stamina(stamina, state.effort, state.recovery, p)

    cycle = state.cycle + 1
    # HFO's referee (HFORef::analyse) resets its untouched time whenever a player is strictly
    # within kickable_area of the ball at the end of a cycle
    ball_touched = state.ball_touched.copy()
    near = _distance2(ball_pos, pos) < p.kickable_area**2
    np.copyto(ball_touched, cycle, where=near.any(axis=1))

    return SoccerState(
        ball_pos=ball_pos,
        ball_vel=ball_vel,
        pos=pos,
        vel=vel,
        body=new_body,
        stamina=stamina,
        effort=effort,
        recovery=recovery,
        cycle=cycle,
        collided_ball=col_ball,
        collided_player=col_player,
        collided_post=col_post,
        ball_touched=ball_touched,
    )
