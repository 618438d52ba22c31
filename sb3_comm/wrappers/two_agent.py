"""Turn a two-agent PettingZoo ParallelEnv into one shared-parameter Gymnasium environment.

Each agent becomes a row of a stacked observation ``(2, obs_dim)`` and action
``(2, action_dim)``, laid out as :class:`sb3_comm.common.layout.CommLayout` describes: own
features (zero padded to the larger agent), a role one-hot, and the message received from the
teammate. The wrapper knows nothing about soccer: it needs two agents with 1-D ``Box`` spaces.

The message channel (paper §2): a message ``m_t`` sent with the action at step ``t`` is received
by the teammate at ``t + 1``, appended to its observation; the received message is 0 at the first
step. If the ParallelEnv already carries a channel (it has a ``channel_size`` attribute: it reads
the outgoing message from the last entries of each action and puts the received message in the
last entries of each observation), the wrapper uses it; otherwise the wrapper adds one.

An environment with a channel of its own that the wrapper should not use (MPE's
``simple_reference``, say) is opened with ``silence=NativeChannel(observation=..., action=...)``
(:mod:`sb3_comm.wrappers.silence`): its said action entries are set to a constant, its heard
observation entries are dropped from the rows, so that messages pass only through the wrapper's
channel.

An environment whose episodes end at a fixed step limit may be made time-aware with
``time_limit=T`` (Pardo et al. 2018, "Time Limits in Reinforcement Learning"; the feature of
sb3-contrib's ``TimeFeatureWrapper``): each agent's features end with the remaining time
``1 - t / T`` (1 at the first observation, 0 at the limit), and an episode that reaches step ``T``
is *terminated*, not truncated, since the limit is then part of the state the agents see. It is
the ``time_feature`` option of sb3-comm's own tasks, for any ParallelEnv.

SB3 needs one scalar reward per environment: the wrapper returns the team's mean reward and puts
each agent's own reward in ``info["agent_rewards"]`` (what :class:`sb3_comm.CommDDPG` learns from).
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from sb3_comm.common.layout import CommLayout, HybridActionLayout
from sb3_comm.common.validation import check_observation
from sb3_comm.wrappers.silence import NativeChannel, SilenceNativeChannel

__all__ = ["RowCodec", "TwoAgentEnv", "check_action", "make_task_env"]


def check_action(
    action: np.ndarray, expected_shape: tuple[int, ...], agent_names: tuple[str, ...]
) -> np.ndarray:
    """Return ``action`` as a float array of ``expected_shape`` or raise a ``ValueError``.

    The error names the agent whose action is not finite and the shape that is accepted.
    """
    array = np.asarray(action, dtype=np.float32)
    if array.shape != expected_shape:
        raise ValueError(
            f"Action has shape {array.shape}; expected {expected_shape} "
            f"(one row per agent: {list(agent_names)})"
        )
    finite = np.isfinite(array)
    if not finite.all():
        bad_rows = (~finite).reshape(-1, expected_shape[-2], expected_shape[-1]).any(axis=(0, 2))
        bad = [name for name, is_bad in zip(agent_names, bad_rows, strict=False) if is_bad]
        raise ValueError(f"Action of agent(s) {bad} contains NaN or inf; expected finite values")
    return array


class RowCodec:
    """Packs per-agent arrays into the stacked rows of a :class:`CommLayout`, and back.

    :param feature_sizes: length of each agent's own observation (without any message).
    :param action_sizes: length of each agent's own action (without any message).
    :param channel_size: message size ``n``.
    """

    def __init__(self, feature_sizes: list[int], action_sizes: list[int], channel_size: int) -> None:
        self.n_agents = len(feature_sizes)
        self.feature_sizes = feature_sizes
        self.action_sizes = action_sizes
        self.channel_size = channel_size
        self.max_features = max(feature_sizes)
        self.max_actions = max(action_sizes)
        self.obs_dim = self.max_features + self.n_agents + channel_size
        self.action_dim = self.max_actions + channel_size
        # Rows start with the role one-hot in place; only features and messages change later.
        self._template = np.zeros((self.n_agents, self.obs_dim), dtype=np.float32)
        for i in range(self.n_agents):
            self._template[i, self.max_features + i] = 1.0

    def observations(self, features: list[np.ndarray], messages: np.ndarray) -> np.ndarray:
        """Stack per-agent features ``(B, F_i)`` and received messages ``(B, n_agents, n)``."""
        batch = messages.shape[0]
        out = np.broadcast_to(self._template, (batch, *self._template.shape)).copy()
        for i, feats in enumerate(features):
            out[:, i, : self.feature_sizes[i]] = feats
        if self.channel_size:
            out[:, :, self.obs_dim - self.channel_size :] = messages
        return out

    def split_action(self, action: np.ndarray, agent: int) -> tuple[np.ndarray, np.ndarray]:
        """One agent's own action and outgoing message (clipped to [-1, 1]) from stacked rows."""
        own = action[..., agent, : self.action_sizes[agent]]
        message = np.clip(action[..., agent, self.action_dim - self.channel_size :], -1.0, 1.0)
        return own, message

    def layout(self, agent_names: tuple[str, ...], hybrid: HybridActionLayout | None) -> CommLayout:
        """The :class:`CommLayout` these rows follow."""
        return CommLayout(
            n_agents=self.n_agents,
            obs_dim=self.obs_dim,
            action_dim=self.action_dim,
            channel_size=self.channel_size,
            agent_names=agent_names,
            hybrid=hybrid,
        )

    def spaces(
        self,
        feature_bounds: list[tuple[np.ndarray, np.ndarray]],
        action_bounds: list[tuple[np.ndarray, np.ndarray]],
    ) -> tuple[spaces.Box, spaces.Box]:
        """Observation and action spaces of the stacked rows (padding is bounded to 0 / [-1, 1])."""
        obs_low = np.zeros((self.n_agents, self.obs_dim), dtype=np.float32)
        obs_high = np.zeros((self.n_agents, self.obs_dim), dtype=np.float32)
        act_low = -np.ones((self.n_agents, self.action_dim), dtype=np.float32)
        act_high = np.ones((self.n_agents, self.action_dim), dtype=np.float32)
        for i in range(self.n_agents):
            low, high = feature_bounds[i]
            obs_low[i, : self.feature_sizes[i]], obs_high[i, : self.feature_sizes[i]] = low, high
            obs_high[i, self.max_features : self.max_features + self.n_agents] = 1.0
            obs_low[i, self.obs_dim - self.channel_size :] = -1.0
            obs_high[i, self.obs_dim - self.channel_size :] = 1.0
            low, high = action_bounds[i]
            act_low[i, : self.action_sizes[i]], act_high[i, : self.action_sizes[i]] = low, high
        return (
            spaces.Box(obs_low, obs_high, dtype=np.float32),
            spaces.Box(act_low, act_high, dtype=np.float32),
        )


def _copy_infos(infos: dict[str, Any]) -> dict[str, Any]:
    """Per-agent infos in new dicts: some ParallelEnvs (mpe2) return the same objects every step."""
    return {agent: dict(value) if isinstance(value, dict) else value for agent, value in infos.items()}


def _env_channel_size(env: Any) -> int:
    return int(getattr(env, "channel_size", 0) or 0)


class TwoAgentEnv(gym.Env):
    """A two-agent ParallelEnv seen as one Gymnasium environment with stacked agent rows.

    :param env: a PettingZoo ``ParallelEnv`` with exactly two agents and 1-D ``Box`` spaces.
    :param channel_size: message size. If ``env`` carries its own channel it must match (or be
        None); otherwise the wrapper adds a channel of this size (required).
    :param silence: the environment's own communication entries, to be closed: one
        :class:`~sb3_comm.wrappers.silence.NativeChannel` for both agents or a dict by agent name.
        The said action entries are set to its ``action_fill`` and removed from the action rows;
        the heard observation entries are removed from the observation rows. None (default) keeps
        every entry. Not accepted for an environment whose channel the wrapper itself uses.
    :param time_limit: the episode's step limit ``T``, to make the agents time-aware: every row's
        features end with the remaining time ``1 - t / T``, and reaching step ``T`` terminates the
        episode (a truncation by the environment before ``T`` stays a truncation). None (default)
        adds nothing. Not accepted for an environment that shows the time itself
        (``time_feature=True``).
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        env: Any,
        channel_size: int | None = None,
        silence: NativeChannel | dict[str, NativeChannel] | None = None,
        time_limit: int | None = None,
    ) -> None:
        super().__init__()
        agents = tuple(getattr(env, "possible_agents", ()))
        if len(agents) != 2:
            raise ValueError(
                f"TwoAgentEnv needs a ParallelEnv with exactly 2 agents; got {len(agents)}: {list(agents)}"
            )
        for agent in agents:
            for kind, space in (
                ("observation", env.observation_space(agent)),
                ("action", env.action_space(agent)),
            ):
                if not isinstance(space, spaces.Box) or len(space.shape) != 1:
                    raise ValueError(
                        f"TwoAgentEnv accepts 1-D Box spaces only; the {kind} space of agent "
                        f"{agent!r} is {space}"
                    )
        env_channel = _env_channel_size(env)
        if silence is not None and env_channel:
            raise ValueError(
                f"silence is for an environment's own channel that the wrapper does not use; this "
                f"environment's channel (channel_size={env_channel}) is the wrapper's message channel"
            )
        if time_limit is not None:
            if isinstance(time_limit, bool) or not isinstance(time_limit, int | np.integer) or time_limit < 1:
                raise ValueError(
                    f"time_limit must be a whole number of steps >= 1 or None, got {time_limit!r}"
                )
            if getattr(env, "time_feature", False):
                raise ValueError(
                    "time_limit adds the remaining time to the rows, but this environment already "
                    "shows it (time_feature=True); use one of the two"
                )
        self.time_limit = None if time_limit is None else int(time_limit)
        self.silenced = silence is not None
        if silence is not None:
            env = SilenceNativeChannel(env, silence)
        self.env = env
        self.agent_names = agents
        if env_channel:
            if channel_size is not None and channel_size != env_channel:
                raise ValueError(
                    f"channel_size={channel_size} does not match the environment's channel of size "
                    f"{env_channel}; pass channel_size={env_channel} or None"
                )
            channel = env_channel
        else:
            if channel_size is None or channel_size < 1:
                raise ValueError(
                    "The environment carries no message channel: pass channel_size >= 1 so that the "
                    f"wrapper adds one (got {channel_size})"
                )
            channel = int(channel_size)
        self.env_carries_channel = bool(env_channel)
        strip = channel if self.env_carries_channel else 0
        obs_spaces = [env.observation_space(a) for a in agents]
        act_spaces = [env.action_space(a) for a in agents]
        # Entries of each agent's own observation and action that reach the rows.
        self._obs_keep = [np.arange(s.shape[0] - strip) for s in obs_spaces]
        self._act_keep = [np.arange(s.shape[0] - strip) for s in act_spaces]
        self._act_sizes = [s.shape[0] for s in act_spaces]
        if self.silenced:
            for i, agent in enumerate(agents):
                hushed = env.channels.get(agent)
                if hushed is not None:
                    self._obs_keep[i] = hushed.kept(obs_spaces[i].shape[0], "observation")
                    self._act_keep[i] = hushed.kept(act_spaces[i].shape[0], "action")
        timed = int(self.time_limit is not None)  # the remaining time, after each agent's features
        self.codec = RowCodec(
            [k.size + timed for k in self._obs_keep], [k.size for k in self._act_keep], channel
        )
        clock = (np.zeros(timed, dtype=np.float32), np.ones(timed, dtype=np.float32))
        self.observation_space, self.action_space = self.codec.spaces(
            [
                (np.concatenate([s.low[k], clock[0]]), np.concatenate([s.high[k], clock[1]]))
                for s, k in zip(obs_spaces, self._obs_keep, strict=True)
            ],
            [(s.low[k], s.high[k]) for s, k in zip(act_spaces, self._act_keep, strict=True)],
        )
        self.comm_layout = self.codec.layout(
            agents, HybridActionLayout.from_dict(getattr(env, "metadata", {}).get("hybrid_action"))
        )
        self.render_mode = getattr(env, "render_mode", None)
        self._inbox = np.zeros((2, channel), dtype=np.float32)
        self._returns = np.zeros(2, dtype=np.float64)
        self._length = 0

    def _assemble(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        n = self.codec.channel_size
        rows = [np.asarray(obs[a], dtype=np.float32) for a in self.agent_names]
        if self.env_carries_channel:
            features = [r[None, : r.shape[0] - n] for r in rows]
            messages = np.stack([r[r.shape[0] - n :] for r in rows])[None]
        else:
            if self.silenced:
                features = [r[None, keep] for r, keep in zip(rows, self._obs_keep, strict=True)]
            else:
                features = [r[None] for r in rows]
            messages = self._inbox[None]
        if self.time_limit is not None:
            remaining = np.float32(max(0.0, 1.0 - self._length / self.time_limit))
            features = [np.append(f, np.full((1, 1), remaining, np.float32), axis=1) for f in features]
        rows = self.codec.observations(features, messages)[0]
        check_observation(rows, self.agent_names)  # NaN from the environment: blame it, not the actions
        return rows

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict]:
        """Reset the ParallelEnv; received messages start at zero."""
        super().reset(seed=seed)
        obs, infos = self.env.reset(seed=seed, options=options)
        self._inbox[:] = 0.0
        self._returns[:] = 0.0
        self._length = 0
        return self._assemble(obs), {"agent_infos": _copy_infos(infos)}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Step both agents; the outgoing messages reach the teammate at the next step."""
        action = check_action(action, self.action_space.shape, self.agent_names)
        actions = {}
        outgoing = np.zeros_like(self._inbox)
        for i, agent in enumerate(self.agent_names):
            own, message = self.codec.split_action(action, i)
            outgoing[i] = message
            if self.env_carries_channel:
                actions[agent] = np.concatenate([own, message])
            elif self.silenced:
                full = np.zeros(self._act_sizes[i], dtype=np.float32)  # SilenceNativeChannel fills the rest
                full[self._act_keep[i]] = own
                actions[agent] = full
            else:
                actions[agent] = own
        obs, rewards, terminations, truncations, infos = self.env.step(actions)
        self._inbox = outgoing[::-1].copy()  # agent 0 hears agent 1 and vice versa
        agent_rewards = np.array([rewards[a] for a in self.agent_names], dtype=np.float32)
        self._returns += agent_rewards
        self._length += 1
        terminated = any(bool(terminations[a]) for a in self.agent_names)
        truncated = any(bool(truncations[a]) for a in self.agent_names) and not terminated
        if self.time_limit is not None and self._length >= self.time_limit:
            terminated, truncated = True, False  # the agents see the limit: it is a terminal state
        info: dict[str, Any] = {"agent_rewards": agent_rewards, "agent_infos": _copy_infos(infos)}
        if terminated or truncated:
            info["agent_returns"] = self._returns.astype(np.float32)
        return self._assemble(obs), float(agent_rewards.mean()), terminated, truncated, info

    def render(self) -> Any:
        """Render through the ParallelEnv (``render_mode="rgb_array"`` gives an RGB array)."""
        return self.env.render()

    def close(self) -> None:
        """Close the ParallelEnv."""
        self.env.close()


def make_task_env(task: str, **kwargs: Any) -> TwoAgentEnv:
    """Build ``TwoAgentEnv(spec.parallel_env(**kwargs))`` for a task of :data:`envs.registry.TASKS`;
    the entry point of the registered ids.

    :param task: the task's Gymnasium id (``"BlindSoccer-v0"``), short key (``"blind_soccer"``) or
        PettingZoo name (``"blind_soccer_v0"``, what earlier versions registered).
    :param kwargs: the task's own options (e.g. ``channel_size``, ``max_steps``, ``render_mode``).
    :raises KeyError: for an unknown task, naming the accepted ones.
    """
    from envs.registry import get_task

    return TwoAgentEnv(get_task(task).parallel_env(**kwargs))
