"""Stance (zero-velocity) detectors for a foot-mounted IMU.

Each detector is a configured object with one entry method, ``detect(acc_b, gyro_b, t_s) ->
StanceResult`` (``base.StanceDetector``), in a module of its own with its equations and references, and
registered by name in ``DETECTORS``: ``adaptive`` (the default: a per-stride threshold read off the
recording itself, no tuning), ``shoe`` (SHOE/GLRT [Skog2010], the source paper's eq. 2 [Heidari2019], squared
or the paper's printed form), ``shoe-literal`` (the printed form as the paper used it), ``ared``, ``mv``,
``mag`` [Skog2010], ``paper_accmag`` (the paper's empirical acceleration threshold), ``xio`` (x-io filtered
magnitude [Madgwick]). ``postprocess`` holds the mask post-processing they share (hysteresis, minimum
stance / swing durations).

Entry point of the pipeline: ``detect_stance(t_s, acc_b, gyro_b, settings, gravity, saturated=None) ->
StanceResult``; it builds the detector named by ``DetectorSettings.method`` (the saved settings) and
excludes saturated samples (the recording's bitmask and/or automatically detected clipping plateaus).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

from . import postprocess
from ._common import as_imu_arrays, clipped_samples, saturation_mask
from .base import DETECTORS, StanceDetector, StanceResult, detector_class, register

from . import adaptive, ared, mag, mv, paper_accmag, shoe, xio  # noqa: F401  (importing them fills DETECTORS)

__all__ = ["DETECTORS", "DetectorSettings", "StanceDetector", "StanceResult", "detect_stance", "detector_class",
           "postprocess", "register"]


@dataclass
class DetectorSettings:
    """Every tunable of stance detection, as saved with the results; ``build`` makes the detector.

    method: registry name of the detector (``DETECTORS``; ``bootnav process --list-detectors``), default
        "adaptive".
    window_s: window of SHOE/ARED/MV/MAG in seconds (pyshoe: 5 samples at 200 Hz = 0.025 s [Wagstaff2017]);
        converted with the recording's median sample interval, at least 3 samples. ``window_samples``
        overrides it (to reproduce a published setting literally, e.g. OpenShoe's 3 samples at 820 Hz).
    sigma_acc_mps2, sigma_gyro_radps: σ_a, σ_ω of SHOE/ARED/MV/MAG and of the adaptive rule's SHOE
        statistic (OpenShoe/pyshoe: 0.01 m/s², 0.1 °/s [Nilsson2012]).
    threshold: γ of the fixed-threshold detectors in the units of their statistic (dimensionless for
        SHOE/ARED/MV/MAG, m/s² for "paper_accmag", g for "xio"); None -> the detector's default (its class
        docstring; None for "shoe-literal" and "paper_accmag" means read off the recording). Ignored by
        "adaptive".
    literal_paper_form: SHOE only: the paper's printed form (un-squared σ and acceleration norm).
    hysteresis_ratio: > 1 enables two-threshold hysteresis: stance runs are T < ratio·γ runs that reach
        T < γ somewhere (1 = off).
    min_stance_s: stance runs shorter than this are dropped.
    min_swing_s: swing gaps shorter than this (between two stance runs) are filled.
    detect_clipping: also treat per-axis full-scale plateaus as saturated (files without a mask).
    saturation_guard_s: saturated samples are grown by this much (and at least by the detector window) on
        each side before being excluded.
    adaptive_*: the parameters of the adaptive detector without the prefix (window, span, α, floor δ in
        decades, noise quantile, minimum stance / swing, isolated stance, rate ceiling); see
        ``adaptive.AdaptiveDetector``, which takes its other parameters from the unprefixed fields.
    shoe_literal_*, paper_accmag_*, xio_*: minimum stance / swing of the source paper's detectors and of
        x-io's (their class docstrings; "-" in a method name reads as "_").
    """

    method: str = "adaptive"
    window_s: float = 0.025
    window_samples: int | None = None
    sigma_acc_mps2: float = 0.01
    sigma_gyro_radps: float = math.radians(0.1)
    threshold: float | None = None
    literal_paper_form: bool = False
    hysteresis_ratio: float = 1.0
    min_stance_s: float = 0.0
    min_swing_s: float = 0.0
    detect_clipping: bool = True
    saturation_guard_s: float = 0.02
    adaptive_window_s: float = 0.05
    adaptive_span_s: float = 1.5
    adaptive_alpha: float = 0.3
    adaptive_floor_decades: float = 1.0
    adaptive_noise_quantile: float = 0.05
    adaptive_min_stance_s: float = 0.05
    adaptive_isolated_min_stance_s: float = 0.035
    adaptive_isolation_s: float = 0.4
    adaptive_min_swing_s: float = 0.1
    adaptive_max_rate_radps: float = 4.0
    shoe_literal_min_stance_s: float = 0.05
    shoe_literal_min_swing_s: float = 0.2
    paper_accmag_min_stance_s: float = 0.1
    paper_accmag_min_swing_s: float = 0.2
    xio_min_stance_s: float = 0.05
    xio_min_swing_s: float = 0.2

    def __post_init__(self):
        detector_class(self.method)  # unknown name: ValueError listing the registered ones
        for name in ("window_s", "sigma_acc_mps2", "sigma_gyro_radps", "adaptive_window_s", "adaptive_span_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"DetectorSettings.{name} must be > 0, got {getattr(self, name)!r}")
        if not 0.0 < self.adaptive_alpha < 1.0:
            raise ValueError(f"DetectorSettings.adaptive_alpha must be in (0, 1), got {self.adaptive_alpha!r}")
        if self.threshold is not None and not self.threshold > 0:
            raise ValueError(f"DetectorSettings.threshold must be > 0 (or None for the default), got {self.threshold!r}")

    def to_dict(self) -> dict:
        return asdict(self)

    def build(self, gravity: float = 9.80665) -> StanceDetector:
        """The configured detector of ``method``.

        Each parameter of the detector class is read from the field ``<method>_<parameter>`` if there is
        one, else from the field ``<parameter>``; parameters without a field keep the class default.

        Parameters
        ----------
        gravity : float
            Local gravity, m/s².

        Returns
        -------
        StanceDetector
            An instance of ``DETECTORS[method]``.
        """
        cls = detector_class(self.method)
        saved = {f.name for f in fields(self)}
        params: dict = {"gravity_mps2": float(gravity)}
        for f in fields(cls):
            for key in (f"{self.method.replace('-', '_')}_{f.name}", f.name):
                if key in saved:
                    params[f.name] = getattr(self, key)
                    break
        return cls(**params)


def detect_stance(t_s, acc_b, gyro_b, settings: DetectorSettings | None = None, gravity: float = 9.80665, *,
                  saturated=None) -> StanceResult:
    """Stance mask of one recording with the detector the settings name.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Sample times, s.
    acc_b, gyro_b : array_like, shape (N, 3)
        Specific force (m/s², gravity included) and angular rate (rad/s) in the body frame.
    settings : DetectorSettings, optional
        Detector and its parameters (default: ``DetectorSettings()``, the adaptive detector).
    gravity : float
        Local gravity, m/s².
    saturated : array_like, shape (N,) or (N, k), optional
        The recording's saturation bitmask or bool mask; with ``settings.detect_clipping`` the full-scale
        plateaus found in the data are added. Saturated samples are never stance.

    Returns
    -------
    StanceResult
        Stance mask, statistic, threshold, method and ``info`` (with ``n_saturated``).
    """
    s = settings or DetectorSettings()
    t_s, acc_b, gyro_b = as_imu_arrays(t_s, acc_b, gyro_b)
    sat = saturation_mask(saturated, t_s.shape[0])
    if s.detect_clipping:
        sat = sat | clipped_samples(acc_b) | clipped_samples(gyro_b)
    result = s.build(gravity).detect(acc_b, gyro_b, t_s, excluded=sat)
    result.info["n_saturated"] = int(sat.sum())
    return result
