"""SHOE: the stance hypothesis optimal (GLRT) detector (seed-004 eq. 2).

Skog, Händel, Nilsson, Rantakokko, "Zero-velocity detection — an algorithm evaluation", IEEE Trans.
Biomed. Eng. 57(11), 2010, eq. (9); OpenShoe ``zero_velocity_detector.m`` function GLRT. Over a window
W_k of N samples centred on k (squared form, the derivation's)::

    T_k = (1/N) Σ_{λ∈W_k} [ ‖f_λ − g f̄_k/‖f̄_k‖‖² / σ_a²  +  ‖ω_λ‖² / σ_ω² ],   stance ⇔ T_k < γ

f̄_k = window mean of the specific force. Vectorised with the identity
Σ‖f_λ − g u‖² = N (mean‖f‖² − 2 g ‖f̄‖ + g²) for the unit vector u = f̄/‖f̄‖.

``literal=True`` evaluates the paper's printed variant (seed-004 §2.2, "[DEC]"): un-squared σ's and an
un-squared acceleration norm::

    T_k = (1/N) Σ_{λ∈W_k} [ ‖f_λ − g f̄_k/‖f̄_k‖‖ / σ_a  +  ‖ω_λ‖² / σ_ω ]

(computed with a loop over the N window offsets, vectorised over samples).
"""

from __future__ import annotations

import numpy as np

from ._common import moving_mean


def shoe_statistic(acc_b: np.ndarray, gyro_b: np.ndarray, n: int, sigma_acc: float, sigma_gyro: float,
                   gravity: float, *, literal: bool = False) -> np.ndarray:
    acc_b = np.asarray(acc_b, dtype=np.float64)
    gyro_b = np.asarray(gyro_b, dtype=np.float64)
    f_mean = moving_mean(acc_b, n)
    f_mean_norm = np.linalg.norm(f_mean, axis=1)
    w2 = np.einsum("ij,ij->i", gyro_b, gyro_b)
    if not literal:
        a2 = moving_mean(np.einsum("ij,ij->i", acc_b, acc_b), n)
        acc_term = np.maximum(a2 - 2.0 * gravity * f_mean_norm + gravity**2, 0.0)
        return acc_term / sigma_acc**2 + moving_mean(w2, n) / sigma_gyro**2
    u = f_mean / np.where(f_mean_norm > 0, f_mean_norm, 1.0)[:, None]
    acc_sum = np.zeros(acc_b.shape[0])
    half = n // 2
    idx = np.arange(acc_b.shape[0])
    for off in range(-half, n - half):  # loop over window offsets only (N is a handful of samples)
        j = np.clip(idx + off, 0, acc_b.shape[0] - 1)
        acc_sum += np.linalg.norm(acc_b[j] - gravity * u, axis=1)
    return acc_sum / n / sigma_acc + moving_mean(w2, n) / sigma_gyro
