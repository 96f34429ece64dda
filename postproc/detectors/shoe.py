"""SHOE: the stance hypothesis optimal (GLRT) detector [Skog2010, eq. 9], the source paper's eq. 2
[Heidari2019, eq. 2]; OpenShoe ``zero_velocity_detector.m``, function GLRT [Nilsson2012]. Over a window
W_k of N samples centred on k (squared form, the derivation's)::

    T_k = (1/N) Σ_{λ∈W_k} [ ‖f_λ − g f̄_k/‖f̄_k‖‖² / σ_a²  +  ‖ω_λ‖² / σ_ω² ],   stance ⇔ T_k < γ

f̄_k = window mean of the specific force. Vectorised with the identity
Σ‖f_λ − g u‖² = N (mean‖f‖² − 2 g ‖f̄‖ + g²) for the unit vector u = f̄/‖f̄‖.

``literal=True`` evaluates the paper's printed variant [Heidari2019, eq. 2, as printed]: un-squared σ's and
an un-squared acceleration norm::

    T_k = (1/N) Σ_{λ∈W_k} [ ‖f_λ − g f̄_k/‖f̄_k‖‖ / σ_a  +  ‖ω_λ‖² / σ_ω ]

(computed with a loop over the N window offsets, vectorised over samples). The registry entry
``shoe-literal`` is that form as the paper used it: its threshold read off each recording and one stance
block per step (``_paper``); ``shoe`` with ``literal_paper_form`` keeps a fixed threshold.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bootnav.core.arrays import moving_mean, row_norm
from ._paper import PaperRule
from .base import WindowedDetector, register


def shoe_statistic(acc_b: np.ndarray, gyro_b: np.ndarray, n: int, sigma_acc: float, sigma_gyro: float,
                   gravity: float, *, literal: bool = False) -> np.ndarray:
    """SHOE statistic T (N,) over a centred window of ``n`` samples (module docstring)."""
    acc_b = np.asarray(acc_b, dtype=np.float64)
    gyro_b = np.asarray(gyro_b, dtype=np.float64)
    f_mean = moving_mean(acc_b, n)
    f_mean_norm = row_norm(f_mean)
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
        acc_sum += row_norm(acc_b[j] - gravity * u)
    return acc_sum / n / sigma_acc + moving_mean(w2, n) / sigma_gyro


@register("shoe")
@dataclass(kw_only=True)
class ShoeDetector(WindowedDetector):
    """SHOE / GLRT: specific force off gravity plus angular-rate energy over a window [Skog2010]

    sigma_acc_mps2, sigma_gyro_radps: σ_a, σ_ω, the noise weights of the two terms (OpenShoe/pyshoe:
        0.01 m/s², 0.1 °/s [Nilsson2012, Wagstaff2017]).
    literal_paper_form: evaluate the paper's printed form instead of the squared one (module docstring).
    threshold: γ, dimensionless (T is a sum of squared, σ-normalised residuals). Default 3e5 for the
        squared form with the default σ's and window, 1e3 for the printed form: the best single values
        over the developer recordings (pre-LODO; docs/tuning-log.md). pyshoe's published G = 8.5e7
        [Wagstaff2017] belongs to σ_a = 0.00098 m/s², σ_ω = 8.7266e-5 rad/s (0.005 °/s), not to these σ's.
    """

    DEFAULT_THRESHOLD = 3e5
    DEFAULT_THRESHOLD_LITERAL = 1e3

    sigma_acc_mps2: float = 0.01
    sigma_gyro_radps: float = math.radians(0.1)
    literal_paper_form: bool = False

    def default_threshold(self) -> float:
        return self.DEFAULT_THRESHOLD_LITERAL if self.literal_paper_form else self.DEFAULT_THRESHOLD

    def statistic(self, acc_b, gyro_b, dt):
        return shoe_statistic(acc_b, gyro_b, self.window(dt), self.sigma_acc_mps2, self.sigma_gyro_radps,
                              self.gravity_mps2, literal=self.literal_paper_form)

    def _info(self) -> dict:
        return {"sigma_acc_mps2": self.sigma_acc_mps2, "sigma_gyro_radps": self.sigma_gyro_radps,
                "form": "literal_paper" if self.literal_paper_form else "squared"}


@register("shoe-literal")
@dataclass(kw_only=True)
class ShoeLiteralDetector(PaperRule, WindowedDetector):
    """The paper's eq. 2 as printed, threshold read off the recording, one stance block per step [Heidari2019]

    sigma_acc_mps2, sigma_gyro_radps: σ_a, σ_ω as in ``shoe``.
    threshold: γ of the printed statistic; None (default) -> Otsu's split of log10 T of this recording
        (``_paper.log_otsu_threshold``): the paper's "threshold obtained experimentally", whose value it
        does not give; the printed statistic's rest level moves with the sensor's noise and scale error
        (≈ 6-110 on simulated MPU6050s, seeds 0-2), so no single number fits.
    min_stance_s, min_swing_s: 0.05 s and 0.2 s: shorter quiet runs are dips inside a swing, shorter
        gaps are impacts inside a stance; the paper's Chart 1 shows one block per step (``_paper``).
    """

    DEFAULT_THRESHOLD = None

    sigma_acc_mps2: float = 0.01
    sigma_gyro_radps: float = math.radians(0.1)
    min_stance_s: float = 0.05
    min_swing_s: float = 0.2

    def statistic(self, acc_b, gyro_b, dt):
        return shoe_statistic(acc_b, gyro_b, self.window(dt), self.sigma_acc_mps2, self.sigma_gyro_radps,
                              self.gravity_mps2, literal=True)

    def _info(self) -> dict:
        return {"sigma_acc_mps2": self.sigma_acc_mps2, "sigma_gyro_radps": self.sigma_gyro_radps,
                "form": "literal_paper"}
