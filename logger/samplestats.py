"""Figures of a recording's samples accumulated block by block: what ``bootnav info`` reports.

``SampleStats`` takes the rows of a recording in order, in blocks of any size, and keeps, in memory that
does not grow with the length: the time steps (``StepStats``: exact median, extremes, jitter, gap
candidates), the saturation bits and the figures of the acc/gyro channels the data warnings need
(``ChannelStats``, in the stored units, so a scale factor corrected after the samples were written still
applies).

Two users, one definition: ``bootnav info`` scans a recording with it, and ``RecordingWriter`` feeds it the
rows it writes and stores the result beside them when the recording closes (``imu`` attribute ``summary``,
valid for the rows it counts), so ``info`` on a closed recording reads a few hundred bytes instead of
decompressing every time stamp. A recording whose writer died has no summary and is scanned.
"""

from __future__ import annotations

import json
import math

import numpy as np

from bootnav.core.timebase import GAP_FACTOR, gap_mask, missing_samples, nominal_period

#: Distinct step lengths counted for the exact median; timestamps with more (a float host clock) keep their
#: positive steps instead (8 bytes a sample; a writer then stores no summary).
MAX_DISTINCT_STEPS = 1 << 20
#: Gap candidates kept per block; a block with more is read again once the median is known.
MAX_GAP_CANDIDATES = 1 << 16
#: Steps kept as gap candidates: above this many times the block's own median step. Below ``GAP_FACTOR`` so
#: the candidates hold every gap of a block whose median exceeds the recording's by up to 20 % (a block of a
#: µs clock always differs from the whole in the last bits of its median: with ``GAP_FACTOR`` itself, half of
#: the blocks would be read again).
CANDIDATE_FACTOR = 1.25
#: Rows a writer collects before folding them into the figures (small appends of a live recorder would
#: otherwise leave one entry per append).
FOLD_ROWS = 1 << 16
#: Time gaps stored in a summary at most; a recording with more is scanned by ``info``.
MAX_SUMMARY_GAPS = 10_000
SUMMARY_VERSION = 1


class StepStats:
    """The time steps ``dt[i] = t[i+1] - t[i]``, fed block by block (``add``): the positive finite ones as
    distinct values with counts (exact median, extremes and jitter), and per block the steps above a bound,
    ``CANDIDATE_FACTOR`` times the block's own middle step, as gap candidates. Those hold every gap of the
    block when its bound does not exceed ``GAP_FACTOR`` times the recording's median; else ``gaps`` reads the
    block again (a block at a lower rate than the rest), or, without the data, says the candidates are
    incomplete (``complete``)."""

    def __init__(self):
        self.values, self.counts = np.zeros(0), np.zeros(0, np.int64)  # distinct positive finite steps, sorted
        self.raw: list | None = None  # the steps themselves, once there are more than MAX_DISTINCT_STEPS distinct
        self.blocks: list = []  # (first step, end step, bound, candidates or None)
        self.t_first = self.t_last = float("nan")
        self.rows = 0

    def add(self, t) -> None:
        """The next rows of ``t_s`` (float64), in order."""
        start = self.rows
        t_ext = np.concatenate(([self.t_last], t)) if start else t
        first = start - 1 if start else 0  # index of the first step of this block
        if not start and t.size:
            self.t_first = t[0]
        if t.size:
            self.t_last = t[-1]
        self.rows += t.size
        dt = np.diff(t_ext)
        pos = dt[np.isfinite(dt) & (dt > 0)]
        v, c = np.unique(pos.view(np.int64), return_counts=True)  # positive floats sort as their bits, faster
        v = v.view(np.float64)
        bound = CANDIDATE_FACTOR * _kth(v, np.cumsum(c), (pos.size - 1) // 2) if pos.size else float("nan")
        idx = np.flatnonzero(dt > bound)
        cand = (first + idx, t_ext[idx + 1], dt[idx]) if idx.size <= MAX_GAP_CANDIDATES else None
        self.blocks.append((first, first + dt.size, bound, cand))
        if self.raw is not None:
            self.raw.append(pos)
            return
        u, inv = np.unique(np.concatenate((self.values, v)), return_inverse=True)
        self.values, self.counts = u, np.bincount(inv, weights=np.concatenate((self.counts, c))).astype(np.int64)
        if u.size > MAX_DISTINCT_STEPS:
            self.raw, self.values, self.counts = [np.repeat(u, self.counts)], np.zeros(0), np.zeros(0, np.int64)

    @property
    def count(self) -> int:
        return sum(x.size for x in self.raw) if self.raw is not None else int(self.counts.sum())

    def median(self) -> float:
        """``timebase.nominal_period`` of all steps: NaN without a positive step."""
        if self.raw is not None:
            return nominal_period(np.concatenate(self.raw))
        p, cum = int(self.counts.sum()), np.cumsum(self.counts)
        if p == 0:
            return float("nan")
        if p % 2:
            return float(_kth(self.values, cum, (p - 1) // 2))
        return float((_kth(self.values, cum, p // 2 - 1) + _kth(self.values, cum, p // 2)) / 2)

    def jitter(self, med: float) -> float:
        """``timebase.timing_summary``'s jitter: std of the positive steps below ``GAP_FACTOR * med``."""
        if self.count == 0:
            return float("nan")
        if self.raw is not None:
            x = np.concatenate(self.raw)
            return float(np.std(x[x < GAP_FACTOR * med]))
        keep = self.values < GAP_FACTOR * med
        v, c = self.values[keep], self.counts[keep]
        mean = float((v * c).sum() / c.sum())
        return float(np.sqrt((c * (v - mean) ** 2).sum() / c.sum()))

    def min(self) -> float:
        if self.count == 0:
            return float("nan")
        return float(min(x.min() for x in self.raw if x.size)) if self.raw is not None else float(self.values[0])

    def max(self) -> float:
        if self.count == 0:
            return float("nan")
        return float(max(x.max() for x in self.raw if x.size)) if self.raw is not None else float(self.values[-1])

    def complete(self, med: float) -> bool:
        """Whether the kept candidates hold every gap (no block needs to be read again)."""
        return all(cand is not None and bound <= GAP_FACTOR * med for _, _, bound, cand in self.blocks)

    def gaps(self, t_ds, med: float, n: int):
        """Sample index, time and missing samples of every gap (``timebase.gap_mask``) given the median;
        ``t_ds`` (the time stamps, indexable) is read only for blocks whose candidates are incomplete."""
        parts = []
        for first, end, bound, cand in self.blocks if math.isfinite(med) else []:
            if cand is None or not bound <= GAP_FACTOR * med:  # candidates may miss a gap: read the block again
                t = t_ds[first:min(end + 1, n)].astype(np.float64)
                cand = (first + np.arange(t.size - 1), t[1:], np.diff(t))
            keep = gap_mask(cand[2], med)
            parts.append((cand[0][keep] + 1, cand[1][keep], missing_samples(cand[2][keep], med)))
        if not parts:
            return (), (), ()
        return tuple(np.concatenate(x) for x in zip(*parts))


def _kth(values, cum_counts, k: int):
    """The ``k``-th smallest (0-based) of values repeated by counts, given their cumulative counts."""
    return values[cum_counts.searchsorted(k, side="right")]


class ChannelStats:
    """Figures of an (N, 3) acc or gyro channel fed block by block (``add``): non-finite rows, whether any
    finite value is non-zero, per-axis std (Chan's parallel update) and largest |value|.

    A writer feeds the stored values (counts or SI floats) and ``from_state`` restores them with the factor to
    SI read when they are used (``to_si``, the channel's ``scale_to_si``; valid when ``offset_to_si`` is 0,
    then std and |value| scale by |scale|), so a scale corrected after the samples were written applies.
    ``info`` scanning a recording feeds SI values (``to_si`` 1). The std and the largest value stop at the
    first non-finite row: a channel with one is reported as such and its other figures are not used."""

    def __init__(self, to_si: float = 1.0):
        self.to_si = abs(to_si)
        self.nonfinite, self.first_bad = 0, -1
        self.any_finite = self.any_nonzero = False
        self.n, self.mean, self.m2, self.absmax_raw = 0, np.zeros(3), np.zeros(3), 0.0

    def add(self, raw, a: int, scale: float = 1.0, offset: float = 0.0) -> None:
        """Rows ``a .. a + len(raw)`` of the channel, as stored, taken as ``raw * scale + offset``."""
        raw = np.asarray(raw)
        with np.errstate(over="ignore", invalid="ignore"):  # 1e308 values: the importer refuses them
            self._add(raw, a, scale, offset)

    def _add(self, raw, a, scale, offset) -> None:
        x = raw.astype(np.float64)
        if scale != 1.0 or offset != 0.0:
            x = x * scale + offset
        finite = x
        if raw.dtype.kind == "f":  # integer counts times a finite scale cannot be non-finite
            ok = np.isfinite(x)
            bad = ~np.all(ok, axis=1)
            if bad.any():
                self.first_bad = a + int(np.argmax(bad)) if self.first_bad < 0 else self.first_bad
                self.nonfinite += int(bad.sum())
                finite = x[ok]
        self.any_finite |= bool(finite.size)
        self.any_nonzero |= bool(np.any(finite != 0))
        if self.nonfinite or not x.size:
            return
        nb, mean_b = x.shape[0], x.mean(axis=0)
        delta, tot = mean_b - self.mean, self.n + nb
        self.m2 += ((x - mean_b) ** 2).sum(axis=0) + delta ** 2 * self.n * nb / tot
        self.mean += delta * nb / tot
        self.n = tot
        self.absmax_raw = max(self.absmax_raw, float(np.abs(x).max()))

    def std(self):
        """Per-axis std in SI units."""
        return (self.m2 / self.n) ** 0.5 * self.to_si

    @property
    def absmax(self) -> float:
        """Largest |value| in SI units."""
        return self.absmax_raw * self.to_si

    def state(self) -> dict:
        return {"nonfinite": self.nonfinite, "first_bad": self.first_bad, "any_finite": self.any_finite,
                "any_nonzero": self.any_nonzero, "n": self.n, "mean": self.mean.tolist(), "m2": self.m2.tolist(),
                "absmax": self.absmax_raw}

    @classmethod
    def from_state(cls, d: dict, to_si: float) -> "ChannelStats":
        ch = cls(to_si)
        ch.nonfinite, ch.first_bad, ch.any_finite = int(d["nonfinite"]), int(d["first_bad"]), bool(d["any_finite"])
        ch.any_nonzero, ch.n, ch.absmax_raw = bool(d["any_nonzero"]), int(d["n"]), float(d["absmax"])
        ch.mean, ch.m2 = np.asarray(d["mean"], np.float64), np.asarray(d["m2"], np.float64)
        return ch


class SampleStats:
    """``StepStats``, saturation histogram and ``ChannelStats`` of acc and gyro of one recording, fed the
    rows a writer appends (``append``, any block size; folded every ``FOLD_ROWS`` rows) and turned into the
    ``summary`` attribute when it closes (``summary``)."""

    def __init__(self):
        self.steps = StepStats()
        self.channels = {"acc": ChannelStats(), "gyro": ChannelStats()}
        self.sat_hist = np.zeros(256, np.int64)
        self.pending: list[tuple] = []
        self.pending_rows = 0

    def append(self, t_s, acc, gyro, saturated) -> None:
        """The next rows, as stored (``t_s`` float64, acc/gyro in their dataset's dtype, saturation bits)."""
        if len(t_s) >= FOLD_ROWS:  # a big block (a whole recording): folded in slices, never copied whole
            self.fold()
            for a in range(0, len(t_s), 16 * FOLD_ROWS):
                b = a + 16 * FOLD_ROWS
                self._add(t_s[a:b], acc[a:b], gyro[a:b], saturated[a:b])
            return
        self.pending.append(tuple(np.array(x) for x in (t_s, acc, gyro, saturated)))  # copies: a caller may reuse
        self.pending_rows += len(t_s)
        if self.pending_rows >= FOLD_ROWS:
            self.fold()

    def fold(self) -> None:
        """Fold the small blocks collected so far into the figures, as one block."""
        if self.pending:
            self._add(*(np.concatenate(x) for x in zip(*self.pending)))
            self.pending, self.pending_rows = [], 0

    def _add(self, t, acc, gyro, sat) -> None:
        row0 = self.steps.rows
        self.steps.add(np.asarray(t, np.float64))
        self.channels["acc"].add(acc, row0)
        self.channels["gyro"].add(gyro, row0)
        self.sat_hist += np.bincount(np.asarray(sat, np.uint8), minlength=256)

    def summary(self) -> str | None:
        """The ``summary`` attribute (JSON) of the rows appended, or None when it would not be exact without
        the data (too many distinct steps, incomplete gap candidates, too many gaps)."""
        self.fold()
        s = self.steps
        if s.raw is not None:
            return None
        med = s.median()
        if math.isfinite(med) and not s.complete(med):
            return None
        idx, t_gap, missing = s.gaps(None, med, s.rows)
        if len(idx) > MAX_SUMMARY_GAPS:
            return None
        return json.dumps({
            "version": SUMMARY_VERSION, "rows": s.rows, "t_first": float(s.t_first), "t_last": float(s.t_last),
            "step_count": s.count, "dt_median_s": med, "jitter_s": s.jitter(med), "dt_min_s": s.min(),
            "dt_max_s": s.max(),
            "time_gaps": [[int(i), float(t), int(m)] for i, t, m in zip(idx, t_gap, missing)],
            "saturated_hist": self.sat_hist.tolist(),
            "channels": {k: ch.state() for k, ch in self.channels.items()},
        }, allow_nan=True)


def read_summary(imu, n: int) -> dict | None:
    """The ``summary`` attribute of the ``imu`` group when it describes exactly its ``n`` rows (row count,
    first and last time stamp), else None (no summary, written by another version, or data changed since)."""
    text = imu.attrs.get("summary")
    if text is None:
        return None
    try:
        s = json.loads(text.decode() if isinstance(text, bytes) else str(text))
        if s.get("version") != SUMMARY_VERSION or s["rows"] != n or not n:
            return None
        ends = imu["t_s"][[0, n - 1]] if n > 1 else imu["t_s"][:1].repeat(2)
        if not (_same(ends[0], s["t_first"]) and _same(ends[1], s["t_last"])):
            return None
    except (ValueError, KeyError, TypeError):
        return None
    return s


def _same(a, b) -> bool:
    return float(a) == float(b) or (math.isnan(float(a)) and math.isnan(float(b)))
