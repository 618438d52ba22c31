"""HFO's referee: when does a half-field episode end, and how.

Source: ``HFORef::analyse`` in the rcssserver fork HFO builds (``mhauskn/rcssserver``,
``src/referee.cpp``) and ``Referee::crossGoalLine``; SPEC §3, §6 items 3. The statuses are HFO's
(``IN_GAME``, ``GOAL``, ``OUT_OF_BOUNDS``, ``OUT_OF_TIME``; the defense-only
``CAPTURED_BY_DEFENSE`` cannot happen without defenders). The server keeps the ball position
of the previous cycle (``M_prev_ball_pos``) and, each cycle, in this order:

* ``GOAL`` when ``crossGoalLine(RIGHT, prev)``: the ball was at x <= 52.585 (52.5 + ball_size)
  and now is beyond it, and the line from the previous to the current position crosses
  x = 52.585 at |y| <= 7.07 (goal_width / 2 + goal_post_radius);
* ``OUT_OF_BOUNDS`` when ``! inHFOArea(prev)``: the *previous* position is outside
  0 <= x <= 52.5, |y| <= 34, so the ball is declared out one cycle after it left (and a ball
  rolling into the goal mouth is scored before it is declared out);
* out of time after HFO's untouched time (``M_untouched_time > hfo_max_untouched_time``,
  reset when a player is strictly within kickable_area of the ball) or the task's cycle limit.
"""

from __future__ import annotations

import numpy as np

from envs.soccer.params import ServerParams
from envs.soccer.state import SoccerState

__all__ = ["GOAL", "IN_GAME", "OUT_OF_BOUNDS", "OUT_OF_TIME", "STATUS_NAMES", "judge"]

IN_GAME, GOAL, OUT_OF_BOUNDS, OUT_OF_TIME = 0, 1, 2, 3
"""Episode statuses (HFO's names and order)."""

STATUS_NAMES = ("IN_GAME", "GOAL", "OUT_OF_BOUNDS", "OUT_OF_TIME")
"""Name of each status, indexed by its value."""


def judge(
    state: SoccerState,
    params: ServerParams,
    max_cycles: int,
    untouched_cycles: int | None = None,
    previous: SoccerState | None = None,
) -> np.ndarray:
    """Status of every game after a step from ``previous`` to ``state``.

    * ``GOAL``: the ball's move from its previous to its current position crosses the goal line
      x = goal_line_x (52.585) between the posts, |y at the crossing| <= goal_half_width (7.07),
      having started on the field side of it (``Referee::crossGoalLine``);
    * ``OUT_OF_BOUNDS``: otherwise, the *previous* ball position is outside 0 <= x <= half_length,
      |y| <= half_width (``HFORef::inHFOArea(M_prev_ball_pos)``);
    * ``OUT_OF_TIME``: otherwise, cycle >= max_cycles, or ``untouched_cycles`` is given and the
      untouched time exceeds it: cycle - last touch > untouched_cycles + 1 (the server tests
      ``M_untouched_time > max`` before counting the current cycle; a reset counts as a touch
      at cycle 0);
    * ``IN_GAME`` otherwise.

    :param state: the state after the step.
    :param params: field geometry.
    :param max_cycles: episode length in cycles.
    :param untouched_cycles: HFO's untouched-time limit, or None for none.
    :param previous: the state before the step (``None``: the ball did not move, so no goal).
    :return: (N,) int64 statuses.
    """
    bx = state.ball_pos[:, 0]
    by = state.ball_pos[:, 1]
    prev = state.ball_pos if previous is None else previous.ball_pos
    px = prev[:, 0]
    py = prev[:, 1]
    line = params.goal_line_x
    goal = (bx > line) & (px <= line)
    if goal.any():
        rows = np.flatnonzero(goal)
        # y where the move crosses x = line, computed as the server does; px < bx here
        slope = (by[rows] - py[rows]) / (bx[rows] - px[rows])
        y_cross = slope * line + (py[rows] - slope * px[rows])
        beside = (np.abs(py[rows]) > params.goal_half_width) & (px[rows] > params.half_length)
        goal[rows] = (np.abs(y_cross) <= params.goal_half_width) & ~beside  # "behind the post"
    out = (px < 0.0) | (px > params.half_length) | (np.abs(py) > params.half_width)

    cycle = state.cycle
    late = cycle >= max_cycles
    if untouched_cycles is not None:
        late |= cycle - np.maximum(state.ball_touched, 0) > untouched_cycles + 1
    status = np.zeros(cycle.shape[0], dtype=np.int64)
    status[late] = OUT_OF_TIME
    status[out] = OUT_OF_BOUNDS
    status[goal] = GOAL
    return status
