"""Frequency–variance (activity) model, [Bayindir2014, eqs. 5–6] (after Shin, Lee, Ladetto):

    v = sqrt((1/N) sum (a(i) - a_m)^2)          (eq. 5: a standard deviation of |a| over the step)
    L = alpha f + beta v + gamma,  alpha = 0.2 m/Hz, beta = 0.01, gamma = 0.22 m   [literal Table 2]

Quirk: eq. 5 is a standard deviation, but beta's printed unit (s^4/m) needs a variance.
``v_mode="std"`` follows eq. 5 literally (default); ``"var"`` matches the unit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.length.base import StepLengthModel, register


@register("frequency_variance")
@dataclass
class FrequencyVarianceLength(StepLengthModel):
    alpha: float = 0.2
    beta: float = 0.01
    gamma: float = 0.22
    v_mode: str = "std"

    def estimate(self, feat) -> np.ndarray:
        v = feat.mag_std_mps2 if self.v_mode == "std" else feat.mag_var
        return self.alpha * np.asarray(feat.freq_hz) + self.beta * v + self.gamma
