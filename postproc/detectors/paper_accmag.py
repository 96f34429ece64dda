"""The paper's implemented stance indicator (seed-004 §2.2 and §4, "[LIT]"): "a threshold obtained
experimentally: whenever the acceleration is below the threshold the indicator is one". Read as the
gravity-free acceleration magnitude, sample by sample (no window)::

    T_k = | ‖f_k‖ − g |,   stance ⇔ T_k < threshold_mps2

The paper gives no value; the default 0.3 m/s² is the best single value on the developer recordings
(benchmarks/tune_detectors.py); the x-io template the paper resembles uses 0.05 g = 0.49 m/s² on a
filtered magnitude (xio.py).
"""

from __future__ import annotations

import numpy as np


def paper_accmag_statistic(acc_b: np.ndarray, gravity: float) -> np.ndarray:
    return np.abs(np.linalg.norm(np.asarray(acc_b, dtype=np.float64), axis=1) - gravity)
