"""Samples as increments: the two-sample sculling and coning corrections of a strapdown step [Savage1998].

Why: a rate sensor's output at a few hundred hertz is the average of its fast internal samples over the
output interval (the DLPF / accumulate-and-dump stage; a block mean when a recording is decimated), i.e. an
angle increment Δθ_k = ω_k Δt and a velocity increment Δv_k = f_k Δt in the body frame, whose orientation
changes during the interval. A strapdown step that treats them as constant over the interval makes three
errors, each growing as the interval lengthens (a foot swings at up to 10 rad/s: ωΔt = 0.1 rad at 100 Hz):

1. rotation compensation, ½ Δθ_k × Δv_k (first order): the specific force belongs to the middle of the
   interval, not to its end. ``FilterSettings.strapdown`` "midpoint" and "increments" rotate f_b with the
   attitude at the middle of the step (``mechanization.py``, in the kernels);
2. sculling (second order): the part of the velocity increment that comes from f and ω varying together
   within the interval. With the previous sample's increments it is estimated, for f and ω linear over the
   two intervals, as (the two-sample form [Savage1998])::

       δv_k = (1/12) (Δθ_{k−1} × Δv_k + Δv_{k−1} × Δθ_k)
       ⇒  f_k' = f_k + (Δt'/12) (ω_{k−1} × f_k + f_{k−1} × ω_k)

3. coning (second order): the non-commutativity of the rotation within the interval [Savage1998a],
   δθ_k = (1/12) Δθ_{k−1} × Δθ_k  ⇒  ω_k' = ω_k + (Δt'/12) ω_{k−1} × ω_k.

Δt' = min(Δt_{k−1}, Δt_k): the two-sample form assumes two adjacent intervals of one length; after a gap
(``bootnav.core.timebase``) the shorter one bounds the correction, and a duplicate timestamp (Δt = 0) gives
none. The first sample of a record (no previous one) is left as it is (a foot recording starts at rest).

"increments" (the default of ``FilterSettings.strapdown``) applies 2 and 3 to every sample before the
kernel (both engines, every chunking: ``stream.StreamNavigator`` keeps the previous sample), 1 in the kernel.
On exact simulated foot data block-averaged from 800 Hz the final height of a level loop then stays within
a few millimetres at 800 / 200 / 100 Hz (``tests/test_ins_increments.py``; figures in docs/tuning-log.md,
"Height at low rates").
"""

from __future__ import annotations

import numpy as np


def previous_rows(x: np.ndarray, before: np.ndarray | None) -> np.ndarray:
    """Rows of ``x`` shifted down by one: row k is x[k − 1]; row 0 is ``before`` (or x[0] when None)."""
    out = np.empty_like(x)
    out[1:] = x[:-1]
    if len(x):
        out[0] = x[0] if before is None else before
    return out


def sculling_coning(acc_b: np.ndarray, gyro_b: np.ndarray, dt_s: np.ndarray, acc_prev_b: np.ndarray,
                    gyro_prev_b: np.ndarray, dt_prev_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The specific force and rate of every sample with the two-sample sculling and coning terms added.

    Parameters
    ----------
    acc_b, gyro_b : (N, 3) specific force (m/s²) and rate (rad/s) of samples k (interval averages).
    dt_s : (N,) Δt_k, s (the step to sample k).
    acc_prev_b, gyro_prev_b, dt_prev_s : the same of samples k − 1 (``previous_rows``).

    Returns
    -------
    (acc_b', gyro_b') : (N, 3) arrays (module docstring), new arrays; the inputs are not modified.
    """
    h = (np.minimum(dt_s, dt_prev_s) / 12.0)[:, None]
    acc = acc_b + h * (np.cross(gyro_prev_b, acc_b) + np.cross(acc_prev_b, gyro_b))
    gyro = gyro_b + h * np.cross(gyro_prev_b, gyro_b)
    return acc, gyro
