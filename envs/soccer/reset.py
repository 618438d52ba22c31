"""HFO's episode reset: where the ball and the offense players start.

Source: ``HFORef::resetField`` in the rcssserver fork HFO builds (``mhauskn/rcssserver``,
``src/referee.cpp``); SPEC §3. The ball is placed uniformly at
x in [xmin, xmax] * half_length, |y| <= 0.8 * half_width; the offense players at
ball + 0.1 * pitch_length * (U(0, 1) + offset), one offset each from a shuffled list of ten,
clipped to x in [-0.1, half_length], |y| <= 0.8 * half_width. Velocities are zero and stamina
full. HFO kept each player's previous body angle; here it is drawn uniformly (SPEC §3), so that
an episode does not depend on the one before.
"""

from __future__ import annotations

import numpy as np

from envs.soccer.params import ServerParams
from envs.soccer.state import SoccerState

__all__ = ["HFO_OFFSETS", "reset_state"]

HFO_OFFSETS = np.array(
    [(-1, -1), (-1, 1), (1, 1), (1, -1), (0, 2), (0, -2), (-2, -2), (-2, 2), (2, 2), (2, -2)],
    dtype=np.float64,
)
"""HFO's offsets of the offense players from the ball, in units of ``reset_player_spread``."""
HFO_OFFSETS.flags.writeable = False

_MIN_PLAYER_X = -0.1
"""HFO clips the offense players' x to [-0.1, half_length]."""


def reset_state(
    rng: np.random.Generator,
    n_games: int,
    n_players: int,
    params: ServerParams,
    ball_x_range: tuple[float, float] = (0.0, 0.8),
) -> SoccerState:
    """Fresh start states of ``n_games`` games with ``n_players`` offense players (HFO reset).

    Draws, in this order: ball x ~ U(xmin, xmax) * half_length and ball y ~ U(-1, 1) *
    reset_y_limit per game; a shuffle of :data:`HFO_OFFSETS` per game (player i takes the i-th
    offset, so offsets are distinct within a game); U(0, 1) per player and axis; body angle
    U(-180, 180) per player. Player i is placed at ball + reset_player_spread * (U + offset_i),
    then x is clipped to [-0.1, half_length] and |y| to reset_y_limit.

    :param rng: the source of every random draw.
    :param n_games: number of games N.
    :param n_players: number of offense players P (at most 10, HFO's number of offsets).
    :param params: field geometry and reset constants.
    :param ball_x_range: (xmin, xmax) as fractions of half_length (HFO's ``hfo_min_ball_x`` and
        ``hfo_max_ball_x``), clipped to [0, 1] with xmax >= xmin as HFO does.
    :return: a new state at cycle 0, ball never touched.
    """
    if not 1 <= n_players <= len(HFO_OFFSETS):
        raise ValueError(f"n_players must be in [1, {len(HFO_OFFSETS)}] (HFO's offsets), got {n_players}")
    lo = min(max(float(ball_x_range[0]), 0.0), 1.0)
    hi = max(min(max(float(ball_x_range[1]), 0.0), 1.0), lo)
    y_lim = params.reset_y_limit

    state = SoccerState.zeros(n_games, n_players, stamina=params.stamina_max)
    state.effort.fill(params.effort_max)
    state.recovery.fill(params.recover_max)

    ball_x = state.ball_pos[:, 0]
    ball_y = state.ball_pos[:, 1]
    ball_x[:] = rng.uniform(lo * params.half_length, hi * params.half_length, n_games)
    ball_y[:] = rng.uniform(-y_lim, y_lim, n_games)

    # a random permutation of the offsets per game; the players take the first P
    order = np.argsort(rng.random((n_games, len(HFO_OFFSETS))), axis=1)[:, :n_players]
    offsets = HFO_OFFSETS[order]  # (N, P, 2)
    spread = params.reset_player_spread
    pos = state.pos
    pos[:] = rng.random((n_games, n_players, 2))
    pos += offsets
    pos *= spread
    pos[..., 0] += ball_x[:, None]
    pos[..., 1] += ball_y[:, None]
    np.clip(pos[..., 0], _MIN_PLAYER_X, params.half_length, out=pos[..., 0])
    np.clip(pos[..., 1], -y_lim, y_lim, out=pos[..., 1])

    body = rng.uniform(-180.0, 180.0, (n_games, n_players))
    body[body >= 180.0] = -180.0  # uniform() may round up to the open end
    state.body[:] = body
    return state
