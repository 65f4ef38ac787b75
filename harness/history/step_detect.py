"""Step detection over a cell's nightly history: where its level changed, by how much, how surely.

The model and the fit are asv's (``asv/step_detect.py``, after Friedrich et al., *Complexity
penalized M-estimation*, JCGS 17, 2008): a series is piecewise constant plus noise, and the
fit is the segmentation that minimises the weighted L1 ("Potts") functional

    F = sum over segments r of  sum_{i in r} |x_i - mu_r| / s_i   +   gamma * (number of steps)

with ``mu_r`` the weighted median of its segment and ``1 / s_i`` the weight of point i (the
inverse of its noise, as asv weighs each point by its measured spread). What differs from asv,
and why:

* **Values in log space**, x = ln y: a 25% slowdown is the same step at any level, a cost
  creeping up 3% a night a straight line, and a relative spread an absolute noise.
* **The exact minimiser**: optimal partitioning, a dynamic programme over segment ends with
  every interval's cost (the weighted medians as ``numpy.quantile`` with weights gives them), where
  asv approximates for its long series. A nightly history is short; at most ``WINDOW`` runs
  are judged.
* **gamma in units of the noise** instead of asv's Schwarz criterion over the gamma path
  (dominated by its noise floor with a nightly's 3-60 points): a step must explain
  ``PENALTY`` = 6 noise units of deviation, or 1.5 ln m in a series of m > 54 points (as the
  Schwarz criterion grows with ln m: a longer series has more places where a spurious split
  pays). The latest night alone becomes a level of its own when it lies 6 noise units from
  the level before it; a step followed by n nights needs about 6 / n units on each.
* **No one-night level inside the history** (asv's ``min_size``): a segment of one point is
  allowed only as the last, the newest night, which cannot yet have company. One noisy night
  between normal ones is an outlier, never two steps.

The noise. The point's own noise is ``s_i = max(s, ln(1 + spread_i) / SPREAD_PER_NOISE)``: the
cell's noise, or the night's measured spread (a range of repeats, about two standard
deviations) where larger: a noisy night weighs less. The cell's noise ``s`` is not the spread
of repeats within one process, which misses how much one process differs from the next
(``harness.history.compare``; the figures are in docs/performance.md). It is measured, where
the series can say it: from ``MIN_POINTS_FOR_NOISE`` points on, the median absolute deviation
of successive differences (``scipy.stats.median_abs_deviation``, gaussian scale) over sqrt 2,
which a step (one difference) or a steady drift (every difference alike) does not inflate; and
where the newest night was measured again in fresh processes
(``harness.nightly.run.remeasure_slowdowns``), the process-to-process noise they show is the
least it may be (``noise_floor``). Two values are policy, not measurements of one machine:

* ``PRIOR_NOISE`` (0.07, log units) is the noise of a series too short to say its own (under
  five successive differences, a median absolute deviation says little). It sets what a young
  history may report: the newest night as a level of its own from exp(``PENALTY`` x 0.07) - 1,
  about 52%, the two newest from exp(``PENALTY`` / 2 x 0.07) - 1, about 23%. A young history
  reports large changes only; the smaller wait until the series says its own noise. The value is set at the largest
  process-to-process spread recorded for a cost cell (docs/performance.md), so that what a
  change of process alone can do is not reported before the series can tell it apart.
* ``NOISE_FLOOR`` (0.02, log units) is the least noise a cell is credited with, however steady
  its series: the history's resolution. A series whose nights agree more closely than one
  process's figure can stand for (identical figures, injected timings: a median absolute
  deviation of zero) would otherwise report any change at all as a certain step. With it the
  newest night alone is a level of its own from exp(``PENALTY`` x 0.02) - 1, about 13%, and a
  level held over several nights a regression from exp(``REGRESSION_NOISE`` x 0.02) - 1, about
  4%: changes of a few percent in a cost ratio are below what the harness claims to resolve.

A **regression** (``regression``) is asv's rule with the noise as its threshold: the latest
level is above the best (lowest) level before it by more than ``REGRESSION_NOISE`` noise
units. A slow drift, fitted as a staircase of small steps, is caught by the sum of them.

How often it finds a step, a one-night step and a drift, and how often a flat series raises a
regression, on synthetic series of two noise levels: docs/nightly.md ("How well a step is found").

Each step's **confidence** is the probability that a level difference as large arises from
noise alone, under gaussian noise of scale ``s`` on the segments' levels (``scipy.stats.norm``),
subtracted from one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Noise units a step must explain (gamma / s) ...
PENALTY = 6.0
#: ... or this many times ln m where larger (m > 54: more places for a spurious split to pay).
PENALTY_PER_LOG = 1.5
#: Noise units by which the latest level must exceed the best earlier one to be a regression.
REGRESSION_NOISE = 2.0
#: Points from which the cell's noise is estimated from the series (5 successive differences).
MIN_POINTS_FOR_NOISE = 6
#: Policy (module docstring): the cell's noise (log units) with fewer points, so that a young
#: history reports only changes beyond what a change of process can do.
PRIOR_NOISE = 0.07
#: Policy (module docstring): the least noise (log units) a cell is credited with, the history's
#: resolution; a series that agrees exactly would otherwise make any change a certain step.
NOISE_FLOOR = 0.02
#: A night's measured spread is the range of its 3-9 repeats, (max - min) / min: about this many
#: of their standard deviations (the expected range of 3 gaussian draws is 1.7 sigma, of 9, 3.0).
SPREAD_PER_NOISE = 2.0
#: The fewest points step detection is run on.
MIN_POINTS = 3


@dataclass(frozen=True)
class Step:
    """A change of level at point ``index`` (the first point of the new level)."""

    index: int
    before: float  # the level before (in the series' units)
    after: float  # the level from ``index`` on
    confidence: float

    @property
    def size(self) -> float:
        """Relative change, after / before - 1."""
        return self.after / self.before - 1.0


@dataclass(frozen=True)
class Fit:
    """A series' piecewise-constant fit: ``segments`` as (start, end) point ranges with their
    ``levels``, the ``steps`` between them and the cell's ``noise`` (log units)."""

    segments: tuple[tuple[int, int], ...]
    levels: tuple[float, ...]
    steps: tuple[Step, ...]
    noise: float
    point_noise: tuple[float, ...]  # s_i of each point (log units)

    def level_at(self, i: int) -> float:
        for (a, b), level in zip(self.segments, self.levels):
            if a <= i < b:
                return level
        raise IndexError(i)

    def regression(self, worse_if_higher: bool = True) -> tuple[int, float, float] | None:
        """(index of the first step after the best level, best level, latest level) when the latest
        level is worse than the best before it by more than ``REGRESSION_NOISE`` noise units: the
        cell's noise, or the newest point's own where larger (a night whose figure was measured
        again in fresh processes carries their spread, ``harness.nightly.run.remeasure_slowdowns``)."""
        if len(self.levels) < 2:
            return None
        sign = 1.0 if worse_if_higher else -1.0
        logs = [sign * math.log(v) for v in self.levels]
        best = int(np.argmin(logs[:-1]))
        noise = max(self.noise, self.point_noise[-1]) if self.point_noise else self.noise
        if logs[-1] - logs[best] > REGRESSION_NOISE * noise:
            return self.segments[best + 1][0], self.levels[best], self.levels[-1]
        return None


def penalty(m: int) -> float:
    """gamma / s for a series of ``m`` points: ``PENALTY``, growing as ln m beyond 54 points."""
    return max(PENALTY, PENALTY_PER_LOG * math.log(max(m, 1)))


def cell_noise(x: np.ndarray) -> float:
    """The cell's noise in log units (module docstring)."""
    if len(x) < MIN_POINTS_FOR_NOISE:
        return PRIOR_NOISE
    from scipy.stats import median_abs_deviation  # here: scipy.stats is most of this module's import time

    return max(NOISE_FLOOR, float(median_abs_deviation(np.diff(x), scale="normal")) / math.sqrt(2.0))


def _segment_costs(x: np.ndarray, w: np.ndarray, start: int) -> tuple[np.ndarray, np.ndarray]:
    """Weighted medians and weighted L1 costs of every segment [start, end), end = start+1 .. m.

    The medians are ``numpy.quantile(..., 0.5, weights=..., method="inverted_cdf")`` of each
    segment (the smallest value whose cumulative weight reaches half the total; the test holds
    the two equal), computed for all the segments from one start at once: numpy's weighted
    quantile walks the rows of a 2-D input in Python, one row at a time (docs/performance.md)."""
    xs, ws = x[start:], w[start:]
    n = len(xs)
    order = np.argsort(xs, kind="stable")
    included = order[None, :] <= np.arange(n)[:, None]  # row r: the points start .. start + r, sorted
    cum = np.cumsum(np.where(included, ws[order][None, :], 0.0), axis=1)
    half = 0.5 * cum[:, -1]
    medians = xs[order][np.argmax(cum >= half[:, None], axis=1)]
    W = np.tril(np.broadcast_to(ws, (n, n)))
    return medians, (W * np.abs(xs[None, :] - medians[:, None])).sum(axis=1)


def detect_steps(values, spreads=None, noise_floor: float = 0.0) -> Fit:
    """Fit the series ``values`` (> 0; ``spreads``: each point's measured relative spread, or None);
    ``noise_floor``: the least cell noise (log units), where it was measured otherwise (the
    process-to-process noise of the newest night's re-measurement)."""
    y = np.asarray(values, dtype=float)
    if y.ndim != 1 or len(y) == 0 or not np.all(np.isfinite(y)) or np.any(y <= 0):
        raise ValueError("step detection needs a non-empty series of finite values > 0")
    x = np.log(y)
    m = len(x)
    spread = np.zeros(m) if spreads is None else np.nan_to_num(np.asarray(spreads, dtype=float), nan=0.0)
    s = max(cell_noise(x), float(noise_floor))
    s_i = np.maximum(s, np.log1p(np.maximum(spread, 0.0)) / SPREAD_PER_NOISE)
    w = 1.0 / s_i
    gamma = penalty(m)
    # best[j]: least F over the first j points; back[j]: where its last segment starts.
    best = np.full(m + 1, np.inf)
    best[0] = 0.0
    back = np.zeros(m + 1, dtype=int)
    medians = {}
    for i in range(m):
        med, cost = _segment_costs(x, w, i)
        for r in range(m - i):
            j = i + r + 1
            if r == 0 and j != m:
                continue  # one-night segments only as the newest level
            f = best[i] + cost[r] + (gamma if i > 0 else 0.0)
            if f < best[j]:
                best[j], back[j] = f, i
            medians[(i, j)] = med[r]
    bounds, j = [], m
    while j > 0:
        bounds.append((int(back[j]), j))
        j = back[j]
    bounds.reverse()
    levels = [math.exp(medians[b]) for b in bounds]
    steps = []
    for k in range(1, len(bounds)):
        (a0, a1), (b0, b1) = bounds[k - 1], bounds[k]
        dx = abs(math.log(levels[k]) - math.log(levels[k - 1]))
        z = dx / (s * math.sqrt(1.0 / (a1 - a0) + 1.0 / (b1 - b0)))
        steps.append(Step(b0, levels[k - 1], levels[k], float(1.0 - 2.0 * _norm_sf(z))))
    return Fit(tuple(bounds), tuple(levels), tuple(steps), s, tuple(float(v) for v in s_i))


def _norm_sf(z: float) -> float:
    from scipy.stats import norm  # here: scipy.stats is most of this module's import time

    return norm.sf(z)
