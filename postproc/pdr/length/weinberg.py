"""Fourth-root (Weinberg) step length, [NKUA2009, §5.2]:

    L = K (A_max - A_min)^(1/4)

A_max, A_min = max/min vertical acceleration during the step. Literal K = 0.95 (the C# code), applied to
the range in g (the unit that makes 0.95 plausible, [NKUA2009, appendix code Π2] [reconstructed]); the
thesis text suggests
K ~ 0.55 (``K_TEXT``); Table 5.2.1 per-user values 0.50 / 0.55 / 0.57 (``K_TABLE_5_2_1``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.length.base import StepLengthModel, register
from bootnav.postproc.pdr.signals import G0

K_CODE = 0.95
K_TEXT = 0.55
K_TABLE_5_2_1 = {"A": 0.50, "B": 0.55, "C": 0.57}  # leg lengths 0.94, 1.06, 1.08 m


def weinberg(delta_a, k: float = K_CODE) -> np.ndarray:
    """L = k * delta_a ** 0.25 (delta_a in the unit k was fitted for)."""
    return k * np.power(np.maximum(np.asarray(delta_a, float), 0.0), 0.25)


@register("weinberg")
@dataclass
class WeinbergLength(StepLengthModel):
    k: float = K_CODE
    acc_unit: str = "g"

    def estimate(self, feat) -> np.ndarray:
        d = feat.vert_range_mps2 / (G0 if self.acc_unit == "g" else 1.0)
        return weinberg(d, self.k)

    def fit(self, feat, true_length_m) -> "WeinbergLength":
        """Least-squares K from steps of known length (per-user K, [NKUA2009, Table 5.2.1 / §5.4])."""
        d = weinberg(feat.vert_range_mps2 / (G0 if self.acc_unit == "g" else 1.0), 1.0)
        self.k = float(np.dot(d, true_length_m) / max(np.dot(d, d), 1e-12))
        return self
