"""Is there walking motion at all? A bout of detected steps is kept only when the acceleration in the walking band
stands clearly above what the sensor's own noise puts there.

Any detector finds "steps" in noise: band-passed white noise has peaks at a random, walking-like rhythm. What noise
cannot do is put more power into the walking band than its density allows. So:

1. Noise floor sigma_n (m/s^2 per sample) of the magnitude a = |f_b| at the recording's rate fs, from its part
   above F_HIGH = 6 Hz (twice the band's top: the walking band's first harmonics stay below it): white noise
   puts the fraction 1 - 2 F_HIGH / fs of its power there, so sigma_n = std(HP(a)) / sqrt(1 - 2 F_HIGH / fs),
   taken in the quietest 1-s windows (10th percentile over the windows, as the stance detectors take their
   floor from the quietest part of the recording). Below fs = 3 F_HIGH the two cannot be told apart and the
   gate is off.
2. White noise of std sigma_n spreads its power evenly over 0..fs/2, so the walking band B = [0.3, 3.0] Hz
   (the robust detector's band, walking cadence <= 3 Hz [NKUA2009, ch. 2]) holds
   sigma_band = sigma_n sqrt(2 (3.0 - 0.3) / fs).
3. A bout (steps closer than ``gap_s``) is walking when the RMS of the band-passed magnitude over its span is
   at least ``SNR_MIN`` x sigma_band. The RMS of band-limited noise measured over T seconds scatters by about
   1 / sqrt(2 B T) (0.3 for the shortest bout of 4 steps, ~2 s): a ratio of 3 is ~7 such deviations above
   noise, while walking at the waist or lower back gives peaks of 1-5 m/s^2 (the ~0.1 g minimum of slow
   walking is 1 m/s^2) against a band noise of a few 0.01 m/s^2 for a MEMS accelerometer.

This gate only removes bouts; it never adds or moves a step.
"""

from __future__ import annotations

import numpy as np

from bootnav.postproc.pdr.signals import butter_filter, magnitude, nominal_rate_hz, resample_uniform

WALK_BAND_HZ = (0.3, 3.0)
F_HIGH_HZ = 6.0  # noise-floor band starts here (module docstring)
SNR_MIN = 3.0  # band RMS / noise-predicted band RMS (derivation in the module docstring)


def noise_floor(t_s: np.ndarray, acc_b: np.ndarray) -> tuple[float, float, np.ndarray, np.ndarray]:
    """(sigma_n in m/s^2, fs in Hz, uniform time grid, band-passed magnitude on it) of a recording; sigma_n is
    NaN (no verdict) below fs = 3 F_HIGH_HZ or for fewer than 4 s."""
    fs = nominal_rate_hz(t_s)
    tg, a = resample_uniform(t_s, magnitude(acc_b), fs)
    if fs < 3 * F_HIGH_HZ or a.size < 4 * max(int(round(fs)), 5):
        return float("nan"), fs, tg, a
    d = butter_filter(a, fs, F_HIGH_HZ, btype="high") / np.sqrt(1.0 - 2.0 * F_HIGH_HZ / fs)
    n = max(int(round(fs)), 5)
    k = d.size // n
    sigma = float(np.percentile(d[: k * n].reshape(k, n).std(axis=1), 10)) if k else float(np.std(d))
    band = butter_filter(a, fs, WALK_BAND_HZ, btype="bandpass")
    return sigma, fs, tg, band


def walking_bouts(t_s, acc_b, t_steps: np.ndarray, gap_s: float = 1.6) -> tuple[np.ndarray, str | None]:
    """Keep-mask over ``t_steps`` (bouts whose band RMS passes ``SNR_MIN``) and a warning, or None, when
    steps were dropped or none was found."""
    sigma, fs, tg, band = noise_floor(t_s, acc_b)
    if not np.isfinite(sigma):  # too slow a rate or too short a recording to tell noise from motion
        return np.ones(t_steps.size, bool), None
    sigma_band = sigma * np.sqrt(2.0 * (WALK_BAND_HZ[1] - WALK_BAND_HZ[0]) / fs)
    keep = np.zeros(t_steps.size, bool)
    starts = np.flatnonzero(np.r_[True, np.diff(t_steps) > gap_s]) if t_steps.size else np.array([], int)
    ends = np.r_[starts[1:], t_steps.size]
    best = 0.0
    for a, b in zip(starts, ends):  # one iteration per bout
        lo, hi = np.searchsorted(tg, [t_steps[a] - 0.5, t_steps[b - 1] + 0.5])
        rms = float(np.sqrt(np.mean(band[lo:hi] ** 2))) if hi > lo else 0.0
        best = max(best, rms)
        keep[a:b] = rms >= SNR_MIN * sigma_band
    if keep.all() and t_steps.size:
        return keep, None
    band_txt = f"walking band {WALK_BAND_HZ[0]:g}-{WALK_BAND_HZ[1]:g} Hz"
    noise_txt = f"sensor noise {sigma:.3g} m/s^2 at {fs:.0f} Hz, i.e. {sigma_band:.3g} m/s^2 RMS in the {band_txt}"
    if not t_steps.size:
        return keep, f"0 steps: no walking motion in this recording ({noise_txt})"
    dropped = int(t_steps.size - keep.sum())
    what = "no walking motion: " if not keep.any() else ""
    return keep, (f"{what}{dropped} of {t_steps.size} step-like peaks dropped as noise: at most {best:.3g} m/s^2 RMS "
                  f"in the {band_txt}, under {SNR_MIN:g}x the {noise_txt}")
