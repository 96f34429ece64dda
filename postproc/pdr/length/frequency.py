"""Frequency–step model, [Bayindir2014, eq. 3] (after Li et al., Leppäkoski et al.):  L = a f + b,
a = 0.22 m/Hz, b = 0.28 m [literal Table 2]; f = 1 / step duration [inferred]."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.length.base import StepLengthModel, register


@register("frequency")
@dataclass
class FrequencyLength(StepLengthModel):
    a: float = 0.22
    b: float = 0.28

    def estimate(self, feat) -> np.ndarray:
        return self.a * np.asarray(feat.freq_hz) + self.b
