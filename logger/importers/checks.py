"""Plausibility checks of declared units, and saturation flags.

**Gravity check.** At rest an accelerometer reads |f| = g = 9.80665 m/s². We take the *quietest second*
(the 1-s window whose |acc| has the smallest standard deviation) and its median |acc| after applying the
declared unit. If it is not within ±25 % of g, the declared unit (or range) is wrong; the error message
says which unit *would* fit: |acc| ≈ 1 means g, ≈ 9.81 means m/s², ≈ 32768/R means int16 counts at ±R g.
(±25 % tolerates a sensor tilted while moving slowly, and still separates a range off by 2x.)

**Gyro check.** Walking feet turn at up to ~10-15 rad/s (about 600-900 °/s); the MPU6050 tops out at
2000 °/s = 34.9 rad/s. A 99.9th-percentile |ω| above 35 rad/s after conversion is physically absurd and
almost always deg/s declared as rad/s (x57.3); the error suggests ``--gyro-unit dps``.

A gyro that barely turns (99.9th percentile below 0.3 rad/s = 17 deg/s) while the accelerometer shows motion is
only a warning (``note`` event): rad/s declared as deg/s, or a genuinely quiet recording.

**Saturation.** A sample is saturated on an axis when its raw value is at full scale: for int16 counts
≥ 32767 or ≤ -32768; for values in physical units |v| ≥ (1 - 0.5 %) · range (the margin absorbs the
rounding of printed values, e.g. 19.62 for 2 g). Bits as in ``bootnav.logger.recording.SATURATION_BITS``;
one ``saturation`` event per run of consecutive saturated samples per axis.
"""

from __future__ import annotations

import numpy as np

from bootnav.core.runs import runs
from bootnav.logger.mpu6050 import STANDARD_GRAVITY

ACC_TOLERANCE = 0.25
GYRO_ABSURD_RADPS = 35.0
SI_MARGIN = 0.005


def quietest_second(acc_si: np.ndarray, rate_hz: float) -> tuple[float, int]:
    """(median |acc| in the quietest 1-s window, start index of that window)."""
    mag = np.linalg.norm(acc_si, axis=1)
    mag = mag[np.isfinite(mag)]
    n = max(int(round(rate_hz)) if np.isfinite(rate_hz) else 1, 5)
    if mag.size < n:
        return float(np.median(mag)) if mag.size else float("nan"), 0
    k = mag.size // n
    win = mag[: k * n].reshape(k, n)
    j = int(np.argmin(win.std(axis=1)))
    return float(np.median(win[j])), j * n


def acc_unit_problem(acc_raw: np.ndarray, scale_to_si: float, declared: str, rate_hz: float) -> str | None:
    """None if the gravity magnitude fits the declared unit, else a message with a suggestion."""
    raw_mag, i0 = quietest_second(np.asarray(acc_raw, dtype=np.float64), rate_hz)
    if not np.isfinite(raw_mag):
        return None
    si = raw_mag * scale_to_si
    if abs(si / STANDARD_GRAVITY - 1.0) <= ACC_TOLERANCE:
        return None
    candidates = [("--acc-unit g", 1.0), ("--acc-unit mps2", STANDARD_GRAVITY)]
    candidates += [(f"--acc-unit counts --acc-range {r}", 32768.0 / r) for r in (2, 4, 8, 16)]
    fits = [flag for flag, ref in candidates if abs(raw_mag / ref - 1.0) <= ACC_TOLERANCE]
    hint = f"; it fits {fits[0]}" if fits else "; no unit fits (is gravity removed, i.e. linear acceleration?)"
    return (f"gravity check failed: at rest (quietest second, from sample {i0}) the median |acc| is {raw_mag:.4g} "
            f"in the file = {si:.4g} m/s^2 with the declared unit {declared!r}, expected 9.81 m/s^2 +-25%{hint}")


def gyro_unit_problem(gyro_si: np.ndarray, declared: str) -> str | None:
    mag = np.linalg.norm(np.asarray(gyro_si, dtype=np.float64), axis=1)
    mag = mag[np.isfinite(mag)]
    if mag.size == 0:
        return None
    p = float(np.percentile(mag, 99.9))
    if p <= GYRO_ABSURD_RADPS:
        return None
    hint = "--gyro-unit dps" if declared == "radps" else "--gyro-unit radps or check --gyro-range"
    return (f"gyro check failed: 99.9th percentile of |rate| is {p:.4g} rad/s with the declared unit {declared!r}, "
            f"more than any foot or MEMS gyro reaches ({GYRO_ABSURD_RADPS} rad/s = 2000 deg/s); try {hint}")


def gyro_too_small(acc_si: np.ndarray, gyro_si: np.ndarray) -> str | None:
    """A warning (not an error) when the accelerometer shows walking but the gyro barely turns.

    A walking foot, waist or phone turns at > 1 rad/s; rad/s data declared as deg/s is 57x too small.
    """
    acc_mag = np.linalg.norm(np.asarray(acc_si, dtype=np.float64), axis=1)
    gyro_mag = np.linalg.norm(np.asarray(gyro_si, dtype=np.float64), axis=1)
    ok = np.isfinite(acc_mag) & np.isfinite(gyro_mag)
    if ok.sum() < 100:
        return None
    moving = float(np.std(acc_mag[ok])) > 2.0  # m/s^2: clearly more than sensor noise at rest
    p = float(np.percentile(gyro_mag[ok], 99.9))
    if moving and p < 0.3:
        return (f"gyro suspiciously small: 99.9th percentile of |rate| is {p:.3g} rad/s while the accelerometer "
                f"shows motion; if the file is in rad/s, use --gyro-unit radps")
    return None


def saturation(raw: np.ndarray, full_scale: float, counts: bool, first_bit: int) -> tuple[np.ndarray, list[dict]]:
    """Bitmask (uint8) and one event per run of saturated samples per axis of a (N, 3) block."""
    mask = np.zeros(raw.shape[0], dtype=np.uint8)
    events: list[dict] = []
    if not np.isfinite(full_scale):
        return mask, events
    for axis in range(raw.shape[1]):
        v = raw[:, axis]
        if counts:
            hit = (v >= 32767) | (v <= -32768)
        else:
            hit = np.abs(v) >= full_scale * (1.0 - SI_MARGIN)
        if not hit.any():
            continue
        mask |= (hit.astype(np.uint8) << (first_bit + axis))
        for s, e in zip(*runs(hit)):
            events.append(dict(kind="saturation", sample_index=int(s), axis=first_bit + axis, count=int(e - s),
                               detail=f"{'acc' if first_bit == 0 else 'gyro'} {'xyz'[axis]} at full scale "
                                      f"for {e - s} sample(s)"))
    return mask, events
