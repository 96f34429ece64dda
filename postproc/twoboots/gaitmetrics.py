"""Walker path and per-stride gait figures of two fused feet.

* **Walker path**: the midpoint of the two foot sensors, on the left foot's sample times (the right foot's
  position interpolated linearly in time).
* **Strides** of each foot: ``bootnav.postproc.strides.segment_strides`` on the fused path (one definition).
* **Step width** of a footprint: its horizontal distance from the line through the two footprints of the
  other foot that bracket it in time (the standard gait-lab definition: the distance between the feet
  perpendicular to the direction of progression); only when the bracketing footprints are one stride of the
  other foot (not across a pause or a turn on the spot: both within ``max_stride_time_s`` and at least
  ``min_stride_m`` apart). Sign: positive when the right foot is right of the left foot's line of
  progression (or the left foot left of the right foot's), i.e. the feet are not crossed. A step width
  from two foot-mounted INS is only as good as their relative heading: an error of δψ shifts the feet
  apart by δψ × the distance walked since the last correction, and the separation bound corrects nothing
  while the feet stay closer than γ, so read it on short walks or as a variability figure [Rebula2013].
"""

from __future__ import annotations

import numpy as np

from bootnav.postproc.strides import footprints, segment_strides


def walker_path(t_left: np.ndarray, pos_left: np.ndarray, t_right: np.ndarray, pos_right: np.ndarray) -> np.ndarray:
    """Midpoint of the two feet (N_left, 3), m, at ``t_left``."""
    pr = np.column_stack([np.interp(t_left, t_right, pos_right[:, j]) for j in range(3)])
    return 0.5 * (np.asarray(pos_left, float) + pr)


def step_widths(t_a: np.ndarray, fp_a: np.ndarray, t_b: np.ndarray, fp_b: np.ndarray, side: float,
                min_stride_m: float, max_stride_time_s: float) -> np.ndarray:
    """Step width (m) of every footprint of foot A against foot B's progression line; NaN where undefined.

    ``side`` = +1 when A is the right foot (right of B's line is positive), −1 when A is the left foot.
    """
    out = np.full(len(t_a), np.nan)
    if len(t_b) < 2 or len(t_a) == 0:
        return out
    j = np.searchsorted(t_b, t_a) - 1
    ok = (j >= 0) & (j < len(t_b) - 1)
    idx = np.flatnonzero(ok)
    j = j[ok]
    b0, b1 = fp_b[j, :2], fp_b[j + 1, :2]
    line = b1 - b0
    length = np.hypot(line[:, 0], line[:, 1])
    good = (length >= min_stride_m) & (t_b[j + 1] - t_b[j] <= max_stride_time_s)
    rel = fp_a[idx, :2] - b0
    cross = line[:, 0] * rel[:, 1] - line[:, 1] * rel[:, 0]  # > 0: A left of B's direction of travel
    with np.errstate(invalid="ignore", divide="ignore"):
        w = -side * cross / length
    out[idx[good]] = w[good]
    return out


def gait_table(left: dict, right: dict, min_stride_m: float, max_stride_time_s: float = 2.0,
               floors=None, floor_z: dict | None = None) -> dict:
    """Per-foot strides with their step width.

    Parameters
    ----------
    left, right
        ``{"t_s", "pos_n", "stance"}`` of each fused foot.
    min_stride_m
        Shorter moves are not strides (``ProcessSettings.selftune.min_stride_m``).
    max_stride_time_s
        Longest time between two footprints of one stride (a pause in between is not a stride), s.
    floors
        ``FloorSettings`` of the ``floor`` column (None: the defaults).
    floor_z
        Optional ``{"left": (K,), "right": (K,)}`` height per stance phase to count floors from
        (``segment_strides``' ``floor_z``: the storeys' numbers).

    Returns
    -------
    dict
        ``{"left": steps, "right": steps}``, each the ``segment_strides`` dict plus ``step_width_m``.
    """
    fps = {k: footprints(np.asarray(v["t_s"], float), np.asarray(v["pos_n"], float), v["stance"])
           for k, v in (("left", left), ("right", right))}
    out = {}
    for name, other, side in (("left", "right", -1.0), ("right", "left", 1.0)):
        src = left if name == "left" else right
        steps = segment_strides(src["t_s"], src["pos_n"], src["stance"], min_stride_m, floors=floors,
                                floor_z=(floor_z or {}).get(name))
        t_fp, fp = fps[name]
        width = step_widths(t_fp, fp, *fps[other], side, min_stride_m, max_stride_time_s)
        k = np.searchsorted(t_fp, steps["t_s"])  # the footprint ending each stride
        steps["step_width_m"] = width[np.clip(k, 0, max(len(width) - 1, 0))] if len(width) else np.zeros(0)
        out[name] = steps
    return out
