"""Step-and-heading table from a foot-mounted INS (ZUPT) trajectory, so foot and waist/phone PDR compare on
one recording. Plain arrays in, no dependency on bootnav.postproc.pipeline.

For a foot sensor one "step" is a stride (one stance phase to the next, METRICS.md). With stance phases
k = 0..K (contiguous runs of stance = True) and p_k = mean horizontal position over stance phase k:

    stride k (k >= 1):  t_k = start time of stance phase k (initial contact),
                        length_k = ||p_k - p_{k-1}||_xy,  yaw_k = atan2(dN, dE)  (yaw_enu_rad, ccw from E)

Stance phases closer than ``min_stride_m`` to the previous kept one (standing still, weight shifts, a
stance split by a noisy detector) are merged into it: they are not strides.
"""

from __future__ import annotations

import numpy as np

from bootnav.core.runs import runs


def steps_from_foot_ins(t_s, pos_n, stance, min_stance_samples: int = 3, min_stride_m: float = 0.1) -> dict:
    """Returns dict with t_s, length_m, yaw_enu_rad, x_m, y_m (positions at the end of each stride)."""
    t = np.asarray(t_s, float)
    p = np.asarray(pos_n, float)
    a, b = runs(stance, min_samples=min_stance_samples)
    if a.size < 2:
        z = np.zeros(0)
        return {"t_s": z, "length_m": z, "yaw_enu_rad": z, "x_m": z, "y_m": z}
    pk = np.array([p[i:j, :2].mean(axis=0) for i, j in zip(a, b)])
    keep = [0]
    for k in range(1, len(pk)):  # loop over stance phases (tens to hundreds), not samples
        if np.hypot(*(pk[k] - pk[keep[-1]])) >= min_stride_m:
            keep.append(k)
    a, pk = a[keep], pk[keep]
    d = np.diff(pk, axis=0)
    return {
        "t_s": t[a[1:]],
        "length_m": np.hypot(d[:, 0], d[:, 1]),
        "yaw_enu_rad": np.arctan2(d[:, 1], d[:, 0]),
        "x_m": pk[1:, 0] - pk[0, 0],
        "y_m": pk[1:, 1] - pk[0, 1],
    }
