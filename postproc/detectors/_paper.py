"""The threshold and duration rules of the source paper's stance indicators [Heidari2019, §4].

The paper thresholds its statistic "with a threshold obtained experimentally" and gives no value; its
Chart 1 shows the result as a clean 0/1 indicator, one stance block per step. The rules here restate that
for any recording:

* **threshold read off the recording** (``threshold=None``): the statistic of a walk is bimodal — the
  foot at rest (sensor noise) and the foot in swing, decades apart — so the threshold is the split of the
  histogram of log10 T that maximises the between-class variance [Otsu1979]. No number is tuned, and a
  sensor-dependent rest level (noise, bias, the acceleration scale) moves the split with it.
* **one block per step**: stance runs shorter than ``min_stance_s`` are dropped first (an instant of the
  swing where the statistic dips, e.g. where ‖f‖ crosses g), then swing gaps shorter than ``min_swing_s``
  are filled (a walking swing lasts ≥ 0.3 s; shorter gaps are impacts or rolling inside the stance), then
  runs shorter than ``min_stance_s`` are dropped again (``base.StanceDetector.detect``).

``rest_magnitude`` gives the specific-force magnitude this sensor reads at rest (its own "g", scale and
bias included), from the accelerometer alone.
"""

from __future__ import annotations

import numpy as np

from . import postprocess
from bootnav.core.arrays import moving_mean, row_norm, window_samples


def log_otsu_threshold(statistic: np.ndarray, bins: int = 256) -> float:
    """Threshold between the two modes of a positive statistic: Otsu's split of log10 T [Otsu1979].

    Parameters
    ----------
    statistic : ndarray, shape (N,)
        Detector statistic; non-finite and non-positive values are ignored.
    bins : int
        Histogram bins over the range of log10 T.

    Returns
    -------
    float
        The threshold in the statistic's units (NaN if fewer than two distinct positive values).
    """
    x = np.asarray(statistic, dtype=np.float64)
    x = np.log10(x[np.isfinite(x) & (x > 0)])
    if x.size < 2 or np.ptp(x) == 0:
        return float("nan")
    counts, edges = np.histogram(x, bins=bins)
    centres = 0.5 * (edges[:-1] + edges[1:])
    w0 = np.cumsum(counts)
    w1 = w0[-1] - w0
    m0 = np.cumsum(counts * centres)
    mu0 = m0 / np.maximum(w0, 1)
    mu1 = (m0[-1] - m0) / np.maximum(w1, 1)
    between = w0 * w1 * (mu0 - mu1) ** 2
    # the split lies at the upper edge of the last bin of the lower class
    return float(10.0 ** edges[int(np.argmax(between)) + 1])


def rest_magnitude(acc_b: np.ndarray, dt: float, *, window_s: float = 0.1, quantile: float = 0.1) -> float:
    """‖f‖ this sensor reads at rest: the median ‖f‖ over the samples whose moving standard deviation of
    ‖f‖ (over ``window_s``) is in its lowest ``quantile`` (a foot at rest is the steadiest part of a walk).

    Parameters
    ----------
    acc_b : ndarray, shape (N, 3)
        Specific force, m/s².
    dt : float
        Sample interval, s.
    window_s, quantile : float
        Window of the moving standard deviation; fraction of the steadiest samples used.

    Returns
    -------
    float
        m/s².
    """
    f = row_norm(acc_b)
    n = window_samples(window_s, dt, 3)
    sd = np.sqrt(np.maximum(moving_mean(f * f, n) - moving_mean(f, n) ** 2, 0.0))
    return float(np.median(f[sd <= np.quantile(sd, quantile)]))


class PaperRule:
    """Mixin for a ``ThresholdDetector``: a threshold of None (``DEFAULT_THRESHOLD = None``) ->
    ``log_otsu_threshold`` of the recording, and stance runs shorter than ``min_stance_s`` are dropped
    before the swing gaps are filled (module docstring). Defines no fields."""

    def classify(self, acc_b, gyro_b, dt, bad):
        stat = self.statistic(acc_b, gyro_b, dt)
        rule = "fixed" if self.threshold is not None else "log_otsu"
        thr = float(self.threshold) if self.threshold is not None else log_otsu_threshold(stat[~bad])
        if self.hysteresis_ratio > 1.0:
            raw = postprocess.hysteresis(stat, thr, thr * self.hysteresis_ratio)
        else:
            raw = stat < thr
        raw = postprocess.remove_short_runs(raw, np.arange(raw.size) * dt, self.min_stance_s, dt)
        n = self.window(dt)
        return raw, stat, thr, n, {"window_samples": n, "window_s": n * dt, "threshold_rule": rule, **self._info()}
