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
* ``MPObject::_inc`` and ``MPObject::noise`` (``src/object.cpp``): :func:`move_objects`;
* ``Stadium::collisions`` (``src/stadium.cpp``) and the goal posts: :func:`resolve_collisions`;
* ``Player::updateStamina``: :func:`update_stamina`.

:func:`step` chains them. All functions are pure functions of batched arrays whose first axis is
the game (unless a docstring says "in place"); the only Python loops run over the players
(P is 2) or pairs of players. Every random draw comes from the generator passed in; with
``params.without_noise()`` a step is exactly deterministic, and a batch of games gives bit for
bit the results of the same games stepped one at a time.

Simplifications against the server (SPEC §3): one collision pass instead of up to ten; a
ball-player overlap moves only the ball; goal posts push players (not the ball) out and reflect
them like every other collision (velocity times -0.1); coincident centres separate along +x
instead of a random direction; no wind, no heterogeneous players, no ``extra_stamina`` and no
``stamina_capacity``.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from envs.soccer.params import ServerParams
from envs.soccer.state import DASH, KICK, TURN, Commands, SoccerState

__all__ = [
    "COLLISION_VELOCITY_FACTOR",
    "dash_acceleration",
    "dash_direction",
    "dash_direction_rate",
    "dash_power_and_stamina",
    "hfo_turn_moment",
    "kick_effective_power",
    "kick_noise",
    "kickable",
    "move_objects",
    "resolve_collisions",
    "step",
    "turn_body",
    "turn_moment_effect",
    "update_stamina",
    "wrap_degrees",
]

COLLISION_VELOCITY_FACTOR = -0.1
"""Velocities of colliding objects are multiplied by this (rcssserver ``updateCollisionVel``)."""

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
def kickable(state: SoccerState, params: ServerParams) -> np.ndarray:
    """(N, P) bool: the ball centre is within ``kickable_area`` (1.085) of the player centre.

    Server (``Player::ballKickable``): ``distance2(player, ball) <= kickable_area ** 2``.
    """
    dx = _relative(state.ball_pos[:, 0], state.pos[..., 0])
    dy = _relative(state.ball_pos[:, 1], state.pos[..., 1])
    dx *= dx
    dy *= dy
    dx += dy
    return dx <= params.kickable_area**2


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
) -> tuple[np.ndarray, np.ndarray]:
    """One cycle of motion for a batch of objects of one kind (players or the ball).

    a <- a * min(1, accel_max / |a|); v <- v + a; v <- v * min(1, speed_max / |v|);
    v <- v + noise, noise of magnitude U(0, rand * |v|) in a uniform direction U(-pi, pi);
    pos <- pos + v; v <- v * decay.

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
    :return: new (pos, vel).
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
    v *= decay
    return new_pos, v


# ------------------------------------------------------------------------------------------------
# collisions (Stadium::collisions, goal posts)
# ------------------------------------------------------------------------------------------------
def _unit_rows(
    dx: np.ndarray, dy: np.ndarray, d2: np.ndarray, length: float
) -> tuple[np.ndarray, np.ndarray]:
    """(dx, dy) rescaled to ``length``; zero vectors become (length, 0)."""
    d = np.sqrt(d2)
    zero = d == 0.0
    if _count(zero):
        dx = dx + zero
        d += zero
    np.divide(length, d, out=d)
    return dx * d, dy * d


def _push_off_posts(pos: np.ndarray, col_post: np.ndarray, params: ServerParams) -> bool:
    """Move players that overlap a goal post out to touching distance, in place; mark them in
    ``col_post``. Tests x near the goal line, then |y| near a post, then the distance, so that
    the usual case (nobody near a post) costs two numpy calls. Returns whether any moved."""
    touch = params.player_size + params.goal_post_radius
    post_x = params.half_length
    post_y = 0.5 * params.goal_width
    near = pos[..., 0] > post_x - touch
    if not _count(near):
        return False
    flat = np.flatnonzero(near)  # index into pos seen as (N * P, 2)
    flat_pos = pos.reshape(-1, 2)
    y = flat_pos[flat, 1]
    gap = np.abs(y)
    gap -= post_y
    near = np.abs(gap) < touch
    if not _count(near):
        return False
    flat = flat[near]
    x = flat_pos[flat, 0]
    y = y[near]
    hit = np.zeros(flat.shape[0], dtype=bool)
    for post in (-post_y, post_y):
        dx = x - post_x
        dy = y - post
        d2 = dx * dx
        d2 += dy * dy
        on_post = d2 < touch * touch
        if _count(on_post):
            ux, uy = _unit_rows(dx[on_post], dy[on_post], d2[on_post], touch)
            x[on_post] = post_x + ux
            y[on_post] = post + uy
            hit |= on_post
    if not _count(hit):
        return False
    flat_pos[flat, 0] = x
    flat_pos[flat, 1] = y
    col_post.reshape(-1)[flat[hit]] = True
    return True


def resolve_collisions(
    ball_pos: np.ndarray,
    ball_vel: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    params: ServerParams,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Push overlapping objects apart to touching distance and reflect their velocities, in place.

    * ball-player: |ball - player| < ball_size + player_size moves the ball along the centre
      line to touching distance (players in index order);
    * player-player: |p_i - p_j| < 2 player_size moves each by half the overlap along the
      centre line;
    * player-post: |player - post| < player_size + goal_post_radius, posts at
      (half_length, +-goal_width / 2), moves the player out to touching distance.

    Coincident centres separate along +x. Each object that collided gets v <- -0.1 v (once,
    however many collisions). Overlaps are rare, so after one test over the batch the
    corrections are computed only for the overlapping rows, gathered by index.

    :param ball_pos: (N, 2), modified in place.
    :param ball_vel: (N, 2), modified in place.
    :param pos: (N, P, 2) C-contiguous, modified in place.
    :param vel: (N, P, 2) C-contiguous, modified in place.
    :return: (collided_ball, collided_player, collided_post), each (N, P) bool.
    """
    if not (pos.flags.c_contiguous and vel.flags.c_contiguous):
        raise ValueError("resolve_collisions needs C-contiguous pos and vel (it writes through flat views)")
    n, n_players = pos.shape[:2]
    col_ball = np.zeros((n, n_players), dtype=bool)
    col_player = np.zeros((n, n_players), dtype=bool)
    col_post = np.zeros((n, n_players), dtype=bool)
    hit_any = False
    px = pos[..., 0]
    py = pos[..., 1]
    bx = ball_pos[:, 0]
    by = ball_pos[:, 1]

    # ball - player, in player order: a push by player i re-measures the ball against the others
    touch = params.ball_size + params.player_size
    touch2 = touch * touch
    dx = _relative(bx, px)
    dy = _relative(by, py)
    d2 = dx * dx
    d2 += dy * dy
    hit = d2 < touch2
    if _count(hit):
        hit_any = True
        for i in range(n_players):
            rows = np.flatnonzero(hit[:, i])
            if rows.shape[0] == 0:
                continue
            ux, uy = _unit_rows(dx[rows, i], dy[rows, i], d2[rows, i], touch)
            bx[rows] = px[rows, i] + ux
            by[rows] = py[rows, i] + uy
            col_ball[rows, i] = True
            if i + 1 < n_players:
                rdx = bx[rows, None] - px[rows]
                rdy = by[rows, None] - py[rows]
                dx[rows] = rdx
                dy[rows] = rdy
                rdx *= rdx
                rdy *= rdy
                rdx += rdy
                d2[rows] = rdx
                hit[rows] = rdx < touch2

    # player - player: split the correction
    touch = 2.0 * params.player_size
    touch2 = touch * touch
    for i in range(n_players - 1):
        for j in range(i + 1, n_players):
            dx = px[:, j] - px[:, i]
            dy = py[:, j] - py[:, i]
            d2 = dx * dx
            d2 += dy * dy
            hit = d2 < touch2
            if not _count(hit):
                continue
            hit_any = True
            rows = np.flatnonzero(hit)
            ux, uy = _unit_rows(dx[rows], dy[rows], d2[rows], 0.5 * touch)
            mid = px[rows, i] + px[rows, j]
            mid *= 0.5
            px[rows, i] = mid - ux
            px[rows, j] = mid + ux
            mid = py[rows, i] + py[rows, j]
            mid *= 0.5
            py[rows, i] = mid - uy
            py[rows, j] = mid + uy
            col_player[rows, i] = True
            col_player[rows, j] = True

    # player - goal post
    hit_any |= _push_off_posts(pos, col_post, params)

    if hit_any:
        players = col_ball | col_player
        players |= col_post
        rows = np.flatnonzero(players)  # into vel seen as (N * P, 2)
        flat_vel = vel.reshape(-1, 2)
        flat_vel[rows] *= COLLISION_VELOCITY_FACTOR
        # a game whose ball hit two players appears twice: an augmented fancy assignment
        # still applies once per game
        ball_vel[np.flatnonzero(col_ball) // n_players] *= COLLISION_VELOCITY_FACTOR
    return col_ball, col_player, col_post


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
    the cycle. ``ball_touched`` becomes the new cycle in games where a kick succeeded.

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
    u = rng.random((n, 5 * n_players + 2)) if noisy else None

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
    kicked = None
    is_kick = kind == KICK
    if _count(is_kick):
        ball_pos = state.ball_pos
        dx = _relative(ball_pos[:, 0], state.pos[..., 0])
        dy = _relative(ball_pos[:, 1], state.pos[..., 1])
        dist = dx * dx
        dist += dy * dy
        kicking = dist <= p.kickable_area**2  # as kickable()
        kicking &= is_kick
        if _count(kicking):
            np.sqrt(dist, out=dist)
            dist -= p.player_size + p.ball_size
            dir_diff = np.arctan2(dy, dx)
            dir_diff *= _RAD2DEG
            dir_diff -= body
            np.abs(dir_diff, out=dir_diff)  # in [0, 360]: fold into [0, 180]
            np.minimum(dir_diff, 360.0 - dir_diff, out=dir_diff)
            kick_power = np.minimum(np.maximum(power, p.minpower), p.maxpower)
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
            kicked = kicking[:, 0].copy()
            for i in range(1, n_players):
                bax += ax[:, i]
                bay += ay[:, i]
                kicked |= kicking[:, i]
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
    pos, vel = move_objects(
        state.pos,
        state.vel,
        player_accel,
        player_accel_max,
        p.player_speed_max,
        p.player_rand,
        p.player_decay,
        u_pm,
        u_pd,
    )
    ball_pos, ball_vel = move_objects(
        state.ball_pos,
        state.ball_vel,
        ball_accel,
        p.ball_accel_max,
        p.ball_speed_max,
        p.ball_rand,
        p.ball_decay,
        u_bm,
        u_bd,
    )

    # --- players stay within the pitch plus its margin ---
    x_lim = p.half_length + p.pitch_margin
    y_lim = p.half_width + p.pitch_margin
    coord = pos[..., 0]
    np.minimum(np.maximum(coord, -x_lim, out=coord), x_lim, out=coord)
    coord = pos[..., 1]
    np.minimum(np.maximum(coord, -y_lim, out=coord), y_lim, out=coord)

    col_ball, col_player, col_post = resolve_collisions(ball_pos, ball_vel, pos, vel, p)
    stamina, effort, recovery = update_stamina(stamina, state.effort, state.recovery, p)

    cycle = state.cycle + 1
    ball_touched = state.ball_touched.copy()
    if kicked is not None:
        np.copyto(ball_touched, cycle, where=kicked)

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
