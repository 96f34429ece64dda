"""Array helpers of the processing stages (stance detectors, checks, calibration, self-tuning): IMU array
shapes, windows in seconds, centred moving means, row norms and dots, saturation / clipping masks, rows grown
in place (``GrowingRows``). Vectorised with scipy.ndimage (no per-sample Python loop); scipy is imported
where it is used, so that importing the detector registry stays light (``bootnav process --help``)."""

from __future__ import annotations

import math

import numpy as np

from bootnav.core.timebase import sample_period


def as_imu_arrays(t_s, acc_b, gyro_b) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """float64 arrays t_s (N,), acc_b (N, 3), gyro_b (N, 3); ValueError naming the shapes otherwise."""
    t_s = np.asarray(t_s, dtype=np.float64)
    acc_b = np.asarray(acc_b, dtype=np.float64)
    gyro_b = np.asarray(gyro_b, dtype=np.float64)
    n_samples = t_s.shape[0]
    if acc_b.shape != (n_samples, 3) or gyro_b.shape != (n_samples, 3):
        raise ValueError(f"expected acc_b and gyro_b of shape ({n_samples}, 3); got {acc_b.shape}, {gyro_b.shape}")
    return t_s, acc_b, gyro_b


median_dt = sample_period  # the one definition lives in bootnav.core.timebase


def window_samples(window_s: float, dt: float, minimum: int = 1) -> int:
    """Window length in samples for a window defined in seconds at the recording's own rate."""
    return max(minimum, int(round(window_s / dt)))


def moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Centred moving mean over ``n`` samples along axis 0 (edges: nearest value repeated)."""
    from scipy.ndimage import uniform_filter1d

    return uniform_filter1d(np.asarray(x, dtype=np.float64), size=int(n), axis=0, mode="nearest")


def row_norm(x: np.ndarray) -> np.ndarray:
    """Euclidean norm of each row of an (N, 3) array, equal to the last bit to ``np.linalg.norm(x, axis=1)``.

    Same arithmetic (squares summed left to right, as numpy reduces a row of three, then sqrt) on whole
    columns: numpy's reduction along a short last axis is several times slower.
    """
    sq = np.square(np.asarray(x, dtype=np.float64))
    return np.sqrt(sq[:, 0] + sq[:, 1] + sq[:, 2])


def row_dot(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Dot product of each row of two (N, 3) arrays, equal to the last bit to ``np.sum(x * y, axis=1)``
    (``row_norm``'s column arithmetic)."""
    p = x * y
    return p[:, 0] + p[:, 1] + p[:, 2]


def rows_finite(x: np.ndarray) -> np.ndarray:
    """bool (N,): every value of the row of an (N, 3) array is finite (``np.all(np.isfinite(x), axis=1)``,
    column by column as ``row_norm``)."""
    f = np.isfinite(x)
    return f[:, 0] & f[:, 1] & f[:, 2]


def clipped_axes(x: np.ndarray, *, min_repeats: int = 3, rel_tol: float = 1e-6) -> dict[int, np.ndarray]:
    """Per-axis full-scale plateaus of an (N, k) signal: {axis: bool (N,)} for the axes that have one.

    A clipped axis repeats its extreme value exactly; an unclipped one reaches its extreme once or twice.
    Each sign is tested on its own, because the two rails of a two's-complement sensor differ by one LSB
    (MPU6050: −32768 and +32767 counts, i.e. 3e-5 relative — more than ``rel_tol``): flags
    x >= (1 − rel_tol) max x (and likewise x <= (1 − rel_tol) min x) on an axis whose extreme on that side
    is hit ``min_repeats`` times or more, but by less than half of the samples (a constant axis is not
    clipping), and is not exceeded in magnitude by the other side (a full-scale range is symmetric: a
    plateau below the opposite extreme is a repeated value, e.g. a duplicated row, not a rail).
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    out: dict[int, np.ndarray] = {}
    for k in range(x.shape[1]):  # column by column: numpy reduces a strided column faster than axis 0 of (N, k)
        col = x[:, k]
        pos_peak, neg_peak = np.nanmax(col), -np.nanmin(col)
        # -x >= p  <=>  x <= -p exactly (negation is exact): no negated copy of the column
        for upper, peak, other in ((True, pos_peak, neg_peak), (False, neg_peak, pos_peak)):
            if not (peak > 0 and peak >= other * (1.0 - 1e-3)):
                continue
            mask = col >= peak * (1.0 - rel_tol) if upper else col <= -(peak * (1.0 - rel_tol))
            count = np.count_nonzero(mask)
            if min_repeats <= count < 0.5 * x.shape[0]:
                out[k] = out[k] | mask if k in out else mask
    return out


RAIL_LEVEL_TOL = 0.02  # rail level wander across swings, fraction of full scale (calibrated outputs' cross-axis terms)
RAIL_TOP_POWER = 4.0  # a rail's top is flatter than a quartic maximum (a swing peak is about a parabola: 2)
GYRO_MIN_FULL_SCALE_RADPS = math.radians(125.0)  # the smallest range of MEMS gyros (e.g. BMI160, ICM-42688: ±125 °/s)


def _dwell(col: np.ndarray, j: int, level: float, a: int, b: int) -> tuple[int, int, float]:
    """First and last sample of the run above ``level`` that holds sample ``j``, and its duration in samples
    with the crossings interpolated (NaN when the run touches an end of the record). The run lies inside the
    excursion ``col[a:b]`` that holds ``j`` (``level`` is above the excursions' threshold), so only that
    excursion is searched."""
    below = np.flatnonzero(~(col[a:b] > level)) + a
    r = int(np.searchsorted(below, j))
    i0 = int(below[r - 1]) + 1 if r > 0 else a
    i1 = int(below[r]) - 1 if r < len(below) else b - 1
    if i0 == 0 or i1 == len(col) - 1:
        return i0, i1, math.nan
    return i0, i1, ((i1 - i0) + (col[i0] - level) / (col[i0] - col[i0 - 1])
                    + (col[i1] - level) / (col[i1] - col[i1 + 1]))


def sloping_rails(x: np.ndarray, min_full_scale: float, *, min_repeats: int = 3,
                  level_tol: float = RAIL_LEVEL_TOL, top_power: float = RAIL_TOP_POWER) -> dict[int, np.ndarray]:
    """Per-axis rails of an (N, k) uniformly sampled signal that a calibrated output makes slope:
    {axis: bool (N,)} of the samples on a rail, for the axes that have one.

    A sensor that clips and then applies its factory calibration (scale, cross-axis terms, e.g. MicroStrain's
    ``scaledGyro``) does not repeat one value at full scale (``clipped_axes`` then sees nothing): the flat
    top wanders by the cross-axis terms times the other axes' rates, up to ``level_tol`` of full scale. What
    stays is the shape: a swing peak of a foot is a smooth maximum, a rail is a flat top entered and left
    steeply. Near a maximum shaped 1 − |t|^p the time it stays within h of its top grows as h^(1/p), so the
    dwells within h and 2h give its power, p = log 2 / log(T(2h) / T(h)): 2 for a parabola, 1 for a sharp
    peak, and without bound for a rail (T(2h) only adds the steep ramps). Per axis and sign, the excursions
    (runs beyond half the extreme) whose maximum lies within h = ``level_tol`` × extreme of the extreme are
    measured; the sign has a rail when ``min_repeats`` or more of them are flatter than ``top_power`` (the
    same level reached flat in separate swings: not one odd peak, and not a regular gait's equal smooth
    peaks). Then the samples within h of the top of every excursion reaching the band are flagged (a short
    touch of the rail is on it too). A sign whose extreme is below ``min_full_scale`` (the smallest
    full-scale range such sensors have) holds no rail (an axis that only carries noise on that side).
    Dimensionless in samples: no time base needed.
    """
    from .runs import runs

    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    n = x.shape[0]
    out: dict[int, np.ndarray] = {}
    max_ratio = 2.0 ** (1.0 / top_power)
    for k in range(x.shape[1]):
        for sign in (1.0, -1.0):
            col = sign * x[:, k]
            peak = float(np.nanmax(col)) if n else 0.0
            if not peak >= min_full_scale:
                continue
            h = level_tol * peak
            a, b = runs(col > 0.5 * peak)
            if len(a) < min_repeats:
                continue
            top = np.maximum.reduceat(col, a)  # top of each excursion
            near = np.flatnonzero(top >= peak - h)
            if len(near) < min_repeats:
                continue
            mask = np.zeros(n, dtype=bool)
            flat = 0
            for e in near:  # one iteration per excursion at the top band (a few dozen at most)
                j = int(a[e] + np.argmax(col[a[e]:b[e]]))
                i0, i1, t1 = _dwell(col, j, top[e] - h, a[e], b[e])
                t2 = _dwell(col, j, top[e] - 2.0 * h, a[e], b[e])[2]
                mask[i0:i1 + 1] = True
                flat += bool(t2 < max_ratio * t1)
            if flat >= min_repeats:
                out[k] = out[k] | mask if k in out else mask
    return out


def clipped_samples(x: np.ndarray, *, min_repeats: int = 3, rel_tol: float = 1e-6) -> np.ndarray:
    """Samples of an (N, k) signal that sit at a per-axis full-scale plateau on any axis (bool (N,));
    ``clipped_axes`` says which plateau counts."""
    x = np.asarray(x, dtype=np.float64)
    out = np.zeros(x.shape[0], dtype=bool)
    for mask in clipped_axes(x, min_repeats=min_repeats, rel_tol=rel_tol).values():
        out |= mask
    return out


def saturation_mask(saturated, n: int) -> np.ndarray:
    """bool (N,) from None, a bool array or a uint8 bitmask (recording's ``saturated``)."""
    if saturated is None:
        return np.zeros(n, dtype=bool)
    s = np.asarray(saturated)
    if s.shape[0] != n:
        raise ValueError(f"saturated mask has {s.shape[0]} samples, the signal {n}")
    return s.astype(bool) if s.ndim == 1 else np.any(s.astype(bool), axis=1)


def dilate(mask: np.ndarray, n: int) -> np.ndarray:
    """Grow a bool mask by ``n`` samples on both sides."""
    from scipy.ndimage import binary_dilation

    if n <= 0 or not mask.any():
        return mask.copy()
    return binary_dilation(mask, structure=np.ones(2 * n + 1, dtype=bool))


class GrowingRows:
    """Rows of ``width`` values appended in order into a buffer that doubles (no Python object per row: 8 B per
    float64 value, at most twice that with the spare room); what the block passes keep per stance phase."""

    def __init__(self, width: int, dtype=np.float64):
        self._buf = np.empty((64, width), dtype)
        self._n = 0

    def append(self, row) -> None:
        """Add one row."""
        if self._n == len(self._buf):
            self._buf = np.concatenate((self._buf, np.empty_like(self._buf)))
        self._buf[self._n] = row
        self._n += 1

    def extend(self, rows) -> None:
        """Add rows (m, width), or m values when ``width`` is 1."""
        rows = np.asarray(rows).reshape(-1, self._buf.shape[1])
        need = self._n + len(rows)
        if need > len(self._buf):
            size = len(self._buf)
            while size < need:
                size *= 2
            buf = np.empty((size, self._buf.shape[1]), self._buf.dtype)
            buf[:self._n] = self._buf[:self._n]
            self._buf = buf
        self._buf[self._n:need] = rows
        self._n = need

    def __len__(self) -> int:
        return self._n

    @property
    def rows(self) -> np.ndarray:
        """The rows so far (n, width), a view."""
        return self._buf[:self._n]
