"""The batched core every task is built on: N games stepped at once, no per-game Python loop.

A task owns a :class:`~envs.soccer.state.SoccerState` of ``n_games`` games and a message
channel between the teammates. One call to :meth:`BatchedTask.step` takes every agent's action
vector, ``[HFO action (8) | outgoing message (channel_size)]``, and

1. clips the outgoing messages to [-1, 1] (the channel's bounds, SPEC §1),
2. decodes the HFO part into server commands (:func:`~envs.tasks.hfo_actions.decode_actions`),
3. advances the physics one cycle (:func:`envs.soccer.physics.step`),
4. asks the referee and the task for rewards, termination and truncation,
5. delivers the messages: the message an agent sends at step t is the last ``channel_size``
   entries of its teammate's observation at step t+1 (zeros at the first step of an episode),
6. with ``autoreset=True`` resets the games that ended and returns their first observation.

The observation of an agent is ``[HFO low-level features | task entries | remaining time |
received message]``; the remaining time is there only with ``time_feature=True``.
Subclasses choose the features (:meth:`_features`), the task entries (``_extra``), the rewards
and the termination rule (:meth:`_evaluate`); see ``blind_soccer.py`` and ``guess_my_number.py``.
The Gymnasium and PettingZoo classes are thin shells around this core.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from envs.soccer import features, physics, referee
from envs.soccer.params import DEFAULT_PARAMS, ServerParams
from envs.soccer.reset import reset_state
from envs.soccer.state import SoccerState
from envs.tasks.hfo_actions import (
    ACTION_HIGH,
    ACTION_LOW,
    HYBRID_LAYOUT,
    N_HFO_ACTION,
    check_finite,
    decode_actions,
)

__all__ = ["RULES", "BatchedTask", "check_rules", "proximity"]

RULES = ("paper", "dqn-hfo")
"""Rule sets of the paper's two tasks: ``"paper"``, the rules as the paper's text states them
(the default), and ``"dqn-hfo"``, as the authors' code (dqn-hfo's ``scenario``) ran them; see
SPEC §6 items 6 and 7 and each task's docstring."""


def check_rules(rules: str, accepted: tuple[str, ...] = RULES) -> str:
    """``rules`` if it is one of ``accepted``; otherwise a ``ValueError`` naming the accepted values."""
    if rules not in accepted:
        names = ", ".join(repr(r) for r in accepted)
        raise ValueError(f"rules must be one of {names}, got {rules!r}.")
    return rules


def proximity(distance: np.ndarray, params: ServerParams) -> np.ndarray:
    """HFO's proximity of an object at ``distance``: ``1 - 2 * clip(distance / max_dist, 0, 1)``."""
    return 1.0 - 2.0 * np.clip(distance / params.max_dist, 0.0, 1.0)


class BatchedTask:
    """Base class of a cooperative soccer task played in ``n_games`` games at once.

    :param n_games: number of games stepped in parallel (the batch axis N).
    :param seed: seed of the task's ``np.random.Generator`` (``None``: fresh entropy). The
        constructor resets every game with it; :meth:`reset` may reseed.
    :param params: server parameters (``None``: :data:`~envs.soccer.params.DEFAULT_PARAMS`).
    :param noise: ``False`` switches every random perturbation of the physics off
        (``params.without_noise()``); resets stay random.
    :param max_steps: steps after which an episode is truncated (``None``: the task's default).
    :param autoreset: reset games that ended at the end of the same step (see :meth:`step`).
        With ``False`` the caller resets them with :meth:`reset_games`; until then a game that
        ended keeps running and its rewards mean nothing.
    :param channel_size: size n of the message each agent sends per step (``None``: the task's
        default).
    :param ball_x_range: ball reset x range as fractions of the half length (``None``: the
        task's default).
    :param time_feature: make the step limit part of the task's state ("time awareness", Pardo et
        al. 2018, "Time Limits in Reinforcement Learning"): every agent observes the remaining
        time ``1 - t / max_steps`` (1 at an episode's first observation, 0 at the limit; the same
        feature as sb3-contrib's ``TimeFeatureWrapper``), placed after the task entries and before
        the received message, and an episode that reaches ``max_steps`` is *terminated* instead
        of truncated: with the time in the state the limit is a terminal state of the task, so
        neither a TD target nor a Monte-Carlo return should look past it. ``False`` (default):
        the agents do not see the time and the limit truncates, as in HFO. HFO's untouched-ball
        rule, which the agents cannot see, truncates either way.
    """

    name: str = "batched_task"
    """Task name (used in the PettingZoo metadata)."""
    possible_agents: tuple[str, ...] = ("agent_0", "agent_1")
    """Agent names, index i is player i of the offense team."""
    default_channel_size: int = 0
    default_max_steps: int = 100
    ball_x_range: tuple[float, float] = (0.0, 0.8)
    """Ball reset x range as a fraction of the half length (HFO's ``ball_x_min/max``)."""
    untouched_cycles: int | None = None
    """HFO's untouched-ball rule passed to the referee (``None``: off)."""
    hybrid_layout: dict = HYBRID_LAYOUT
    """Layout of the parameterised part of the action (the message follows it)."""

    def __init__(
        self,
        n_games: int = 1,
        seed: int | None = None,
        params: ServerParams | None = None,
        noise: bool = True,
        max_steps: int | None = None,
        autoreset: bool = True,
        channel_size: int | None = None,
        ball_x_range: tuple[float, float] | None = None,
        time_feature: bool = False,
    ) -> None:
        if int(n_games) < 1:
            raise ValueError(f"n_games must be >= 1, got {n_games}.")
        params = DEFAULT_PARAMS if params is None else params
        self.params: ServerParams = params if noise else params.without_noise()
        self.noise = bool(noise)
        self.n_games = int(n_games)
        self.n_players = len(self.possible_agents)
        self.max_steps = int(self.default_max_steps if max_steps is None else max_steps)
        if self.max_steps < 1:
            raise ValueError(f"max_steps must be >= 1, got {max_steps}.")
        self.autoreset = bool(autoreset)
        if ball_x_range is not None:
            low, high = (float(x) for x in ball_x_range)
            if not 0.0 <= low <= high <= 1.0:
                raise ValueError(f"ball_x_range must satisfy 0 <= low <= high <= 1, got {ball_x_range!r}.")
            self.ball_x_range = (low, high)
        self.channel_size = int(self.default_channel_size if channel_size is None else channel_size)
        if self.channel_size < 0:
            raise ValueError(f"channel_size must be >= 0, got {channel_size}.")
        if self.n_players == 1 and self.channel_size:
            raise ValueError("A one-agent task has no teammate to send messages to: channel_size must be 0.")

        self.can_dash = np.ones(self.n_players, dtype=bool)
        """(P,) bool: players whose Dash is executed (a Dash of the others is a no-op)."""
        self.n_features = features.feature_size(self.n_players - 1)
        self._extra = self._extra_observation()
        if not isinstance(time_feature, bool | np.bool_):
            raise TypeError(f"time_feature must be True or False, got {time_feature!r}.")
        self.time_feature = bool(time_feature)
        self.n_extra = self._extra.shape[-1] + int(self.time_feature)
        """Observation entries between the features and the message: the task entries, then the
        remaining time (with ``time_feature``)."""
        self.observation_size = self.n_features + self.n_extra + self.channel_size
        self.action_size = N_HFO_ACTION + self.channel_size
        self.observation_low = np.full(self.observation_size, -1.0, dtype=np.float32)
        self.observation_high = np.full(self.observation_size, 1.0, dtype=np.float32)
        self.action_low = np.concatenate([ACTION_LOW, -np.ones(self.channel_size, np.float32)])
        self.action_high = np.concatenate([ACTION_HIGH, np.ones(self.channel_size, np.float32)])
        # player i receives the message of teammate _teammate[i]
        self._teammate = np.arange(self.n_players)[::-1].copy()

        self._rng = np.random.default_rng(seed)
        self._post_init()
        self.reset()

    # ------------------------------------------------------------------------------------------
    # hooks for subclasses
    # ------------------------------------------------------------------------------------------
    def _post_init(self) -> None:
        """Set task attributes that depend on the constructor arguments (``can_dash``...)."""

    def _extra_observation(self) -> np.ndarray:
        """(P, E) task entries appended after the features of each agent (default: none)."""
        return np.zeros((self.n_players, 0), dtype=np.float32)

    def _features(self, state: SoccerState, out: np.ndarray) -> None:
        """Write the (N, P, n_features) float32 features of every agent, each in [-1, 1], into
        ``out`` (default: HFO low-level features)."""
        features.low_level_features(state, self.params, out=out)

    def _judge(self, previous: SoccerState, state: SoccerState) -> np.ndarray:
        """(N,) referee code after a step from ``previous`` to ``state`` (HFO's referee)."""
        return referee.judge(state, self.params, self.max_steps, self.untouched_cycles, previous)

    def _evaluate(
        self,
        previous: SoccerState,
        state: SoccerState,
        received: np.ndarray,
        outcome: np.ndarray,
        sent: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Rewards (N, P) and termination (N,) of a step from ``previous`` to ``state``.

        :param received: (N, P, channel_size) the messages in the observation the agents acted on.
        :param outcome: (N,) referee codes of ``state``.
        :param sent: (N, P, channel_size) the messages the agents send at this step.
        """
        raise NotImplementedError

    def _on_reset(self, games: np.ndarray) -> None:
        """Reset per-game task memory of the given game indices (default: none)."""

    # ------------------------------------------------------------------------------------------
    # public API
    # ------------------------------------------------------------------------------------------
    @property
    def rng(self) -> np.random.Generator:
        """The generator behind every random draw of the task (resets and physics noise)."""
        return self._rng

    @property
    def sent_messages(self) -> np.ndarray:
        """(N, P, channel_size) messages sent at the last step (in flight to the teammates)."""
        return self._sent

    @property
    def received_messages(self) -> np.ndarray:
        """(N, P, channel_size) messages in the current observations (sent by the teammates)."""
        return self._received

    @property
    def episode_steps(self) -> np.ndarray:
        """(N,) steps taken in each game's current episode."""
        return self._steps

    def reset(self, seed: int | None = None) -> np.ndarray:
        """Reset every game; with a ``seed`` the generator is re-created first.

        :return: observations (N, P, observation_size) float32.
        """
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        n, p = self.n_games, self.n_players
        self.state = reset_state(self._rng, n, p, self.params, self.ball_x_range)
        self.previous_state = self.state
        self._sent = np.zeros((n, p, self.channel_size), dtype=np.float32)
        self._received = np.zeros((n, p, self.channel_size), dtype=np.float32)
        self._steps = np.zeros(n, dtype=np.int64)
        self._returns = np.zeros((n, p), dtype=np.float64)
        self._on_reset(np.arange(n))
        self.obs = self._observe(self.state, self._received, self._steps)
        return self.obs

    def reset_games(self, mask: np.ndarray) -> np.ndarray:
        """Reset the games selected by a boolean mask (N,) or an index array.

        :return: the observations of all games (N, P, observation_size), new ones for the reset
            games.
        """
        games = np.asarray(mask)
        games = np.flatnonzero(games) if games.dtype == bool else games.astype(np.int64).ravel()
        if games.size:
            self.state = self.state.copy()  # never write into arrays a caller may still hold
            self.obs = self.obs.copy()
            self.obs[games] = self._reset_indices(games)
        return self.obs

    def load_state(self, state: SoccerState, received: np.ndarray | None = None) -> np.ndarray:
        """Replace the world state (e.g. a hand-made situation) and recompute the observations.

        :param state: a state of ``n_games`` games and ``P`` players (copied).
        :param received: (N, P, channel_size) messages in the new observations (default zeros).
        :return: the observations (N, P, observation_size).
        """
        if state.n_games != self.n_games or state.n_players != self.n_players:
            raise ValueError(
                f"state has {state.n_games} games x {state.n_players} players, "
                f"expected {self.n_games} x {self.n_players}."
            )
        self.state = state.copy()
        self.previous_state = self.state
        shape = (self.n_games, self.n_players, self.channel_size)
        self._received = np.zeros(shape, np.float32) if received is None else np.array(received, np.float32)
        if self._received.shape != shape:
            raise ValueError(f"received must have shape {shape}, got {self._received.shape}.")
        self._sent = self._received[:, self._teammate].copy()
        self.obs = self._observe(self.state, self._received, self._steps)
        return self.obs

    def step(
        self, actions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Advance every game one step (one server cycle).

        :param actions: (N, P, action_size) per-agent ``[HFO action | message]``; (P, action_size)
            is accepted when N == 1.
        :return: ``(obs, rewards, terminated, truncated, info)`` with obs (N, P, observation_size)
            float32, rewards (N, P) float32, terminated and truncated (N,) bool. ``info`` holds
            ``done`` (N,) bool, ``outcome`` (N,) referee code (``OUT_OF_TIME`` on truncation),
            ``episode_return`` (N, P) and ``episode_length`` (N,) (valid where ``done``) and
            ``final_observation`` (N, P, observation_size): the last observation of the games
            that ended, equal to ``obs`` elsewhere. With ``autoreset=True`` the games that ended
            are already reset and ``obs`` holds their first observation; when no game ended,
            ``final_observation`` is ``obs`` itself (same array).
        :raises ValueError: on a wrong shape or a NaN / infinite entry, naming the agent.
        """
        actions = self._check_actions(actions)
        sent = np.clip(actions[..., N_HFO_ACTION:], -1.0, 1.0).astype(np.float32, copy=False)
        commands = decode_actions(actions, self.state, self.params, self.can_dash, check=False)

        previous = self.state
        state = physics.step(previous, commands, self.params, self._rng)
        self._steps += 1
        outcome = self._judge(previous, state)
        rewards, terminated = self._evaluate(previous, state, self._received, outcome, sent)
        rewards = rewards.astype(np.float32, copy=False)
        terminated = np.asarray(terminated, dtype=bool)
        # HFO's untouched-ball rule is a time limit too: it truncates rather than terminates
        timed_out = ~terminated & ((self._steps >= self.max_steps) | (outcome == referee.OUT_OF_TIME))
        outcome = np.where(timed_out & (outcome == referee.IN_GAME), referee.OUT_OF_TIME, outcome)
        if self.time_feature:  # the agents see the step limit: reaching it is a terminal state
            terminated = terminated | (timed_out & (self._steps >= self.max_steps))
        truncated = timed_out & ~terminated

        self.previous_state = previous
        self.state = state
        self._sent = sent
        self._received = sent[:, self._teammate]  # a message is heard one step after it is sent
        self._returns += rewards
        done = terminated | truncated
        info: dict[str, Any] = {
            "done": done,
            "outcome": outcome,
            "episode_return": self._returns.astype(np.float32),
            "episode_length": self._steps.copy(),
        }
        if self.autoreset and done.any():
            # one feature pass over the stepped games and the fresh ones (a pass has a fixed cost)
            games = np.flatnonzero(done)
            fresh = reset_state(self._rng, games.size, self.n_players, self.params, self.ball_x_range)
            # padded to a few batch sizes, so that the feature pass reuses its work arrays
            # (features of a game do not depend on the others; the padding is dropped)
            padding = _padded_size(games.size) - games.size
            combined = _concatenate(state, fresh, fresh.select(np.zeros(padding, dtype=np.intp)))
            silence = np.zeros((games.size + padding, self.n_players, self.channel_size), dtype=np.float32)
            steps = np.concatenate([self._steps, np.zeros(games.size + padding, dtype=np.int64)])
            both = self._observe(combined, np.concatenate([self._received, silence]), steps)
            final_obs = both[: self.n_games]
            obs = final_obs.copy()
            obs[games] = both[self.n_games : self.n_games + games.size]
            self._install(games, fresh)
        else:
            obs = final_obs = self._observe(state, self._received, self._steps)
        info["final_observation"] = final_obs
        self.obs = obs
        return obs, rewards, terminated, truncated, info

    def render(self, game: int = 0, width: int = 640, height: int = 420) -> np.ndarray:
        """An RGB frame (H, W, 3) uint8 of one game, with the messages in flight drawn as bars."""
        from envs.soccer import render  # drawing libraries are only needed when rendering

        messages = self._sent[game] if self.channel_size else None
        return render.render_frame(
            self.state,
            self.params,
            game=game,
            messages=messages,
            width=width,
            height=height,
            labels=list(self.possible_agents),
        )

    @property
    def state_size(self) -> int:
        """Length of one game's :meth:`global_state`."""
        return self.n_players * (self.n_features + self.n_extra + self.channel_size)

    def global_state(self) -> np.ndarray:
        """(N, state_size) float32 full-information state, for centralised critics and analysis.

        Every player's HFO features as if it could see (nobody blinded), the task entries (and the
        remaining time, with ``time_feature``), and the messages in flight (sent at the last step),
        player after player.
        """
        n = self.n_games
        state = np.empty((n, self.n_players, self.observation_size), dtype=np.float32)
        f, e = self.n_features, self.n_extra
        state[..., :f] = features.low_level_features(self.state, self.params)
        self._write_extra(state, self._steps)
        state[..., f + e :] = self._sent
        return state.reshape(n, -1)

    def close(self) -> None:
        """Nothing to release (kept for symmetry with the environment APIs)."""

    # ------------------------------------------------------------------------------------------
    # internals
    # ------------------------------------------------------------------------------------------
    def _check_actions(self, actions: np.ndarray) -> np.ndarray:
        a = np.asarray(actions)
        if a.dtype.kind != "f":
            try:
                a = a.astype(np.float64)
            except (TypeError, ValueError) as err:
                raise ValueError(f"actions must be a float array, got dtype {a.dtype}.") from err
        expected = (self.n_games, self.n_players, self.action_size)
        if a.ndim == 2 and self.n_games == 1:
            a = a[None]
        if a.shape != expected:
            raise ValueError(
                f"actions must have shape (n_games, n_agents, action_size) = {expected} "
                f"(agents {list(self.possible_agents)}, each [HFO action (8) | message "
                f"({self.channel_size})]), got {np.shape(actions)}."
            )
        check_finite(a, self.possible_agents)
        return a

    def remaining_time(self, steps: np.ndarray) -> np.ndarray:
        """The time feature of games that have taken ``steps`` steps: ``1 - steps / max_steps``,
        clipped to [0, 1] (a game kept running past its limit with ``autoreset=False`` reads 0)."""
        return np.clip(1.0 - np.asarray(steps, dtype=np.float64) / self.max_steps, 0.0, 1.0)

    def _write_extra(self, obs: np.ndarray, steps: np.ndarray) -> None:
        """Write the task entries and, with ``time_feature``, the remaining time of games that have
        taken ``steps`` (one per game of ``obs``) into ``obs`` (N, P, observation_size)."""
        f, task_entries = self.n_features, self._extra.shape[-1]
        if task_entries:
            obs[..., f : f + task_entries] = self._extra
        if self.time_feature:
            obs[..., f + task_entries] = self.remaining_time(steps)[:, None]

    def _observe(self, state: SoccerState, received: np.ndarray, steps: np.ndarray) -> np.ndarray:
        obs = np.empty((state.n_games, self.n_players, self.observation_size), dtype=np.float32)
        f, e = self.n_features, self.n_extra
        self._features(state, obs[..., :f])
        self._write_extra(obs, steps)
        if self.channel_size:
            obs[..., f + e :] = received
        return obs

    def _reset_indices(self, games: np.ndarray) -> np.ndarray:
        """Reset the given games in place; returns their first observations (k, P, obs)."""
        fresh = reset_state(self._rng, games.size, self.n_players, self.params, self.ball_x_range)
        self._install(games, fresh)
        return self._observe(fresh, self._received[games], self._steps[games])

    def _install(self, games: np.ndarray, fresh: SoccerState) -> None:
        """Write the fresh states of the given games into the task and clear their episode."""
        # the physics may share untouched arrays between the previous and the new state
        for field in dataclasses.fields(self.state):
            value = getattr(self.state, field.name)
            if value is getattr(self.previous_state, field.name):
                setattr(self.state, field.name, value.copy())
        self.state.assign(games, fresh)
        self._sent = self._sent.copy()
        self._sent[games] = 0.0
        self._received = self._received.copy()
        self._received[games] = 0.0
        self._steps[games] = 0
        self._returns[games] = 0.0
        self._on_reset(games)


def _padded_size(k: int) -> int:
    """The batch size ``k`` fresh games are padded to: the next power of two."""
    return 1 << (k - 1).bit_length()


def _concatenate(*states: SoccerState) -> SoccerState:
    """The games of ``states``, one after the other."""
    return SoccerState(
        **{
            field.name: np.concatenate([getattr(state, field.name) for state in states])
            for field in dataclasses.fields(states[0])
        }
    )
