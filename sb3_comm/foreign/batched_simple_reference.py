"""mpe2's ``simple_reference`` with its own channel silenced, re-implemented for N games at once.

The same game as ``MPESimpleReference-v0`` (:func:`~sb3_comm.foreign.simple_reference.simple_reference_env`:
mpe2's ``simple_reference_v3`` with continuous actions behind
:class:`~sb3_comm.wrappers.TwoAgentEnv`), stepped for every game in one numpy call, without mpe2 or
PettingZoo. Training on the PettingZoo environment spends most of its time in their per-agent
Python; :func:`sb3_comm.make_comm_vec_env` builds this batched version (``batched=False`` gives
mpe2's own). The tests check it against mpe2 step for step from the same world state:
observations, rewards, ends and received messages.

mpe2's rules, as its source (``mpe2/simple_reference``, ``_mpe_utils/core.py`` and
``simple_env.py``) runs them with its default arguments:

* Reset: each agent ``i`` gets a goal landmark ``g_i`` uniform among the 3; the two agents' and
  then the three landmarks' positions are uniform in [-1, 1]²; velocities are zero.
* Action of agent ``i``: ``[no_action, left, right, down, up]`` clipped to [0, 1]; the force is
  ``u = 5 · (right − left, up − down)``. Nothing collides (``collide=False``), no noise, mass 1.
* Physics, ``dt = 0.1``, damping 0.25: ``p ← p + v·dt``, then ``v ← 0.75·v + u·dt``.
* Reward: agent ``i`` knows ``g_i``, the goal of its teammate ``j``, and is scored by the
  teammate's distance to it, ``r_i = −‖p_j − L_{g_i}‖``; with ``local_ratio`` λ (0.5) agent
  ``i`` receives ``(1 − λ)·(r_0 + r_1)/2 + λ·r_i``. Episodes are truncated after ``max_cycles``
  steps (25); none terminates.
* Observation of agent ``i``: ``[v_i, L_k − p_i for k = 0, 1, 2, colour(L_{g_i})]`` with the
  landmark colours (0.75, 0.25, 0.25), (0.25, 0.75, 0.25), (0.25, 0.25, 0.75), computed in
  float64 and cast to float32; mpe2's own heard entries are silenced, i.e. left out.

Then the channel of :class:`~sb3_comm.wrappers.TwoAgentEnv`: the message an agent sends (the last
``channel_size`` action entries, clipped to [-1, 1]) is the last ``channel_size`` entries of its
teammate's next observation, zero at the first step of an episode.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["LANDMARK_COLOURS", "SimpleReferenceTask"]

N_LANDMARKS = 3
N_MOVE = 5
"""Movement entries of an action: ``[no_action, left, right, down, up]``."""
N_FEATURES = 2 + 2 * N_LANDMARKS + 3
"""An agent's own observation: velocity, landmarks relative to it, its teammate's goal colour."""
LANDMARK_COLOURS = np.array([[0.75, 0.25, 0.25], [0.25, 0.75, 0.25], [0.25, 0.25, 0.75]])
"""Colours of landmarks 0, 1, 2 (mpe2's ``reset_world``)."""
DT = 0.1
DAMPING = 0.25
SENSITIVITY = 5.0


class SimpleReferenceTask:
    """``n_games`` games of silenced ``simple_reference``, with the batched-task protocol that
    :class:`~sb3_comm.wrappers.BatchedTwoAgentVecEnv` drives (the same rows as ``MPESimpleReference-v0``).

    :param n_games: games stepped at once.
    :param seed: seed of the generator behind the resets (``None``: fresh entropy).
    :param channel_size: size of the message each agent sends per step.
    :param max_cycles: episode length in steps.
    :param local_ratio: weight λ of an agent's own reward against the team's, in [0, 1].
    :param silence: must be True: this version has no native channel (mpe2's own, with
        ``batched=False``, keeps it with ``silence=False``).
    :param autoreset: reset the games that ended at the end of the same step.
    :param time_feature: time awareness (as the soccer tasks' option, :class:`envs.tasks.BatchedTask`):
        each agent observes the remaining time ``1 - t / max_cycles`` after its 11 features (before
        the received message), and an episode that reaches ``max_cycles`` is terminated instead of
        truncated. Not in mpe2's own environment (``batched=False``).
    """

    name = "simple_reference"
    possible_agents: tuple[str, ...] = ("agent_0", "agent_1")
    hybrid_layout = None
    """Plain continuous actions: no dash/turn/kick heads."""

    def __init__(
        self,
        n_games: int = 1,
        seed: int | None = None,
        channel_size: int = 4,
        max_cycles: int = 25,
        local_ratio: float = 0.5,
        silence: bool = True,
        autoreset: bool = True,
        time_feature: bool = False,
    ) -> None:
        if int(n_games) < 1:
            raise ValueError(f"n_games must be >= 1, got {n_games}")
        if int(channel_size) < 1:
            raise ValueError(f"channel_size must be >= 1 (the team's only channel), got {channel_size}")
        if int(max_cycles) < 1:
            raise ValueError(f"max_cycles must be >= 1, got {max_cycles}")
        if not 0.0 <= float(local_ratio) <= 1.0:
            raise ValueError(f"local_ratio is a proportion in [0, 1], got {local_ratio}")
        if silence is not True:
            raise ValueError(
                "the batched simple_reference has no native channel (silence must be True); "
                "make_comm_vec_env(..., batched=False) gives mpe2's own environment, which keeps it "
                f"with silence=False (got silence={silence!r})"
            )
        self.n_games = int(n_games)
        self.n_players = 2
        self.channel_size = int(channel_size)
        self.max_cycles = int(max_cycles)
        self.local_ratio = float(local_ratio)
        self.autoreset = bool(autoreset)
        if not isinstance(time_feature, bool | np.bool_):
            raise TypeError(f"time_feature must be True or False, got {time_feature!r}.")
        self.time_feature = bool(time_feature)
        self.n_extra = int(self.time_feature)
        """Entries between the features and the message: the remaining time, with ``time_feature``."""
        self.observation_size = N_FEATURES + self.n_extra + self.channel_size
        self.action_size = N_MOVE + self.channel_size
        self.observation_low = np.concatenate(
            [
                np.full(N_FEATURES, -np.inf, np.float32),
                np.zeros(self.n_extra, np.float32),
                -np.ones(self.channel_size, np.float32),
            ]
        )
        self.observation_high = np.abs(self.observation_low)
        self.observation_high[N_FEATURES : N_FEATURES + self.n_extra] = 1.0
        self.action_low = np.concatenate(
            [np.zeros(N_MOVE, np.float32), -np.ones(self.channel_size, np.float32)]
        )
        self.action_high = np.ones(self.action_size, dtype=np.float32)
        self._rng = np.random.default_rng(seed)
        self.reset()

    # ------------------------------------------------------------------------------------------
    @property
    def rng(self) -> np.random.Generator:
        """The generator behind every reset."""
        return self._rng

    def reset(self, seed: int | None = None) -> np.ndarray:
        """Reset every game; with a ``seed`` the generator is re-created first.

        :return: observations ``(N, 2, observation_size)`` float32.
        """
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        n = self.n_games
        self.goal = np.zeros((n, 2), dtype=np.int64)
        """(N, 2) ``g_i``: the landmark agent i knows, the goal of its teammate."""
        self.agent_pos = np.zeros((n, 2, 2))
        self.agent_vel = np.zeros((n, 2, 2))
        self.landmark_pos = np.zeros((n, N_LANDMARKS, 2))
        self._received = np.zeros((n, 2, self.channel_size), dtype=np.float32)
        self._steps = np.zeros(n, dtype=np.int64)
        self._returns = np.zeros((n, 2), dtype=np.float64)
        self._draw(np.arange(n))
        self.obs = self._observe()
        return self.obs

    def load_state(
        self,
        agent_pos: np.ndarray,
        agent_vel: np.ndarray,
        landmark_pos: np.ndarray,
        goal: np.ndarray,
    ) -> np.ndarray:
        """Replace the world (e.g. copied from mpe2), start new episodes, and observe it.

        :param agent_pos: (N, 2, 2) positions of the agents.
        :param agent_vel: (N, 2, 2) their velocities.
        :param landmark_pos: (N, 3, 2) positions of the landmarks.
        :param goal: (N, 2) index of the landmark each agent knows (its teammate's goal).
        :return: observations ``(N, 2, observation_size)``.
        """
        n = self.n_games
        for name, value, shape in (
            ("agent_pos", agent_pos, (n, 2, 2)),
            ("agent_vel", agent_vel, (n, 2, 2)),
            ("landmark_pos", landmark_pos, (n, N_LANDMARKS, 2)),
            ("goal", goal, (n, 2)),
        ):
            if np.shape(value) != shape:
                raise ValueError(f"{name} must have shape {shape}, got {np.shape(value)}")
        goal = np.asarray(goal)
        if goal.dtype.kind not in "iu" or goal.min() < 0 or goal.max() >= N_LANDMARKS:
            raise ValueError(f"goal must hold landmark indices 0..{N_LANDMARKS - 1}, got {goal.tolist()}")
        self.agent_pos = np.array(agent_pos, dtype=np.float64)
        self.agent_vel = np.array(agent_vel, dtype=np.float64)
        self.landmark_pos = np.array(landmark_pos, dtype=np.float64)
        self.goal = goal.astype(np.int64)
        self._received = np.zeros((n, 2, self.channel_size), dtype=np.float32)
        self._steps = np.zeros(n, dtype=np.int64)
        self._returns = np.zeros((n, 2), dtype=np.float64)
        self.obs = self._observe()
        return self.obs

    def step(
        self, actions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Advance every game one step.

        :param actions: ``(N, 2, action_size)``: per agent ``[movement (5) | message]``.
        :return: ``(obs, rewards, terminated, truncated, info)``: obs ``(N, 2, observation_size)``
            float32, rewards ``(N, 2)`` float32, terminated and truncated ``(N,)`` bool; ``info``
            holds ``episode_return`` ``(N, 2)`` and ``episode_length`` ``(N,)`` (valid where an
            episode ended) and ``final_observation``, the last observation of the games that
            ended (with ``autoreset`` their ``obs`` is already the next episode's first).
        :raises ValueError: a wrong shape, or an entry that is NaN or infinite.
        """
        a = np.asarray(actions, dtype=np.float32)
        expected = (self.n_games, 2, self.action_size)
        if a.shape != expected:
            raise ValueError(
                f"actions must have shape (n_games, 2, 5 + channel_size) = {expected} (each agent: "
                f"[no_action, left, right, down, up | message ({self.channel_size})]), "
                f"got {np.shape(actions)}"
            )
        if not np.isfinite(a).all():
            bad = [self.possible_agents[i] for i in range(2) if not np.isfinite(a[:, i]).all()]
            raise ValueError(f"Action of agent(s) {bad} contains NaN or inf; expected finite values")
        move = np.clip(a[..., :N_MOVE], 0.0, 1.0)  # mpe2's ClipOutOfBoundsWrapper
        sent = np.clip(a[..., N_MOVE:], -1.0, 1.0)
        # float32 differences added to a float64 zero vector, as mpe2's _set_action does
        force = np.stack([move[..., 2] - move[..., 1], move[..., 4] - move[..., 3]], axis=-1).astype(
            np.float64
        )
        force *= SENSITIVITY
        self.agent_pos = self.agent_pos + self.agent_vel * DT
        self.agent_vel = self.agent_vel * (1 - DAMPING) + (force / 1.0) * DT

        rewards = self._rewards().astype(np.float32)
        self._steps += 1
        self._returns += rewards
        self._received = sent[:, ::-1].copy()  # agent 0 hears agent 1 and vice versa, one step later
        ended = self._steps >= self.max_cycles
        # with the time in the state the limit is a terminal state; otherwise a truncation (mpe2)
        terminated = ended if self.time_feature else np.zeros(self.n_games, dtype=bool)
        truncated = ended & ~terminated
        info: dict[str, Any] = {
            "episode_return": self._returns.astype(np.float32),
            "episode_length": self._steps.copy(),
        }
        obs = final = self._observe()
        if self.autoreset and ended.any():
            games = np.flatnonzero(ended)
            self._draw(games)
            self._received[games] = 0.0
            self._steps[games] = 0
            self._returns[games] = 0.0
            obs = final.copy()
            obs[games] = self._observe(games)
        info["final_observation"] = final
        self.obs = obs
        return obs, rewards, terminated, truncated, info

    def render(self, game: int = 0, size: int = 350) -> np.ndarray:
        """An RGB frame ``(size, size, 3)`` uint8 of one game: landmarks in their colours, agents in
        grey, the view ``[-1.5, 1.5]²`` (y up)."""
        ys, xs = np.mgrid[0:size, 0:size]
        x = (xs + 0.5) / size * 3.0 - 1.5
        y = 1.5 - (ys + 0.5) / size * 3.0
        frame = np.full((size, size, 3), 255, dtype=np.uint8)
        entities = [(p, c) for p, c in zip(self.landmark_pos[game], LANDMARK_COLOURS, strict=True)]
        entities += [(p, np.array([0.25, 0.25, 0.25])) for p in self.agent_pos[game]]
        for position, colour in entities:
            disk = (x - position[0]) ** 2 + (y - position[1]) ** 2 <= 0.05**2 * 4
            frame[disk] = (colour * 200).astype(np.uint8)
        return frame

    def close(self) -> None:
        """Nothing to release."""

    # ------------------------------------------------------------------------------------------
    def _draw(self, games: np.ndarray) -> None:
        """New episodes in ``games``: goals first, then agents' and landmarks' positions."""
        k = games.size
        self.goal[games] = self._rng.integers(N_LANDMARKS, size=(k, 2))
        self.agent_pos[games] = self._rng.uniform(-1.0, 1.0, size=(k, 2, 2))
        self.agent_vel[games] = 0.0
        self.landmark_pos[games] = self._rng.uniform(-1.0, 1.0, size=(k, N_LANDMARKS, 2))

    def _rewards(self) -> np.ndarray:
        """(N, 2) float64: ``(1 − λ)·mean_i r_i + λ·r_i`` with ``r_i = −‖p_j − L_{g_i}‖``."""
        target = np.take_along_axis(self.landmark_pos, self.goal[..., None], axis=1)  # (N, 2, 2)
        delta = self.agent_pos[:, ::-1] - target  # teammate j's position against the goal i knows
        own = -np.sqrt(np.square(delta[..., 0]) + np.square(delta[..., 1]))
        team = (own[:, 0] + own[:, 1]) / 2
        return team[:, None] * (1 - self.local_ratio) + own * self.local_ratio

    def _observe(self, games: np.ndarray | None = None) -> np.ndarray:
        """Observations ``(N or k, 2, observation_size)`` of all games or of ``games``."""
        index = slice(None) if games is None else games
        pos, vel = self.agent_pos[index], self.agent_vel[index]
        k = pos.shape[0]
        obs = np.empty((k, 2, self.observation_size), dtype=np.float32)
        obs[..., 0:2] = vel
        relative = self.landmark_pos[index][:, None] - pos[:, :, None]  # (k, 2, 3, 2)
        obs[..., 2 : 2 + 2 * N_LANDMARKS] = relative.reshape(k, 2, 2 * N_LANDMARKS)
        obs[..., 2 + 2 * N_LANDMARKS : N_FEATURES] = LANDMARK_COLOURS[self.goal[index]]
        if self.time_feature:
            remaining = np.clip(1.0 - self._steps[index] / self.max_cycles, 0.0, 1.0)
            obs[..., N_FEATURES] = remaining[:, None]
        obs[..., N_FEATURES + self.n_extra :] = self._received[index]
        return obs
