"""ARED: angular rate energy detector (Skog et al. 2010, eq. (12))::

    T_k = (1/N) Σ_{λ∈W_k} ‖ω_λ‖² / σ_ω²,   stance ⇔ T_k < γ
"""

from __future__ import annotations

import numpy as np

from ._common import moving_mean


def ared_statistic(gyro_b: np.ndarray, n: int, sigma_gyro: float) -> np.ndarray:
    gyro_b = np.asarray(gyro_b, dtype=np.float64)
    return moving_mean(np.einsum("ij,ij->i", gyro_b, gyro_b), n) / sigma_gyro**2
