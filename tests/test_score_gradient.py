"""``score_gradient="alternatives"``: the action scores move by the critic's advantage of executing
each discrete action, the parameters by the critic's gradient as before."""

from __future__ import annotations

import pytest
import torch as th

from sb3_comm import CommDDPG, HybridDDPG, make_comm_vec_env
from sb3_comm.hybrid_ddpg.policies import SWITCH_MARGIN

SMALL = {"net_arch": [16, 16]}


def test_score_entries_are_the_advantages_of_switching_and_the_rest_is_the_critic_gradient() -> None:
    model = HybridDDPG(
        "MlpPolicy", "HFOMoveToBall-v0", learning_starts=50, seed=0, device="cpu",
        policy_kwargs={**SMALL, "score_gradient": "alternatives"},
    )  # fmt: skip
    model.learn(120)
    policy = model.policy
    obs = model.replay_buffer.sample(8).observations
    out = policy.actor_outputs(obs).detach()
    grad, own_q = policy.critic_action_gradients(obs, out)

    # by hand: action k's score 0.05 above the highest (at most 1), the others at least 0.05 below
    values = []
    for k in range(3):
        alternative = out.clone()
        top = min(float(out[0, :3].max()) + SWITCH_MARGIN, 1.0)
        alternative[0, :3] = th.clamp(out[0, :3], max=top - SWITCH_MARGIN)
        alternative[0, k] = top
        with th.no_grad():
            values.append(float(policy.q_values(obs[:1], alternative[:1])[0]))
    mean = sum(values) / 3
    th.testing.assert_close(grad[0, :3], th.tensor([v - mean for v in values]), atol=1e-6, rtol=1e-5)

    current = out.clone().requires_grad_(True)
    expected = th.autograd.grad(policy.q_values(obs, current)[0].sum(), current)[0]
    th.testing.assert_close(grad[:, 3:], expected[:, 3:])
    th.testing.assert_close(own_q, policy.q_values(obs, out)[0])

    policy.score_gradient = "critic"
    plain, _ = policy.critic_action_gradients(obs, out)
    th.testing.assert_close(plain, expected)


def test_a_team_gets_one_advantage_per_agent_and_keeps_the_option_through_save_and_load(tmp_path) -> None:
    env = make_comm_vec_env("BlindSoccer-v0", n_envs=2, seed=0)
    model = CommDDPG(
        "GSN", env, learning_starts=40, seed=0, device="cpu",
        policy_kwargs={**SMALL, "gsn_net_arch": [8], "score_gradient": "alternatives"},
    )  # fmt: skip
    model.learn(80)
    obs = model.replay_buffer.sample(4).observations
    out = model.policy.actor_outputs(obs).detach()
    advantages = model.policy.alternative_advantages(obs, out)
    assert advantages.shape == (4, 2, 3)
    th.testing.assert_close(advantages.sum(dim=-1), th.zeros(4, 2), atol=1e-6, rtol=0)
    grad, _ = model.policy.critic_action_gradients(obs, out)
    th.testing.assert_close(grad[..., :3], advantages)
    model.save(tmp_path / "model.zip")
    loaded = CommDDPG.load(tmp_path / "model.zip", device="cpu")
    assert loaded.policy.score_gradient == "alternatives"


def test_an_unknown_score_gradient_is_a_clear_error() -> None:
    expected = r"policy_kwargs\['score_gradient'\] must be 'critic' or 'alternatives', got 'argmax'"
    with pytest.raises(ValueError, match=expected):
        HybridDDPG("MlpPolicy", "HFOMoveToBall-v0", policy_kwargs={"score_gradient": "argmax"}, device="cpu")
