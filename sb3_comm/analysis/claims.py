"""The paper's claims as data: one :class:`Claim` record each, judged on the statistics tables.

A claim names its task, says what is measured (``statement``), quotes the paper (``paper``), states
the rule that turns the measurement into a verdict (``rule``) and carries the function that
applies it (``evaluate``). :data:`PAPER_CLAIMS` lists the claims of Hausknecht & Stone (2016);
:func:`judge_claims` judges a list of claims, in order, on the tables of
:mod:`~sb3_comm.analysis.tables`. To add a claim, build a :class:`Claim` (from the evaluators
here or a new one) and judge ``[*PAPER_CLAIMS, claim]``.

Verdicts: ``reproduced``, ``partly``, ``not`` or ``not measured``. SPEC §5 asks for at least
:data:`MIN_SEEDS` training seeds: a claim met with fewer is only ``partly`` met
(:func:`require_seeds`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from types import MappingProxyType
from typing import Any

import numpy as np

from sb3_comm.analysis.markdown import fmt, interval_text
from sb3_comm.comm_ddpg.methods import PAPER_METHODS

__all__ = [
    "BEYOND_CLAIMS",
    "MIN_SEEDS",
    "PAPER_CLAIMS",
    "PAPER_METHODS",
    "SOLVED_FRACTION",
    "Claim",
    "Evidence",
    "judge_claims",
    "messages_predict_next_action",
    "only_solver",
    "require_seeds",
    "solves",
    "solves_every_task",
    "zeroing_changes_nothing",
    "zeroing_lowers_return",
]

SOLVED_FRACTION = 0.9
"""A method solves a task when its mean final return reaches this fraction of the oracle's."""

MIN_SEEDS = 3
"""Training seeds a claim needs to count as reproduced (SPEC §5)."""

BLIND_SOCCER, GUESS_MY_NUMBER = "BlindSoccer-v0", "GuessMyNumber-v0"


@dataclass(frozen=True)
class Evidence:
    """What claims are judged on.

    :param finals: final-returns tables by task (:func:`~sb3_comm.analysis.tables.final_returns_table`).
    :param communication: communication tables by task
        (:func:`~sb3_comm.analysis.tables.communication_table`).
    :param verdicts: verdicts of the claims judged before, by claim id.
    """

    finals: Mapping[str, Any]
    communication: Mapping[str, Any]
    verdicts: Mapping[str, str] = field(default_factory=dict)

    def row(self, task: str, method: str) -> dict[str, Any] | None:
        """The final-returns row of ``method`` on ``task`` (None when it has no runs)."""
        return self.finals.get(task, {}).get(method)


Measurement = dict[str, Any]
"""An evaluator's answer: ``measured`` (text), ``verdict`` and, when measured, ``value`` or
``values`` and ``n_seeds``."""

Evaluator = Callable[[Evidence], Measurement]


@dataclass(frozen=True)
class Claim:
    """One claim of the paper and how it is judged.

    :param id: short id (``"C1"``), unique in a list of claims.
    :param task: the task id it is about.
    :param statement: what is measured, in one sentence.
    :param paper: what the paper says (with the figure or section).
    :param rule: how the measurement becomes a verdict, in words.
    :param evaluate: ``evaluate(evidence) -> measurement`` applying ``rule``.
    :param methods: the methods it is about.
    """

    id: str
    task: str
    statement: str
    paper: str
    rule: str
    evaluate: Evaluator
    methods: tuple[str, ...] = ()
    """The methods the claim is about (empty: not said); a report shows a claim beyond the paper
    when one of them has runs."""

    def judge(self, evidence: Evidence, min_seeds: int = MIN_SEEDS) -> dict[str, Any]:
        """The claim's record: ``id``, ``task``, ``claim``, ``paper``, ``rule`` and the
        measurement, with :func:`require_seeds` applied."""
        record = {
            "id": self.id,
            "task": self.task,
            "claim": self.statement,
            "paper": self.paper,
            "rule": self.rule,
            **self.evaluate(evidence),
        }
        return require_seeds(record, min_seeds)


def require_seeds(claim: dict[str, Any], min_seeds: int) -> dict[str, Any]:
    """SPEC §5 asks for >= ``min_seeds`` training seeds: a claim met with fewer is only partly met."""
    n_seeds = claim.get("n_seeds")
    if n_seeds is not None and n_seeds < min_seeds and claim["verdict"] == "reproduced":
        claim["verdict"] = "partly"
        claim["measured"] += f" (met, but with {n_seeds} < {min_seeds} seeds)"
    return claim


def judge_claims(
    finals: Mapping[str, Any],
    communication: Mapping[str, Any],
    min_seeds: int = MIN_SEEDS,
    claims: Sequence[Claim] | None = None,
) -> list[dict[str, Any]]:
    """Judge ``claims`` (default :data:`PAPER_CLAIMS`) in order; a claim sees the verdicts of
    those before it (:attr:`Evidence.verdicts`).

    :return: one record per claim (see :meth:`Claim.judge`).
    """
    records, verdicts = [], {}
    for claim in PAPER_CLAIMS if claims is None else claims:
        evidence = Evidence(finals, communication, MappingProxyType(dict(verdicts)))
        record = claim.judge(evidence, min_seeds)
        verdicts[claim.id] = record["verdict"]
        records.append(record)
    return records


# ------------------------------------------------------------------------------ evaluators --
def _fraction_solved(task: str, method: str, evidence: Evidence) -> Measurement:
    row = evidence.row(task, method)
    if not row or "fraction_of_oracle" not in row or row["fraction_of_oracle"]["n_runs"] == 0:
        return {"measured": "no runs", "verdict": "not measured"}
    est = row["fraction_of_oracle"]
    point, high = est["mean"]["point"], est["mean"]["high"]
    verdict = (
        "reproduced"
        if point >= SOLVED_FRACTION
        else ("partly" if point >= 0.5 or high >= SOLVED_FRACTION else "not")
    )
    measured = f"fraction of oracle {interval_text(est)} over {est['n_runs']} seeds"
    return {"measured": measured, "value": point, "verdict": verdict, "n_seeds": est["n_runs"]}


def solves(cid: str, task: str, method: str, paper: str) -> Claim:
    """Claim that ``method`` solves ``task``: its mean final return reaches
    :data:`SOLVED_FRACTION` of the oracle's."""
    return Claim(
        id=cid,
        task=task,
        statement=f"{task}: {method} reaches >= {SOLVED_FRACTION} of the oracle's return",
        paper=paper,
        rule=f"reproduced: mean fraction >= {SOLVED_FRACTION}; partly: mean >= 0.5 or the 95% interval "
        f"reaches {SOLVED_FRACTION}; not: otherwise",
        evaluate=partial(_fraction_solved, task, method),
    )


def _only_solver(task: str, winner: str, winner_claim: str, evidence: Evidence) -> Measurement:
    measured_rows = {
        m: row["fraction_of_oracle"]
        for m, row in evidence.finals.get(task, {}).items()
        if m in PAPER_METHODS
        and m not in (winner, "NONE")
        and "fraction_of_oracle" in row
        and row["fraction_of_oracle"]["n_runs"]
    }
    others = {m: est["mean"]["point"] for m, est in measured_rows.items()}
    if not others:
        return {"measured": "no other method measured", "verdict": "not measured"}
    measured = ", ".join(f"{m} {fmt(v)}" for m, v in sorted(others.items()))
    if any(v >= SOLVED_FRACTION for v in others.values()):
        verdict = "not"
    else:
        verdict = "reproduced" if evidence.verdicts.get(winner_claim) == "reproduced" else "partly"
    return {
        "measured": f"fractions of oracle: {measured}",
        "values": others,
        "verdict": verdict,
        "n_seeds": min(est["n_runs"] for est in measured_rows.values()),
    }


def only_solver(cid: str, task: str, winner: str, winner_claim: str, paper: str) -> Claim:
    """Claim that only ``winner`` solves ``task``: every other measured method of the paper
    (:data:`PAPER_METHODS`, NONE aside) stays below :data:`SOLVED_FRACTION` of the oracle, and
    ``winner_claim`` (that ``winner`` solves it,
    judged before) is reproduced."""
    return Claim(
        id=cid,
        task=task,
        statement=f"{task}: only {winner} solves it; the paper's other methods stay below "
        f"{SOLVED_FRACTION} of the oracle",
        paper=paper,
        rule=f"reproduced: {winner} solves it and every other measured method's mean fraction < "
        f"{SOLVED_FRACTION}; partly: the others stay below but {winner} does not reach it; not: another "
        "method reaches it",
        evaluate=partial(_only_solver, task, winner, winner_claim),
    )


def zeroing_lowers_return(task: str, method: str, evidence: Evidence) -> Measurement:
    """Zeroing ``method``'s messages lowers its return: reproduced when the drop's 95% interval is
    above 0 and the drop normalised by (oracle - random) is >= 0.5, partly when the mean drop > 0."""
    row = evidence.row(task, method)
    if not row or row["zero_drop"]["n_runs"] == 0:
        return {"measured": "no runs", "verdict": "not measured"}
    drop = row["zero_drop"]
    normalised = row.get("zero_drop_normalised", {}).get("mean", {}).get("point")
    point, low = drop["mean"]["point"], drop["mean"]["low"]
    strong = low > 0 and normalised is not None and normalised >= 0.5
    return {
        "measured": f"intact {interval_text(row['none'])}, zeroed {interval_text(row['zero'])}, drop "
        f"{interval_text(drop)} (normalised {fmt(normalised)})",
        "value": point,
        "verdict": "reproduced" if strong else ("partly" if point > 0 else "not"),
        "n_seeds": drop["n_runs"],
    }


def zeroing_changes_nothing(task: str, methods: Sequence[str], evidence: Evidence) -> Measurement:
    """Zeroing the messages of each of ``methods`` leaves its return unchanged: the normalised drop
    is within 0.1 for each measured method (reproduced), within 0.25 (partly)."""
    finals = evidence.finals.get(task, {})
    drop_rows = {
        m: finals[m]["zero_drop_normalised"]
        for m in methods
        if m in finals and "zero_drop_normalised" in finals[m] and finals[m]["zero_drop_normalised"]["n_runs"]
    }
    drops = {m: est["mean"]["point"] for m, est in drop_rows.items()}
    if not drops:
        return {"measured": "no runs", "verdict": "not measured"}
    worst = max(abs(v) for v in drops.values())
    return {
        "measured": "normalised drops: " + ", ".join(f"{m} {fmt(v)}" for m, v in drops.items()),
        "values": drops,
        "verdict": "reproduced" if worst < 0.1 else ("partly" if worst < 0.25 else "not"),
        "n_seeds": min(est["n_runs"] for est in drop_rows.values()),
    }


def messages_predict_next_action(task: str, method: str, direction: str, evidence: Evidence) -> Measurement:
    """``method``'s messages along ``direction`` (e.g. ``"sighted->blind"``) predict the receiver's
    next action: linear-probe accuracy minus the majority rate is >= 0.05 on average and > 0 in
    every seed (reproduced), > 0 on average (partly)."""
    values = evidence.communication.get(task, {}).get(method, {}).get(direction)
    gains = []
    if values:
        acc, maj = values["probe_accuracy"]["per_seed"], values["majority_rate"]["per_seed"]
        gains = [a - b for a, b in zip(acc, maj, strict=True) if math.isfinite(a) and math.isfinite(b)]
    if not gains:
        return {"measured": "no communication metrics", "verdict": "not measured"}
    mean_gain = float(np.mean(gains))
    strong = mean_gain >= 0.05 and min(gains) > 0
    return {
        "measured": f"probe accuracy {fmt(values['probe_accuracy']['mean'])} vs majority "
        f"{fmt(values['majority_rate']['mean'])} (gain {fmt(mean_gain)}; CIC {fmt(values['cic']['mean'])} "
        f"nats) over {len(gains)} seeds",
        "value": mean_gain,
        "verdict": "reproduced" if strong else ("partly" if mean_gain > 0 else "not"),
        "n_seeds": len(gains),
    }


def _solves_every_task(tasks: Sequence[str], method: str, evidence: Evidence) -> Measurement:
    per_task, seeds, verdicts = [], [], []
    for task in tasks:
        row = evidence.row(task, method)
        if not row or "fraction_of_oracle" not in row or row["fraction_of_oracle"]["n_runs"] == 0:
            per_task.append(f"{task}: no runs")
            verdicts.append("not measured")
            continue
        est = row["fraction_of_oracle"]
        values = [v for v in est["per_seed"] if math.isfinite(v)]
        mean, worst = est["mean"]["point"], min(values)
        seeds.append(len(values))
        below = sum(v < SOLVED_FRACTION for v in values)
        per_task.append(
            f"{task}: {interval_text(est)}, worst seed {fmt(worst)}, {below} of {len(values)} seeds below"
        )
        verdicts.append("reproduced" if below == 0 else ("partly" if mean >= SOLVED_FRACTION else "not"))
    if "not measured" in verdicts:
        verdict = "not measured"
    elif all(v == "reproduced" for v in verdicts):
        verdict = "reproduced"
    elif any(v == "reproduced" or v == "partly" for v in verdicts):
        verdict = "partly"
    else:
        verdict = "not"
    out: Measurement = {"measured": "; ".join(per_task), "verdict": verdict}
    if seeds:
        out["n_seeds"] = min(seeds)
    return out


def solves_every_task(cid: str, tasks: Sequence[str], method: str, paper: str) -> Claim:
    """Claim that ``method`` solves every one of ``tasks``: on each, every seed's final return
    reaches :data:`SOLVED_FRACTION` of the oracle's (reproduced); partly when the mean does on
    some task but a seed falls short, or only some tasks are solved; not otherwise."""
    return Claim(
        id=cid,
        task=" + ".join(tasks),
        statement=f"{method} solves {' and '.join(tasks)}: every seed >= {SOLVED_FRACTION} of the oracle "
        "on each",
        paper=paper,
        rule=f"holds (reproduced): on every task every seed's fraction of the oracle >= {SOLVED_FRACTION}; "
        f"partly: a task's mean >= {SOLVED_FRACTION} with a seed below, or only some tasks solved; "
        "not: no task solved",
        evaluate=partial(_solves_every_task, tuple(tasks), method),
        methods=(method,),
    )


# ---------------------------------------------------------------------------------- claims --
PAPER_CLAIMS: tuple[Claim, ...] = (
    solves("C1", BLIND_SOCCER, "GSN", paper="GSN solves Blind Soccer (Figure 2; maximum about 0.6)"),
    only_solver(
        "C2",
        BLIND_SOCCER,
        "GSN",
        winner_claim="C1",
        paper="only GSN solves Blind Soccer; RIAL and TCG do not (Figure 2)",
    ),
    Claim(
        id="C3",
        task=BLIND_SOCCER,
        statement=f"{BLIND_SOCCER}: zeroing GSN's messages lowers its return",
        paper="with communication disabled the blind agent walks straight ahead regardless of the ball (§7)",
        rule="drop = intact - zeroed return, normalised by (oracle - random); reproduced: the drop's 95% "
        "interval is above 0 and the normalised drop >= 0.5; partly: mean drop > 0; not: otherwise",
        evaluate=partial(zeroing_lowers_return, BLIND_SOCCER, "GSN"),
    ),
    Claim(
        id="C4",
        task=BLIND_SOCCER,
        statement=f"{BLIND_SOCCER}: RIAL's and TCG's returns do not change when their messages are zeroed",
        paper="policies learned by RIAL and TCG remain unchanged when communication is disabled (§7)",
        rule="normalised drop (intact - zeroed) / (oracle - random): reproduced: |drop| < 0.1 for each "
        "measured method; partly: < 0.25; not: otherwise",
        evaluate=partial(zeroing_changes_nothing, BLIND_SOCCER, ("RIAL", "TCG")),
    ),
    Claim(
        id="C5",
        task=BLIND_SOCCER,
        statement=f"{BLIND_SOCCER}: GSN's messages predict the blind agent's next action (dash or turn)",
        paper="strong correlation between the message and the teammate's next action (Figure 3)",
        rule="linear-probe accuracy (cross-validated) minus the majority rate, mean over seeds: "
        "reproduced: >= 0.05 and > 0 in every seed; partly: mean > 0; not: otherwise",
        evaluate=partial(messages_predict_next_action, BLIND_SOCCER, "GSN", "sighted->blind"),
    ),
    solves("C6", GUESS_MY_NUMBER, "TCG", paper="TCG solves Guess My Number (Figure 4; maximum about 10)"),
    only_solver(
        "C7",
        GUESS_MY_NUMBER,
        "TCG",
        winner_claim="C6",
        paper="only TCG solves Guess My Number; RIAL and GSN do not (Fig. 4)",
    ),
)
"""The claims of Hausknecht & Stone (2016), C1-C7, in report order."""


BEYOND_CLAIMS: tuple[Claim, ...] = (
    solves_every_task(
        "B1",
        (BLIND_SOCCER, GUESS_MY_NUMBER),
        "GSN-MAX",
        paper="future work (§8): no method of the paper solves both tasks (GSN only Blind Soccer, TCG only "
        "Guess My Number)",
    ),
)
"""Claims beyond the paper, judged in the report's "Beyond the paper" section."""
