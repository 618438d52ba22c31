"""Silence a ParallelEnv's own communication, so that messages pass only through our channel.

Many multi-agent benchmarks ship a communication channel of their own: some entries of each
agent's action are "said", and the teammate reads them in some entries of its observation (MPE's
``simple_reference``: actions 5–14 are said, observations 11–20 are heard). A study of learned
communication must close that channel, or the agents may talk around the method under test.

:class:`NativeChannel` names those entries. :class:`SilenceNativeChannel` is a ParallelEnv
wrapper that keeps the spaces as they are, overwrites the said entries of every action with a
constant before the environment sees them, and zeroes the heard entries of every observation:
whatever a policy writes there, the teammate receives nothing. ``TwoAgentEnv(env, channel_size,
silence=channel)`` applies it and also removes the dead entries from its agent rows, so that the
learner neither sees nor emits them.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

__all__ = ["NativeChannel", "SilenceNativeChannel", "resolve_native_channels"]


def _indices(value: Iterable[int] | slice, size: int, what: str) -> tuple[int, ...]:
    if isinstance(value, slice):
        out = tuple(range(size))[value]
    else:
        try:
            out = tuple(int(i) for i in value)
        except (TypeError, ValueError) as error:
            raise TypeError(f"{what}: expected a slice or a sequence of ints, got {value!r}") from error
    bad = [i for i in out if not 0 <= i < size]
    if bad:
        raise ValueError(f"{what}: indices {bad} are outside [0, {size}) (the space has {size} entries)")
    if len(set(out)) != len(out):
        raise ValueError(f"{what}: indices {list(out)} repeat")
    if len(out) >= size:
        raise ValueError(f"{what}: silencing all {size} entries leaves the agent nothing; name fewer")
    return tuple(sorted(out))


@dataclass(frozen=True)
class NativeChannel:
    """The entries through which an environment's agents talk to each other.

    :param observation: indices (or a slice) of the observation where an agent hears its teammate.
    :param action: indices (or a slice) of the action where an agent says something.
    :param action_fill: what the silenced action entries are set to before the environment sees
        them (it must lie in the action space: MPE's is [0, 1], so 0 means "say nothing").
    """

    observation: Iterable[int] | slice = ()
    action: Iterable[int] | slice = ()
    action_fill: float = 0.0

    def resolve(self, obs_space: spaces.Box, act_space: spaces.Box, agent: str) -> _Resolved:
        """Check the entries against one agent's spaces and return them as index tuples."""
        obs = _indices(self.observation, obs_space.shape[0], f"silence observation of agent {agent!r}")
        act = _indices(self.action, act_space.shape[0], f"silence action of agent {agent!r}")
        fill = float(self.action_fill)
        if not np.isfinite(fill):
            raise ValueError(f"silence action_fill must be finite, got {self.action_fill!r}")
        if act:
            low, high = act_space.low[list(act)], act_space.high[list(act)]
            if (fill < low).any() or (fill > high).any():
                raise ValueError(
                    f"silence action_fill={fill} lies outside the action space of agent {agent!r} "
                    f"at the silenced entries ([{low.min()}, {high.max()}])"
                )
        if not obs and not act:
            raise ValueError(f"silence names no observation or action entries for agent {agent!r}")
        return _Resolved(obs, act, fill)


@dataclass(frozen=True)
class _Resolved:
    observation: tuple[int, ...]
    action: tuple[int, ...]
    action_fill: float

    def kept(self, size: int, which: str) -> np.ndarray:
        dropped = set(self.observation if which == "observation" else self.action)
        return np.array([i for i in range(size) if i not in dropped], dtype=np.int64)


def resolve_native_channels(
    env: Any, silence: NativeChannel | Mapping[str, NativeChannel]
) -> dict[str, _Resolved]:
    """One checked :class:`NativeChannel` per agent of ``env`` (one for all, or a dict by agent)."""
    agents = list(env.possible_agents)
    if isinstance(silence, NativeChannel):
        per_agent = dict.fromkeys(agents, silence)
    elif isinstance(silence, Mapping):
        unknown = sorted(set(silence) - set(agents))
        if unknown:
            raise ValueError(f"silence names unknown agents {unknown}; the agents are {agents}")
        per_agent = dict(silence)
        for agent, channel in per_agent.items():
            if not isinstance(channel, NativeChannel):
                raise TypeError(f"silence[{agent!r}] must be a NativeChannel, got {type(channel).__name__}")
    else:
        raise TypeError(
            "silence must be a NativeChannel or a dict {agent: NativeChannel}, "
            f"got {type(silence).__name__}"
        )
    out = {}
    for agent, channel in per_agent.items():
        obs_space, act_space = env.observation_space(agent), env.action_space(agent)
        for kind, space in (("observation", obs_space), ("action", act_space)):
            if not isinstance(space, spaces.Box) or len(space.shape) != 1:
                raise ValueError(f"silence needs 1-D Box spaces; the {kind} space of {agent!r} is {space}")
        out[agent] = channel.resolve(obs_space, act_space, agent)
    return out


class SilenceNativeChannel:
    """A ParallelEnv whose own communication entries carry nothing (same spaces as ``env``).

    Every action's said entries are replaced by ``action_fill`` before ``env`` steps, and every
    observation's heard entries are set to 0. Everything else is passed through.

    :param env: a PettingZoo ``ParallelEnv`` with 1-D ``Box`` spaces.
    :param silence: the entries, one :class:`NativeChannel` for every agent or a dict by agent
        (agents left out of the dict keep their channel).
    """

    def __init__(self, env: Any, silence: NativeChannel | Mapping[str, NativeChannel]) -> None:
        self.env = env
        self.channels = resolve_native_channels(env, silence)

    def __getattr__(self, name: str) -> Any:  # possible_agents, metadata, render_mode, ...
        if name == "env":
            raise AttributeError(name)
        return getattr(self.env, name)

    def observation_space(self, agent: str) -> spaces.Space:
        """The wrapped environment's space."""
        return self.env.observation_space(agent)

    def action_space(self, agent: str) -> spaces.Space:
        """The wrapped environment's space."""
        return self.env.action_space(agent)

    def _hush(self, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        out = {}
        for agent, value in obs.items():
            channel = self.channels.get(agent)
            if channel is not None and channel.observation:
                value = np.array(value, dtype=np.float32, copy=True)
                value[list(channel.observation)] = 0.0
            out[agent] = value
        return out

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        """Reset ``env``; heard entries are zero."""
        obs, infos = self.env.reset(seed=seed, options=options)
        return self._hush(obs), infos

    def step(self, actions: dict[str, np.ndarray]) -> tuple[dict, dict, dict, dict, dict]:
        """Step ``env`` with the said entries replaced; heard entries are zero."""
        muted = {}
        for agent, action in actions.items():
            channel = self.channels.get(agent)
            if channel is not None and channel.action:
                action = np.array(action, dtype=np.float32, copy=True)
                action[list(channel.action)] = channel.action_fill
            muted[agent] = action
        obs, rewards, terminations, truncations, infos = self.env.step(muted)
        return self._hush(obs), rewards, terminations, truncations, infos

    def render(self) -> Any:
        """Render ``env``."""
        return self.env.render()

    def close(self) -> None:
        """Close ``env``."""
        self.env.close()
