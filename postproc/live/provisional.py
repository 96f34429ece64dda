"""Provisional strides: where the foot has just stopped, drawn before the stance detector has decided.

The configured detector decides a sample a look-ahead after it (1.4 s for ``adaptive``: its noise-floor and
valley/peak context), and the filter's rows become final once the smoother has closed the stride, so a final
stride reaches the page about 2 s after its stance phase began. A low-latency cue says earlier that the foot
has stopped: SHOE's statistic [Skog2010] over its 0.025 s window under its threshold for ``cue_min_stance_s``
(the ``shoe`` detector streamed with that minimum stance, ``detectors.stream.StreamStance``; look-ahead
about 0.2 s). At that moment the navigator has filtered the samples up to its ``last_index`` only (the
configured detector's look-ahead + the ZUPT onset delay behind); the provisional position is its nominal
state there (position, velocity, attitude; the biases of its latest final row) propagated through the newer
samples up to the cue's stance start by the same strapdown equations its kernel uses
(``ins.fast.filter_chunk``, [Heidari2019, eq. 1]) — dead reckoning of the pushed state, no second filter, so
no ZUPT over that stretch. The final stride replaces it when the filter's rows covering its stance phase
are final.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bootnav.postproc.ins.kernels import quat_times_exp, rotmat_into


@njit(cache=True)
def propagate_position(pos_n, vel_n, q_nb, acc_bias_b, gyro_bias_b, t_prev_s, t_s, acc_b, gyro_b, still, gravity):
    """Position after strapdown propagation of a nominal state through samples (no measurement update; the
    velocity is reset to zero on the samples flagged ``still``).

    Parameters
    ----------
    pos_n, vel_n : (3,) arrays
        Position (m) and velocity (m/s), nav frame ENU, at time ``t_prev_s``.
    q_nb : (4,) array
        Attitude wxyz at ``t_prev_s``.
    acc_bias_b, gyro_bias_b : (3,) arrays
        Biases subtracted from the samples (m/s², rad/s).
    t_prev_s : float
        Time of the state, s.
    t_s, acc_b, gyro_b : (m,), (m, 3), (m, 3) arrays
        The samples after it (s, m/s² with gravity, rad/s).
    still : (m,) bool array
        Samples the cue says are stance: velocity zero there, so the position holds.
    gravity : float
        Local gravity, m/s².

    Returns
    -------
    (3,) array
        Position at ``t_s[-1]``, m.
    """
    p = pos_n.copy()
    v = vel_n.copy()
    qw, qx, qy, qz = q_nb[0], q_nb[1], q_nb[2], q_nb[3]
    c = np.empty((3, 3))
    t_last = t_prev_s
    for k in range(t_s.shape[0]):
        dt = t_s[k] - t_last
        t_last = t_s[k]
        if dt <= 0.0:
            continue
        qw, qx, qy, qz = quat_times_exp(qw, qx, qy, qz, (gyro_b[k, 0] - gyro_bias_b[0]) * dt,
                                        (gyro_b[k, 1] - gyro_bias_b[1]) * dt, (gyro_b[k, 2] - gyro_bias_b[2]) * dt)
        rotmat_into(c, qw, qx, qy, qz)
        fb0, fb1, fb2 = acc_b[k, 0] - acc_bias_b[0], acc_b[k, 1] - acc_bias_b[1], acc_b[k, 2] - acc_bias_b[2]
        for i in range(3):
            a = c[i, 0] * fb0 + c[i, 1] * fb1 + c[i, 2] * fb2 - (gravity if i == 2 else 0.0)
            p[i] += v[i] * dt + 0.5 * a * dt * dt
            v[i] += a * dt
        if still[k]:
            v[:] = 0.0
    return p


class RecentSamples:
    """The samples from an absolute index on (those the navigator has not filtered yet), bounded by trimming,
    with the cue's stance decisions as they come (False until decided)."""

    def __init__(self):
        self.start = 0  # absolute index of the first kept sample
        self.t_s = np.zeros(0)
        self.acc_b = np.zeros((0, 3))
        self.gyro_b = np.zeros((0, 3))
        self.still = np.zeros(0, bool)

    def push(self, t_s, acc_b, gyro_b) -> None:
        self.t_s = np.concatenate((self.t_s, t_s))
        self.acc_b = np.concatenate((self.acc_b, acc_b))
        self.gyro_b = np.concatenate((self.gyro_b, gyro_b))
        self.still = np.concatenate((self.still, np.zeros(len(t_s), bool)))

    def mark(self, start: int, still: np.ndarray) -> None:
        """The cue's decisions of the samples from absolute index ``start`` on."""
        i = start - self.start
        lo, hi = max(i, 0), min(i + len(still), len(self.still))  # the part not trimmed yet
        if hi > lo:
            self.still[lo:hi] = still[lo - i:hi - i]

    def trim(self, first: int) -> None:
        """Drop the samples before absolute index ``first``."""
        k = max(0, first - self.start)
        if k:
            self.t_s, self.acc_b, self.gyro_b = self.t_s[k:], self.acc_b[k:], self.gyro_b[k:]
            self.still = self.still[k:]
            self.start += k

    def between(self, a: int, b: int):
        """Samples of absolute indices a..b-1 (t_s, acc_b, gyro_b, still)."""
        i, j = max(0, a - self.start), max(0, b - self.start)
        return self.t_s[i:j], self.acc_b[i:j], self.gyro_b[i:j], self.still[i:j]
