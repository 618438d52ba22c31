"""Measures of a learned communication protocol, as pure functions on arrays (SPEC §5).

* :func:`causal_influence_of_communication` (CIC, Lowe et al. 2019, "On the Pitfalls of Measuring
  Emergent Communication"): how much forcing a message into the receiver's observation changes the
  receiver's action distribution, summed over messages (the reference implementation averages
  where the definition sums, which adds ``log K``).
* :func:`speaker_consistency`: I(a_sender; m), does the sender say different things when it does
  different things.
* :func:`instantaneous_coordination`: I(m_t; a_receiver_{t+1}), does the message carry the
  receiver's next action.
* :func:`linear_probe`: cross-validated accuracy of a logistic regression predicting a label
  (the receiver's next action type) from the raw continuous message, against the majority rate.

Mutual informations are plug-in estimates in nats on discretised messages
(:func:`discretise_messages`): each message dimension is cut into ``n_bins`` equally populated
bins by the mid-rank of each value (its empirical quantile; equal values share a bin) and the
per-dimension bin indices are combined into one symbol,
``sum_d bin_d * n_bins**d``. The default ``n_bins`` keeps the alphabet at most 16 symbols
(16 bins for a 1-value message, 2 for a 4-value one), which holds the plug-in bias,
about (|X| - 1)(|Y| - 1) / (2 N) nats, near 0.03 for a few hundred samples.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
from scipy.stats import rankdata
from sklearn.exceptions import ConvergenceWarning
from sklearn.linear_model import LogisticRegression
from sklearn.metrics import mutual_info_score
from sklearn.model_selection import StratifiedKFold
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

__all__ = [
    "MAX_SYMBOLS",
    "causal_influence_of_communication",
    "default_n_bins",
    "discretise_messages",
    "instantaneous_coordination",
    "linear_probe",
    "majority_rate",
    "mutual_information",
    "speaker_consistency",
]

MAX_SYMBOLS = 16
"""Largest message alphabet the default discretisation produces."""


def causal_influence_of_communication(p_action_do_message: np.ndarray, p_message: np.ndarray) -> float:
    """One-step causal influence of communication, in nats, averaged over receiver states.

    For each receiver state ``s``::

        CIC(s) = sum_m p(m) sum_a p(a | do m) log[ p(a | do m) / sum_m' p(m') p(a | do m') ]

    (0 log 0 = 0). It is the mutual information between the forced message and the action, so it
    lies in ``[0, min(log K, log n_actions)]``; 0 when the receiver ignores the message.

    :param p_action_do_message: ``(n_states, K, n_actions)`` action distribution of the receiver
        when message ``k`` is forced into its observation (rows sum to 1; one-hot for a
        deterministic policy).
    :param p_message: ``(K,)`` or ``(n_states, K)`` probabilities of the K messages (normalised
        here if they do not sum to 1).
    :return: mean over states of CIC(s).
    """
    p_a = np.asarray(p_action_do_message, dtype=np.float64)
    if p_a.ndim != 3:
        raise ValueError(f"p_action_do_message must be (n_states, K, n_actions), got shape {p_a.shape}")
    p_m = np.asarray(p_message, dtype=np.float64)
    if p_m.ndim == 1:
        p_m = np.broadcast_to(p_m, p_a.shape[:2])
    if p_m.shape != p_a.shape[:2]:
        raise ValueError(f"p_message must be (K,) or (n_states, K) = {p_a.shape[:2]}, got {p_m.shape}")
    if (p_m < 0).any() or (p_a < 0).any():
        raise ValueError("Probabilities must be non-negative")
    if p_a.shape[0] == 0:
        return float("nan")
    p_m = p_m / p_m.sum(axis=1, keepdims=True)
    marginal = np.einsum("sk,ska->sa", p_m, p_a)  # p(a) = sum_m' p(m') p(a | do m')
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(p_a > 0, p_a / marginal[:, None, :], 1.0)
    per_state = np.einsum("sk,ska->s", p_m, p_a * np.log(ratio))
    return float(max(per_state.mean(), 0.0))


def default_n_bins(channel_size: int, max_symbols: int = MAX_SYMBOLS) -> int:
    """Bins per message dimension such that ``n_bins ** channel_size <= max_symbols`` (at least 2)."""
    if channel_size < 1:
        return 1
    return max(2, math.floor(max_symbols ** (1.0 / channel_size) + 1e-9))


def discretise_messages(messages: np.ndarray, n_bins: int | None = None) -> np.ndarray:
    """Map continuous messages to integer symbols (see the module docstring).

    :param messages: ``(N,)`` or ``(N, n)`` messages.
    :param n_bins: bins per dimension (default :func:`default_n_bins`). Equal values always share
        a bin, so a constant dimension uses one bin and a two-valued one two.
    :return: ``(N,)`` int64 symbols in ``[0, n_bins ** n)``.
    """
    x = np.asarray(messages, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    n_samples, channel_size = x.shape
    if n_bins is None:
        n_bins = default_n_bins(channel_size)
    symbols = np.zeros(n_samples, dtype=np.int64)
    if n_samples == 0:
        return symbols
    for d in range(channel_size):
        # Mid-ranks (ties share one) give equally populated bins that never split equal values.
        quantile = (rankdata(x[:, d], method="average") - 0.5) / n_samples
        bins = np.minimum((quantile * n_bins).astype(np.int64), n_bins - 1)
        symbols = symbols * n_bins + bins
    return symbols


def mutual_information(x: np.ndarray, y: np.ndarray) -> float:
    """Plug-in mutual information, in nats, between two discrete label sequences of equal length."""
    x, y = np.asarray(x).ravel(), np.asarray(y).ravel()
    if x.shape != y.shape:
        raise ValueError(f"x and y must have the same length, got {x.shape} and {y.shape}")
    if x.size == 0:
        return float("nan")
    return float(max(mutual_info_score(x, y), 0.0))


def speaker_consistency(sender_actions: np.ndarray, messages: np.ndarray, n_bins: int | None = None) -> float:
    """I(a_sender; m) in nats: the sender's discrete action and the message it sent at the same step.

    :param sender_actions: ``(N,)`` discrete action of the sender at each step.
    :param messages: ``(N, n)`` the messages it sent at those steps (discretised here).
    :param n_bins: bins per message dimension (see :func:`discretise_messages`).
    """
    return mutual_information(sender_actions, discretise_messages(messages, n_bins))


def instantaneous_coordination(
    messages: np.ndarray, receiver_next_actions: np.ndarray, n_bins: int | None = None
) -> float:
    """I(m_t; a_receiver_{t+1}) in nats: a message and the receiver's action once it has heard it.

    :param messages: ``(N, n)`` messages sent at step t (discretised here).
    :param receiver_next_actions: ``(N,)`` the receiver's discrete action at step t + 1.
    :param n_bins: bins per message dimension (see :func:`discretise_messages`).
    """
    return mutual_information(discretise_messages(messages, n_bins), receiver_next_actions)


def majority_rate(labels: np.ndarray) -> float:
    """Frequency of the most common label (the accuracy of always guessing it)."""
    labels = np.asarray(labels).ravel()
    if labels.size == 0:
        return float("nan")
    _, counts = np.unique(labels, return_counts=True)
    return float(counts.max() / labels.size)


def linear_probe(
    features: np.ndarray, labels: np.ndarray, n_splits: int = 5, seed: int = 0
) -> dict[str, Any]:
    """Cross-validated accuracy of a linear classifier predicting ``labels`` from ``features``.

    Standardised features and an L2 logistic regression, evaluated with stratified k-fold cross
    validation. When the rarest class has fewer than ``n_splits`` samples the number of folds
    shrinks to it (at least 2); a training fold that holds one class only predicts that class.
    A single class gives accuracy 1.0 (= the majority rate): there is nothing to predict.

    :param features: ``(N, d)`` (or ``(N,)``) continuous inputs, e.g. messages.
    :param labels: ``(N,)`` discrete targets, e.g. the receiver's next action type.
    :param n_splits: number of folds.
    :param seed: seed of the fold shuffling.
    :return: ``accuracy`` (mean over the held-out samples), ``majority_rate``, ``n_samples``,
        ``n_classes`` and ``n_splits`` (folds actually used; 0 when no cross validation ran).
    """
    x = np.asarray(features, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    y = np.asarray(labels).ravel()
    if x.shape[0] != y.shape[0]:
        raise ValueError(f"features and labels must have the same length, got {x.shape[0]} and {y.shape[0]}")
    classes, counts = np.unique(y, return_counts=True)
    result: dict[str, Any] = {
        "accuracy": float("nan"),
        "majority_rate": majority_rate(y),
        "n_samples": int(y.size),
        "n_classes": int(classes.size),
        "n_splits": 0,
    }
    if y.size == 0:
        return result
    if classes.size == 1 or y.size < 4:
        # Nothing to learn (one class) or too few samples to hold any out: the majority guess.
        result["accuracy"] = result["majority_rate"] if classes.size > 1 else 1.0
        return result
    splits = int(min(n_splits, max(2, counts.min()), y.size // 2))
    folds = StratifiedKFold(n_splits=splits, shuffle=True, random_state=seed)
    correct = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "least populated class has only k members"
        warnings.simplefilter("ignore", ConvergenceWarning)
        for train, test in folds.split(x, y):
            train_classes = np.unique(y[train])
            if train_classes.size == 1:
                prediction = np.full(test.size, train_classes[0])
            else:
                model = make_pipeline(StandardScaler(), LogisticRegression(max_iter=1000))
                prediction = model.fit(x[train], y[train]).predict(x[test])
            correct += int((prediction == y[test]).sum())
    result["accuracy"] = correct / y.size
    result["n_splits"] = splits
    return result
