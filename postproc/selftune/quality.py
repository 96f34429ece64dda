"""Per-stride plausibility flags (``stride_quality``, ``stride_flags``, ``StrideQualityAccumulator``) and the
split-stride warning (``split_strides``); the flags' meaning is in ``bootnav.postproc.selftune``."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.core.arrays import GrowingRows, row_norm
from bootnav.core.runs import runs
from bootnav.postproc.strides import footprints

from .settings import SelfTuneSettings


FAST, MISSED, VERTICAL, ROLLING, TINY = 1, 2, 4, 8, 16


IMPLAUSIBLE = FAST | MISSED | VERTICAL


FLAG_NAMES = {FAST: "fast", MISSED: "missed_stance", VERTICAL: "vertical", ROLLING: "rolling", TINY: "tiny"}


@dataclass
class StrideQuality:
    """Per stride (rows of ``segment_strides``): flags bitmask; and the share of implausible strides."""

    flags: np.ndarray
    duration_s: np.ndarray  # footprint to footprint (mid-stance to mid-stance)
    swing_s: np.ndarray  # end of the previous stance phase to the start of this one (unaided interval)
    stance_rate_radps: np.ndarray
    bad_fraction: float


def stride_quality(t_s, pos_n, stance, gyro_b, gyro_bias_b, period_s: float,
                   settings: SelfTuneSettings | None = None) -> StrideQuality:
    """Per-stride plausibility flags (module docstring) for the strides of ``segment_strides``.

    Parameters
    ----------
    t_s, pos_n, stance : the path and its stance mask.
    gyro_b : (N, 3) rad/s; gyro_bias_b : (3,) or (N, 3) estimated bias, rad/s.
    period_s : gait period (NaN: the MISSED flag is not evaluated).
    settings : ``SelfTuneSettings``.

    Returns
    -------
    ``StrideQuality`` with one flag word per stride.
    """
    stance = np.asarray(stance, bool)
    starts, stops = runs(stance)
    if starts.size < 2:
        return stride_flags(np.zeros(0), np.zeros((0, 3)), np.zeros(0), np.zeros(0), np.zeros(0), period_s, settings)
    t_mid, fp = footprints(np.asarray(t_s, float), np.asarray(pos_n, float), stance)
    rate = row_norm(gyro_b - gyro_bias_b)
    # median turning rate over each stance phase (sorted per phase via a lexsort on (phase, rate))
    ph = np.zeros(len(stance), np.int64)
    ph[starts[1:]] = 1
    ph = np.cumsum(ph)
    sel = stance
    order = np.lexsort((rate[sel], ph[sel]))
    r_sorted = rate[sel][order]
    counts = stops - starts
    offs = np.concatenate(([0], np.cumsum(counts)))
    med = 0.5 * (r_sorted[offs[:-1] + (counts - 1) // 2] + r_sorted[offs[:-1] + counts // 2])
    return stride_flags(t_mid, fp, t_s[starts], t_s[stops - 1], med, period_s, settings)


def stride_flags(t_mid, fp, t_first, t_last, med_rate, period_s: float,
                 settings: SelfTuneSettings | None = None) -> StrideQuality:
    """``stride_quality`` from per-stance-phase figures (K phases): mid times and footprints (``footprints``),
    the times of each phase's first and last sample, s, and its median turning rate ‖ω − b_g‖, rad/s. The one
    definition of the flags: the whole path gives them through ``stride_quality``, a path pushed in blocks
    through ``StrideQualityAccumulator``."""
    s = settings or SelfTuneSettings()
    if len(t_mid) < 2:
        return StrideQuality(np.zeros(0, np.uint8), np.zeros(0), np.zeros(0), np.zeros(0), 1.0)
    fp = np.asarray(fp, float)
    d = np.diff(fp, axis=0)
    length = np.hypot(d[:, 0], d[:, 1])
    dur = np.diff(np.asarray(t_mid, float))
    swing = np.asarray(t_first, float)[1:] - np.asarray(t_last, float)[:-1]
    med = np.asarray(med_rate, float)
    flags = np.zeros(len(length), np.uint8)
    flags[(length > s.max_stride_m) | (length > s.max_speed_mps * np.maximum(dur, 1e-9))] |= FAST
    if np.isfinite(period_s):
        flags[(swing > s.missed_factor * period_s) & (length > 0.1)] |= MISSED
    flags[np.abs(d[:, 2]) > s.max_dz_m] |= VERTICAL
    flags[med[1:] > s.max_stance_rate_radps] |= ROLLING
    flags[length < s.min_stride_m] |= TINY
    bad = float(np.mean((flags & IMPLAUSIBLE) > 0)) if len(flags) else 1.0
    return StrideQuality(flags, dur, swing, med[1:], bad)


class StrideQualityAccumulator:
    """The per-stance-phase figures of ``stride_flags`` from a path pushed in consecutive chunks (bounded
    memory: the turning rates of the open stance phase). ``finish`` gives what ``stride_quality`` gives on the
    whole path (the same medians; footprints to rounding: ``strides.FootprintAccumulator``)."""

    def __init__(self):
        from bootnav.postproc.strides import FootprintAccumulator

        self._fp = FootprintAccumulator()
        self._phases = GrowingRows(3)  # per stance phase: first and last time, median rate (24 B each)
        self._open: list[np.ndarray] = []  # turning rates of the open phase, chunk by chunk
        self._open_t: tuple[float, float] | None = None

    def push(self, t_s, pos_n, stance, gyro_b, gyro_bias_b) -> None:
        """Consecutive rows: s, m ENU, bool, rad/s (N, 3), rad/s ((3,) or (N, 3))."""
        m = len(t_s)
        if m == 0:
            return
        stance = np.asarray(stance, bool)
        self._fp.push(t_s, pos_n, stance)
        rate = row_norm(np.asarray(gyro_b) - gyro_bias_b)
        starts, stops = runs(stance)
        if self._open_t is not None and (starts.size == 0 or starts[0] > 0):
            self._close()
        for a, b in zip(starts.tolist(), stops.tolist()):  # one iteration per stance phase
            if a == 0 and self._open_t is not None:
                self._open_t = (self._open_t[0], float(t_s[b - 1]))
            else:
                self._open_t = (float(t_s[a]), float(t_s[b - 1]))
            self._open.append(rate[a:b])
            if b < m:
                self._close()

    def _close(self) -> None:
        if self._open_t is None:
            return
        r = np.sort(np.concatenate(self._open))
        c = len(r)
        self._phases.append((self._open_t[0], self._open_t[1], 0.5 * (r[(c - 1) // 2] + r[c // 2])))
        self._open, self._open_t = [], None

    def finish(self, period_s: float, settings: SelfTuneSettings | None = None) -> StrideQuality:
        """The flags of every stride pushed (``stride_flags``)."""
        self._close()
        t_mid, fp = self._fp.finish()
        first, last, med = self._phases.rows.T
        return stride_flags(t_mid, fp, first, last, med, period_s, settings)


def implausible_strides(quality: StrideQuality) -> str:
    """Why the configured detector fails on its strides (``StrideQuality`` over ``max_bad_fraction``): the
    message of the stance fallback's trigger."""
    return (f"{quality.bad_fraction:.0%} of its {len(quality.flags)} strides are implausible (longer or faster than a "
            "foot moves, a missed stance, or a climb steeper than stairs)")


def split_strides(quality: StrideQuality, period_s: float, settings: SelfTuneSettings | None = None) -> str | None:
    """A warning when most strides are split: a foot rests once per gait cycle, so footprints closer in time
    than ``split_factor`` (1/2) of the gait period are a stance detected inside a swing (or a turn on the spot).
    A zero-velocity update there stops a moving foot, so every split stride is shortened and the distance comes
    out short without any stride looking implausible (each piece is an ordinary short stride, or a TINY one,
    which is informative only). A minority is normal (turns on the spot, the first and last step); when more than
    ``max_split_fraction`` (1/2) of the strides contradict the gait rhythm, the stance sequence itself is wrong.
    None without a gait period or when the strides fit the rhythm."""
    s = settings or SelfTuneSettings()
    dur = np.asarray(quality.duration_s, float)
    if not np.isfinite(period_s) or dur.size < 4:
        return None
    split = float(np.mean(dur < s.split_factor * period_s))
    if split <= s.max_split_fraction:
        return None
    return (f"{split:.0%} of the {dur.size} strides last less than half the gait cycle ({period_s:.2f} s): the stance "
            "detector finds rests inside the swings, which stops the foot mid-stride, so the distance is likely too "
            "short; try another --detector (e.g. shoe) or a higher --threshold")
