"""Analysis of trained teams and experiments: communication measures, statistics, figures, report.

* :mod:`~sb3_comm.analysis.metrics`: CIC, speaker consistency, instantaneous coordination, linear
  probe (pure functions on arrays).
* :mod:`~sb3_comm.analysis.rollout`: record a team's messages and actions; interventional CIC.
* :mod:`~sb3_comm.analysis.communication`: :func:`analyse_communication`, all measures of a model.
* :mod:`~sb3_comm.analysis.stats`: rliable interval estimates over seeds.
* :mod:`~sb3_comm.analysis.plots` and :mod:`~sb3_comm.analysis.report`: figures and
  :func:`make_report`. Figures are drawn without ``pyplot``, so no display is ever needed.

Needs the ``analysis`` extra (matplotlib, scikit-learn, rliable).
"""

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
from sb3_comm.analysis.report import make_report
from sb3_comm.analysis.rollout import Rollout, collect_rollout, communication_directions, interventional_cic
from sb3_comm.analysis.stats import interval_estimates

__all__ = [
    "Rollout",
    "analyse_communication",
    "causal_influence_of_communication",
    "collect_rollout",
    "communication_directions",
    "discretise_messages",
    "instantaneous_coordination",
    "interval_estimates",
    "interventional_cic",
    "linear_probe",
    "majority_rate",
    "make_report",
    "mutual_information",
    "speaker_consistency",
]
