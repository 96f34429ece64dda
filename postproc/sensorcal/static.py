"""Static-pose detection in a hand-held calibration session.

A pose is a run of samples whose centred window (``window_s``) has a small rate spread (per-axis std below
``gyro_std_max_radps``), a small specific-force spread (std of |f| below ``acc_std_max_mps2``) and a mean rate
close to the bias (|window mean − median of the still windows' means| below ``gyro_dev_max_radps``: a slow
steady rotation has a small spread but not the bias's mean). The bias is unknown before the fit (±20 °/s on
an MPU6050), but it is common to every pose, so the median over the first-pass still windows estimates it.
Runs are trimmed by ``edge_trim_s`` at both ends and kept when at least ``min_pose_s`` long. The thresholds
and their sources are in ``settings``. The same test on the accelerometer's norm as in
``postproc.calibration.still_mask``, but with windows and thresholds for a held boot rather than a foot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.core.runs import runs
from bootnav.core.timebase import sample_period

from bootnav.core.arrays import moving_mean, row_norm, rows_finite, window_samples
from .settings import SensorCalSettings


@dataclass
class StaticPoses:
    """The static poses of one session (arrays over poses P, sample indices into the session).

    start, stop: (P,) sample index range (stop exclusive); t_mid_s: (P,) s.
    acc_mean, gyro_mean: (P, 3) raw means over the pose; acc_head, acc_tail: (P, 3) raw specific-force means
    over the first / last ``anchor_s`` of the pose (the gravity anchors of the rotations); head_mid, tail_mid:
    (P,) sample index at the centre of those anchors; temp_mean: (P,) °C (NaN without temperature);
    n: (P,) samples.
    """

    start: np.ndarray
    stop: np.ndarray
    t_mid_s: np.ndarray
    acc_mean: np.ndarray
    gyro_mean: np.ndarray
    acc_head: np.ndarray
    acc_tail: np.ndarray
    head_mid: np.ndarray
    tail_mid: np.ndarray
    temp_mean: np.ndarray
    n: np.ndarray

    def __len__(self) -> int:
        return int(self.start.shape[0])


def still_windows(t_s, acc, gyro, settings: SensorCalSettings, bias_radps=None) -> np.ndarray:
    """Bool (N,): the centred window passes the spread tests (and, with ``bias_radps``, the mean-rate test)."""
    n = window_samples(settings.window_s, sample_period(t_s), minimum=3)
    amag = row_norm(acc)
    a_m = moving_mean(amag, n)
    a_sd = np.sqrt(np.maximum(moving_mean(amag**2, n) - a_m**2, 0.0))
    g_m = moving_mean(gyro, n)
    g_sd = np.sqrt(np.maximum(moving_mean(gyro**2, n) - g_m**2, 0.0)).max(axis=1)
    ok = (g_sd < settings.gyro_std_max_radps) & (a_sd < settings.acc_std_max_mps2)
    if bias_radps is not None:
        ok &= row_norm(g_m - bias_radps) < settings.gyro_dev_max_radps
    return ok & rows_finite(acc) & rows_finite(gyro)


def _runs_min(t_s, mask, settings: SensorCalSettings):
    starts, stops = runs(mask)
    dt = sample_period(t_s)
    trim = int(round(settings.edge_trim_s / dt))
    starts, stops = starts + trim, stops - trim
    keep = (stops > starts) & ((t_s[np.maximum(stops - 1, 0)] - t_s[np.minimum(starts, len(t_s) - 1)] + dt)
                               >= settings.min_pose_s)
    return starts[keep], stops[keep]


def detect_static_poses(t_s, acc, gyro, temp_degc=None, settings: SensorCalSettings | None = None,
                        saturated=None) -> StaticPoses:
    """Static poses of a session (see module docstring); raw (uncalibrated) SI arrays in, ``StaticPoses`` out."""
    s = settings or SensorCalSettings()
    t_s = np.asarray(t_s, dtype=np.float64)
    acc = np.asarray(acc, dtype=np.float64)
    gyro = np.asarray(gyro, dtype=np.float64)
    ok = still_windows(t_s, acc, gyro, s)
    if saturated is not None:
        ok &= np.asarray(saturated) == 0
    st, sp = _runs_min(t_s, ok, s)
    if st.size:
        means = np.array([gyro[a:b].mean(axis=0) for a, b in zip(st, sp)])  # one row per pose, not per sample
        bias = np.median(means, axis=0)
        ok &= still_windows(t_s, acc, gyro, s, bias_radps=bias)
        st, sp = _runs_min(t_s, ok, s)
    return _summarise(t_s, acc, gyro, temp_degc, st, sp, s)


def _summarise(t_s, acc, gyro, temp_degc, st, sp, s: SensorCalSettings) -> StaticPoses:
    dt = sample_period(t_s)
    na = max(1, int(round(s.anchor_s / dt)))
    # cumulative sums give every per-pose mean without a loop over samples
    ca = np.vstack([np.zeros((1, 3)), np.cumsum(acc, axis=0)])
    cg = np.vstack([np.zeros((1, 3)), np.cumsum(gyro, axis=0)])
    n = (sp - st).astype(np.int64)
    nh = np.minimum(na, n)
    head_stop, tail_start = st + nh, sp - nh
    with np.errstate(invalid="ignore", divide="ignore"):
        acc_mean = (ca[sp] - ca[st]) / n[:, None]
        gyro_mean = (cg[sp] - cg[st]) / n[:, None]
        acc_head = (ca[head_stop] - ca[st]) / nh[:, None]
        acc_tail = (ca[sp] - ca[tail_start]) / nh[:, None]
    if temp_degc is not None:
        temp = np.asarray(temp_degc, dtype=np.float64)
        temp = np.where(np.isfinite(temp), temp, 0.0)
        ct = np.concatenate([[0.0], np.cumsum(temp)])
        temp_mean = (ct[sp] - ct[st]) / np.maximum(n, 1)
    else:
        temp_mean = np.full(st.shape, np.nan)
    return StaticPoses(start=st, stop=sp, t_mid_s=0.5 * (t_s[st] + t_s[np.maximum(sp - 1, st)]),
                       acc_mean=acc_mean.reshape(-1, 3), gyro_mean=gyro_mean.reshape(-1, 3),
                       acc_head=acc_head.reshape(-1, 3), acc_tail=acc_tail.reshape(-1, 3),
                       head_mid=(st + head_stop) // 2, tail_mid=(tail_start + sp) // 2, temp_mean=temp_mean, n=n)
