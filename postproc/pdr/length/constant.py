"""Constant step lengths.

* FootPath ([Bayindir2014, eq. 2]):  L = 0.415 h,  h = 1.83 m [literal Table 2] -> 0.75945 m.
* Constant ([NKUA2009, §5.1]): L = 0.5 m [literal example].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.length.base import StepLengthModel, register


@register("footpath")
@dataclass
class FootPathLength(StepLengthModel):
    height_m: float = 1.83
    k: float = 0.415

    def estimate(self, feat) -> np.ndarray:
        return np.full(len(feat), self.k * self.height_m)

    def fit(self, feat, true_length_m) -> "FootPathLength":
        """k = mean true step length / height (the user's own ratio instead of 0.415)."""
        self.k = float(np.mean(true_length_m)) / self.height_m
        return self


@register("constant")
@dataclass
class ConstantLength(StepLengthModel):
    length_m: float = 0.5

    def estimate(self, feat) -> np.ndarray:
        return np.full(len(feat), self.length_m)

    def fit(self, feat, true_length_m) -> "ConstantLength":
        """The user's mean step length ([NKUA2009, §5.1]: "entering a per-user mean could help")."""
        self.length_m = float(np.mean(true_length_m))
        return self
