"""HFO's referee: when does a half-field episode end, and how.

Source: ``HFORef::analyse`` in the rcssserver fork HFO builds (``mhauskn/rcssserver``,
``src/referee.cpp``) and ``Referee::crossGoalLine``; SPEC §3. The statuses are HFO's
(``IN_GAME``, ``GOAL``, ``OUT_OF_BOUNDS``, ``OUT_OF_TIME``; the defense-only
``CAPTURED_BY_DEFENSE`` cannot happen without defenders).

Stateless simplifications of the server's rules, which look at the previous ball position:

* a goal is the ball beyond ``goal_line_x`` (52.5 + ball_size) with |y| <= ``goal_half_width``
  (goal_width / 2 + goal_post_radius = 7.07), judged on the current position instead of the
  intercept of the last movement with the goal line;
* the ball is out of bounds when it leaves 0 <= x <= 52.5, |y| <= 34, except in the goal mouth,
  where it stays in play up to the goal line x = ``goal_line_x``: a ball rolling into the goal
  crosses that strip and scores, as in HFO (which judges out of bounds on the previous position,
  after the goal test);
* out of time after ``max_cycles`` cycles, or (optional) after ``untouched_cycles`` cycles
  without a kick (HFO's ``hfo_max_untouched_time``).

A goal wins over out of bounds, which wins over out of time, as in ``HFORef::analyse``.
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
    state: SoccerState, params: ServerParams, max_cycles: int, untouched_cycles: int | None = None
) -> np.ndarray:
    """Status of every game after a step.

    * ``GOAL``: ball x > goal_line_x and |y| <= goal_half_width;
    * ``OUT_OF_BOUNDS``: otherwise, the ball is outside 0 <= x <= half_length, |y| <= half_width,
      and not in the goal mouth strip (half_length < x <= goal_line_x, |y| <= goal_half_width);
    * ``OUT_OF_TIME``: otherwise, cycle >= max_cycles, or ``untouched_cycles`` is given and
      cycle - last kick >= untouched_cycles (the last kick counts as cycle 0 when there was none);
    * ``IN_GAME`` otherwise.

    :param state: the state after the step.
    :param params: field geometry.
    :param max_cycles: episode length in cycles.
    :param untouched_cycles: HFO's untouched-time limit, or None for none.
    :return: (N,) int64 statuses.
    """
    bx = state.ball_pos[:, 0]
    ay = np.abs(state.ball_pos[:, 1])
    mouth = ay <= params.goal_half_width
    goal = bx > params.goal_line_x
    goal &= mouth
    out = bx > params.half_length
    mouth &= bx <= params.goal_line_x  # the ball on the goal line between the posts is in play
    out &= ~mouth
    out |= bx < 0.0
    out |= ay > params.half_width

    cycle = state.cycle
    late = cycle >= max_cycles
    if untouched_cycles is not None:
        late |= cycle - np.maximum(state.ball_touched, 0) >= untouched_cycles
    status = np.zeros(cycle.shape[0], dtype=np.int64)
    status[late] = OUT_OF_TIME
    status[out] = OUT_OF_BOUNDS
    status[goal] = GOAL
    return status
