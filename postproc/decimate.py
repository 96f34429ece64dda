"""Decimation of long signals and paths for drawing, fed chunk by chunk with bounded memory.

A chart has a few hundred to a thousand pixel columns; an hour at 200 Hz is 720 000 samples. What a
rasteriser draws of a line in one pixel column is the range between its lowest and highest sample there, so
keeping the minimum and the maximum of every time column keeps every peak, down to a single sample
(``TimeEnvelope``). A path seen from above or in 3-D keeps its extent when, in every time column, the samples
at the minimum and the maximum of each coordinate are kept (``PathExtremes``).

Both take the recording's first and last time and its sample count before the first sample (a recording
knows them: ``bootnav.logger.recording.sample_count`` and its clock), so the columns are fixed in time and
their memory is bounded by the column count, not by the recording's length. Samples are pushed in time order
(non-decreasing times, as ``checks`` enforces) in chunks of any size; the result is the same for every
chunking, exactly (minima and maxima do not depend on the order they are taken in; ties keep the earliest
sample). A record short enough to be drawn whole (``n_samples`` at most twice the columns for a time series,
``max_points`` for a path) is kept whole, so short records draw exactly as their samples.
"""

from __future__ import annotations

import numpy as np


def _column_of(t_s: np.ndarray, t_start_s: float, t_end_s: float, n_cols: int) -> np.ndarray:
    """Index of the time column (of ``n_cols`` equal ones over [t_start, t_end]) each time falls in."""
    span = t_end_s - t_start_s
    scale = n_cols / span if span > 0 else 0.0
    return np.clip(((np.asarray(t_s, float) - t_start_s) * scale).astype(np.int64), 0, n_cols - 1)


def _check_room(n_pushed: int, n_samples: int) -> None:
    if n_pushed > n_samples:
        raise ValueError(f"{n_pushed} samples pushed, more than the {n_samples} announced (n_samples)")


def _segments(cols: np.ndarray) -> np.ndarray:
    """Start index of each run of equal column indices in a chunk (times are non-decreasing)."""
    return np.flatnonzero(np.r_[True, cols[1:] != cols[:-1]])


class TimeEnvelope:
    """Minimum and maximum of k signals per time column, fed in chunks (``push``), read by ``band`` and
    ``joins`` (a record kept whole also by ``samples``).

    Parameters
    ----------
    t_start_s, t_end_s : float
        Time of the first and the last sample that will be pushed, s.
    n_cols : int
        Time columns (about the chart's width in pixels, or more).
    n_samples : int
        Samples that will be pushed; at most ``2 n_cols`` are also kept whole (drawn as they are).
    n_signals : int
        Signals per sample (k).
    """

    def __init__(self, t_start_s: float, t_end_s: float, n_cols: int, n_samples: int, n_signals: int):
        self.t_start_s, self.t_end_s, self.n_cols = float(t_start_s), float(t_end_s), max(int(n_cols), 1)
        self.lo = np.full((self.n_cols, n_signals), np.inf)
        self.hi = np.full((self.n_cols, n_signals), -np.inf)
        self.t_first = np.full(self.n_cols, np.inf)
        self.t_last = np.full(self.n_cols, -np.inf)
        self.y_first = np.zeros((self.n_cols, n_signals))  # each column's first and last sample
        self.y_last = np.zeros((self.n_cols, n_signals))
        self.whole = n_samples <= 2 * self.n_cols
        self._t_raw = np.empty(n_samples if self.whole else 0)
        self._y_raw = np.empty((n_samples if self.whole else 0, n_signals))
        self.n = 0

    def push(self, t_s: np.ndarray, y: np.ndarray) -> None:
        """Add consecutive samples: times (m,) s, signals (m, k) (or (m,) for k = 1)."""
        t_s = np.asarray(t_s, float)
        m = len(t_s)
        if m == 0:
            return
        y = np.asarray(y, float).reshape(m, -1)
        if self.whole:
            _check_room(self.n + m, len(self._t_raw))
            self._t_raw[self.n:self.n + m] = t_s
            self._y_raw[self.n:self.n + m] = y
        self.n += m
        cols = _column_of(t_s, self.t_start_s, self.t_end_s, self.n_cols)
        starts = _segments(cols)
        c, ends = cols[starts], np.r_[starts[1:], m] - 1
        unseen = self.t_first[c] == np.inf  # times come in order: a column's first sample comes first
        self.y_first[c[unseen]] = y[starts[unseen]]
        self.y_last[c] = y[ends]
        np.minimum.at(self.lo, c, np.minimum.reduceat(y, starts, axis=0))
        np.maximum.at(self.hi, c, np.maximum.reduceat(y, starts, axis=0))
        np.minimum.at(self.t_first, c, t_s[starts])
        np.maximum.at(self.t_last, c, t_s[ends])

    def samples(self) -> tuple[np.ndarray, np.ndarray]:
        """The samples themselves, times (n,) s and signals (n, k), of a record kept whole (``whole``)."""
        if not self.whole:
            raise ValueError("samples() of a decimated record: it kept only the columns (band())")
        return self._t_raw[: self.n], self._y_raw[: self.n]

    def band(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every column: its mid time (between its first and last sample; its centre if empty), minimum and
        maximum, and whether it has samples.

        Returns
        -------
        (t_s, lo, hi, filled) : (n_cols,), (n_cols, k), (n_cols, k) and (n_cols,) arrays
        """
        filled = self.t_first <= self.t_last
        edges = self.column_edges_s()
        t_mid = 0.5 * (edges[:-1] + edges[1:])
        t_mid[filled] = 0.5 * (self.t_first[filled] + self.t_last[filled])
        return t_mid, self.lo, self.hi, filled

    def joins(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Across every run of empty columns (a gap in time), the line the samples draw: from the last
        sample before it to the first one after it.

        Returns
        -------
        (t0_s, y0, t1_s, y1) : (G,), (G, k), (G,) and (G, k) arrays
        """
        full = np.flatnonzero(self.t_first <= self.t_last)
        a = full[:-1][np.diff(full) > 1]
        b = full[1:][np.diff(full) > 1]
        return self.t_last[a], self.y_last[a], self.t_first[b], self.y_first[b]

    def column_edges_s(self) -> np.ndarray:
        """Start times of the columns and the end of the last, (n_cols + 1,) s."""
        return np.linspace(self.t_start_s, self.t_end_s, self.n_cols + 1)


class PathExtremes:
    """A path decimated for drawing: per time column, the samples where each coordinate is lowest and
    highest, plus the first and the last sample; fed in chunks (``push``), read by ``points``.

    The drawn line passes through every column's extreme samples, so it has the path's extent in every
    column (and overall, exactly); at most ``max_points`` points.

    Parameters
    ----------
    t_start_s, t_end_s : float
        Time of the first and the last sample that will be pushed, s.
    max_points : int
        Most points kept (>= 2 + 2 dim); a path of at most this many samples is kept whole.
    n_samples : int
        Samples that will be pushed.
    dim : int
        Coordinates per sample.
    """

    def __init__(self, t_start_s: float, t_end_s: float, max_points: int, n_samples: int, dim: int = 3):
        self.t_start_s, self.t_end_s, self.dim = float(t_start_s), float(t_end_s), int(dim)
        self.n_cols = max((int(max_points) - 2) // (2 * self.dim), 1)
        self.whole = n_samples <= max_points
        n_raw = n_samples if self.whole else 0
        self._raw = (np.empty(n_raw, np.int64), np.empty(n_raw), np.empty((n_raw, self.dim)))
        shape = (2 * self.dim, self.n_cols)  # [min of coordinate 0, max of 0, min of 1, ...] x columns
        self.value = np.full(shape, np.inf)
        self.value[1::2] = -np.inf
        self.index = np.full(shape, -1, np.int64)
        self.t_s = np.zeros(shape)
        self.pos = np.zeros(shape + (self.dim,))
        self.first: tuple | None = None
        self.last: tuple | None = None
        self.n = 0

    def push(self, t_s: np.ndarray, pos: np.ndarray) -> None:
        """Add consecutive samples: times (m,) s, positions (m, dim)."""
        t_s = np.asarray(t_s, float)
        m = len(t_s)
        if m == 0:
            return
        pos = np.asarray(pos, float).reshape(m, self.dim)
        idx = np.arange(self.n, self.n + m)
        if self.whole:
            _check_room(self.n + m, len(self._raw[0]))
            for buf, v in zip(self._raw, (idx, t_s, pos)):
                buf[self.n:self.n + m] = v
        if self.first is None:
            self.first = (int(idx[0]), float(t_s[0]), pos[0].copy())
        self.last = (int(idx[-1]), float(t_s[-1]), pos[-1].copy())
        self.n += m
        cols = _column_of(t_s, self.t_start_s, self.t_end_s, self.n_cols)
        starts = _segments(cols)
        c = cols[starts]
        seg = np.repeat(np.arange(len(starts)), np.diff(np.r_[starts, m]))
        for k in range(self.dim):
            v = pos[:, k]
            for row, reduce, better in ((2 * k, np.minimum, np.less), (2 * k + 1, np.maximum, np.greater)):
                ext = reduce.reduceat(v, starts)
                hit = np.flatnonzero(v == ext[seg])
                at = hit[np.r_[True, seg[hit][1:] != seg[hit][:-1]]]  # the first sample at each extreme
                new = better(ext, self.value[row, c])  # strictly: on a tie the earlier sample stays
                cn, an = c[new], at[new]
                self.value[row, cn] = ext[new]
                self.index[row, cn] = idx[an]
                self.t_s[row, cn] = t_s[an]
                self.pos[row, cn] = pos[an]

    def points(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The kept samples in time order.

        Returns
        -------
        (index, t_s, pos) : (M,), (M,) and (M, dim) arrays
            Sample index (from 0 at the first pushed sample), time (s), position.
        """
        if self.whole or self.n == 0:
            return tuple(b[: self.n] for b in self._raw)
        kept = self.index >= 0
        idx = np.r_[self.index[kept], self.first[0], self.last[0]]
        t = np.r_[self.t_s[kept], self.first[1], self.last[1]]
        pos = np.vstack((self.pos[kept], self.first[2], self.last[2]))
        idx, at = np.unique(idx, return_index=True)  # sorted; a sample kept for two extremes is drawn once
        return idx, t[at], pos[at]
