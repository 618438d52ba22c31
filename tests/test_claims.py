"""The paper's claims as data (sb3_comm.analysis.claims), judged on synthetic tables."""

from __future__ import annotations

from typing import Any

import pytest

from sb3_comm.analysis import PAPER_CLAIMS, Claim, judge_claims
from sb3_comm.analysis.claims import (
    BEYOND_CLAIMS,
    Evidence,
    messages_predict_next_action,
    only_solver,
    solves,
    zeroing_changes_nothing,
    zeroing_lowers_return,
)
from sb3_comm.analysis.tables import communication_table, final_returns_table
from sb3_comm.results import RunResult

TASK = "BlindSoccer-v0"
ORACLE, RANDOM = 0.6, -0.4


def _runs(method: str, finals: list[tuple[float, float]], probe: float | None = None) -> list[dict[str, Any]]:
    """Runs as :func:`load_runs` gives them: (intact, zeroed) final return per seed."""
    runs = []
    for seed, (intact, zero) in enumerate(finals):
        result: dict[str, Any] = {
            "final": {
                "none": {"mean_return": intact},
                "zero": {"mean_return": zero},
                "shuffle": {"mean_return": zero},
            }
        }
        if probe is not None:
            metrics = {"probe_accuracy": probe, "majority_rate": 0.6, "cic": 0.1}
            result["communication"] = {"directions": {"sighted->blind": metrics}}
        runs.append({"seed": seed, "result": RunResult(method, TASK, seed, **result)})
    return runs


def _evidence(methods: dict[str, list[dict[str, Any]]]) -> tuple[dict, dict]:
    ref = {"oracle": ORACLE, "random": RANDOM}
    return {TASK: final_returns_table(methods, ref, reps=200, seed=0)}, {TASK: communication_table(methods)}


def test_paper_claims_are_records_with_unique_ids() -> None:
    assert [c.id for c in PAPER_CLAIMS] == [f"C{k}" for k in range(1, 8)]
    assert all(isinstance(c, Claim) and c.statement and c.paper and c.rule for c in PAPER_CLAIMS)
    assert {c.task for c in PAPER_CLAIMS} == {"BlindSoccer-v0", "GuessMyNumber-v0"}


@pytest.mark.parametrize(
    ("fractions", "verdict"),
    [((0.95, 0.97, 0.93), "reproduced"), ((0.6, 0.7, 0.5), "partly"), ((0.1, 0.2, 0.15), "not")],
)
def test_solves_judges_the_fraction_of_the_oracle(fractions: tuple[float, ...], verdict: str) -> None:
    finals, comm = _evidence({"GSN": _runs("GSN", [(f * ORACLE, 0.0) for f in fractions])})
    claim = solves("X1", TASK, "GSN", paper="GSN solves it")
    record = claim.judge(Evidence(finals, comm))
    assert record["verdict"] == verdict and record["n_seeds"] == 3
    assert record["id"] == "X1" and record["claim"] == f"{TASK}: GSN reaches >= 0.9 of the oracle's return"
    assert record["value"] == pytest.approx(sum(fractions) / 3)


def test_a_claim_met_with_too_few_seeds_is_partly_met_and_unmeasured_claims_say_so() -> None:
    finals, comm = _evidence({"GSN": _runs("GSN", [(0.59, 0.0), (0.58, 0.0)])})
    record = solves("X1", TASK, "GSN", paper="").judge(Evidence(finals, comm), min_seeds=3)
    assert record["verdict"] == "partly" and "(met, but with 2 < 3 seeds)" in record["measured"]
    assert (
        solves("X1", TASK, "GSN", paper="").judge(Evidence(finals, comm), min_seeds=2)["verdict"]
        == "reproduced"
    )
    missing = solves("X2", TASK, "TCG", paper="").judge(Evidence(finals, comm))
    assert missing["verdict"] == "not measured" and missing["measured"] == "no runs"


def test_only_solver_depends_on_the_verdict_of_the_claim_before_it() -> None:
    methods = {
        "GSN": _runs("GSN", [(0.58, -0.4)] * 3),
        "TCG": _runs("TCG", [(0.1, 0.1)] * 3),
        "NONE": _runs("NONE", [(0.59, 0.59)] * 3),  # NONE is not a competitor
    }
    finals, comm = _evidence(methods)
    claims = [solves("A", TASK, "GSN", paper=""), only_solver("B", TASK, "GSN", winner_claim="A", paper="")]
    assert [r["verdict"] for r in judge_claims(finals, comm, claims=claims)] == ["reproduced", "reproduced"]
    assert judge_claims(finals, comm, claims=claims)[1]["values"] == {"TCG": pytest.approx(0.1 / ORACLE)}
    # with fewer seeds than required, GSN's claim is only partly met, and so is "only GSN"
    verdicts = [r["verdict"] for r in judge_claims(finals, comm, min_seeds=5, claims=claims)]
    assert verdicts == ["partly", "partly"]
    methods["TCG"] = _runs("TCG", [(0.59, 0.59)] * 3)
    finals, comm = _evidence(methods)
    assert judge_claims(finals, comm, claims=claims)[1]["verdict"] == "not"


def test_message_ablation_and_probe_evaluators() -> None:
    methods = {
        "GSN": _runs("GSN", [(0.58, -0.4), (0.56, -0.3), (0.57, -0.35)], probe=0.9),
        "RIAL": _runs("RIAL", [(0.1, 0.1), (0.12, 0.11), (0.09, 0.1)], probe=0.55),
        "TCG": _runs("TCG", [(0.1, -0.3), (0.1, -0.3), (0.1, -0.3)]),
    }
    evidence = Evidence(*_evidence(methods))
    assert zeroing_lowers_return(TASK, "GSN", evidence)["verdict"] == "reproduced"
    assert zeroing_lowers_return(TASK, "RIAL", evidence)["verdict"] == "not"
    assert zeroing_changes_nothing(TASK, ("RIAL",), evidence)["verdict"] == "reproduced"
    changed = zeroing_changes_nothing(TASK, ("RIAL", "TCG"), evidence)  # TCG drops by 0.4 of 1.0
    assert changed["verdict"] == "not" and changed["values"]["TCG"] == pytest.approx(0.4)
    probe = messages_predict_next_action(TASK, "GSN", "sighted->blind", evidence)
    assert probe["verdict"] == "reproduced" and probe["value"] == pytest.approx(0.3)
    assert messages_predict_next_action(TASK, "RIAL", "sighted->blind", evidence)["verdict"] == "not"
    assert messages_predict_next_action(TASK, "TCG", "sighted->blind", evidence)["verdict"] == "not measured"


def test_the_claims_list_is_data_that_can_be_extended() -> None:
    finals, comm = _evidence({"GSN": _runs("GSN", [(0.58, -0.4)] * 3, probe=0.9)})
    extra = Claim(
        id="B1",
        task=TASK,
        statement="beyond the paper: GSN's zeroed return is below random",
        paper="(not in the paper)",
        rule="reproduced: mean zeroed return < random",
        evaluate=lambda ev: {
            "measured": "zeroed vs random",
            "verdict": "reproduced"
            if ev.row(TASK, "GSN")["zero"]["mean"]["point"] < RANDOM + 0.01
            else "not",
        },
    )
    records = judge_claims(finals, comm, claims=[*PAPER_CLAIMS, extra])
    assert [r["id"] for r in records] == [*(c.id for c in PAPER_CLAIMS), "B1"]
    assert records[-1]["verdict"] == "reproduced" and records[-1]["claim"].startswith("beyond the paper")
    verdicts = {r["id"]: r["verdict"] for r in records}
    assert verdicts["C1"] == verdicts["C3"] == verdicts["C5"] == "reproduced"
    assert verdicts["C6"] == "not measured"  # no Guess My Number runs


def _two_task_evidence(fractions: dict[str, list[float]]) -> Evidence:
    """GSN-MAX's finals on each task, given as fractions of the oracle per seed."""
    finals = {}
    for task, values in fractions.items():
        runs = [
            {
                "seed": seed,
                "result": RunResult(
                    "GSN-MAX",
                    task,
                    seed,
                    final={a: {"mean_return": f * ORACLE} for a in ("none", "zero", "shuffle")},
                ),
            }
            for seed, f in enumerate(values)
        ]
        finals[task] = final_returns_table({"GSN-MAX": runs}, {"oracle": ORACLE, "random": RANDOM}, 200, 0)
    return Evidence(finals, {})


@pytest.mark.parametrize(
    ("fractions", "verdict"),
    [
        ({"BlindSoccer-v0": [0.95, 0.91, 0.93], "GuessMyNumber-v0": [0.99, 0.97, 0.98]}, "reproduced"),
        ({"BlindSoccer-v0": [0.99, 0.85, 0.97], "GuessMyNumber-v0": [0.99, 0.97, 0.98]}, "partly"),
        ({"BlindSoccer-v0": [0.2, 0.1, 0.3], "GuessMyNumber-v0": [0.99, 0.97, 0.98]}, "partly"),
        ({"BlindSoccer-v0": [0.2, 0.1, 0.3], "GuessMyNumber-v0": [0.1, 0.0, 0.2]}, "not"),
        ({"BlindSoccer-v0": [0.95, 0.91, 0.93]}, "not measured"),
    ],
)
def test_beyond_the_paper_gsn_max_must_solve_every_task_on_every_seed(
    fractions: dict[str, list[float]], verdict: str
) -> None:
    (claim,) = BEYOND_CLAIMS
    record = claim.judge(_two_task_evidence(fractions))
    assert record["id"] == "B1" and record["verdict"] == verdict
    if verdict != "not measured":
        assert "worst seed" in record["measured"] and record["n_seeds"] == 3


def test_a_method_beyond_the_paper_does_not_change_the_papers_only_solver_claims() -> None:
    methods = {
        "GSN": _runs("GSN", [(0.58, -0.4)] * 3),
        "TCG": _runs("TCG", [(0.1, 0.1)] * 3),
        "GSN-MAX": _runs("GSN-MAX", [(0.59, -0.4)] * 3),  # solves it too, but is not the paper's
    }
    finals, comm = _evidence(methods)
    records = {r["id"]: r for r in judge_claims(finals, comm)}
    assert records["C2"]["verdict"] == "reproduced" and "GSN-MAX" not in records["C2"]["values"]
