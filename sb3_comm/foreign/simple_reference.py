"""A foreign benchmark: MPE's ``simple_reference`` (mpe2), with its own channel silenced.

Two agents and three coloured landmarks on a plane. Each agent must reach a target landmark that
only its teammate knows: agent ``i``'s observation holds the colour of agent ``j``'s target. Both
move (continuous actions), and the team is rewarded by the distances of both agents to their
targets (``local_ratio`` 0.5: half own, half team). Episodes last ``max_cycles`` (25) steps. It is
not a soccer task and it was never used to tune sb3-comm, which is what makes it a test of the
defaults (issue "a learner that works on tasks it was not tuned for").

The environment's own channel (10 said action entries, 10 heard observation entries) is closed
with :data:`SIMPLE_REFERENCE_CHANNEL` (see :mod:`sb3_comm.wrappers.silence`), so that the goal can
only pass through the channel of :class:`~sb3_comm.wrappers.TwoAgentEnv`. With the native channel
removed each agent's own features are::

    [vel_x, vel_y, (landmark_k - self) for k = 0, 1, 2 (6 entries), teammate's target colour (3)]

The action of each agent is MPE's ``[no_action, left, right, down, up]`` in [0, 1] (the force is
``5 · (right − left, up − down)``), then the message.

Scripted references, all policies over the rows of :class:`TwoAgentEnv` with ``predict`` as SB3
models have (so :func:`sb3_comm.evaluation.evaluate_team` scores them):

* :class:`OracleTeam`: full information: each agent reads its target from its teammate's row.
* :class:`NoCommTeam`: the best policy without communication that we could script: go to the
  geometric median of the three landmarks (the point with the least expected distance to a target
  drawn uniformly among them).
* :class:`RandomTeam`: uniformly random actions.
* :class:`NativeChannelTeam`: the oracle's knowledge sent through the environment's *own*
  channel: it beats no-comm only while that channel is open (what the silencing tests check).

mpe2 is an optional extra: ``pip install "sb3-comm[mpe]"``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sb3_comm.wrappers.silence import NativeChannel

__all__ = [
    "ENV_ID",
    "SIMPLE_REFERENCE_CHANNEL",
    "NativeChannelTeam",
    "NoCommTeam",
    "OracleTeam",
    "RandomTeam",
    "simple_reference_env",
]

ENV_ID = "MPESimpleReference-v0"
"""Gymnasium id (registered by ``import sb3_comm``; needs mpe2 when made)."""

N_LANDMARKS = 3
VELOCITY = slice(0, 2)
LANDMARKS = slice(2, 8)
TARGET_COLOUR = slice(8, 11)
NATIVE_HEARD = slice(11, 21)
NATIVE_SAID = slice(5, 15)


SIMPLE_REFERENCE_CHANNEL = NativeChannel(observation=NATIVE_HEARD, action=NATIVE_SAID, action_fill=0.0)
"""simple_reference's own channel: said action entries 5–14, heard observation entries 11–20."""


def _import_mpe2() -> Any:
    try:
        from mpe2 import simple_reference_v3
    except ImportError as error:
        raise ImportError(
            f"{ENV_ID} needs the optional package mpe2: pip install 'sb3-comm[mpe]' (or pip install mpe2)"
        ) from error
    return simple_reference_v3


def simple_reference_env(
    channel_size: int = 4,
    silence: bool = True,
    max_cycles: int = 25,
    local_ratio: float = 0.5,
    render_mode: str | None = None,
    time_feature: bool = False,
) -> Any:
    """mpe2's ``simple_reference_v3`` (continuous actions) as a :class:`~sb3_comm.wrappers.TwoAgentEnv`.

    :param channel_size: size of the wrapper's message channel.
    :param silence: close the environment's own channel (default). False keeps its 10 said and 10
        heard entries in the rows, beside the wrapper's channel.
    :param max_cycles: episode length in steps.
    :param local_ratio: weight of an agent's own reward against the team's.
    :param render_mode: mpe2's render mode (``"rgb_array"``).
    :param time_feature: time awareness, as the batched game's option: each agent observes the
        remaining time ``1 - t / max_cycles`` after its features, and the last step terminates the
        episode (``TwoAgentEnv(time_limit=max_cycles)``).
    """
    from sb3_comm.wrappers.two_agent import TwoAgentEnv

    for name, flag in (("silence", silence), ("time_feature", time_feature)):
        if not isinstance(flag, bool):
            raise TypeError(f"{name} must be True or False, got {flag!r}")
    module = _import_mpe2()
    env = module.parallel_env(
        continuous_actions=True,
        max_cycles=int(max_cycles),
        local_ratio=float(local_ratio),
        render_mode=render_mode,
    )
    return TwoAgentEnv(
        env,
        channel_size=channel_size,
        silence=SIMPLE_REFERENCE_CHANNEL if silence else None,
        time_limit=int(max_cycles) if time_feature else None,
    )


def steer(relative: np.ndarray, velocity: np.ndarray, gain: float = 8.0, damping: float = 2.0) -> np.ndarray:
    """MPE movement actions ``(..., 5)`` that drive a point mass to ``relative`` (a PD controller).

    :param relative: target minus own position, ``(..., 2)``.
    :param velocity: own velocity, ``(..., 2)``.
    :param gain: force per unit of distance; the default pair (8, 2) was the best of a one-off
        grid ``gain`` ∈ {2, 4, 8, 16} × ``damping`` ∈ {0.5, 1, 2, 4} on 100 games, for the oracle
        and the no-comm policy alike (not kept in ``benchmarks/results``).
    :param damping: force per unit of velocity.
    """
    force = np.clip(gain * relative - damping * velocity, -1.0, 1.0)
    action = np.zeros((*force.shape[:-1], 5), dtype=np.float32)
    action[..., 1] = np.maximum(-force[..., 0], 0.0)
    action[..., 2] = np.maximum(force[..., 0], 0.0)
    action[..., 3] = np.maximum(-force[..., 1], 0.0)
    action[..., 4] = np.maximum(force[..., 1], 0.0)
    return action


def geometric_median(points: np.ndarray, iterations: int = 30) -> np.ndarray:
    """Weiszfeld's iteration over the second-to-last axis of ``points`` ``(..., k, 2)``."""
    estimate = points.mean(axis=-2)
    for _ in range(iterations):
        distance = np.maximum(np.linalg.norm(points - estimate[..., None, :], axis=-1), 1e-9)
        weight = 1.0 / distance
        estimate = (points * weight[..., None]).sum(axis=-2) / weight.sum(axis=-1, keepdims=True)
    return estimate


class _ScriptedTeam:
    """A scripted policy over the stacked rows ``(n_games, 2, obs_dim)`` of :class:`TwoAgentEnv`."""

    def __init__(self, env: Any, seed: int = 0) -> None:
        layout = env.get_attr("comm_layout", indices=[0])[0] if hasattr(env, "get_attr") else env.comm_layout
        space = env.action_space
        self.action_dim = int(layout.action_dim)
        self.low, self.high = space.low, space.high
        self.rng = np.random.default_rng(seed)

    @staticmethod
    def _landmarks(obs: np.ndarray) -> np.ndarray:
        return obs[..., LANDMARKS].reshape(*obs.shape[:-1], N_LANDMARKS, 2)

    def _go_to(self, obs: np.ndarray, target: np.ndarray) -> np.ndarray:
        action = np.zeros((*obs.shape[:-1], self.action_dim), dtype=np.float32)
        action[..., :5] = steer(target, obs[..., VELOCITY])
        return action

    def _no_comm_target(self, obs: np.ndarray) -> np.ndarray:
        return geometric_median(self._landmarks(obs))

    def act(self, obs: np.ndarray) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    def predict(
        self,
        observation: np.ndarray,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, None]:
        """Actions for a batch of rows, as an SB3 model's ``predict`` returns them."""
        obs = np.asarray(observation, dtype=np.float32)
        single = obs.ndim == 2
        action = self.act(obs[None] if single else obs)
        return (action[0] if single else action), None


class OracleTeam(_ScriptedTeam):
    """Full information: agent ``i`` reads its target's colour from agent ``j``'s row."""

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Steer each agent to the landmark its teammate's row names."""
        target_index = obs[..., ::-1, TARGET_COLOUR].argmax(axis=-1)  # the teammate's view of my target
        landmarks = self._landmarks(obs)
        target = np.take_along_axis(landmarks, target_index[..., None, None], axis=-2)[..., 0, :]
        return self._go_to(obs, target)


class NoCommTeam(_ScriptedTeam):
    """No communication: each agent goes to the geometric median of the three landmarks."""

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Steer each agent to the landmarks' geometric median."""
        return self._go_to(obs, self._no_comm_target(obs))


class RandomTeam(_ScriptedTeam):
    """Uniformly random actions (movement and message)."""

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Draw actions uniformly in the action space."""
        return self.rng.uniform(self.low, self.high, size=(obs.shape[0], *self.low.shape)).astype(np.float32)


class NativeChannelTeam(_ScriptedTeam):
    """The oracle's knowledge sent through simple_reference's *own* channel (needs ``silence=False``).

    Each agent says its teammate's target (a one-hot in native said entries 5–7) and steers to the
    target it hears (native heard entries 11–13); while it hears nothing it goes where
    :class:`NoCommTeam` goes. It needs the native entries in its rows: on ``TwoAgentEnv(env,
    silence=None)`` its messages get through; behind :class:`~sb3_comm.wrappers.SilenceNativeChannel`
    (same rows, the channel closed) it hears nothing.
    """

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Say the teammate's target natively, steer to the heard one."""
        heard = obs[..., NATIVE_HEARD][..., :N_LANDMARKS]
        landmarks = self._landmarks(obs)
        chosen = np.take_along_axis(landmarks, heard.argmax(axis=-1)[..., None, None], axis=-2)[..., 0, :]
        silent = (heard.max(axis=-1) <= 0.0)[..., None]
        action = self._go_to(obs, np.where(silent, self._no_comm_target(obs), chosen))
        said = np.zeros((*obs.shape[:-1], N_LANDMARKS), dtype=np.float32)
        np.put_along_axis(said, obs[..., TARGET_COLOUR].argmax(axis=-1)[..., None], 1.0, axis=-1)
        action[..., NATIVE_SAID.start : NATIVE_SAID.start + N_LANDMARKS] = said
        return action
