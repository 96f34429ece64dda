"""Linear frequency/variance model, [NKUA2009, §5.5] (its general model [21], probably Ladetto 2000):

    L = A + B f + C var + w,   w ~ N(0, sigma)

A, B, C come from linear least squares (``fit``). The thesis gives no values; the defaults are the
[Bayindir2014, Table 2] constants of the same form (A = gamma = 0.22 m, B = alpha = 0.2 m/Hz, C = beta = 0.01)
[borrowed], with ``var`` = variance of |a| in m^2/s^4 (the unit that matches beta's printed s^4/m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.length.base import StepLengthModel, register


@register("ladetto")
@dataclass
class LadettoLength(StepLengthModel):
    a: float = 0.22
    b: float = 0.2
    c: float = 0.01

    def estimate(self, feat) -> np.ndarray:
        return self.a + self.b * feat.freq_hz + self.c * feat.mag_var

    def fit(self, feat, true_length_m) -> "LadettoLength":
        """Least-squares A, B, C from steps with known length (per-user calibration, [NKUA2009, §5.4])."""
        X = np.column_stack([np.ones(len(feat)), feat.freq_hz, feat.mag_var])
        (self.a, self.b, self.c), *_ = np.linalg.lstsq(X, np.asarray(true_length_m, float), rcond=None)
        return self
