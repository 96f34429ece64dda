"""Adaptive stance detector (the default): a per-stride threshold read off the recording's own SHOE
statistic, so that no per-recording tuning is needed across walking, running, stairs, 100-820 Hz and
sensors of very different noise.

Why: the SHOE threshold γ that minimises the position error varies over orders of magnitude between trials
of the same sensor, from slow walking to running [Wahlstrom2021], because a real foot never stops
completely: the stance "valley" of the statistic lies well above the sensor noise and rises with speed,
while the swing level rises too. A fixed γ is therefore either too strict when running (stances missed, the
path explodes) or too loose when walking (ZUPTs in early/late swing).

Rule (all in log10, so it is scale-free: σ's, units and sensor noise only shift L by a constant)::

    T_k   = SHOE statistic (shoe.py, squared form [Skog2010]) over a window of ``window_s`` seconds, of the
            samples' centred moving mean over ``average_s`` seconds
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
unless they are alone between two swings of ≥ ``isolation_s`` and last ≥ ``isolated_min_stance_s`` or
stand for a foot-flat (run + window) of ≥ ``isolated_min_flat_fraction`` of the local stride period
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
from bootnav.core.arrays import moving_mean, window_samples
from .base import FRACTION, NON_NEGATIVE, POSITIVE, StanceDetector, register
from .shoe import shoe_statistic


# change of gravity over a building's height (free-air gradient 3.086e-6 s⁻² [NIMA2000] × 100 m), m/s²
REST_DG_MPS2 = 3.086e-6 * 100.0


@register("adaptive")
@dataclass(kw_only=True)
class AdaptiveDetector(StanceDetector):
    """SHOE statistic with a per-stride threshold read off the recording itself (no tuning) [Skog2010]

    window_s: SHOE window, s; flat optimum over 0.025-0.05 s on the developer recordings.
    average_s: the statistic reads the samples' centred moving mean over this long, s (round(average_s / Δt)
        samples, none below 2), so that a foot at rest shows the noise of one bandwidth at every rate from
        1 / average_s up: white noise of density N has the per-sample variance N² / Δt, so without it the
        rest valley of log10 T falls by log10 k when a sensor delivers k-fold block means (a lower rate),
        while the swing peak does not, and α of the range puts the threshold (1 − α) log10 k decades lower:
        later onsets, earlier offsets and stances split at 100-400 Hz that are whole at 820 Hz. 0 = off.
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
    isolation_s, isolated_min_stance_s: a shorter stance run with no other stance within 0.4 s on both
        sides is a running foot-flat when it lasts ≥ 0.035 s (≈ an 80 ms foot-flat with the 50 ms window)
        or when it passes the share rule below.
    isolated_min_flat_fraction: 0.075 (0 = off); an isolated run is also kept when the foot-flat it stands
        for (run + ``window_s``) lasts at least this share of the local stride period (from the previous stance
        start when within ``span_s``, else ``span_s``). It lies between a quiet blip of a slow stride (a foot
        translating at 1 m/s on stairs: 6 % of a 1.04 s stride, pyshoe_vicon) and the shortest running
        foot-flats (8-11 %: pyshoe_vicon's missed ones, the simulator's 70 ms of 0.7 s; detected real ones
        13-17 %); real data is flat over 7.5-15 % (leave-one-dataset-out), and without it running strides get
        no ZUPT and an uncalibrated boot loses its height on a mission (docs/tuning-log.md 2026-12-02). In
        running without a foot-flat it takes the rolling foot's slowest moment as stance, as the fallback does.
    """

    BOUNDS: ClassVar[dict] = {"window_s": POSITIVE, "span_s": POSITIVE, "alpha": FRACTION, "noise_quantile": FRACTION,
                              "max_rate_radps": NON_NEGATIVE,
                              "isolated_min_flat_fraction": (lambda v: 0 <= v < 1, "in [0, 1)")}

    window_s: float = 0.05
    average_s: float = 0.0
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
    isolated_min_flat_fraction: float = 0.075

    def rest_floor(self) -> float:
        """The smallest T that still tells one rest from another: T = (δg/σ_a)², δg = ``REST_DG_MPS2``.

        The detector compares |f| with the gravity read at the initial rest (``calibration.stance_reference``);
        gravity itself changes with height by the free-air gradient, 3.086e-6 s⁻² [NIMA2000], i.e. by
        3.1e-4 m/s² over the 100 m a tall building spans. A rest that differs from the first by less is the same
        rest: without this floor a noise-free (simulated) start sets a noise floor of T ≈ 0 that a rest on
        another storey (T ≈ 1e-8) can never get under. Real MEMS noise (≥ 0.005 m/s², T ≥ 0.25) lies far above
        it, so it only matters for noise-free data.
        """
        return (REST_DG_MPS2 / self.sigma_acc_mps2) ** 2

    def average_samples(self, dt: float) -> int:
        """Samples of the moving mean the statistic reads (``average_s``; 1 = the samples as they are)."""
        return window_samples(self.average_s, dt, 1)

    def log_statistic(self, acc_b: np.ndarray, gyro_b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, int]:
        """(L = log10 T, T, SHOE window in samples) of finite samples every ``dt`` s (the class docstring's
        rule; ``detectors.stream.StreamStance`` runs the same)."""
        m = self.average_samples(dt)
        if m > 1:
            acc_b, gyro_b = moving_mean(acc_b, m), moving_mean(gyro_b, m)
        n = window_samples(self.window_s, dt, 3)
        T = shoe_statistic(acc_b, gyro_b, n, self.sigma_acc_mps2, self.sigma_gyro_radps, self.gravity_mps2)
        return np.log10(np.maximum(T, self.rest_floor())), T, n

    def classify(self, acc_b, gyro_b, dt, bad):
        from scipy.ndimage import maximum_filter1d, minimum_filter1d

        L, T, n = self.log_statistic(acc_b, gyro_b, dt)
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
            "average_samples": self.average_samples(dt),
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

    def drop_short_runs(self, stance, t_s, dt):
        return postprocess.remove_short_fragments(stance, t_s, self.min_stance_s, dt,
                                                  isolated_min_s=self.isolated_min_stance_s,
                                                  isolation_s=self.isolation_s,
                                                  window_s=window_samples(self.window_s, dt, 3) * dt,
                                                  min_flat_fraction=self.isolated_min_flat_fraction,
                                                  max_period_s=self.span_s)
