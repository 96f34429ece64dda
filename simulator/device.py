"""One MPU6050 unit (``--device D``) and the chip's temperature (warm-up, ambient ramp).

Without a device the simulator draws every sensor error afresh from ``--seed`` (``imu_model.ErrorModel``):
each recording is a new chip. A real boot keeps its chip. ``draw_unit(D)`` draws what is fixed for one unit
from the device id alone (a generator seeded with ``[DEVICE_SALT, D]``), so every recording of device D
shares them whatever its seed:

* sensitivity and cross-axis matrices ``M_a``, ``M_g`` (``I + diag(scale) + off-diagonal``, full 3x3);
* the mean of its turn-on biases at the reference temperature T0 = 25 C (the datasheet's condition);
* bias temperature coefficients ``k`` and sensitivity temperature coefficients ``s`` per axis;
* the resonator's frequency error (device clock = true time x (1 + e)).

``--seed`` draws what changes per power-on and per walk: the turn-on bias repeatability around the unit's
mean, noise, bias random walk, timing jitter, drops, and the walk.

Split of the datasheet's turn-on tolerance (sigma_total = tolerance / 3, as ``imu_model``): the per-unit part
has sigma_total sqrt(1 - r^2) and the per-power-on part sigma_total r, so the population of (unit, power-on)
pairs keeps exactly the datasheet's spread. r = ``repeat_fraction`` [ENG] (no MPU6050 turn-on repeatability
is published; docs/simulator.md gives the reasoning and the figures used).

With a unit the sensor model becomes, with dT = T(t) - T0 (T the chip temperature),

    y = (I + diag(s) dT) M x + b_unit + b_rep + k dT + b_rw(t) + n(t)

Temperature (``chip_temperature``): the die follows the ambient air through a first-order lag of time
constant tau and warms by its own dissipation (3.9 mA at 3.3 V plus the Arduino beside it) by ``self_heating``
towards ambient + self_heating. With the ambient A(t) = A0 + R * ramp(t) (a linear ramp of R C/min from
``ramp_start_s`` for ``ramp_duration_s``) the exact solution of tau T' = A(t) + S - T, T(0) = A0, is

    T(t) = A0 + S (1 - exp(-t / tau)) + R [r(t - t1) - r(t - t2)],   r(u) = u - tau (1 - exp(-u / tau)) for u > 0

(r is the lag's response to a unit ramp; t1, t2 the start and end of the ramp, R in C/s).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from bootnav.logger.mpu6050 import STANDARD_GRAVITY
from bootnav.simulator.imu_model import misalignment_matrix

DEVICE_SALT = 0x0B0075EE  # fixed: one device id is one unit, in every release and for every seed
DEVICE_ID_MAX = 0xFFFFFFFF  # the recorder's device id is a uint32 (logger/protocol.py)
T_REFERENCE_DEGC = 25.0  # datasheet conditions: TA = 25 C


@dataclass(frozen=True)
class DeviceModel:
    """How one unit's constants are drawn (defaults: MPU-6000/6050 Product Specification rev 3.4).

    Bias and sensitivity temperature coefficients are linear in T; their sigma is the datasheet's change over
    temperature divided by the largest distance from 25 C inside the quoted range (the change is quoted
    relative to the 25 C value) and by 3 (the ``imu_model`` convention: a +- figure is 3 sigma).
    """

    repeat_fraction: float = 0.25  # per-power-on share of the turn-on bias sigma [ENG]
    gyro_bias_tempco_sigma_dps_per_degc: float = 20.0 / 65.0 / 3.0  # ZRO +-20 deg/s over -40..85 C
    accel_bias_tempco_sigma_mg_per_degc: tuple[float, float, float] = (35.0 / 45.0 / 3.0, 35.0 / 45.0 / 3.0,
                                                                       60.0 / 45.0 / 3.0)  # 0..70 C: 35/60 mg
    gyro_scale_tempco_sigma_per_degc: float = 0.02 / 65.0 / 3.0  # +-2 % over -40..85 C
    accel_scale_tempco_sigma_per_degc: float = 0.0002 / 3.0  # +-0.02 %/C

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class TemperatureProfile:
    """Ambient air and die heating of the chip (module doc); every recording with a device uses one."""

    ambient_degc: float = 25.0  # ambient at power-on (the chip starts at it)
    self_heating_degc: float = 3.0  # die rise above ambient in steady state [ENG]
    tau_s: float = 300.0  # thermal time constant [ENG; warm-up of 10-15 min = 2-3 tau, EDTracker2014]
    ramp_degc_per_min: float = 0.0  # ambient ramp (a boot carried into a hot building)
    ramp_start_s: float = 0.0
    ramp_duration_s: float = math.inf

    def __post_init__(self):
        for name in ("ambient_degc", "self_heating_degc", "ramp_degc_per_min", "ramp_start_s"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"temperature: {name} must be a finite number, got {getattr(self, name)}")
        if not (self.tau_s > 0 and math.isfinite(self.tau_s)):
            raise ValueError(f"temperature: the time constant must be > 0 s, got {self.tau_s}")
        if not self.ramp_duration_s > 0:
            raise ValueError(f"temperature: the ramp duration must be > 0 s, got {self.ramp_duration_s}")
        if not -40.0 <= self.ambient_degc <= 85.0:
            raise ValueError(f"temperature: ambient {self.ambient_degc} C is outside the MPU6050's specified "
                             "range -40..85 C")

    def to_dict(self) -> dict:
        d = asdict(self)
        d["ramp_duration_s"] = None if math.isinf(self.ramp_duration_s) else self.ramp_duration_s
        return d

    def ambient(self, t: np.ndarray) -> np.ndarray:
        """Ambient air temperature, C, at true times ``t``."""
        t = np.asarray(t, dtype=float)
        ramp = np.clip(t - self.ramp_start_s, 0.0, self.ramp_duration_s)
        return self.ambient_degc + self.ramp_degc_per_min / 60.0 * ramp

    def chip(self, t: np.ndarray) -> np.ndarray:
        """Die temperature, C, at true times ``t`` (module doc; exact solution of the first-order lag)."""
        t = np.asarray(t, dtype=float)
        temp = self.ambient_degc + self.self_heating_degc * (1 - np.exp(-t / self.tau_s))
        if self.ramp_degc_per_min != 0.0:
            tau = self.tau_s

            def r(u):
                u = np.maximum(u, 0.0)
                return u - tau * (-np.expm1(-u / tau))

            t1 = self.ramp_start_s
            resp = r(t - t1)
            if math.isfinite(self.ramp_duration_s):
                resp = resp - r(t - t1 - self.ramp_duration_s)
            temp = temp + self.ramp_degc_per_min / 60.0 * resp
        return temp


def parse_device_id(value) -> int:
    """A device id from an int or a decimal / 0x-hex string, checked to 0..2^32-1."""
    if isinstance(value, str):
        text = value.strip()
        try:
            value = int(text, 0) if text.lower().startswith("0x") else int(text, 10)
        except ValueError:
            raise ValueError(f"device id {text!r} is not an integer (decimal or 0x-hex)") from None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"device id must be an integer, got {value!r}")
    value = int(value)
    if not 0 <= value <= DEVICE_ID_MAX:
        raise ValueError(f"device id {value} is outside 0..{DEVICE_ID_MAX} (0..0xFFFFFFFF, the recorder's uint32)")
    return value


@dataclass(frozen=True)
class DeviceUnit:
    """The stable constants of one unit (SI; b = sensor body frame; ``y = M x`` at T0)."""

    device_id: int
    M_a: np.ndarray  # (3, 3) accelerometer sensitivity and cross-axis
    M_g: np.ndarray  # (3, 3) gyroscope
    acc_bias_mean_mps2: np.ndarray  # (3,) mean turn-on bias at T0
    gyro_bias_mean_radps: np.ndarray  # (3,)
    acc_bias_repeat_sigma_mps2: np.ndarray  # (3,) per-power-on sigma around the mean
    gyro_bias_repeat_sigma_radps: float
    acc_bias_tempco_mps2_per_degc: np.ndarray  # (3,)
    gyro_bias_tempco_radps_per_degc: np.ndarray  # (3,)
    acc_scale_tempco_per_degc: np.ndarray  # (3,) relative sensitivity change per C
    gyro_scale_tempco_per_degc: np.ndarray  # (3,)
    clock_error: float  # device clock = true time (1 + clock_error)
    t_reference_degc: float = T_REFERENCE_DEGC

    def to_dict(self) -> dict:
        d = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.__dict__.items()}
        d["device_id_hex"] = f"0x{self.device_id:08X}"
        return d


def draw_unit(device_id, profile, model: DeviceModel = DeviceModel()) -> DeviceUnit:
    """The unit ``device_id`` of ``profile`` (an ``imu_model.SensorProfile``): a function of the id alone.

    The sigmas of scale, cross-axis, turn-on bias and clock are the profile's (so ``mpu6050-noise-only`` has
    none); a profile without turn-on bias (or scale) error has no bias (or sensitivity) temperature
    coefficient either. The draw order is fixed; changing it changes every device.
    """
    did = parse_device_id(device_id)
    rng = np.random.default_rng([DEVICE_SALT, did])
    p = profile
    g = STANDARD_GRAVITY
    rs = math.sqrt(1.0 - model.repeat_fraction**2)

    M_a = misalignment_matrix(rng, p.accel_scale_sigma, p.accel_cross_axis_sigma)
    M_g = misalignment_matrix(rng, p.gyro_scale_sigma, p.gyro_cross_axis_sigma)
    sig_a = np.asarray(p.accel_turn_on_bias_sigma_mg, dtype=float) * 1e-3 * g
    sig_g = math.radians(p.gyro_turn_on_bias_sigma_dps)
    b_a = rng.normal(0.0, 1.0, 3) * sig_a * rs
    b_g = rng.normal(0.0, 1.0, 3) * sig_g * rs
    has_a, has_g = bool(np.any(sig_a > 0)), sig_g > 0
    k_a = rng.normal(0.0, 1.0, 3) * np.asarray(model.accel_bias_tempco_sigma_mg_per_degc) * 1e-3 * g * has_a
    k_g = rng.normal(0.0, 1.0, 3) * math.radians(model.gyro_bias_tempco_sigma_dps_per_degc) * has_g
    s_a = rng.normal(0.0, 1.0, 3) * model.accel_scale_tempco_sigma_per_degc * (p.accel_scale_sigma > 0)
    s_g = rng.normal(0.0, 1.0, 3) * model.gyro_scale_tempco_sigma_per_degc * (p.gyro_scale_sigma > 0)
    clock = float(rng.normal() * p.clock_error_ppm_sigma * 1e-6)
    return DeviceUnit(did, M_a, M_g, b_a, b_g, sig_a * model.repeat_fraction, sig_g * model.repeat_fraction,
                      k_a, k_g, s_a, s_g, clock)
