"""The source paper's stance indicator [Heidari2019, §2.2 and §4]: "a threshold obtained experimentally:
whenever the acceleration is below the threshold the indicator is one". Read as the gravity-free
acceleration magnitude, sample by sample (no window)::

    T_k = | ‖f_k‖ − f_rest |,   stance ⇔ T_k < threshold (m/s²)

f_rest is the magnitude this sensor reads at rest (``_paper.rest_magnitude``), the paper's "gravity
effect" as the sensor sees it: an MPU6050's turn-on bias and scale error put its rest ‖f‖ up to ≈ 1 m/s²
away from the local g, more than its stance noise (≈ 0.03 m/s²), so | ‖f‖ − g | would be no indicator at
all. The threshold is read off the recording and short runs are cleaned as the paper's Chart 1 implies
(``_paper``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.core.arrays import row_norm
from ._paper import PaperRule, rest_magnitude
from .base import ThresholdDetector, register


def paper_accmag_statistic(acc_b: np.ndarray, rest_mps2: float) -> np.ndarray:
    """| ‖f_k‖ − rest_mps2 | (N,), m/s²."""
    return np.abs(row_norm(acc_b) - rest_mps2)


@register("paper_accmag")
@dataclass(kw_only=True)
class PaperAccMagDetector(PaperRule, ThresholdDetector):
    """The source paper's threshold on | |f| - f_rest |, sample by sample, no window [Heidari2019]

    threshold: in m/s²; None (default) -> Otsu's split of log10 T of this recording (``_paper``): the
        paper gives no value ("obtained experimentally"). The x-io template the paper resembles uses
        0.05 g = 0.49 m/s² on a filtered magnitude (``xio``).
    min_stance_s, min_swing_s: 0.1 s and 0.2 s. A sample-wise test passes wherever ‖f‖ crosses f_rest
        in mid-swing, for a few samples; those runs go first, then gaps shorter than a swing are filled.
    """

    DEFAULT_THRESHOLD = None

    min_stance_s: float = 0.1
    min_swing_s: float = 0.2

    def statistic(self, acc_b, gyro_b, dt):
        return paper_accmag_statistic(acc_b, rest_magnitude(acc_b, dt))
