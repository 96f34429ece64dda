"""ARED: angular rate energy detector [Skog2010, eq. 12]::

    T_k = (1/N) Σ_{λ∈W_k} ‖ω_λ‖² / σ_ω²,   stance ⇔ T_k < γ
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bootnav.core.arrays import moving_mean
from .base import WindowedDetector, register


def ared_statistic(gyro_b: np.ndarray, n: int, sigma_gyro: float) -> np.ndarray:
    """ARED statistic T (N,) over a centred window of ``n`` samples."""
    gyro_b = np.asarray(gyro_b, dtype=np.float64)
    return moving_mean(np.einsum("ij,ij->i", gyro_b, gyro_b), n) / sigma_gyro**2


@register("ared")
@dataclass(kw_only=True)
class AredDetector(WindowedDetector):
    """ARED: angular-rate energy over a window [Skog2010]

    sigma_gyro_radps: σ_ω, the gyro noise weight (0.1 °/s as for SHOE).
    threshold: γ, dimensionless; default 3e5 with the default σ_ω and window, the best single value over
        the developer recordings (pre-LODO; docs/tuning-log.md).
    """

    DEFAULT_THRESHOLD = 3e5

    sigma_gyro_radps: float = math.radians(0.1)

    def statistic(self, acc_b, gyro_b, dt):
        return ared_statistic(gyro_b, self.window(dt), self.sigma_gyro_radps)

    def _info(self) -> dict:
        return {"sigma_gyro_radps": self.sigma_gyro_radps}
