"""Adaptive stance detector (the default): a per-stride threshold read off the recording's own SHOE
statistic, so that no per-recording tuning is needed across walking, running, stairs, 100-820 Hz and
sensors of very different noise.

Why: the SHOE threshold γ that minimises the position error varies over orders of magnitude between trials
of the same sensor, from slow walking to running [Wahlstrom2021], because a real foot never stops
completely: the stance "valley" of the statistic lies well above the sensor noise and rises with speed,
while the swing level rises too. A fixed γ is therefore either too strict when running (stances missed, the
path explodes) or too loose when walking (ZUPTs in early/late swing).

Rule (all in log10, so it is scale-free: σ's, units and sensor noise only shift L by a constant)::

    T_k   = SHOE statistic (shoe.py, squared form [Skog2010]) over a window of ``window_s`` seconds
    L_k   = log10 T_k
    M_k   = min  of L over the centred span ``span_s`` (≥ one stride, so it holds one valley)
    P_k   = max  of L over the same span               (the swing peak next to it)
    F     = ``noise_quantile`` quantile of L over the recording (the noise floor: foot at rest)
    γ_k   = min( max( M_k + α (P_k − M_k),  F + δ ),  C )    α = ``alpha``, δ = ``floor_decades``
    C     = log10(ω_max² / σ_ω²)   (ω_max = ``max_rate_radps``)
    stance_k ⇔ L_k < γ_k

The first term puts the threshold a fixed fraction α of the way up from the valley floor to the swing peak
of the same stride: a local, per-stride version of a threshold between the two modes of a histogram
[Otsu1979]. The second keeps long rests whole, where the local range P − M is only noise. The ceiling C
refuses stance in a window as energetic as a foot turning at ω_max: a safety net that keeps a recording
without any rest (a sensor shaken in the hand) from getting invented stances. Then the shared
post-processing (``base.StanceDetector.detect``): swing gaps < ``min_swing_s`` are filled, excluded
(saturated) samples grown by the window are never stance, and stance runs < ``min_stance_s`` are dropped
unless they are alone between two swings of ≥ ``isolation_s`` and last ≥ ``isolated_min_stance_s``
(``postprocess.remove_short_fragments``): the brief foot-flat of a running stride.

The defaults were chosen on all developer recordings at once (pre-LODO);
the figures, the sensitivity of each parameter and the variants tried and not kept are in
docs/tuning-log.md. α is the sensitive one: a larger α turns high stance valleys (near-running) into
stance at a rotating foot, so a change of α or of the statistic must be checked per trial, not on set means.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from . import postprocess
from bootnav.core.arrays import window_samples
from .base import FRACTION, NON_NEGATIVE, POSITIVE, StanceDetector, register
from .shoe import shoe_statistic


@register("adaptive")
@dataclass(kw_only=True)
class AdaptiveDetector(StanceDetector):
    """SHOE statistic with a per-stride threshold read off the recording itself (no tuning) [Skog2010]

    window_s: SHOE window, s; flat optimum over 0.025-0.05 s on the developer recordings.
    sigma_acc_mps2, sigma_gyro_radps: σ_a, σ_ω of SHOE (0.01 m/s², 0.1 °/s [Nilsson2012]); they only shift
        log10 T by a constant, except against the ceiling C.
    span_s: span of the valley / peak search, s; at least one stride, so that it holds one valley.
    alpha: α, the fraction of the valley-to-peak range (in log10 T) below which a sample is stance.
    floor_decades: δ, decades above the recording's noise floor that always count as stance (long rests).
    noise_quantile: quantile of log10 T taken as the noise floor: the quietest 5 % of a walk is a foot at rest.
    max_rate_radps: ω_max of the ceiling, rad/s; 4 rad/s lies above the stance valleys of every developer
        recording, running included; 0 = no ceiling.
    min_swing_s: 0.1 s; shorter swing gaps are impacts inside the stance.
    min_stance_s: 0.05 s; shorter stance runs next to another stance are heel / toe-roll fragments.
    isolated_min_stance_s, isolation_s: a stance run of at least 0.035 s with no other stance within
        0.4 s on both sides is kept: the 45-70 ms foot-flat of a running stride.
    """

    BOUNDS: ClassVar[dict] = {"window_s": POSITIVE, "span_s": POSITIVE, "alpha": FRACTION, "noise_quantile": FRACTION,
                              "max_rate_radps": NON_NEGATIVE}

    window_s: float = 0.05
    sigma_acc_mps2: float = 0.01
    sigma_gyro_radps: float = math.radians(0.1)
    span_s: float = 1.5
    alpha: float = 0.3
    floor_decades: float = 1.0
    noise_quantile: float = 0.05
    max_rate_radps: float = 4.0
    min_swing_s: float = 0.1
    min_stance_s: float = 0.05
    isolated_min_stance_s: float = 0.035
    isolation_s: float = 0.4

    def _classify(self, acc_b, gyro_b, dt, bad):
        from scipy.ndimage import maximum_filter1d, minimum_filter1d

        n = window_samples(self.window_s, dt, 3)
        T = shoe_statistic(acc_b, gyro_b, n, self.sigma_acc_mps2, self.sigma_gyro_radps, self.gravity_mps2)
        L = np.log10(np.maximum(T, 1e-300))
        span = window_samples(self.span_s, dt, 3)
        valley = minimum_filter1d(L, span, mode="nearest")
        peak = maximum_filter1d(L, span, mode="nearest")
        # absolute ceiling: never stance where T exceeds that of a foot turning at max_rate_radps
        ceiling = np.log10(self.max_rate_radps**2 / self.sigma_gyro_radps**2) if self.max_rate_radps else np.inf
        usable = L[~bad] if (~bad).any() else L
        floor = float(np.quantile(usable, self.noise_quantile))
        gamma = np.maximum(valley + self.alpha * (peak - valley), floor + self.floor_decades)
        if self.max_rate_radps:
            gamma = np.minimum(gamma, ceiling)
        info = {
            "window_samples": n,
            "span_samples": span,
            "sigma_acc_mps2": self.sigma_acc_mps2,
            "sigma_gyro_radps": self.sigma_gyro_radps,
            "noise_floor_log10": floor,
            "alpha": self.alpha,
            "floor_decades": self.floor_decades,
            "ceiling_log10": float(ceiling),
            "threshold_log10_per_sample": gamma,
            "threshold_log10_range": (float(np.min(gamma)), float(np.max(gamma))),
        }
        return L < gamma, T, float(10.0 ** np.median(gamma)), n, info

    def _drop_short_runs(self, stance, t_s, dt):
        return postprocess.remove_short_fragments(stance, t_s, self.min_stance_s, dt,
                                                  isolated_min_s=self.isolated_min_stance_s,
                                                  isolation_s=self.isolation_s)
