"""HFO's parameterised action as a flat vector, and its decoding into server commands.

Each agent outputs 3 action scores and 5 continuous parameters (Hausknecht & Stone, "Deep
Reinforcement Learning in Parameterized Action Space", ICLR 2016; SPEC §2)::

    0 score_dash   1 score_turn       2 score_kick       3 dash_power
    4 dash_direction   5 turn_direction   6 kick_power   7 kick_direction

The executed action is the argmax of the scores (ties go to the lowest index) with its own
parameters. The bounds are those of HFO's DDPG agent: dash power in [0, 100] (the server accepts
[-100, 100]; HFO's DDPG never dashed backwards), directions in [-180, 180] degrees, kick power in
[0, 100]. Values outside the bounds are passed on unchanged: the server step clips them the way
rcssserver does, after librcsc's own changes (a negative kick power becomes 0, and no kick is sent
unless the ball is within librcsc's kickable distance, 1.03).
"""

from __future__ import annotations

import numpy as np

from envs.soccer import physics
from envs.soccer.params import ServerParams
from envs.soccer.state import DASH, KICK, NOOP, TURN, Commands, SoccerState

__all__ = [
    "ACTION_HIGH",
    "ACTION_LOW",
    "ACTION_NAMES",
    "HYBRID_LAYOUT",
    "N_HFO_ACTION",
    "check_finite",
    "decode_actions",
]

N_HFO_ACTION = 8
"""Length of one agent's HFO action vector (3 scores + 5 parameters)."""

ACTION_NAMES = (
    "score_dash",
    "score_turn",
    "score_kick",
    "dash_power",
    "dash_direction",
    "turn_direction",
    "kick_power",
    "kick_direction",
)
"""Name of each entry of the HFO action vector."""

ACTION_LOW = np.array([-1.0, -1.0, -1.0, 0.0, -180.0, -180.0, 0.0, -180.0], dtype=np.float32)
"""Lower bounds (HFO DDPG's ranges; dash power starts at 0, not the server's -100)."""

ACTION_HIGH = np.array([1.0, 1.0, 1.0, 100.0, 180.0, 180.0, 100.0, 180.0], dtype=np.float32)
"""Upper bounds (HFO DDPG's ranges)."""

HYBRID_LAYOUT: dict = {"n_actions": 3, "parameters": [[3, 4], [5], [6, 7]]}
"""Generic description of a parameterised action: the first ``n_actions`` entries are the
discrete action scores, ``parameters[k]`` lists the indices of discrete action ``k``'s
parameters (dash: power, direction; turn: direction; kick: power, direction)."""


def check_finite(values: np.ndarray, agent_names: list[str] | tuple[str, ...] | None = None) -> None:
    """Raise ``ValueError`` naming the first agent (axis -2) whose entries are NaN or infinite.

    :param values: (..., P, K) array; axis -2 indexes agents / players.
    :param agent_names: names of the P agents, used in the message (indices otherwise).
    """
    finite = np.isfinite(values)
    if finite.all():
        return
    bad = np.argwhere(~finite)[0]
    player = int(bad[-2])
    who = f"agent {agent_names[player]!r}" if agent_names is not None else f"player {player}"
    where = f" in game {int(bad[0])}" if values.ndim >= 3 else ""
    raise ValueError(
        f"Action of {who}{where} contains NaN or inf at entry {int(bad[-1])}: actions must be finite."
    )


def decode_actions(
    actions: np.ndarray,
    state: SoccerState,
    params: ServerParams,
    can_dash: np.ndarray | None = None,
    check: bool = True,
) -> Commands:
    """Turn HFO action vectors into one server command per player.

    :param actions: (N, P, 8) HFO action vectors (extra trailing entries, e.g. messages, are
        ignored).
    :param state: the current state; a turn is pre-scaled with the player's current speed
        (:func:`envs.soccer.physics.hfo_turn_moment`), as HFO's client library does.
    :param params: server parameters.
    :param can_dash: (P,) bool; a player that cannot dash gets a no-op when it picks dash.
        ``None``: every player can dash.
    :param check: check that the values are finite (callers that already did may skip it).
    :return: the commands (kind, power, direction), each (N, P).
    :raises ValueError: on a wrong shape or a NaN / infinite entry (naming the player).
    """
    actions = np.asarray(actions)
    if actions.ndim != 3 or actions.shape[-1] < N_HFO_ACTION:
        raise ValueError(f"HFO actions must have shape (N, P, {N_HFO_ACTION}), got {actions.shape}.")
    hfo = actions[..., :N_HFO_ACTION]
    if check:
        check_finite(hfo)

    # argmax of the three scores, ties to the lowest index (comparisons beat np.argmax here)
    s_dash, s_turn, s_kick = hfo[..., 0], hfo[..., 1], hfo[..., 2]
    is_dash = (s_dash >= s_turn) & (s_dash >= s_kick)
    is_turn = s_turn >= s_kick
    is_turn &= ~is_dash
    is_kick = ~(is_dash | is_turn)
    kind = np.where(is_dash, DASH, np.where(is_turn, TURN, KICK))

    vel = state.vel
    speed = np.sqrt(vel[..., 0] * vel[..., 0] + vel[..., 1] * vel[..., 1])
    turn_moment = physics.hfo_turn_moment(hfo[..., 5], speed, params)
    power = np.where(is_dash, hfo[..., 3], np.where(is_kick, hfo[..., 6], 0.0))
    direction = np.where(is_dash, hfo[..., 4], np.where(is_kick, hfo[..., 7], turn_moment))

    if can_dash is not None:
        can_dash = np.asarray(can_dash, dtype=bool)
        if can_dash.shape != (hfo.shape[1],):
            raise ValueError(f"can_dash must have shape ({hfo.shape[1]},), got {can_dash.shape}.")
        if not can_dash.all():
            kind[is_dash & ~can_dash] = NOOP
    return Commands(
        kind=kind.astype(np.int64, copy=False),
        power=power.astype(np.float64, copy=False),
        direction=direction.astype(np.float64, copy=False),
    )
