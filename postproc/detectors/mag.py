"""MAG: acceleration magnitude detector (Skog et al. 2010, eq. (11))::

    T_k = (1/N) Σ_{λ∈W_k} (‖f_λ‖ − g)² / σ_a²,   stance ⇔ T_k < γ
"""

from __future__ import annotations

import numpy as np

from ._common import moving_mean


def mag_statistic(acc_b: np.ndarray, n: int, sigma_acc: float, gravity: float) -> np.ndarray:
    return moving_mean((np.linalg.norm(np.asarray(acc_b, dtype=np.float64), axis=1) - gravity) ** 2, n) / sigma_acc**2
