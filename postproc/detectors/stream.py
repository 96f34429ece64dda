"""Streaming stance detection: a registry detector over samples pushed in chunks (``StreamStance``).

Push raw samples; get back, in order, the samples whose stance decision is final, i.e. whose window context
is complete. A decision at sample k depends on the samples within a bounded radius of k for the detectors
whose statistic is a centred moving window and whose post-processing works on bounded durations: the
radius is half the statistic's windows + the saturation guard + ``min_swing_s`` + 2 ``min_stance_s`` (the
paper's rule drops short runs twice; the adaptive detector: its valley/peak span too, its isolation span
instead of one ``min_stance_s``). The stream runs the detector on the samples from one radius before the
undecided ones (adaptive: one radius + ``span_s`` + ``min_stance_s``, the look-back of its isolated-stance
rule, which needs the previous stance start) to the newest, and keeps the decisions that lie one radius before the newest (both edges of
the record are handled as the whole-array detector handles them), so its output equals ``detect_stance`` on
the whole record for any chunking (tests/test_stream_stance.py), given the same sample period.

Supported, exact: ``shoe`` (both forms), ``ared``, ``mv``, ``mag``, and ``shoe-literal`` with a fixed
``threshold``. Not streamable, they need the whole record: ``xio`` (zero-phase IIR filtering and the rest
magnitude of the record), ``paper_accmag`` (the rest magnitude of the record), ``shoe-literal`` without a
threshold (Otsu's split of the record's histogram) and any detector with hysteresis (a T < ratio·γ run is
stance if it reaches γ anywhere, however long it is): ``StreamStance`` refuses them with an error.

``adaptive`` (the default) reads one number off the whole record, the noise floor F (a low quantile of
log10 T); everything else it does is bounded (its valley / peak span included). The stream takes F from a
bounded look-back instead: the same quantile over every sample decided so far (a histogram of log10 T in
1e-3-decade bins, so the memory stays bounded), or a fixed ``noise_floor_log10`` (e.g. from an earlier
``process`` of the same boot: ``StanceResult.info["noise_floor_log10"]``). With that value the output equals
the whole-array detector's; with the running floor it differs only where F + δ decides (long rests, the
floor being that of the walk so far).

What ``detect_stance`` adds on the whole record and a stream cannot: the clipping plateaus
(``detect_clipping``, ``bootnav.core.arrays.clipped_samples``) are found from the extremes of the whole record; the stream
excludes the samples the pushed ``saturated`` mask flags (the firmware's saturation bits). The sample period
is the device's nominal one (``rate_hz``); ``detect_stance`` uses the record's median step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bootnav.errors import InputError

from bootnav.core.arrays import window_samples
from bootnav.core.conventions import STANDARD_GRAVITY_MPS2
from .base import StanceDetector, WindowedDetector

_HIST_LO, _HIST_STEP, _HIST_N = -20.0, 1e-3, 60_000  # log10 T histogram of the running noise floor


@dataclass
class StanceChunk:
    """Consecutive samples whose stance is decided, as pushed (``start``: absolute index of the first)."""

    start: int
    t_s: np.ndarray  # (m,)
    acc_b: np.ndarray  # (m, 3)
    gyro_b: np.ndarray  # (m, 3)
    stance: np.ndarray  # (m,) bool
    saturated: np.ndarray  # (m,) uint8 saturation bitmask (bits ax, ay, az, gx, gy, gz), for the navigator's push
    statistic: np.ndarray | None = None  # (m,) the detector's statistic (``StanceResult.statistic``'s rows)
    threshold_log10: np.ndarray | None = None  # (m,) the adaptive detector's per-sample log10 γ (else None)

    def __len__(self) -> int:
        return int(self.t_s.shape[0])


def _unsupported(det: StanceDetector) -> str | None:
    """Why ``det`` cannot be streamed exactly, or None."""
    if getattr(det, "hysteresis_ratio", 1.0) > 1.0:
        return "hysteresis (hysteresis_ratio > 1) makes a stance run depend on its whole T < ratio·γ run"
    if det.name == "adaptive":
        return None
    if not isinstance(det, WindowedDetector):
        return "its statistic needs the whole record (zero-phase filtering or the record's rest magnitude)"
    if getattr(det, "threshold", None) is None:
        return "its threshold is read off the whole record (give a fixed threshold)"
    return None


class StreamStance:
    """A registry detector over chunks of samples (module docstring).

    Parameters
    ----------
    settings : DetectorSettings
        The detector and its parameters (``DetectorSettings.build``).
    rate_hz : float
        The device's nominal sample rate, Hz (windows and durations in seconds are converted with it).
    gravity : float
        Local gravity, m/s².
    noise_floor_log10 : float, optional
        ``adaptive`` only: a fixed noise floor F (log10 of the statistic) instead of the running one.
    gyro_bias_b : (3,) array, optional
        Subtracted from the rate the detector sees (not from the samples it returns), rad/s: the initial rest's
        rate (``calibration.stance_reference``, as ``process`` does); pass its gravity as ``gravity``.

    Raises
    ------
    InputError
        A detector that needs the whole record, or a bad rate.
    """

    def __init__(self, settings, rate_hz: float, gravity: float = STANDARD_GRAVITY_MPS2, *,
                 noise_floor_log10: float | None = None, gyro_bias_b=None):
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise InputError(f"rate_hz must be the device's positive sample rate in Hz, got {rate_hz!r}")
        det = settings.build(gravity)
        why = _unsupported(det)
        if why:
            raise InputError(f"stance detector '{det.name}' cannot run on a stream: {why}; choose one of "
                             f"{', '.join(streamable_detectors())} (bootnav process --detector NAME)")
        self.detector = det
        self._gyro_bias = None if gyro_bias_b is None else np.asarray(gyro_bias_b, dtype=np.float64).reshape(3)
        self.dt_s = dt = 1.0 / float(rate_hz)
        self._adaptive = det.name == "adaptive"
        self._floor = noise_floor_log10 if self._adaptive else None
        if self._adaptive:
            n_w = window_samples(det.window_s, dt, 3)
            span = window_samples(det.span_s, dt, 3)
            reach = n_w // 2 + span // 2 + det.average_samples(dt) // 2 + 2
            durations = det.min_swing_s + det.min_stance_s + det.isolation_s
            # the isolated-run rule looks back for the previous stance start up to span_s before the run
            history_s = det.span_s + det.min_stance_s
            self._hist = np.zeros(_HIST_N, dtype=np.int64) if noise_floor_log10 is None else None
        else:
            n_w = det.window(dt)
            reach = n_w // 2 + 2
            durations = det.min_swing_s + 2 * det.min_stance_s  # the paper's rule drops short runs twice
            history_s = 0.0
        guard = max(n_w, window_samples(det.saturation_guard_s, dt, 0))
        self.radius = reach + guard + int(math.ceil(durations / dt)) + 4  # samples
        self._history = self.radius + int(math.ceil(history_s / dt))  # samples kept before the undecided ones
        self._t = np.zeros(0)
        self._acc = np.zeros((0, 3))
        self._gyro = np.zeros((0, 3))
        self._bits = np.zeros(0, dtype=np.uint8)
        self._bad = np.zeros(0, dtype=bool)
        self._b0 = 0  # absolute index of the buffer's first sample
        self._decided = 0  # absolute index of the first undecided sample
        self._n = 0
        self._finished = False

    @property
    def noise_floor_log10(self) -> float | None:
        """``adaptive`` only: the noise floor F in use, the given one or the running quantile over the samples
        decided so far (None before the first decision, and for the other detectors)."""
        if not self._adaptive or self._floor is not None:
            return self._floor
        cum = np.cumsum(self._hist)
        if cum[-1] == 0:
            return None
        k = int(np.searchsorted(cum, self.detector.noise_quantile * cum[-1], side="left"))
        return _HIST_LO + (k + 0.5) * _HIST_STEP

    @property
    def lookahead_s(self) -> float:
        """How long after a sample its stance decision comes, s (at the nominal rate)."""
        return self.radius * self.dt_s

    def push(self, t_s, acc_b, gyro_b, saturated=None) -> list[StanceChunk]:
        """Add samples; return the newly decided ones (a list of at most one chunk).

        Parameters
        ----------
        t_s : (m,) array
            Sample times, s.
        acc_b, gyro_b : (m, 3) arrays
            Specific force (m/s², gravity included) and angular rate (rad/s), body frame.
        saturated : (m,) or (m, k) array, optional
            Saturation bitmask or bool mask: those samples are never stance.

        Returns
        -------
        list of StanceChunk
        """
        if self._finished:
            raise InputError("this StreamStance is finished; build a new one for another record")
        t_s = np.asarray(t_s, dtype=np.float64).reshape(-1)
        m = t_s.shape[0]
        acc_b = np.asarray(acc_b, dtype=np.float64).reshape(m, 3) if m else np.zeros((0, 3))
        gyro_b = np.asarray(gyro_b, dtype=np.float64).reshape(m, 3) if m else np.zeros((0, 3))
        bits = _as_bits(saturated, m, self._n)
        bad = (bits > 0) | ~np.all(np.isfinite(acc_b), axis=1) | ~np.all(np.isfinite(gyro_b), axis=1)
        self._t = np.concatenate([self._t, t_s])
        self._acc = np.concatenate([self._acc, acc_b])
        self._gyro = np.concatenate([self._gyro, gyro_b])
        self._bits = np.concatenate([self._bits, bits])
        self._bad = np.concatenate([self._bad, bad])
        self._n += m
        return self._emit(final=False)

    def finish(self) -> list[StanceChunk]:
        """Decide the remaining samples (the record has ended)."""
        if self._finished:
            return []
        out = self._emit(final=True)
        self._finished = True
        return out

    def _emit(self, final: bool) -> list[StanceChunk]:
        end = self._n if final else self._n - self.radius
        if end <= self._decided:
            return []
        t, acc, gyro, bad = self._t, self._acc, self._gyro, self._bad
        gyro_det = gyro if self._gyro_bias is None else gyro - self._gyro_bias
        stance, stat, gamma = self._detect(t, acc, gyro_det, bad, self._decided - self._b0, end - self._b0)
        a, b = self._decided - self._b0, end - self._b0
        chunk = StanceChunk(self._decided, t[a:b], acc[a:b], gyro[a:b], stance[a:b], self._bits[a:b], stat[a:b],
                            None if gamma is None else gamma[a:b])
        self._decided = end
        keep = max(0, end - self._history - self._b0)
        self._t, self._acc, self._gyro, self._bad = t[keep:], acc[keep:], gyro[keep:], bad[keep:]
        self._bits = self._bits[keep:]
        self._b0 += keep
        return [chunk]

    def _detect(self, t, acc, gyro, bad, a, b) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """The detector's ``detect`` on the buffer with the nominal period (``base.StanceDetector.detect``'s
        steps; samples a..b−1 are the ones being decided): (stance mask, statistic, the adaptive detector's
        log10 γ or None) of the buffer."""
        from . import postprocess
        from bootnav.core.arrays import dilate

        det = self.detector
        dt = self.dt_s
        acc0 = np.where(np.isfinite(acc), acc, 0.0) if bad.any() else acc
        gyro0 = np.where(np.isfinite(gyro), gyro, 0.0) if bad.any() else gyro
        gamma = None
        if self._adaptive:
            raw, n_window, stat, gamma = self._adaptive_raw(acc0, gyro0, bad, a, b)
        else:
            raw, stat, _, n_window, _ = det.classify(acc0, gyro0, dt, bad)
        stance = postprocess.clean_stance(raw, t, dt, min_swing_s=det.min_swing_s)
        stance &= ~dilate(bad, max(n_window, window_samples(det.saturation_guard_s, dt, 0)))
        return det.drop_short_runs(stance, t, dt), stat, gamma

    def _adaptive_raw(self, acc, gyro, bad, a, b):
        """``adaptive.AdaptiveDetector``'s rule with the noise floor F from the look-back (module docstring)."""
        from scipy.ndimage import maximum_filter1d, minimum_filter1d

        det, dt = self.detector, self.dt_s
        L, T, n = det.log_statistic(acc, gyro, dt)  # as ``AdaptiveDetector.classify``
        span = window_samples(det.span_s, dt, 3)
        valley = minimum_filter1d(L, span, mode="nearest")
        peak = maximum_filter1d(L, span, mode="nearest")
        if self._floor is None:  # running quantile over every decided sample (bounded look-back)
            new = L[a:b][~bad[a:b]]
            idx = np.clip(np.floor((new - _HIST_LO) / _HIST_STEP).astype(np.int64), 0, _HIST_N - 1)
            self._hist += np.bincount(idx, minlength=_HIST_N)
        floor = self.noise_floor_log10
        if floor is None:  # every decided sample so far is excluded (saturated)
            floor = float(np.quantile(L[a:b], det.noise_quantile))
        gamma = np.maximum(valley + det.alpha * (peak - valley), floor + det.floor_decades)
        if det.max_rate_radps:
            gamma = np.minimum(gamma, np.log10(det.max_rate_radps**2 / det.sigma_gyro_radps**2))
        return L < gamma, n, T, gamma


def _as_bits(saturated, m: int, at: int) -> np.ndarray:
    """A pushed saturation mask as a uint8 bitmask: bits as given, a bool per sample = every axis (as
    ``ins.filter.saturation_variance`` reads it), a bool per axis = its bit."""
    if saturated is None:
        return np.zeros(m, dtype=np.uint8)
    s = np.asarray(saturated)
    if s.shape[0] != m:
        raise InputError(f"push at sample {at}: saturated has {s.shape[0]} rows, the samples {m}")
    if s.ndim == 2:
        return (s[:, :6].astype(bool) * (1 << np.arange(min(s.shape[1], 6)))).sum(axis=1).astype(np.uint8)
    if s.dtype == bool:
        return np.where(s, np.uint8(0b111111), np.uint8(0))
    return s.astype(np.uint8)


class WholeRecordStance:
    """``StreamStance``'s interface for a detector that needs the whole record (``stream_refusal`` names why):
    the pushed samples are kept until ``finish``, which runs ``detect_stance`` once on all of them (with the
    record's median step, as on whole arrays) and returns the decisions cut as the samples were pushed. So the
    block passes run such a detector too, its stance being the whole-record one; its memory grows with the
    record (the samples, about 60 B each, until ``finish``).

    Parameters are ``StreamStance``'s (``rate_hz`` and ``noise_floor_log10`` unused: such a detector reads
    its period and its threshold off the record).
    """

    def __init__(self, settings, rate_hz: float, gravity: float = STANDARD_GRAVITY_MPS2, *,
                 noise_floor_log10: float | None = None, gyro_bias_b=None):
        self.settings = settings
        self.gravity = float(gravity)
        self._gyro_bias = None if gyro_bias_b is None else np.asarray(gyro_bias_b, dtype=np.float64).reshape(3)
        self._parts: list[tuple] = []
        self._n = 0
        self.result = None  # the detector's ``StanceResult`` after ``finish``
        self.noise_floor_log10 = None

    def push(self, t_s, acc_b, gyro_b, saturated=None) -> list[StanceChunk]:
        """Keep the samples (arguments as ``StreamStance.push``); nothing is decided before ``finish``."""
        t_s = np.asarray(t_s, dtype=np.float64).reshape(-1)
        m = t_s.shape[0]
        self._parts.append((t_s, np.asarray(acc_b, np.float64).reshape(m, 3),
                            np.asarray(gyro_b, np.float64).reshape(m, 3), _as_bits(saturated, m, self._n)))
        self._n += m
        return []

    def finish(self) -> list[StanceChunk]:
        """The stance of every sample pushed, one chunk per push."""
        from . import detect_stance

        if not self._parts:
            return []
        t, acc, gyro, bits = (np.concatenate(a) for a in zip(*self._parts))
        gyro_det = gyro if self._gyro_bias is None else gyro - self._gyro_bias
        res = detect_stance(t, acc, gyro_det, self.settings, self.gravity, saturated=bits)
        self.result = res
        stance, stat = np.asarray(res.stance, bool), np.asarray(res.statistic, np.float64)
        out, a = [], 0
        for part in self._parts:
            b = a + len(part[0])
            out.append(StanceChunk(a, *part[:3], stance[a:b], part[3], stat[a:b]))
            a = b
        self._parts = []
        return out


def stance_detector(settings, rate_hz: float, gravity: float = STANDARD_GRAVITY_MPS2, *,
                  noise_floor_log10: float | None = None, gyro_bias_b=None):
    """``StreamStance`` for a detector that streams, ``WholeRecordStance`` for one that cannot (the same
    arguments): what the block passes of ``process`` push their samples through."""
    cls = WholeRecordStance if stream_refusal(settings) else StreamStance
    return cls(settings, rate_hz, gravity, noise_floor_log10=noise_floor_log10, gyro_bias_b=gyro_bias_b)


def stream_refusal(settings) -> str | None:
    """Why ``StreamStance`` refuses these ``DetectorSettings`` (None: it runs them exactly)."""
    return _unsupported(settings.build())


def streamable_detectors() -> list[str]:
    """Names of the registered detectors ``StreamStance`` runs with their default settings."""
    from . import DETECTORS, DetectorSettings

    out = []
    for name in sorted(DETECTORS):
        if _unsupported(DetectorSettings(method=name).build()) is None:
            out.append(name)
    return out


__all__ = ["StanceChunk", "StreamStance", "WholeRecordStance", "stance_detector", "stream_refusal",
           "streamable_detectors"]
