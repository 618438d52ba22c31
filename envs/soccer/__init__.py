"""Vectorised half-field soccer (rcssserver physics, HFO referee, reset and features; SPEC §3).

* ``params``: :class:`ServerParams`, every constant under its rcssserver name.
* ``state``: :class:`SoccerState` (batched arrays, first axis = game) and :class:`Commands`.
* ``physics``: ``step(state, commands, params, rng) -> state`` and ``kickable``.
* ``referee``: ``judge`` (goal, out of bounds, out of time).
* ``reset``: ``reset_state`` (HFO's reset placement).
* ``features``: HFO's low-level features (2016 layout).
* ``render``: frames and videos.

Only ``params`` and ``state`` are imported here; import the other modules by name.
"""

from envs.soccer.params import DEFAULT_PARAMS, ServerParams
from envs.soccer.state import DASH, KICK, NOOP, TURN, Commands, SoccerState

__all__ = ["DASH", "DEFAULT_PARAMS", "KICK", "NOOP", "TURN", "Commands", "ServerParams", "SoccerState"]
