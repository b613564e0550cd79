"""Paired differences of two variants with 95 % intervals (issue 35): per pair (A, B) of an
experiment's variants, B − A over the seeds both flew.

Two statistics of two per-seed arrays aligned by seed:

- a binary metric (0/1 per run, ``sph_success``): the difference of the success rates,
  ``p_B − p_A``, with Newcombe's interval for paired proportions (:func:`success_difference`);
- a continuous metric (``flight_distance`` [m]): the mean paired difference with the paired
  Student-t interval (:func:`mean_difference`). The report takes it only over the seeds where
  both runs succeeded: a crashed or stranded run's distance is how far it got, not the length of
  a path to the goal, and mixing the two would compare unlike things.

:func:`pair_difference` applies both to an experiment's stored rows; ``report.paired_differences``
reads them from a results directory, and the report draws them as one table (:func:`table`) and
``report_files/differences.csv`` (:func:`to_csv`).
"""

from __future__ import annotations

import csv
import io
import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats as sps

from swarmnav.experiments.paired import _number, seed_ranges

TITLE = "Paired differences, B − A (95 % interval)"


@dataclass(frozen=True, slots=True)
class Interval:
    """A point estimate with its confidence interval over ``n`` paired seeds (nan where undefined)."""

    estimate: float
    low: float
    high: float
    n: int


def wilson(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a proportion ``k / n`` (SciPy's ``binomtest(...).proportion_ci``)."""
    ci = sps.binomtest(int(k), int(n)).proportion_ci(confidence_level=confidence, method="wilson")
    return float(ci.low), float(ci.high)


def paired_table(a: np.ndarray, b: np.ndarray) -> tuple[int, int, int, int]:
    """The paired 2×2 table of two aligned 0/1 arrays: ``(both, only A, only B, neither)`` succeeded."""
    a, b = _binary(a, "A"), _binary(b, "B")
    if a.shape != b.shape:
        raise ValueError(f"expected two aligned arrays, got lengths {len(a)} and {len(b)}")
    return (int(np.sum(a & b)), int(np.sum(a & ~b)), int(np.sum(~a & b)), int(np.sum(~a & ~b)))


def phi(table: tuple[int, int, int, int], corrected: bool = False) -> float:
    """Phi correlation of a paired 2×2 table ``(e, f, g, h)`` = (both, only A, only B, neither):
    ``(e h − f g) / sqrt((e + f)(g + h)(e + g)(f + h))``; 0 when a margin is 0 (denominator 0).
    ``corrected``: a positive numerator shrunk by N/2 toward 0 (not below), a negative one kept."""
    e, f, g, h = (float(x) for x in table)
    den = (e + f) * (g + h) * (e + g) * (f + h)
    num = e * h - f * g
    if corrected and num > 0:
        num = max(num - (e + f + g + h) / 2, 0.0)
    return 0.0 if den == 0.0 else num / math.sqrt(den)


def success_difference(a: np.ndarray, b: np.ndarray, confidence: float = 0.95,
                       corrected_phi: bool = True) -> Interval:
    """Difference of two paired success rates, ``p_B − p_A`` (a fraction; the report shows
    percentage points), with Newcombe's hybrid score interval for paired data.

    Source: R. G. Newcombe, "Improved confidence intervals for the difference between binomial
    proportions based on paired data", Stat. Med. 17(22):2635–2650 (1998), method 10. With the
    Wilson score intervals ``(l_A, u_A)`` of ``p_A`` and ``(l_B, u_B)`` of ``p_B`` and the phi
    correlation ``φ`` of the paired 2×2 table (:func:`phi`; 0 when its denominator is 0)::

        θ = p_B − p_A
        L = θ − sqrt((p_B − l_B)² − 2 φ (p_B − l_B)(u_A − p_A) + (u_A − p_A)²)
        U = θ + sqrt((u_B − p_B)² − 2 φ (u_B − p_B)(p_A − l_A) + (p_A − l_A)²)

    With ``φ = 0`` this is Newcombe's interval for independent proportions (the square-and-add
    of the two Wilson intervals); a positive correlation (the same seeds hard for both
    variants) narrows it. Since ``|φ| ≤ 1``, ``L ≥ l_B − u_A ≥ −1`` and ``U ≤ u_B − l_A ≤ 1``.
    ``corrected_phi`` (the default) shrinks a positive numerator ``e h − f g`` of φ by N/2, as Fagerland, Lydersen and Laake
    (*Statistical Analysis of Contingency Tables*, 2017, §8.5) compute this interval: wider,
    and no longer of zero width when every seed agrees at p = 1/2 (3 both, 3 neither: plain
    [0, 0], corrected ±25.5 points). Simulated at n = 20 seeds the plain φ
    (``corrected_phi=False``) covers 92.8-94.4 %, under the nominal 95 %, the corrected one
    94.3-96.6 % (tests/experiments/test_differences.py): hence the corrected default.

    ``a``, ``b``: aligned per-seed arrays of 0/1 (a ValueError otherwise). n = 0 gives nan.
    """
    table = paired_table(a, b)
    n = sum(table)
    if n == 0:
        return Interval(math.nan, math.nan, math.nan, 0)
    e, f, g, _ = table
    pa, pb = (e + f) / n, (e + g) / n
    la, ua = wilson(e + f, n, confidence)
    lb, ub = wilson(e + g, n, confidence)
    r = phi(table, corrected_phi)
    theta = pb - pa
    # |φ| ≤ 1 keeps both radicands ≥ 0; max() only guards against rounding
    low = theta - math.sqrt(max((pb - lb) ** 2 - 2 * r * (pb - lb) * (ua - pa) + (ua - pa) ** 2, 0.0))
    high = theta + math.sqrt(max((ub - pb) ** 2 - 2 * r * (ub - pb) * (pa - la) + (pa - la) ** 2, 0.0))
    return Interval(theta, low, high, n)


def mean_difference(a: np.ndarray, b: np.ndarray, confidence: float = 0.95) -> Interval:
    """Mean paired difference ``mean(B_s − A_s)`` with the paired Student-t interval,
    ``d̄ ± t_{(1+c)/2, n−1} s_d / sqrt(n)`` (SciPy's ``ttest_1samp(d, 0).confidence_interval``).

    ``a``, ``b``: aligned finite per-seed values (a ValueError otherwise), in the metric's unit.
    n < 2: the interval is undefined (nan; the estimate is the one difference, or nan for n = 0).
    Identical differences give the zero-width interval at their value.
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape or a.ndim != 1:
        raise ValueError(f"expected two aligned 1-D arrays, got shapes {a.shape} and {b.shape}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("a paired mean difference needs finite values")
    d = b - a
    n = len(d)
    if n == 0:
        return Interval(math.nan, math.nan, math.nan, 0)
    mean = float(np.mean(d))
    if n == 1:
        return Interval(mean, math.nan, math.nan, 1)
    if np.all(d == d[0]):  # no spread: t is undefined, the interval is the one value
        return Interval(float(d[0]), float(d[0]), float(d[0]), n)
    with warnings.catch_warnings():  # SciPy warns of precision loss for nearly equal differences
        warnings.simplefilter("ignore", RuntimeWarning)
        ci = sps.ttest_1samp(d, 0.0).confidence_interval(confidence)
    return Interval(mean, float(ci.low), float(ci.high), n)


def _binary(x: np.ndarray, name: str) -> np.ndarray:
    v = np.asarray(x, dtype=float)
    if v.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array of 0/1, got shape {v.shape}")
    bad = v[(v != 0.0) & (v != 1.0)]
    if len(bad):
        raise ValueError(f"{name}: a binary metric must be 0 or 1 per run, got {float(bad[0]):g}")
    return v == 1.0


@dataclass(frozen=True, slots=True)
class PairDifference:
    """B − A of one pair of variants: success rates over ``seeds`` (both finished, both with a
    0/1 success value), continuous metrics over the seeds where both succeeded. ``note`` says
    why something is missing ("" if nothing is)."""

    a: str
    b: str
    seeds: tuple[int, ...]
    table: tuple[int, int, int, int]  # (both, only A, only B, neither) succeeded
    success: Interval                 # p_B − p_A [fraction]
    metrics: dict[str, Interval] = field(default_factory=dict)  # mean B − A [metric unit]
    note: str = ""

    @property
    def rate_a(self) -> float:
        """A's success rate over the paired seeds (nan without a 2×2 table)."""
        n = sum(self.table)
        return (self.table[0] + self.table[1]) / n if n else math.nan

    @property
    def rate_b(self) -> float:
        n = sum(self.table)
        return (self.table[0] + self.table[2]) / n if n else math.nan

    @property
    def both_succeeded(self) -> int:
        return self.table[0]


def pair_difference(rows: list[dict], a: str, b: str, success: str, metrics: list[str],
                    known: list[str] | None = None, confidence: float = 0.95) -> PairDifference:
    """B − A from an experiment's stored rows (``runner.job_rows``). A variant not in ``known``
    (the store's variants) or without finished runs gives an empty pair with a note, not an error."""
    empty = Interval(math.nan, math.nan, math.nan, 0)
    nothing = {m: empty for m in metrics}
    absent = [v for v in (a, b) if known is not None and v not in known]
    if absent:
        return PairDifference(a, b, (), (0, 0, 0, 0), empty, nothing,
                              "no paired seeds: " + " and ".join(absent) + " not in this store")
    done = {v: {r["seed"]: r["metrics"] for r in rows if r["variant"] == v and r["status"] == "done"} for v in (a, b)}
    both = sorted(set(done[a]) & set(done[b]))
    notes = []
    for v in (a, b):
        if not done[v]:
            notes.append(f"{v} has no finished run")
    value = {v: {s: _number(done[v][s].get(success)) for s in both} for v in (a, b)}
    seeds = [s for s in both if math.isfinite(value[a][s]) and math.isfinite(value[b][s])]
    if len(seeds) < len(both):
        notes.append(f"{len(both) - len(seeds)} seeds without {success}")
    for v, other in ((a, b), (b, a)):
        only = sorted(set(done[v]) - set(done[other]))
        if only and done[other]:
            notes.append(f"seeds only {v} finished: {seed_ranges(only)}")
    bad = [(v, s) for s in seeds for v in (a, b) if value[v][s] not in (0.0, 1.0)]
    if bad:
        v, s = bad[0]
        notes.append(f"{success} is not a 0/1 metric ({v}, seed {s}: {value[v][s]:g})")
        return PairDifference(a, b, tuple(seeds), (0, 0, 0, 0), empty, nothing, "; ".join(notes))
    sa = np.array([value[a][s] for s in seeds])
    sb = np.array([value[b][s] for s in seeds])
    table, diff = paired_table(sa, sb), success_difference(sa, sb, confidence)
    if not seeds:
        notes.insert(0, "no paired seeds")
    won = [s for s, x, y in zip(seeds, sa, sb) if x == 1.0 and y == 1.0]
    out = {}
    for m in metrics:
        pairs = [(_number(done[a][s].get(m)), _number(done[b][s].get(m))) for s in won]
        ok = [(x, y) for x, y in pairs if math.isfinite(x) and math.isfinite(y)]
        if len(ok) < len(pairs):
            notes.append(f"{m}: {len(pairs) - len(ok)} both-succeeded seeds without a finite value")
        xa, xb = (np.array([p[i] for p in ok], dtype=float) for i in (0, 1))
        out[m] = mean_difference(xa, xb, confidence)
    return PairDifference(a, b, tuple(seeds), table, diff, out, "; ".join(notes))


#: Columns of ``report_files/differences.csv`` before the per-metric ones.
CSV_KEYS = ("a", "b", "seeds_paired", "both_succeeded", "only_a_succeeded", "only_b_succeeded", "neither_succeeded",
            "success_a_pct", "success_b_pct", "d_success_points", "d_success_low", "d_success_high")


def to_csv(diffs: list[PairDifference], metrics: list[str]) -> str:
    """One line per pair: the 2×2 table, the rates [%] and Δ success [points] with its interval,
    then per metric ``d_<m>_mean``, ``d_<m>_low``, ``d_<m>_high`` [unit] and ``<m>_n`` (seeds both
    succeeded with a finite value), and ``note``. Empty cells where undefined."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_KEYS + tuple(k for m in metrics for k in (f"d_{m}_mean", f"d_{m}_low", f"d_{m}_high", f"{m}_n"))
               + ("note",))
    for p in diffs:
        s = p.success
        row: list[Any] = [p.a, p.b, len(p.seeds), *p.table, 100 * p.rate_a, 100 * p.rate_b,
                          100 * s.estimate, 100 * s.low, 100 * s.high]
        for m in metrics:
            iv = p.metrics[m]
            row += [iv.estimate, iv.low, iv.high, iv.n]
        w.writerow(["" if isinstance(x, float) and not math.isfinite(x) else repr(x) if isinstance(x, float) else x
                    for x in row] + [p.note])
    return buf.getvalue()


def _fixed(x: float, decimals: int) -> str:
    """Signed, ``decimals`` places; a value that rounds to zero is unsigned ``0.0``."""
    if not math.isfinite(x):
        return "–"
    x = round(x, decimals)
    return f"{0.0:.{decimals}f}" if x == 0 else f"{x:+.{decimals}f}"


def interval_cell(iv: Interval, scale: float = 1.0, decimals: int | None = None) -> str:
    """``+1.23 [-0.45, +2.91]``; ``+1.23 [–]`` when the interval is undefined (n < 2); ``–``
    without an estimate. ``decimals`` None: three significant digits of the largest of the three."""
    est, lo, hi = (scale * x for x in (iv.estimate, iv.low, iv.high))
    if not math.isfinite(est):
        return "–"
    if decimals is None:
        big = max(abs(x) for x in (est, lo, hi) if math.isfinite(x))
        decimals = 0 if big == 0 else min(6, max(0, 2 - math.floor(math.log10(big))))
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return f"{_fixed(est, decimals)} [–]"
    return f"{_fixed(est, decimals)} [{_fixed(lo, decimals)}, {_fixed(hi, decimals)}]"


def table(diffs: list[PairDifference], success: str, metrics: list[str], units: dict[str, str]) -> dict[str, Any]:
    """The report table (``{"title", "note", "columns", "rows"}``, as ``report.tables``): one row
    per pair."""
    cols = [("A", "name"), ("B", "name"), ("seeds paired", "num"), ("success A [%]", "num"),
            ("success B [%]", "num"), ("Δ success [points]", "num"), ("both succeeded", "num")]
    cols += [(f"Δ {m}" + (f" [{units[m]}]" if units.get(m) else ""), "num") for m in metrics]
    cols += [("note", "name")]
    rows = []
    for p in diffs:
        rate = (lambda x: "–" if not math.isfinite(x) else f"{100 * x:.1f}")
        rows.append([p.a, p.b, str(len(p.seeds)), rate(p.rate_a), rate(p.rate_b),
                     interval_cell(p.success, 100.0, 1), str(p.both_succeeded) if sum(p.table) else "–"]
                    + [interval_cell(p.metrics[m]) for m in metrics] + [p.note or "–"])
    return {"title": TITLE, "note": note(success, metrics),
            "columns": [{"label": c, "metric": None, "kind": k} for c, k in cols], "rows": rows}


def note(success: str, metrics: list[str]) -> str:
    """What the differences table gives, in one paragraph (markdown)."""
    text = (f"B − A, paired by seed over the seeds both variants finished. Δ success: the difference of the "
            f"`{success}` rates in percentage points, with Newcombe's (1998) interval for paired proportions "
            f"(Wilson score intervals combined by the correlation of the paired outcomes).")
    if metrics:
        text += (" Δ " + ", ".join(f"`{m}`" for m in metrics) + ": the mean paired difference with the "
                 "Student-t interval, only over the seeds where both runs succeeded (a failed run's distance "
                 "and time are how far and how long it got, not a path to the goal); `[–]`: fewer than two such seeds.")
    return text + " An interval that excludes 0 is a difference the seeds resolve. Per pair: " \
                  "`report_files/differences.csv`."
