"""Batched state of half-field soccer games and the commands players send.

The first axis of every array is the game (batch) axis ``N``; player arrays have a second
axis ``P`` (players of the offense team, index 0..P-1). Units: metres, cycles, degrees;
y points down, 0 degrees = +x, -90 degrees = up (rcssserver conventions).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

__all__ = ["DASH", "KICK", "NOOP", "TURN", "Commands", "SoccerState"]

DASH, TURN, KICK, NOOP = 0, 1, 2, 3
"""Command kinds, in the order of HFO's parameterised action scores (dash, turn, kick)."""


@dataclass
class SoccerState:
    """State of ``N`` games with ``P`` players each. All arrays float64 unless noted.

    :param ball_pos: (N, 2) ball position.
    :param ball_vel: (N, 2) ball velocity (after the last decay).
    :param pos: (N, P, 2) player positions.
    :param vel: (N, P, 2) player velocities (after the last decay).
    :param body: (N, P) body angles in degrees, in [-180, 180).
    :param stamina: (N, P) stamina.
    :param effort: (N, P) effort.
    :param recovery: (N, P) recovery.
    :param cycle: (N,) int64 cycles since the episode's reset.
    :param collided_ball: (N, P) bool, the player collided with the ball in the last cycle.
    :param collided_player: (N, P) bool, the player collided with another player.
    :param collided_post: (N, P) bool, the player collided with a goal post.
    :param ball_touched: (N,) int64 last cycle that ended with a player strictly within
        ``kickable_area`` of the ball (HFO's untouched-time rule), -1 never.
    """

    ball_pos: np.ndarray
    ball_vel: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    body: np.ndarray
    stamina: np.ndarray
    effort: np.ndarray
    recovery: np.ndarray
    cycle: np.ndarray
    collided_ball: np.ndarray
    collided_player: np.ndarray
    collided_post: np.ndarray
    ball_touched: np.ndarray

    @property
    def n_games(self) -> int:
        """Number of games ``N``."""
        return int(self.ball_pos.shape[0])

    @property
    def n_players(self) -> int:
        """Number of players per game ``P``."""
        return int(self.pos.shape[1])

    @classmethod
    def zeros(cls, n_games: int, n_players: int, stamina: float = 8000.0) -> SoccerState:
        """A state with everything at rest at the origin, full stamina, effort and recovery."""
        n, p = n_games, n_players
        return cls(
            ball_pos=np.zeros((n, 2)),
            ball_vel=np.zeros((n, 2)),
            pos=np.zeros((n, p, 2)),
            vel=np.zeros((n, p, 2)),
            body=np.zeros((n, p)),
            stamina=np.full((n, p), stamina),
            effort=np.ones((n, p)),
            recovery=np.ones((n, p)),
            cycle=np.zeros(n, dtype=np.int64),
            collided_ball=np.zeros((n, p), dtype=bool),
            collided_player=np.zeros((n, p), dtype=bool),
            collided_post=np.zeros((n, p), dtype=bool),
            ball_touched=np.full(n, -1, dtype=np.int64),
        )

    def copy(self) -> SoccerState:
        """A deep copy (every array copied)."""
        return SoccerState(**{f.name: getattr(self, f.name).copy() for f in dataclasses.fields(self)})

    def select(self, games: np.ndarray) -> SoccerState:
        """The sub-batch of the given game indices (or boolean mask), copied."""
        return SoccerState(**{f.name: getattr(self, f.name)[games].copy() for f in dataclasses.fields(self)})

    def assign(self, games: np.ndarray, other: SoccerState) -> None:
        """Write ``other`` (a sub-batch) into the given games of this state, in place."""
        for f in dataclasses.fields(self):
            getattr(self, f.name)[games] = getattr(other, f.name)


@dataclass
class Commands:
    """The server commands of every player in a cycle (one per player, as in rcssserver).

    :param kind: (N, P) int, one of ``DASH``, ``TURN``, ``KICK``, ``NOOP``.
    :param power: (N, P) dash or kick power (server clips to [minpower, maxpower]).
    :param direction: (N, P) degrees: dash or kick direction relative to the body, or the
        turn moment (server clips to [minmoment, maxmoment]).
    """

    kind: np.ndarray
    power: np.ndarray
    direction: np.ndarray

    @classmethod
    def noop(cls, n_games: int, n_players: int) -> Commands:
        """Every player does nothing."""
        shape = (n_games, n_players)
        return cls(np.full(shape, NOOP, dtype=np.int64), np.zeros(shape), np.zeros(shape))
