"""MPU6050 error model: what the chip and the Arduino make of the exact specific force and rate.

Chain, per axis triad (accelerometer a, gyroscope g), at the internal rate f_i (~1 kHz, the MPU6050's
internal sample rate with the DLPF on), then decimated to the output rate f_s = f_i / m
(``SMPLRT_DIV = m - 1``):

    y = M x + b_0 + b_rw(t) + n(t)          M = I + diag(scale) + cross-axis (off-diagonal)
    b_rw[k+1] = b_rw[k] + K sqrt(dt) w_k    (bias random walk, K in unit/s/sqrt(s))
    n[k] ~ N(0, sigma^2),  sigma = n_d sqrt(f_i / 2)
    y_f = DLPF(y)                           (2nd-order Butterworth at the DLPF_CFG bandwidth)
    count = clip(round(y_f[::m] / LSB), -32768, 32767)   (int16 register; saturated at the limits)

``n_d`` is the datasheet's (one-sided) noise spectral density: the RMS over a bandwidth B is n_d sqrt(B)
(datasheet check: 0.005 deg/s/sqrt(Hz) * sqrt(100 Hz) = 0.05 deg/s, the quoted total RMS noise at
DLPF 100 Hz). In Allan terms the white-noise coefficient is N = n_d / sqrt(2): sigma_A(tau) = N/sqrt(tau).
A bias random walk K gives sigma_A(tau) = K sqrt(tau / 3).

Figures used (``mpu6050-*`` profiles), source InvenSense MPU-6000/6050 Product Specification rev 3.4,
tables 6.1/6.2 unless marked [ENG] (engineering assumption, no datasheet figure exists):

* accelerometer noise PSD 400 ug/sqrt(Hz); gyro rate noise 0.005 deg/s/sqrt(Hz);
* turn-on bias: zero-g output tolerance +-50 mg (x, y), +-80 mg (z); gyro ZRO tolerance +-20 deg/s;
  drawn as normal with sigma = tolerance / 3;
* scale factor: initial calibration tolerance +-3 % (both) -> sigma 1 %; cross-axis sensitivity
  +-2 % -> sigma 0.67 %;
* bias random walk [ENG]: K_g = 1e-4 deg/s/sqrt(s), K_a = 1e-4 m/s^2/sqrt(s): gives Allan bias
  instability of the order of 10-20 deg/h and 0.1-0.5 mg over tens of minutes, the range reported for
  MPU6050-class MEMS parts;
* DLPF bandwidths (register map, CONFIG register): accel 260/184/94/44/21/10/5 Hz, gyro
  256/188/98/42/20/10/5 Hz for DLPF_CFG 0..6. A 2nd-order Butterworth has DC group delay
  sqrt(2)/(2 pi f_c): 5.1 ms at 44 Hz vs the datasheet's 4.9 ms (close; the real filter is unpublished);
* timestamps [ENG]: Arduino ``micros()`` (4 us resolution) on a ceramic resonator, clock error sigma
  1000 ppm, read-latency jitter sigma 20 us (clipped at +-3 sigma);
* dropped samples [ENG]: bursts (SD-card write stalls) at 0.01 per second, mean burst 3 samples.

One unit (``simulate(..., device=D)``, ``simulator/device.py``): the sensitivity matrices, the mean turn-on
biases, temperature coefficients and clock error come from the device id; ``ErrorModel`` then draws only this
power-on's bias repeatability and the noise from its generator, and follows the chip temperature.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from bootnav.logger.mpu6050 import (
    ACCEL_LSB_PER_G, GYRO_LSB_PER_DPS, INT16_MAX, INT16_MIN, STANDARD_GRAVITY, accel_code, accel_scale_mps2,
    gyro_code, gyro_scale_radps,
)

DLPF_ACCEL_HZ = {0: 260.0, 1: 184.0, 2: 94.0, 3: 44.0, 4: 21.0, 5: 10.0, 6: 5.0}
DLPF_GYRO_HZ = {0: 256.0, 1: 188.0, 2: 98.0, 3: 42.0, 4: 20.0, 5: 10.0, 6: 5.0}


@dataclass(frozen=True)
class SensorProfile:
    """Every parameter of the sensor model (saved with each simulated recording)."""

    name: str = "mpu6050-16g-2000dps"
    ideal: bool = False  # True: exact SI floats, no errors, no quantisation, no timing faults
    accel_range_g: int = 16
    gyro_range_dps: int = 2000
    dlpf_cfg: int | None = 3  # CONFIG.DLPF_CFG 0..6; None = filter off
    internal_rate_hz: float = 1000.0
    accel_noise_ug_rthz: float = 400.0
    gyro_noise_dps_rthz: float = 0.005
    accel_bias_rw_mps2_rts: float = 1e-4
    gyro_bias_rw_dps_rts: float = 1e-4
    accel_turn_on_bias_sigma_mg: tuple[float, float, float] = (50 / 3, 50 / 3, 80 / 3)
    gyro_turn_on_bias_sigma_dps: float = 20 / 3
    accel_scale_sigma: float = 0.01
    gyro_scale_sigma: float = 0.01
    accel_cross_axis_sigma: float = 0.02 / 3
    gyro_cross_axis_sigma: float = 0.02 / 3
    clock_error_ppm_sigma: float = 1000.0
    timestamp_jitter_s: float = 20e-6
    timestamp_resolution_s: float = 4e-6
    drop_burst_rate_hz: float = 0.01
    drop_burst_mean: float = 3.0
    temp_degc: float = 25.0

    def __post_init__(self):
        if not self.ideal:
            accel_code(self.accel_range_g)
            gyro_code(self.gyro_range_dps)
        if self.dlpf_cfg is not None and self.dlpf_cfg not in DLPF_ACCEL_HZ:
            raise ValueError(f"dlpf_cfg must be 0..6 or None, got {self.dlpf_cfg}")

    # -- register facts ------------------------------------------------------------------------
    @property
    def accel_lsb_mps2(self) -> float:
        return accel_scale_mps2(accel_code(self.accel_range_g))

    @property
    def gyro_lsb_radps(self) -> float:
        return gyro_scale_radps(gyro_code(self.gyro_range_dps))

    @property
    def accel_noise_si(self) -> float:
        """One-sided noise density, m/s^2/sqrt(Hz)."""
        return self.accel_noise_ug_rthz * 1e-6 * STANDARD_GRAVITY

    @property
    def gyro_noise_si(self) -> float:
        """One-sided noise density, rad/s/sqrt(Hz)."""
        return math.radians(self.gyro_noise_dps_rthz)

    def to_dict(self) -> dict:
        d = asdict(self)
        if not self.ideal:
            d["accel_lsb_mps2"] = self.accel_lsb_mps2
            d["gyro_lsb_radps"] = self.gyro_lsb_radps
            d["accel_lsb_per_g"] = ACCEL_LSB_PER_G[accel_code(self.accel_range_g)]
            d["gyro_lsb_per_dps"] = GYRO_LSB_PER_DPS[gyro_code(self.gyro_range_dps)]
        return d


_DEFAULT = SensorProfile()
_NOISE_ONLY = dict(
    accel_turn_on_bias_sigma_mg=(0.0, 0.0, 0.0), gyro_turn_on_bias_sigma_dps=0.0, accel_scale_sigma=0.0,
    gyro_scale_sigma=0.0, accel_cross_axis_sigma=0.0, gyro_cross_axis_sigma=0.0, clock_error_ppm_sigma=0.0,
    timestamp_jitter_s=0.0, timestamp_resolution_s=1e-6, drop_burst_rate_hz=0.0,
)
PROFILES: dict[str, SensorProfile] = {
    p.name: p
    for p in (
        _DEFAULT,
        replace(_DEFAULT, name="mpu6050-8g-1000dps", accel_range_g=8, gyro_range_dps=1000),
        replace(_DEFAULT, name="mpu6050-4g-500dps", accel_range_g=4, gyro_range_dps=500),
        replace(_DEFAULT, name="mpu6050-2g-250dps", accel_range_g=2, gyro_range_dps=250),
        replace(_DEFAULT, name="mpu6050-noise-only", **_NOISE_ONLY),
        SensorProfile(name="ideal", ideal=True, dlpf_cfg=None, **{k: v for k, v in _NOISE_ONLY.items()
                                                                    if k != "timestamp_resolution_s"},
                      accel_noise_ug_rthz=0.0, gyro_noise_dps_rthz=0.0, accel_bias_rw_mps2_rts=0.0,
                      gyro_bias_rw_dps_rts=0.0, timestamp_resolution_s=0.0),
    )
}
PROFILE_HELP = {
    "mpu6050-16g-2000dps": "default: +-16 g, +-2000 deg/s, DLPF 44 Hz, datasheet noise, turn-on errors, jitter, drops",
    "mpu6050-8g-1000dps": "as default with +-8 g, +-1000 deg/s",
    "mpu6050-4g-500dps": "as default with +-4 g, +-500 deg/s",
    "mpu6050-2g-250dps": "as default with +-2 g, +-250 deg/s (power-on register defaults; saturates when walking)",
    "mpu6050-noise-only": "+-16 g, +-2000 deg/s, white noise + bias random walk + DLPF + int16 only",
    "ideal": "exact SI floats: no noise, no quantisation, no timing faults (strapdown checks)",
}


def get_profile(profile: str | SensorProfile) -> SensorProfile:
    if isinstance(profile, SensorProfile):
        return profile
    try:
        return PROFILES[profile]
    except KeyError:
        raise ValueError(f"unknown sensor profile {profile!r}; choose one of {', '.join(PROFILES)}") from None


def quantize(x: np.ndarray, lsb: float) -> tuple[np.ndarray, np.ndarray]:
    """int16 counts = clip(round(x / lsb)) and a per-element 'at full scale' flag."""
    c = np.rint(np.asarray(x, dtype=np.float64) / lsb)
    c = np.clip(c, INT16_MIN, INT16_MAX)
    return c.astype(np.int16), (c == INT16_MAX) | (c == INT16_MIN)


def misalignment_matrix(rng: np.random.Generator, scale_sigma: float, cross_sigma: float) -> np.ndarray:
    """A drawn sensitivity matrix M = I + diag(scale errors) + cross-axis terms (σ's dimensionless, from ``rng``):
    sensor reading = M · true value (the error model and the device model draw it the same way)."""
    M = np.eye(3) + np.diag(rng.normal(0.0, 1.0, 3) * scale_sigma)
    off = rng.normal(0.0, 1.0, (3, 3)) * cross_sigma
    return M + off - np.diag(np.diag(off))


class ErrorModel:
    """Stateful MPU6050 error model: feed exact signals block by block at the internal rate.

    All random numbers come from the one ``rng``; turn-on constants are drawn in ``__init__``. With a
    ``unit`` (``device.DeviceUnit``) the sensitivity matrices, the mean turn-on biases and the temperature
    coefficients are the unit's; ``rng`` then draws only this power-on's bias repeatability (and the noise),
    and ``process`` takes the chip temperature (``simulator/device.py``). Without a unit the draws are
    exactly those of a recording without ``--device``.
    """

    def __init__(self, profile: SensorProfile, internal_rate_hz: float, rng: np.random.Generator, unit=None):
        from scipy import signal  # heavy import kept local

        self.p = profile
        self.fs = float(internal_rate_hz)
        self.rng = rng
        self.unit = unit
        g = STANDARD_GRAVITY
        if unit is None:
            self.M_a = misalignment_matrix(rng, profile.accel_scale_sigma, profile.accel_cross_axis_sigma)
            self.M_g = misalignment_matrix(rng, profile.gyro_scale_sigma, profile.gyro_cross_axis_sigma)
            self.b0_a = rng.normal(0.0, 1.0, 3) * np.asarray(profile.accel_turn_on_bias_sigma_mg) * 1e-3 * g
            self.b0_g = rng.normal(0.0, 1.0, 3) * math.radians(profile.gyro_turn_on_bias_sigma_dps)
        else:  # the unit's stable constants; this power-on's repeatability from the seed
            self.M_a, self.M_g = np.array(unit.M_a), np.array(unit.M_g)
            self.b0_a = unit.acc_bias_mean_mps2 + rng.normal(0.0, 1.0, 3) * unit.acc_bias_repeat_sigma_mps2
            self.b0_g = unit.gyro_bias_mean_radps + rng.normal(0.0, 1.0, 3) * unit.gyro_bias_repeat_sigma_radps
        self.rw_a = np.zeros(3)
        self.rw_g = np.zeros(3)
        self.sigma_a = profile.accel_noise_si * math.sqrt(self.fs / 2.0)
        self.sigma_g = profile.gyro_noise_si * math.sqrt(self.fs / 2.0)
        self.k_a = profile.accel_bias_rw_mps2_rts / math.sqrt(self.fs)
        self.k_g = math.radians(profile.gyro_bias_rw_dps_rts) / math.sqrt(self.fs)
        self.sos_a = self.sos_g = None
        if profile.dlpf_cfg is not None:
            nyq = self.fs / 2.0
            fa, fg = DLPF_ACCEL_HZ[profile.dlpf_cfg], DLPF_GYRO_HZ[profile.dlpf_cfg]
            if max(fa, fg) >= nyq:
                raise ValueError(f"DLPF {max(fa, fg)} Hz needs an internal rate above {2 * max(fa, fg)} Hz")
            self.sos_a = signal.butter(2, fa, fs=self.fs, output="sos")
            self.sos_g = signal.butter(2, fg, fs=self.fs, output="sos")
        self._zi_a = self._zi_g = None

    def constants(self) -> dict:
        """The drawn turn-on constants (saved in /truth attrs); biases at the reference temperature."""
        d = {"accel_misalignment": self.M_a.tolist(), "gyro_misalignment": self.M_g.tolist(),
             "accel_turn_on_bias_mps2": self.b0_a.tolist(), "gyro_turn_on_bias_radps": self.b0_g.tolist()}
        if self.unit is not None:
            d["device"] = self.unit.to_dict()
        return d

    def _walk(self, state: np.ndarray, k: float, n: int) -> np.ndarray:
        """Bias random walk values at the n samples of this block (continuing ``state``)."""
        steps = self.rng.normal(0.0, 1.0, (n, 3)) * k
        walk = state + np.cumsum(steps, axis=0)
        state[:] = walk[-1]
        return walk

    def _dlpf(self, x: np.ndarray, sos, which: str) -> np.ndarray:
        from scipy import signal

        if sos is None:
            return x
        zi = getattr(self, which)
        if zi is None:  # start in steady state at the first value: no power-on transient
            zi = signal.sosfilt_zi(sos)[:, :, None] * x[0][None, None, :]
        y, zi = signal.sosfilt(sos, x, axis=0, zi=zi)
        setattr(self, which, zi)
        return y

    def process(self, f_b: np.ndarray, w_b: np.ndarray, temp_degc: np.ndarray | None = None):
        """One block at the internal rate -> (acc, gyro, bias_acc, bias_gyro), all SI, filtered.

        ``temp_degc`` (chip temperature per sample) is used with a unit only:
        ``y = (I + diag(s) dT) M x + b0 + k dT + b_rw + n``, dT = T - T0 (``device`` module doc).
        """
        n = f_b.shape[0]
        noise_a = self.rng.normal(0.0, 1.0, (n, 3)) * self.sigma_a
        noise_g = self.rng.normal(0.0, 1.0, (n, 3)) * self.sigma_g
        bias_a = self.b0_a + self._walk(self.rw_a, self.k_a, n)
        bias_g = self.b0_g + self._walk(self.rw_g, self.k_g, n)
        if self.unit is None:
            acc = f_b @ self.M_a.T + bias_a + noise_a
            gyro = w_b @ self.M_g.T + bias_g + noise_g
        else:
            u = self.unit
            dT = (np.asarray(temp_degc, dtype=float) - u.t_reference_degc)[:, None]
            bias_a = bias_a + u.acc_bias_tempco_mps2_per_degc * dT
            bias_g = bias_g + u.gyro_bias_tempco_radps_per_degc * dT
            acc = (f_b @ self.M_a.T) * (1.0 + u.acc_scale_tempco_per_degc * dT) + bias_a + noise_a
            gyro = (w_b @ self.M_g.T) * (1.0 + u.gyro_scale_tempco_per_degc * dT) + bias_g + noise_g
        return self._dlpf(acc, self.sos_a, "_zi_a"), self._dlpf(gyro, self.sos_g, "_zi_g"), bias_a, bias_g


def timestamps(n: int, rate_hz: float, profile: SensorProfile, rng: np.random.Generator,
               clock_error: float | None = None):
    """Device timestamps (uint32 us, wrapping) of n nominal samples; returns (t_true, t_device_us_unwrapped).

    ``clock_error``: a unit's resonator error (device clock = true time (1 + e)); None: drawn from ``rng``.
    """
    t_true = np.arange(n) / rate_hz
    if profile.ideal:
        return t_true, np.rint(t_true * 1e6).astype(np.int64)
    e = rng.normal() * profile.clock_error_ppm_sigma * 1e-6 if clock_error is None else float(clock_error)
    jit = np.clip(rng.normal(0.0, 1.0, n), -3, 3) * profile.timestamp_jitter_s
    offset_us = int(rng.integers(1_000_000, 4_000_000))  # micros() already running at first sample
    res = max(profile.timestamp_resolution_s, 1e-6) * 1e6
    t_us = offset_us + res * np.rint((t_true * (1 + e) + jit) * 1e6 / res)
    return t_true, np.maximum.accumulate(t_us.astype(np.int64))


def drop_mask(n: int, rate_hz: float, profile: SensorProfile, rng: np.random.Generator) -> np.ndarray:
    """True for samples that reach the file; bursts start at rate ``drop_burst_rate_hz``."""
    keep = np.ones(n, dtype=bool)
    if profile.ideal or profile.drop_burst_rate_hz <= 0:
        return keep
    starts = np.flatnonzero(rng.random(n) < profile.drop_burst_rate_hz / rate_hz)
    starts = starts[starts > 0]  # the first sample always arrives
    lengths = rng.geometric(1.0 / max(profile.drop_burst_mean, 1.0), starts.size)
    for s, L in zip(starts, lengths):
        keep[s : s + L] = False
    return keep
