"""MV: acceleration moving variance detector [Skog2010, eq. 10]::

    T_k = (1/N) Σ_{λ∈W_k} ‖f_λ − f̄_k‖² / σ_a²,   stance ⇔ T_k < γ

computed as (mean‖f‖² − ‖f̄‖²)/σ_a² with centred moving means.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.core.arrays import moving_mean
from .base import WindowedDetector, register


def mv_statistic(acc_b: np.ndarray, n: int, sigma_acc: float) -> np.ndarray:
    """MV statistic T (N,) over a centred window of ``n`` samples."""
    acc_b = np.asarray(acc_b, dtype=np.float64)
    f_mean = moving_mean(acc_b, n)
    a2 = moving_mean(np.einsum("ij,ij->i", acc_b, acc_b), n)
    return np.maximum(a2 - np.einsum("ij,ij->i", f_mean, f_mean), 0.0) / sigma_acc**2


@register("mv")
@dataclass(kw_only=True)
class MvDetector(WindowedDetector):
    """MV: moving variance of the specific force over a window [Skog2010]

    sigma_acc_mps2: σ_a, the accelerometer noise weight (0.01 m/s² as for SHOE).
    threshold: γ, dimensionless; default 3e2 with the default σ_a and window, the best single value over
        the developer recordings (pre-LODO; docs/tuning-log.md).
    """

    DEFAULT_THRESHOLD = 3e2

    sigma_acc_mps2: float = 0.01

    def statistic(self, acc_b, gyro_b, dt):
        return mv_statistic(acc_b, self.window(dt), self.sigma_acc_mps2)

    def _info(self) -> dict:
        return {"sigma_acc_mps2": self.sigma_acc_mps2}
