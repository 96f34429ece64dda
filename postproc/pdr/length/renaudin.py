"""Height–frequency model (Renaudin, Susi, Lachapelle 2012), [Bayindir2014, eq. 4]:

    L = h (a f + b) + c,   h = 1.83 m, a = 0.13 s, b = 0.13, c = 0.1 m   [literal Table 2]

f = 1 / step duration (the Turkish paper does not say; Renaudin used an STFT) [engineered]."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.length.base import StepLengthModel, register


@register("renaudin")
@dataclass
class RenaudinLength(StepLengthModel):
    height_m: float = 1.83
    a: float = 0.13
    b: float = 0.13
    c: float = 0.1

    def estimate(self, feat) -> np.ndarray:
        return self.height_m * (self.a * np.asarray(feat.freq_hz) + self.b) + self.c
