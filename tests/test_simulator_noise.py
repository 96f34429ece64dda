"""MPU6050 error model statistics against its own parameters.

Tolerances are 5 standard errors of the estimator, computed from the sample count (and, for
filtered noise, from the filter's autocorrelation), never from the observed output.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import signal

from bootnav.simulator.imu_model import PROFILES, ErrorModel, SensorProfile, drop_mask, timestamps

FS = 1000.0
N = 1 << 18  # 262 s at 1 kHz
QUIET = replace(PROFILES["mpu6050-noise-only"], name="test", dlpf_cfg=None, accel_bias_rw_mps2_rts=0.0,
                gyro_bias_rw_dps_rts=0.0)


def _run(profile: SensorProfile, seed: int = 0, n: int = N, blocks: int = 4):
    model = ErrorModel(profile, FS, np.random.default_rng(seed))
    outs = [model.process(np.zeros((n // blocks, 3)), np.zeros((n // blocks, 3))) for _ in range(blocks)]
    return [np.concatenate(o) for o in zip(*outs)], model


def _adev(x: np.ndarray, m: int) -> tuple[float, int]:
    """Non-overlapping Allan deviation at cluster size m; returns (adev, number of clusters)."""
    k = x.shape[0] // m
    means = x[: k * m].reshape(k, m).mean(axis=1)
    return float(np.sqrt(0.5 * np.mean(np.diff(means) ** 2))), k


def test_white_noise_std_matches_datasheet_density():
    (acc, gyro, _, _), _ = _run(QUIET)
    tol = 5 / math.sqrt(2 * acc.size)  # relative standard error of a std estimate
    exp_a = QUIET.accel_noise_si * math.sqrt(FS / 2)  # one-sided density n_d: sigma = n_d sqrt(fs/2)
    exp_g = QUIET.gyro_noise_si * math.sqrt(FS / 2)
    assert np.std(acc) == pytest.approx(exp_a, rel=tol)
    assert np.std(gyro) == pytest.approx(exp_g, rel=tol)
    # datasheet cross-check: RMS over 100 Hz = 0.005 deg/s/sqrt(Hz) * 10 = 0.05 deg/s
    assert math.degrees(QUIET.gyro_noise_si) * math.sqrt(100.0) == pytest.approx(0.05)


def test_allan_deviation_of_white_noise_has_slope_minus_half():
    (acc, gyro, _, _), _ = _run(QUIET)
    for x, nd in ((acc[:, 0], QUIET.accel_noise_si), (gyro[:, 1], QUIET.gyro_noise_si)):
        for m in (10, 100, 1000):
            tau = m / FS
            adev, k = _adev(x, m)
            tol = 5 / math.sqrt(2 * (k - 1))  # relative standard error of ADEV with k clusters
            assert adev == pytest.approx(nd / math.sqrt(2 * tau), rel=tol), (m, adev)
        a10, a1000 = _adev(x, 10)[0], _adev(x, 1000)[0]
        slope = math.log10(a1000 / a10) / 2.0
        assert slope == pytest.approx(-0.5, abs=5 / math.sqrt(2 * (N // 1000 - 1)) / math.log(100))


def test_bias_random_walk_increments_match_K():
    prof = replace(QUIET, accel_noise_ug_rthz=0.0, gyro_noise_dps_rthz=0.0, accel_bias_rw_mps2_rts=2e-3,
                   gyro_bias_rw_dps_rts=0.05)
    (_, _, bias_a, bias_g), _ = _run(prof)
    for b, K in ((bias_a, prof.accel_bias_rw_mps2_rts), (bias_g, math.radians(prof.gyro_bias_rw_dps_rts))):
        for lag in (1, 1000):
            inc = b[lag::lag] - b[:-lag:lag]  # non-overlapping increments, independent
            tol = 5 / math.sqrt(2 * inc.size)
            assert np.std(inc) == pytest.approx(K * math.sqrt(lag / FS), rel=tol), lag
        # Allan deviation of a random walk: K sqrt(tau / 3). Successive cluster-mean differences of a
        # random walk are triangular-weighted sums of increments with correlation 1/4 at lag 1, so the
        # AVAR estimate has relative std sqrt(2 (1 + 2/16) / k) and ADEV half of that.
        adev, k = _adev(b[:, 0], 4096)
        tol = 5 * 0.5 * math.sqrt(2 * (1 + 2 / 16) / (k - 1))
        assert adev == pytest.approx(K * math.sqrt(4.096 / 3), rel=tol)


def test_dlpf_noise_std_follows_the_filter():
    prof = replace(QUIET, dlpf_cfg=3)
    (acc, _, _, _), model = _run(prof)
    imp = np.zeros(4096)
    imp[0] = 1.0
    h = signal.sosfilt(model.sos_a, imp)
    gain = math.sqrt(np.sum(h**2))  # output std / input std for white input
    rho = np.correlate(h, h, "full") / np.sum(h**2)
    var_rel_err = math.sqrt(2 * np.sum(rho**2) / acc.shape[0])  # std error of a sample variance, correlated
    exp = prof.accel_noise_si * math.sqrt(FS / 2) * gain
    assert np.std(acc[:, 2]) == pytest.approx(exp, rel=5 * var_rel_err / 2)
    assert gain < 0.5  # 44 Hz of a 500 Hz band: the DLPF really removes noise


def test_turn_on_constants_follow_their_sigmas():
    prof = PROFILES["mpu6050-16g-2000dps"]
    draws = [ErrorModel(prof, FS, np.random.default_rng(s)) for s in range(400)]
    b0g = np.array([d.b0_g for d in draws])
    b0a = np.array([d.b0_a for d in draws])
    scale = np.array([np.diag(d.M_a) - 1 for d in draws])
    tol = 5 / math.sqrt(2 * b0g.size)
    assert np.std(b0g) == pytest.approx(math.radians(prof.gyro_turn_on_bias_sigma_dps), rel=tol)
    assert np.std(b0a[:, 2]) == pytest.approx(prof.accel_turn_on_bias_sigma_mg[2] * 1e-3 * 9.80665,
                                              rel=5 / math.sqrt(2 * 400))
    assert np.std(scale) == pytest.approx(prof.accel_scale_sigma, rel=tol)
    # the drawn matrix and bias are what is applied: a unit x input reads M[:, 0] + b0
    quiet = replace(prof, accel_noise_ug_rthz=0.0, gyro_noise_dps_rthz=0.0, accel_bias_rw_mps2_rts=0.0,
                    gyro_bias_rw_dps_rts=0.0, dlpf_cfg=None)
    m = ErrorModel(quiet, FS, np.random.default_rng(3))
    acc, *_ = m.process(np.tile([1.0, 0.0, 0.0], (5, 1)), np.zeros((5, 3)))
    assert np.allclose(acc, m.M_a[:, 0] + m.b0_a, atol=1e-15)


def test_timestamp_jitter_and_resolution():
    prof = PROFILES["mpu6050-16g-2000dps"]
    n = 200_000
    t_true, t_us = timestamps(n, 200.0, prof, np.random.default_rng(1))
    assert np.all(np.diff(t_us) > 0)
    assert np.all((t_us - t_us[0]) % 4 == 0)  # micros() ticks in 4 us
    slope, icept = np.polyfit(t_true, t_us * 1e-6, 1)
    resid = t_us * 1e-6 - (slope * t_true + icept)
    from scipy.stats import norm

    c = 3.0  # jitter is a unit normal clipped at +-3 sigma: E[z^2] = P(|z|<c) - 2 c phi(c) + c^2 P(|z|>c)
    var_clip = (2 * norm.cdf(c) - 1) - 2 * c * norm.pdf(c) + c**2 * 2 * norm.sf(c)
    exp = math.sqrt(var_clip * prof.timestamp_jitter_s**2 + (4e-6) ** 2 / 12)  # + uniform rounding to 4 us
    assert np.std(resid) == pytest.approx(exp, rel=5 / math.sqrt(2 * n))
    assert abs(slope - 1) < 6 * prof.clock_error_ppm_sigma * 1e-6


def test_dropped_sample_bursts_match_rate():
    prof = replace(PROFILES["mpu6050-16g-2000dps"], drop_burst_rate_hz=0.5, drop_burst_mean=3.0)
    n, fs = 2_000_000, 200.0
    keep = drop_mask(n, fs, prof, np.random.default_rng(4))
    starts = np.flatnonzero(np.diff(keep.astype(np.int8)) == -1)
    expected = prof.drop_burst_rate_hz * n / fs  # Poisson count of bursts (merging adjacent ones is rare)
    assert starts.size == pytest.approx(expected, abs=5 * math.sqrt(expected) + 0.01 * expected)
    lost = n - keep.sum()
    p = 1 / prof.drop_burst_mean  # geometric burst length: mean 1/p, variance (1 - p) / p^2
    se = math.sqrt((1 - p) / p**2 / starts.size)
    assert lost / starts.size == pytest.approx(prof.drop_burst_mean, abs=5 * se)
    assert keep[0]


def test_delivered_noise_at_rest_end_to_end():
    """Through simulate(): DLPF at 1 kHz, decimation to 200 Hz, int16 rounding. Std of the accel z counts
    during the 10 s still start equals the filtered white noise plus rounding noise (LSB^2 / 12)."""
    from bootnav.simulator import simulate

    prof = replace(PROFILES["mpu6050-noise-only"], accel_range_g=2, accel_bias_rw_mps2_rts=0.0,
                   gyro_bias_rw_dps_rts=0.0)  # +-2 g: 0.06 mg LSB, noise >> LSB
    res = simulate("paper-straight", seed=11, profile=prof, rate_hz=200.0)
    still = res.truth["t_s"] < 9.5
    x = res.acc_mps2[still, 2]
    model = ErrorModel(prof, 1000.0, np.random.default_rng(0))
    imp = np.zeros(4000)
    imp[0] = 1.0
    h = signal.sosfilt(model.sos_a, imp)
    acf = np.correlate(h, h, "full")[h.size - 1:] / np.sum(h**2)  # lags 0.. at 1 kHz
    rho = acf[::5]  # autocorrelation of the 200 Hz samples
    sigma_f = prof.accel_noise_si * math.sqrt(1000.0 / 2) * math.sqrt(np.sum(h**2))
    exp = math.sqrt(sigma_f**2 + prof.accel_lsb_mps2**2 / 12)
    rel = 0.5 * math.sqrt(2 * (1 + 2 * np.sum(rho[1:] ** 2)) / x.size)
    assert np.std(x) == pytest.approx(exp, rel=5 * rel)
    assert res.decimation == 5 and res.attrs["internal_rate_hz"] == 1000.0
