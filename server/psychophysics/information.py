"""Information transfer from an identification confusion matrix (Miller 1955; Houtsma 1983, in
Tobias (ed.), Hearing Research and Theory 2:49).

Maximum-likelihood (plug-in) estimate, with p_ij = n_ij / N:

    T = Σ_ij p_ij · log2(p_ij / (p_i· · p_·j))   bits

exact on constructed matrices (identity k×k: log2 k; every row alike: 0). From few trials it is
biased upwards. The Miller–Madow correction adds (m − 1)/(2N ln 2) to each plug-in entropy of
T = H(row) + H(column) − H(row, column), m the number of non-empty cells of that distribution
(Miller 1955, "Note on the bias of information estimates"):

    T_corrected = T + [(m_row − 1) + (m_col − 1) − (m_cells − 1)] / (2N ln 2)

With fixed row totals (each stimulus presented n_i times) this is the same correction derived from
H(column) − Σ_i p_i H(column | row i). It is not clipped: from a matrix with no information it may
be below 0, and from a perfect one above log2 k (a clip would bias it again). How much it removes
is measured (`viestac bench psychophysics`, docs/psychophysics.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class InformationTransfer:
    bits: float            # maximum-likelihood (plug-in) estimate
    corrected: float       # Miller–Madow corrected
    correction: float      # corrected − bits
    maximum: float         # log2 of the number of stimuli (rows)
    trials: int


def _entropy(counts: np.ndarray, total: float) -> float:
    p = counts[counts > 0] / total
    return float(-(p * np.log2(p)).sum())


def information_transfer(confusion) -> InformationTransfer:
    """`confusion[i, j]`: how often stimulus i was answered j (non-negative counts)."""
    n = np.asarray(confusion, dtype=float)
    if n.ndim != 2 or n.size == 0 or np.any(n < 0) or not np.all(np.isfinite(n)):
        raise ValueError("a confusion matrix is a 2-D table of non-negative counts")
    total = float(n.sum())
    if total <= 0:
        raise ValueError("the confusion matrix is empty")
    rows, cols = n.sum(axis=1), n.sum(axis=0)
    bits = _entropy(rows, total) + _entropy(cols, total) - _entropy(n.ravel(), total)
    bits = 0.0 if abs(bits) < 1e-12 else bits  # rounding noise of an exact 0 (rows alike) is 0
    m_row, m_col, m_cell = int((rows > 0).sum()), int((cols > 0).sum()), int((n > 0).sum())
    correction = ((m_row - 1) + (m_col - 1) - (m_cell - 1)) / (2.0 * total * math.log(2.0))
    return InformationTransfer(bits, bits + correction, correction, math.log2(n.shape[0]), int(round(total)))


def from_distribution(p_answer_given_stimulus, p_stimulus=None) -> float:
    """The true information (bits) of a channel: rows p(answer | stimulus), stimuli p_stimulus
    (uniform by default). For measuring an estimator's bias against the truth."""
    q = np.asarray(p_answer_given_stimulus, dtype=float)
    ps = np.full(q.shape[0], 1.0 / q.shape[0]) if p_stimulus is None else np.asarray(p_stimulus, dtype=float)
    joint = ps[:, None] * q
    return _entropy(ps, 1.0) + _entropy(joint.sum(axis=0), 1.0) - _entropy(joint.ravel(), 1.0)
