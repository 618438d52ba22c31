"""Analysis of trained teams and experiments: communication measures, statistics, figures, report.

* :mod:`~sb3_comm.analysis.metrics`: CIC, speaker consistency, instantaneous coordination, linear
  probe (pure functions on arrays).
* :mod:`~sb3_comm.analysis.rollout`: record a team's messages and actions; interventional CIC.
* :mod:`~sb3_comm.analysis.communication`: :func:`analyse_communication`, all measures of a model.
* :mod:`~sb3_comm.analysis.stats`: rliable interval estimates over seeds.
* :mod:`~sb3_comm.analysis.plots`: figures, drawn without ``pyplot`` (no display is ever needed).
* The report of an experiment folder, :func:`make_report` (:mod:`~sb3_comm.analysis.report`, a
  short orchestrator) built from :mod:`~sb3_comm.analysis.runs` (:func:`load_runs`, the one reader
  of the runs' results), :mod:`~sb3_comm.analysis.references` (:func:`reference_returns`: oracle
  and random returns from the task registry), :mod:`~sb3_comm.analysis.tables` (statistics
  tables), :mod:`~sb3_comm.analysis.claims` (the paper's claims as :class:`Claim` records,
  :data:`PAPER_CLAIMS`, :func:`judge_claims`) and :mod:`~sb3_comm.analysis.markdown` (rendering).

Needs the ``analysis`` extra (matplotlib, scikit-learn, rliable).
"""

from sb3_comm.analysis.claims import PAPER_CLAIMS, Claim, judge_claims
from sb3_comm.analysis.communication import analyse_communication
from sb3_comm.analysis.metrics import (
    causal_influence_of_communication,
    discretise_messages,
    instantaneous_coordination,
    linear_probe,
    majority_rate,
    mutual_information,
    speaker_consistency,
)
from sb3_comm.analysis.references import reference_returns
from sb3_comm.analysis.report import make_report
from sb3_comm.analysis.rollout import Rollout, collect_rollout, communication_directions, interventional_cic
from sb3_comm.analysis.runs import load_runs
from sb3_comm.analysis.stats import interval_estimates

__all__ = [
    "PAPER_CLAIMS",
    "Claim",
    "Rollout",
    "analyse_communication",
    "causal_influence_of_communication",
    "collect_rollout",
    "communication_directions",
    "discretise_messages",
    "instantaneous_coordination",
    "interval_estimates",
    "interventional_cic",
    "judge_claims",
    "linear_probe",
    "load_runs",
    "majority_rate",
    "make_report",
    "mutual_information",
    "reference_returns",
    "speaker_consistency",
]
