"""Post-processing of a raw stance mask: hysteresis, minimum swing and minimum stance durations.

* Hysteresis (two thresholds, e.g. [Wahlstrom2021]): a stance run is a maximal run with T < γ_high that
  contains at least one sample with T < γ_low. Suppresses chatter at the threshold.
* Minimum swing: swing gaps shorter than ``min_swing_s`` between two stance runs are filled (a foot cannot
  complete a swing that fast; these are impacts inside the stance phase).
* Minimum stance: stance runs shorter than ``min_stance_s`` are dropped (one quiet sample in mid-swing
  must not zero the velocity).
Durations use the real timestamps: run duration = t[last] − t[first] + dt_median.
"""

from __future__ import annotations

import numpy as np

from bootnav.core.runs import runs


def hysteresis(statistic: np.ndarray, low: float, high: float) -> np.ndarray:
    """T < high runs that contain at least one sample with T < low."""
    from scipy.ndimage import label

    loose = statistic < high
    labels, n = label(loose)
    if n == 0:
        return loose
    seeded = np.zeros(n + 1, dtype=bool)
    seeded[np.unique(labels[statistic < low])] = True
    seeded[0] = False
    return seeded[labels]


def remove_short_runs(mask: np.ndarray, t_s: np.ndarray, min_s: float, dt: float, *,
                      keep_edges: bool = False) -> np.ndarray:
    """Set to False every True run shorter than ``min_s`` seconds (optionally keep runs touching an end)."""
    out = np.asarray(mask, dtype=bool).copy()
    if min_s <= 0 or not out.any():
        return out
    starts, stops = runs(out)
    dur = t_s[stops - 1] - t_s[starts] + dt
    short = dur < min_s
    if keep_edges:
        short &= (starts > 0) & (stops < out.size)
    if short.any():
        idx = np.zeros(out.size + 1, dtype=np.int32)
        np.add.at(idx, starts[short], 1)
        np.add.at(idx, stops[short], -1)
        out[np.cumsum(idx[:-1]) > 0] = False
    return out


def remove_short_fragments(mask: np.ndarray, t_s: np.ndarray, min_s: float, dt: float, *,
                           isolated_min_s: float, isolation_s: float, window_s: float = 0.0,
                           min_flat_fraction: float = 0.0, max_period_s: float = np.inf) -> np.ndarray:
    """Like ``remove_short_runs``, but a short run that is the only stance within ``isolation_s`` on both
    sides is kept when it lasts at least ``isolated_min_s`` or the foot-flat it stands for lasts at least
    ``min_flat_fraction`` of the local stride period.

    Why: a short quiet run next to a longer stance is a fragment (heel or toe roll) or a quiet instant in
    mid-swing; an isolated one, between two full swings, is the brief foot-flat of a running stride, and
    dropping it leaves the whole stride unaided. Its length is judged as a share of the stride, not in
    absolute time: a foot-flat is a fraction of the gait cycle (≈ 6-18 % when running, pyshoe_vicon's VICON
    labels; more when walking), so a short quiet run is a foot-flat in a fast stride and a blip in a slow one.

    The foot-flat a run stands for: a statistic over a centred window of ``window_s`` is quiet only where the
    whole window is, so a run of the statistic from t_a to t_b means rest from t_a − W/2 to t_b + W/2, a
    foot-flat of (t_b − t_a) + ``window_s`` (one sample under the threshold already certifies one window of
    rest). The local stride period is the interval from the previous stance start to this one when it is
    ≤ ``max_period_s``, else ``max_period_s`` (the longest stride assumed; a longer interval spans a missed
    stance). Only the past is used, so a stream decides it without waiting longer (it keeps
    ``max_period_s`` more history).
    """
    out = np.asarray(mask, dtype=bool).copy()
    if min_s <= 0 or not out.any():
        return out
    starts, stops = runs(out)
    dur = t_s[stops - 1] - t_s[starts] + dt
    gap_before = np.r_[np.inf, t_s[starts[1:]] - t_s[stops[:-1] - 1]]
    gap_after = np.r_[t_s[starts[1:]] - t_s[stops[:-1] - 1], np.inf]
    long_enough = dur >= isolated_min_s
    if min_flat_fraction > 0:
        since_previous = np.r_[np.inf, np.diff(t_s[starts])]
        period = np.where(since_previous <= max_period_s, since_previous, max_period_s)
        flat = dur - dt + window_s
        long_enough |= flat >= min_flat_fraction * period
    isolated = (gap_before >= isolation_s) & (gap_after >= isolation_s) & long_enough
    short = (dur < min_s) & ~isolated
    for a, b in zip(starts[short], stops[short]):
        out[a:b] = False
    return out


def clean_stance(stance: np.ndarray, t_s: np.ndarray, dt: float, *, min_swing_s: float = 0.0,
                 min_stance_s: float = 0.0) -> np.ndarray:
    """Fill swing gaps < min_swing_s (interior only), then drop stance runs < min_stance_s."""
    stance = np.asarray(stance, dtype=bool)
    if min_swing_s > 0:
        stance = ~remove_short_runs(~stance, t_s, min_swing_s, dt, keep_edges=True)
    return remove_short_runs(stance, t_s, min_stance_s, dt)
