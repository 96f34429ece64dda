"""MPU6050 register facts: full-scale codes, sensitivities and conversions to SI.

Source: InvenSense MPU-6000/6050 Register Map rev 4.2 (ACCEL_CONFIG 0x1C, GYRO_CONFIG 0x1B,
TEMP_OUT 0x41: T = raw/340 + 36.53 degC). Sensitivities are exact powers of two for the
accelerometer and rounded datasheet values for the gyro (131, 65.5, 32.8, 16.4 LSB/(deg/s)).
"""

from __future__ import annotations

import math

from bootnav.core.conventions import STANDARD_GRAVITY_MPS2

STANDARD_GRAVITY = STANDARD_GRAVITY_MPS2  # m/s^2, used for g -> m/s^2 everywhere (bootnav.core.conventions)

ACCEL_RANGE_G = {0: 2, 1: 4, 2: 8, 3: 16}  # AFS_SEL code -> +-g
ACCEL_LSB_PER_G = {0: 16384.0, 1: 8192.0, 2: 4096.0, 3: 2048.0}
GYRO_RANGE_DPS = {0: 250, 1: 500, 2: 1000, 3: 2000}  # FS_SEL code -> +-deg/s
GYRO_LSB_PER_DPS = {0: 131.0, 1: 65.5, 2: 32.8, 3: 16.4}
TEMP_LSB_PER_DEGC = 340.0
TEMP_OFFSET_DEGC = 36.53
INT16_MIN, INT16_MAX = -32768, 32767


def accel_code(range_g: float) -> int:
    for code, r in ACCEL_RANGE_G.items():
        if r == range_g:
            return code
    raise ValueError(f"MPU6050 accelerometer range must be one of 2/4/8/16 g, got {range_g}")


def gyro_code(range_dps: float) -> int:
    for code, r in GYRO_RANGE_DPS.items():
        if r == range_dps:
            return code
    raise ValueError(f"MPU6050 gyro range must be one of 250/500/1000/2000 deg/s, got {range_dps}")


def accel_scale_mps2(code: int) -> float:
    """m/s^2 per LSB for AFS_SEL ``code``."""
    return STANDARD_GRAVITY / ACCEL_LSB_PER_G[code]


def gyro_scale_radps(code: int) -> float:
    """rad/s per LSB for FS_SEL ``code``."""
    return math.radians(1.0) / GYRO_LSB_PER_DPS[code]


def temp_counts_to_degc(counts):
    return counts / TEMP_LSB_PER_DEGC + TEMP_OFFSET_DEGC
