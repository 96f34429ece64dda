"""Stance detectors as configured objects: the base class, the result type and the registry.

A detector is a small dataclass configured by physical parameters (windows in seconds, thresholds in the
units of its statistic, noise σ's, gravity) with one entry method, ``detect(acc_b, gyro_b, t_s)``, after
the pattern of gaitmap's ``NormZuptDetector`` / ``ShoeZuptDetector`` [Kuderle2024]. Subclasses supply the
statistic and the rule that turns it into a raw stance mask (``classify``); the base class does what every
detector shares, once: NaN and excluded-sample handling and the post-processing of the mask (minimum swing,
saturation guard, minimum stance).

``@register("name")`` enters a class into ``DETECTORS`` (name -> class, ``bootnav.core.registry``); the name is the ``method`` of
``DetectorSettings`` and the choice of ``bootnav process --detector``, the first line of the class
docstring its one-line description (``bootnav process --list-detectors``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Callable, ClassVar

import numpy as np

from bootnav.core.registry import Registry, description
from bootnav.core.runs import runs
from bootnav.core.conventions import STANDARD_GRAVITY_MPS2

from . import postprocess
from bootnav.core.arrays import as_imu_arrays, dilate, median_dt, rows_finite, window_samples


@dataclass
class StanceResult:
    """Output of a stance detector.

    stance: bool (N,), True = foot at rest (zero velocity).
    statistic: (N,) the detector's statistic, in its own units (stance where it is below the threshold).
    threshold: the threshold in the statistic's units (for a per-sample threshold, a representative value).
    method: registry name of the detector.
    info: what the detector used (window in samples, σ's, sample interval, counts), saved with the results.
    """

    stance: np.ndarray
    statistic: np.ndarray
    threshold: float
    method: str
    info: dict = field(default_factory=dict)

    @property
    def stance_fraction(self) -> float:
        return float(self.stance.mean()) if self.stance.size else 0.0

    def phases(self) -> tuple[np.ndarray, np.ndarray]:
        """(starts, stops) sample indices of the stance phases (stops exclusive)."""
        return runs(self.stance)


#: name -> class of every stance detector (``bootnav.core.registry``: the pattern of the PDR step detectors and
#: step-length models too)
DETECTORS = Registry("stance detector")
register = DETECTORS.register

# physical ranges of parameters (``StanceDetector.BOUNDS``): (test, what the message says)
POSITIVE: tuple[Callable[[float], bool], str] = (lambda v: v > 0, "> 0")
NON_NEGATIVE: tuple[Callable[[float], bool], str] = (lambda v: v >= 0, ">= 0")
FRACTION: tuple[Callable[[float], bool], str] = (lambda v: 0 < v < 1, "in (0, 1)")
AT_LEAST_ONE: tuple[Callable[[float], bool], str] = (lambda v: v >= 1, ">= 1")


def detector_class(name: str) -> type["StanceDetector"]:
    """The registered class of ``name``; ValueError listing the registered names for an unknown one."""
    return DETECTORS.get_class(name)


@dataclass(kw_only=True)
class StanceDetector:
    """Base of the stance detectors (not registered itself).

    gravity_mps2: local gravity g (m/s²), the specific force of a foot at rest.
    min_swing_s: swing gaps shorter than this between two stance runs are filled (a foot cannot complete a
        swing that fast: they are impacts inside the stance).
    min_stance_s: stance runs shorter than this are dropped (one quiet sample in mid-swing must not zero the
        velocity).
    saturation_guard_s: excluded (saturated, non-finite) samples are grown by this much, and at least by the
        detector window, on each side before they are removed from the stance: a window that holds a
        clipped sample has a wrong statistic.
    """

    name: ClassVar[str] = ""
    #: parameter -> its physical range; merged along the class hierarchy. Without an entry, a ``sigma_*``
    #: must be > 0 and a duration ``*_s`` >= 0 (``check``).
    BOUNDS: ClassVar[dict] = {"gravity_mps2": POSITIVE}

    gravity_mps2: float = STANDARD_GRAVITY_MPS2
    min_swing_s: float = 0.0
    min_stance_s: float = 0.0
    saturation_guard_s: float = 0.02

    @classmethod
    def bounds(cls, name: str):
        """(test, text) of parameter ``name``'s range, or None when any finite value is physical."""
        for klass in cls.__mro__:
            if name in vars(klass).get("BOUNDS", {}):
                return vars(klass)["BOUNDS"][name]
        if name.startswith("sigma_"):
            return POSITIVE
        return NON_NEGATIVE if name.endswith("_s") else None

    def check(self) -> None:
        """Raise ValueError naming the first parameter outside its physical range (``BOUNDS``)."""
        for f in fields(self):
            value = getattr(self, f.name)
            rule = self.bounds(f.name)
            if rule is None or value is None or isinstance(value, bool) or not isinstance(value, (int, float)):
                continue
            test, text = rule
            if not test(value):
                raise ValueError(f"{f.name} must be {text}, got {value!r}")

    @classmethod
    def description(cls) -> str:
        """One line for listings: the first line of the class docstring."""
        return description(cls)

    def detect(self, acc_b, gyro_b, t_s, *, excluded=None) -> StanceResult:
        """Stance mask of one recording.

        Parameters
        ----------
        acc_b : array_like, shape (N, 3)
            Specific force in the body (sensor) frame, m/s², gravity included.
        gyro_b : array_like, shape (N, 3)
            Angular rate in the body frame, rad/s.
        t_s : array_like, shape (N,)
            Sample times, s; windows in seconds are converted with the median positive interval.
        excluded : array_like of bool, shape (N,), optional
            Samples that must never be stance (e.g. saturated). Non-finite samples are added.

        Returns
        -------
        StanceResult
            Mask after post-processing, the statistic, the threshold and ``info`` (``dt_s``,
            ``n_stance_phases`` and the detector's own entries).
        """
        t_s, acc_b, gyro_b = as_imu_arrays(t_s, acc_b, gyro_b)
        dt = median_dt(t_s)
        bad = np.zeros(t_s.shape[0], dtype=bool) if excluded is None else np.asarray(excluded, dtype=bool)
        bad = bad | ~rows_finite(acc_b) | ~rows_finite(gyro_b)
        if bad.any():  # NaNs must not poison the moving sums; their samples are excluded below
            acc_b = np.where(np.isfinite(acc_b), acc_b, 0.0)
            gyro_b = np.where(np.isfinite(gyro_b), gyro_b, 0.0)
        raw, stat, thr, n_window, info = self.classify(acc_b, gyro_b, dt, bad)
        stance = postprocess.clean_stance(raw, t_s, dt, min_swing_s=self.min_swing_s)
        # after the gap filling, so that it can never re-admit an excluded sample
        stance &= ~dilate(bad, max(n_window, window_samples(self.saturation_guard_s, dt, 0)))
        stance = self.drop_short_runs(stance, t_s, dt)
        info = {"dt_s": dt, **info, "n_stance_phases": int(runs(stance)[0].size)}
        return StanceResult(stance=stance, statistic=stat, threshold=float(thr), method=self.name, info=info)

    def classify(self, acc_b: np.ndarray, gyro_b: np.ndarray, dt: float, bad: np.ndarray):
        """Return (raw stance mask, statistic, threshold, window in samples, info) on finite data."""
        raise NotImplementedError

    def drop_short_runs(self, stance: np.ndarray, t_s: np.ndarray, dt: float) -> np.ndarray:
        return postprocess.remove_short_runs(stance, t_s, self.min_stance_s, dt)


@dataclass(kw_only=True)
class ThresholdDetector(StanceDetector):
    """Base of the fixed-threshold detectors: stance where the statistic T < γ.

    threshold: γ in the statistic's units; None -> the class default ``DEFAULT_THRESHOLD``.
    hysteresis_ratio: > 1 enables two-threshold hysteresis: a stance run is a T < ratio·γ run that reaches
        T < γ somewhere (suppresses chatter at γ [Wahlstrom2021]); 1 = off.
    """

    DEFAULT_THRESHOLD: ClassVar[float]
    BOUNDS: ClassVar[dict] = {"threshold": POSITIVE, "hysteresis_ratio": AT_LEAST_ONE}

    threshold: float | None = None
    hysteresis_ratio: float = 1.0

    def __post_init__(self):
        if self.threshold is None:
            self.threshold = self.default_threshold()

    def default_threshold(self) -> float:
        return self.DEFAULT_THRESHOLD

    def statistic(self, acc_b: np.ndarray, gyro_b: np.ndarray, dt: float) -> np.ndarray:
        """The detector statistic T (N,) of finite data sampled every ``dt`` seconds."""
        raise NotImplementedError

    def window(self, dt: float) -> int:
        """Window of the statistic in samples (1: sample by sample)."""
        return 1

    def _info(self) -> dict:
        return {}

    def classify(self, acc_b, gyro_b, dt, bad):
        stat = self.statistic(acc_b, gyro_b, dt)
        thr = float(self.threshold)
        if self.hysteresis_ratio > 1.0:
            raw = postprocess.hysteresis(stat, thr, thr * self.hysteresis_ratio)
        else:
            raw = stat < thr
        n = self.window(dt)
        return raw, stat, thr, n, {"window_samples": n, "window_s": n * dt, **self._info()}


@dataclass(kw_only=True)
class WindowedDetector(ThresholdDetector):
    """Base of the detectors whose statistic is a mean over a centred window.

    window_s: window length in seconds (pyshoe: 5 samples at 200 Hz = 0.025 s [Wagstaff2017]), converted
        with the recording's median sample interval, at least 3 samples.
    window_samples: the window in samples, overriding ``window_s`` (to reproduce a published setting
        literally, e.g. OpenShoe's 3 samples at 820 Hz [Nilsson2012]).
    """

    BOUNDS: ClassVar[dict] = {"window_s": POSITIVE, "window_samples": POSITIVE}

    window_s: float = 0.025
    window_samples: int | None = None

    def window(self, dt: float) -> int:
        return self.window_samples if self.window_samples else window_samples(self.window_s, dt, 3)
