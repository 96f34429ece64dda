"""MV: acceleration moving variance detector (Skog et al. 2010, eq. (10))::

    T_k = (1/N) Σ_{λ∈W_k} ‖f_λ − f̄_k‖² / σ_a²,   stance ⇔ T_k < γ

computed as (mean‖f‖² − ‖f̄‖²)/σ_a² with centred moving means.
"""

from __future__ import annotations

import numpy as np

from ._common import moving_mean


def mv_statistic(acc_b: np.ndarray, n: int, sigma_acc: float) -> np.ndarray:
    acc_b = np.asarray(acc_b, dtype=np.float64)
    f_mean = moving_mean(acc_b, n)
    a2 = moving_mean(np.einsum("ij,ij->i", acc_b, acc_b), n)
    return np.maximum(a2 - np.einsum("ij,ij->i", f_mean, f_mean), 0.0) / sigma_acc**2
