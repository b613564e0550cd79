"""Statistics over seeds that stay quiet and defined when a metric is infinite.

Some metrics are +inf by definition for a run that never gets there (``k_con`` of a swarm
that never converges). NumPy's std and linear percentiles then compute ``inf - inf`` and warn
at the end of every sweep; these helpers give the same numbers for finite data and, with
infinities, a mean of inf, a std of nan (the spread is undefined) and percentiles by the same
linear rule, where interpolating toward inf gives inf.
"""

from __future__ import annotations

import math

import numpy as np


def mean(vals: np.ndarray) -> float:
    """Arithmetic mean; inf if any value is +inf (nan for an empty array)."""
    vals = np.asarray(vals, dtype=float)
    if not len(vals):
        return float("nan")
    with np.errstate(invalid="ignore"):
        return float(np.mean(vals))


def std(vals: np.ndarray) -> float:
    """Population standard deviation (as the HES paper reports); nan unless every value is finite."""
    vals = np.asarray(vals, dtype=float)
    if not len(vals) or not np.all(np.isfinite(vals)):
        return float("nan")
    return float(np.std(vals))


def percentile(vals: np.ndarray, q: float) -> float:
    """``np.percentile(vals, q)`` (linear rule) that also holds for infinite values."""
    v = np.sort(np.asarray(vals, dtype=float))
    if not len(v):
        return float("nan")
    pos = q / 100.0 * (len(v) - 1)
    lo, hi = int(np.floor(pos)), int(np.ceil(pos))
    a, b = float(v[lo]), float(v[hi])
    if lo == hi or a == b:
        return a
    if math.isinf(a) or math.isinf(b):  # toward +inf is +inf, away from -inf is -inf, between them undefined
        return b if a > -math.inf else (a if b < math.inf else math.nan)
    return a + (pos - lo) * (b - a)
