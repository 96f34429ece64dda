"""MAG: acceleration magnitude detector [Skog2010, eq. 11]::

    T_k = (1/N) Σ_{λ∈W_k} (‖f_λ‖ − g)² / σ_a²,   stance ⇔ T_k < γ
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.core.arrays import moving_mean, row_norm
from .base import WindowedDetector, register


def mag_statistic(acc_b: np.ndarray, n: int, sigma_acc: float, gravity: float) -> np.ndarray:
    """MAG statistic T (N,) over a centred window of ``n`` samples."""
    return moving_mean((row_norm(acc_b) - gravity) ** 2, n) / sigma_acc**2


@register("mag")
@dataclass(kw_only=True)
class MagDetector(WindowedDetector):
    """MAG: (|f| - g)^2 of the specific force over a window [Skog2010]

    sigma_acc_mps2: σ_a, the accelerometer noise weight (0.01 m/s² as for SHOE).
    threshold: γ, dimensionless; default 1e2 with the default σ_a and window, the best single value over
        the developer recordings (pre-LODO; docs/tuning-log.md).
    """

    DEFAULT_THRESHOLD = 1e2

    sigma_acc_mps2: float = 0.01

    def statistic(self, acc_b, gyro_b, dt):
        return mag_statistic(acc_b, self.window(dt), self.sigma_acc_mps2, self.gravity_mps2)

    def _info(self) -> dict:
        return {"sigma_acc_mps2": self.sigma_acc_mps2}
