"""Stance (zero-velocity) detectors for a foot-mounted IMU.

One module per detector (equations and references in each docstring):
``shoe`` (SHOE/GLRT, seed-004 eq. 2, squared form or the paper's literal form), ``ared``, ``mv``, ``mag``
(Skog et al. 2010), ``paper_accmag`` (the paper's empirical acceleration threshold), ``xio`` (x-io
filtered magnitude), ``adaptive`` (the default: a per-stride threshold read off the recording itself, no tuning), ``postprocess``
(hysteresis, minimum stance / swing durations).

Entry point: ``detect_stance(t_s, acc_b, gyro_b, settings, gravity, saturated=None) -> StanceResult``.
Windows are given in seconds and converted with the recording's median sample interval. Saturated
samples (the recording's bitmask and/or automatically detected clipping plateaus) never count as stance.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from . import postprocess
from ._common import clipped_samples, dilate, median_dt, saturation_mask, window_samples

METHODS = ("adaptive", "shoe", "ared", "mv", "mag", "paper_accmag", "xio")

# Default thresholds of the fixed-threshold methods, in the units of each statistic with the default
# σ's (σ_a = 0.01 m/s², σ_ω = 0.1 °/s) and window (0.025 s): the best single value per method over all
# developer recordings (benchmarks/tune_detectors.py; geometric mean of the per-dataset error ratio).
# "shoe_literal" is the paper's printed form (literal_paper_form=True). "xio" keeps x-io's published 0.05 g.
# pyshoe's published G = 8.5e7 belongs to σ_a = 0.00098 m/s², σ_ω = 8.7266e-5 rad/s (0.005 °/s): with those
# σ's it reproduces the pyshoe anchors of issue 5 (e.g. armse_2d 0.39 m on pyshoe_vicon).
DEFAULT_THRESHOLDS = {"shoe": 3e5, "shoe_literal": 1e3, "ared": 3e5, "mv": 3e2, "mag": 1e2,
                      "paper_accmag": 0.3, "xio": 0.05}


@dataclass
class DetectorSettings:
    """Every tunable of stance detection (saved with the results).

    method: "adaptive" (default) | "shoe" | "ared" | "mv" | "mag" | "paper_accmag" | "xio".
    window_s: detector window in seconds (pyshoe: 5 samples at 200 Hz = 0.025 s); converted with the
        recording's median sample interval, at least 3 samples. ``window_samples`` overrides it (to
        reproduce a published setting literally, e.g. OpenShoe's 3 samples at 820 Hz).
    sigma_acc_mps2, sigma_gyro_radps: σ_a, σ_ω of SHOE/ARED/MV/MAG (OpenShoe/pyshoe: 0.01 m/s², 0.1 °/s).
    threshold: γ for the fixed-threshold methods (None -> DEFAULT_THRESHOLDS[method]). For "xio" in g,
        for "paper_accmag" in m/s². Ignored by "adaptive".
    literal_paper_form: SHOE only: the paper's printed form (un-squared σ and acceleration norm).
    hysteresis_ratio: > 1 enables two-threshold hysteresis: stance runs are T < ratio·γ runs that reach
        T < γ somewhere (1 = off).
    min_stance_s: stance runs shorter than this are dropped.
    min_swing_s: swing gaps shorter than this (between two stance runs) are filled.
    detect_clipping: also treat per-axis full-scale plateaus as saturated (files without a mask).
    saturation_guard_s: saturated samples are grown by this much on each side before being excluded.
    adaptive_*: window, span, α, floor δ (decades), noise quantile, min stance / swing and the rate
        ceiling of the adaptive rule; see ``adaptive.py``.
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
    # a shorter stance run is kept when it is alone between two swings of >= adaptive_isolation_s
    # (the brief foot-flat of a running stride), as long as it lasts adaptive_isolated_min_stance_s
    adaptive_isolated_min_stance_s: float = 0.035
    adaptive_isolation_s: float = 0.4
    adaptive_min_swing_s: float = 0.1
    adaptive_max_rate_radps: float = 4.0

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"unknown stance detector {self.method!r}; choose one of {', '.join(METHODS)}")
        for name in ("window_s", "sigma_acc_mps2", "sigma_gyro_radps", "adaptive_window_s", "adaptive_span_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"DetectorSettings.{name} must be > 0, got {getattr(self, name)!r}")
        if not 0.0 < self.adaptive_alpha < 1.0:
            raise ValueError(f"DetectorSettings.adaptive_alpha must be in (0, 1), got {self.adaptive_alpha!r}")
        if self.threshold is not None and not self.threshold > 0:
            raise ValueError(f"DetectorSettings.threshold must be > 0 (or None for the default), got {self.threshold!r}")

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class StanceResult:
    stance: np.ndarray  # bool (N,), True = foot at rest (zero velocity)
    statistic: np.ndarray  # (N,) the detector statistic (stance where statistic < threshold)
    threshold: float
    method: str
    info: dict = field(default_factory=dict)

    @property
    def stance_fraction(self) -> float:
        return float(self.stance.mean()) if self.stance.size else 0.0

    def phases(self) -> tuple[np.ndarray, np.ndarray]:
        """(starts, stops) sample indices of the stance phases (stops exclusive)."""
        return postprocess.runs(self.stance)


def _statistic(method: str, acc_b, gyro_b, n: int, dt: float, s: DetectorSettings, gravity: float):
    if method == "shoe":
        from .shoe import shoe_statistic

        return shoe_statistic(acc_b, gyro_b, n, s.sigma_acc_mps2, s.sigma_gyro_radps, gravity,
                              literal=s.literal_paper_form)
    if method == "ared":
        from .ared import ared_statistic

        return ared_statistic(gyro_b, n, s.sigma_gyro_radps)
    if method == "mv":
        from .mv import mv_statistic

        return mv_statistic(acc_b, n, s.sigma_acc_mps2)
    if method == "mag":
        from .mag import mag_statistic

        return mag_statistic(acc_b, n, s.sigma_acc_mps2, gravity)
    if method == "paper_accmag":
        from .paper_accmag import paper_accmag_statistic

        return paper_accmag_statistic(acc_b, gravity)
    if method == "xio":
        from .xio import xio_statistic

        return xio_statistic(acc_b, dt, gravity)
    raise ValueError(method)


def detect_stance(t_s, acc_b, gyro_b, settings: DetectorSettings | None = None, gravity: float = 9.80665, *,
                  saturated=None) -> StanceResult:
    """Stance mask of one recording. ``saturated``: the recording's bitmask / bool mask (optional)."""
    s = settings or DetectorSettings()
    t_s = np.asarray(t_s, dtype=np.float64)
    acc_b = np.asarray(acc_b, dtype=np.float64)
    gyro_b = np.asarray(gyro_b, dtype=np.float64)
    n_samples = t_s.shape[0]
    if acc_b.shape != (n_samples, 3) or gyro_b.shape != (n_samples, 3):
        raise ValueError(f"expected acc_b and gyro_b of shape ({n_samples}, 3); got {acc_b.shape}, {gyro_b.shape}")
    dt = median_dt(t_s)
    sat = saturation_mask(saturated, n_samples)
    if s.detect_clipping:
        sat = sat | clipped_samples(acc_b) | clipped_samples(gyro_b)
    bad = sat | ~np.all(np.isfinite(acc_b), axis=1) | ~np.all(np.isfinite(gyro_b), axis=1)
    if bad.any():  # NaNs must not poison the moving sums; their samples are excluded below
        acc_b = np.where(np.isfinite(acc_b), acc_b, 0.0)
        gyro_b = np.where(np.isfinite(gyro_b), gyro_b, 0.0)
    info: dict = {"dt_s": dt, "n_saturated": int(sat.sum())}
    if s.method == "adaptive":
        from .adaptive import adaptive_stance

        stance, stat, thr, ainfo = adaptive_stance(t_s, acc_b, gyro_b, dt, s, gravity, bad)
        info.update(ainfo)
    else:
        n = s.window_samples if s.window_samples else window_samples(s.window_s, dt, 3)
        if s.method in ("paper_accmag", "xio"):
            n = 1
        stat = _statistic(s.method, acc_b, gyro_b, n, dt, s, gravity)
        key = "shoe_literal" if (s.method == "shoe" and s.literal_paper_form) else s.method
        thr = float(s.threshold if s.threshold is not None else DEFAULT_THRESHOLDS[key])
        if s.hysteresis_ratio > 1.0:
            stance = postprocess.hysteresis(stat, thr, thr * s.hysteresis_ratio)
        else:
            stance = stat < thr
        info.update(window_samples=n, window_s=n * dt)
        if s.method in ("shoe", "ared", "mv", "mag"):
            info.update(sigma_acc_mps2=s.sigma_acc_mps2, sigma_gyro_radps=s.sigma_gyro_radps,
                        form="literal_paper" if (s.method == "shoe" and s.literal_paper_form) else "squared")
        stance = postprocess.clean_stance(stance, t_s, dt, min_swing_s=s.min_swing_s, min_stance_s=s.min_stance_s)
        # after cleaning, so that gap filling can never re-admit a saturated sample
        stance &= ~dilate(bad, max(n, window_samples(s.saturation_guard_s, dt, 0)))
        stance = postprocess.remove_short_runs(stance, t_s, s.min_stance_s, dt)
    info["n_stance_phases"] = int(postprocess.runs(stance)[0].size)
    return StanceResult(stance=stance, statistic=stat, threshold=float(thr), method=s.method, info=info)
