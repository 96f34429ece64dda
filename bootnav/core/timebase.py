"""Sample times: the one time base (step lengths, nominal period, gaps) and the one gap rule.

Times are used as recorded: never resampled or reordered. Every consumer (recorder, importers,
``bootnav info``, the input checks and the navigation filter) reads its step lengths, its nominal period and
its gaps from here, so a gap means the same thing everywhere.

**Gap rule.** When the source carries a frame counter (protocol-v1 ``seq``, SD-log ``seq``) the counter is
authoritative: ``missing = (seq_k - seq_{k-1}) mod 2**16 - 1``, exact. Otherwise a step is a gap when

    dt > GAP_FACTOR * T,    GAP_FACTOR = 1.5,    missing = round(dt / T) - 1

with T the nominal period (the declared rate if known, else the median of the positive steps). Why 1.5:
a step that spans k periods hides k - 1 lost samples, and 1.5 T is the decision boundary between one period
(nothing lost) and two (one sample lost) — the rounding in ``missing``. It is the only factor for which
"gap" and "at least one sample is missing" coincide under timestamp jitter below T/2 (the firmware's jitter
is a few µs at T = 1-5 ms); a larger factor (3 T, 5 T) hides up to 2-4 lost samples per step, a smaller one
reports jitter as loss. Steps shorter than 1.5 T are the regular ones the jitter is measured on; a step of
exactly 1.5 T (a quantised clock) is as far from one period as from two, so it is neither.

**Counters.** Device clocks (``micros()`` u32, wraps every 2**32 µs = 71.58 min; ``millis()``) and frame
counters (u16) are unwrapped with the signed modular difference

    d = ((x_k - x_{k-1} + M/2) mod M) - M/2

exact while consecutive samples are less than M/2 apart (35.8 min of µs clock, 32768 frames). A wrap is a
step where the raw value falls but ``d > 0``; ``d < 0`` is a clock going back (device reset), kept as such.
For a gap longer than one seq wrap (65.5 s at 1 kHz) the number of missing frames is ambiguous modulo 65536
and is resolved with the device clock: ``missing = d_seq - 1 + 65536 round((dt / T - d_seq) / 65536)``.

Coarse clocks (an RTC logging whole seconds with several rows per second) are spread evenly inside each
second (``spread_coarse_seconds``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bootnav.core.errors import InputError

GAP_FACTOR = 1.5  # a step longer than 1.5 nominal periods has lost at least one sample (module docstring)
T_US_MODULUS = 1 << 32  # u32 microsecond device clock
SEQ_MODULUS = 1 << 16  # u16 frame counter
T_US_WRAP_S = T_US_MODULUS / 1e6  # 4294.967296 s = 71.58 min
TIME_SCALE = {"s": 1.0, "ms": 1e-3, "us": 1e-6}  # unit -> seconds


# ----------------------------------------------------------------------------------------- the gap rule
def nominal_period(dt_s: np.ndarray) -> float:
    """Median of the positive finite steps ``dt_s`` (s); NaN when there is none."""
    dt_s = np.asarray(dt_s, dtype=np.float64)
    pos = dt_s[np.isfinite(dt_s) & (dt_s > 0)]
    return float(np.median(pos)) if pos.size else float("nan")


def sample_period(t_s: np.ndarray) -> float:
    """Robust sample period of a time axis (s): ``nominal_period`` of its steps (duplicates and gaps do not
    move a median); ValueError when the axis has no positive step."""
    dt = nominal_period(np.diff(np.asarray(t_s, dtype=np.float64)))
    if not np.isfinite(dt):
        raise ValueError("timestamps have no positive interval; cannot derive the sample rate")
    return dt


def gap_mask(dt_s: np.ndarray, nominal_dt_s: float) -> np.ndarray:
    """True where a step is a gap: ``dt > GAP_FACTOR * nominal_dt_s`` (module docstring).

    Parameters
    ----------
    dt_s : ndarray
        Step lengths (s), any shape.
    nominal_dt_s : float
        Nominal sample period (s). NaN gives no gap.

    Returns
    -------
    ndarray of bool, same shape as ``dt_s``.
    """
    return np.asarray(dt_s) > GAP_FACTOR * nominal_dt_s


def missing_samples(dt_s: np.ndarray, nominal_dt_s: float) -> np.ndarray:
    """Samples lost inside each step, ``round(dt / T) - 1`` (>= 1 on every gap, 0 on a regular step)."""
    return np.maximum(np.rint(np.asarray(dt_s, dtype=np.float64) / nominal_dt_s).astype(np.int64) - 1, 0)


# ---------------------------------------------------------------------------- the time base of a record
@dataclass
class TimeBase:
    """Step lengths of a (non-decreasing) timestamp vector, as the strapdown integration uses them.

    ``dt_s[n] = t_n - t_{n-1}`` with ``dt_s[0] = 0`` (sample 0 is the initial state); ``gap_mask[n]`` is True
    where the step into sample n is a gap (``GAP_FACTOR``); ``n_duplicates`` counts zero steps.
    """

    dt_s: np.ndarray
    nominal_dt_s: float
    gap_mask: np.ndarray
    n_duplicates: int

    @property
    def gaps(self) -> list[tuple[int, float]]:
        """(sample index, Δt in s) of every gap."""
        idx = np.flatnonzero(self.gap_mask)
        return [(int(i), float(self.dt_s[i])) for i in idx]


def time_base(t_s: np.ndarray) -> TimeBase:
    """The ``TimeBase`` of timestamps that must not go backwards (input of an integration).

    Parameters
    ----------
    t_s : ndarray, shape (N,)
        Sample times (s), float64, finite.

    Returns
    -------
    TimeBase
        Step lengths, nominal period (median positive step), gaps and duplicate count.

    Raises
    ------
    InputError
        Time goes backwards (naming the first sample), or all timestamps are equal.
    """
    t_s = np.asarray(t_s, dtype=np.float64)
    dt = np.empty_like(t_s)
    dt[0] = 0.0
    np.subtract(t_s[1:], t_s[:-1], out=dt[1:])
    if (dt < 0).any():
        i = int(np.argmax(dt < 0))
        raise InputError(f"timestamps go backwards at sample {i}: t_s[{i - 1}]={t_s[i - 1]!r} > t_s[{i}]={t_s[i]!r}")
    nominal = nominal_period(dt)
    if not np.isfinite(nominal):
        raise InputError("all timestamps are equal: cannot integrate")
    return TimeBase(dt, nominal, gap_mask(dt, nominal), int((dt[1:] == 0).sum()))


def timing_summary(t_s: np.ndarray) -> dict:
    """Measured rate (1 / nominal period, Hz) and jitter (std of the regular steps, < GAP_FACTOR periods, s)."""
    dt = np.diff(np.asarray(t_s, dtype=np.float64))
    dt = dt[np.isfinite(dt) & (dt > 0)]
    if dt.size == 0:
        return {"rate_measured_hz": float("nan"), "jitter_s": float("nan")}
    med = nominal_period(dt)
    return {"rate_measured_hz": 1.0 / med, "jitter_s": float(np.std(dt[dt < GAP_FACTOR * med]))}


def time_events(t_s: np.ndarray, line_numbers: np.ndarray | None, *, nominal_dt: float | None = None,
                with_gaps: bool = True) -> list[dict]:
    """Duplicate, backward and gap events of a time vector (s, unwrapped); samples are kept, never reordered.

    Parameters
    ----------
    t_s : ndarray, shape (N,)
        Sample times (s).
    line_numbers : ndarray of int or None
        Source line of each sample (for the events), or None (line -1).
    nominal_dt : float, optional
        Nominal period (s); default: the median positive step.
    with_gaps : bool
        False when a frame counter reports the gaps instead (SD logs).

    Returns
    -------
    list of dict
        Events with keys ``kind`` (``duplicate_time``, ``nonmonotonic_time``, ``gap``), ``t_s``,
        ``sample_index``, ``line``, ``count`` (missing samples for a gap) and ``detail``.
    """
    events: list[dict] = []
    if t_s.size < 2:
        return events
    d = np.diff(t_s)
    dt0 = nominal_dt or (nominal_period(d) if np.any(d > 0) else 0.0)

    def line(i):
        return int(line_numbers[i]) if line_numbers is not None else -1

    for i in np.flatnonzero(d == 0) + 1:
        events.append(dict(kind="duplicate_time", t_s=float(t_s[i]), sample_index=int(i), line=line(i), count=1,
                           detail=f"same time as the previous sample ({t_s[i]:.6f} s)"))
    for i in np.flatnonzero(d < 0) + 1:
        events.append(dict(kind="nonmonotonic_time", t_s=float(t_s[i]), sample_index=int(i), line=line(i), count=1,
                           detail=f"time goes back by {-d[i - 1]:.6g} s (kept, not reordered)"))
    if with_gaps and dt0 > 0:
        gap_at = np.flatnonzero(gap_mask(d, dt0))
        for i, missing in zip(gap_at + 1, missing_samples(d[gap_at], dt0).tolist()):
            events.append(dict(kind="gap", t_s=float(t_s[i - 1]), sample_index=int(i), line=line(i),
                               count=missing, detail=f"dt {d[i - 1]:.6g} s = {missing} missing sample(s) "
                               f"at {1 / dt0:.4g} Hz"))
    return events


# ------------------------------------------------------------------------------------------- counters
def signed_delta(values: np.ndarray, previous: int | None, modulus: int) -> np.ndarray:
    """Signed modular differences of a block of counter values, the first against ``previous`` (0 if None)."""
    v = np.asarray(values, dtype=np.int64)
    prev = np.concatenate(([v[0] if previous is None else previous], v[:-1]))
    half = modulus // 2
    return (v - prev + half) % modulus - half


def unwrap_counter(raw: np.ndarray, modulus: int = T_US_MODULUS) -> tuple[np.ndarray, np.ndarray]:
    """Unwrap a counter that wraps at ``modulus`` (module docstring).

    Parameters
    ----------
    raw : ndarray, shape (N,)
        Integer-valued counter readings in [0, modulus).
    modulus : int
        Counter range (2**32 for ``micros()``/``millis()``, 2**16 for a frame counter).

    Returns
    -------
    unwrapped : ndarray of float64, shape (N,)
        ``raw[0]`` plus the cumulative signed steps (backward steps stay backward).
    wraps : ndarray of int64
        Indices of the samples right after a wrap.
    """
    raw = np.asarray(raw)
    if raw.size == 0:
        return raw.astype(np.float64), np.zeros(0, dtype=np.int64)
    r = raw.astype(np.int64)
    d = signed_delta(r, None, modulus)
    wraps = np.flatnonzero((d > 0) & (r < np.concatenate((r[:1], r[:-1]))))
    return (r[0] + np.cumsum(d)).astype(np.float64), wraps.astype(np.int64)


def is_u32_counter(raw: np.ndarray) -> bool:
    """Integer-valued, within [0, 2**32): a device tick counter that may wrap."""
    if raw.size == 0 or not np.all(np.isfinite(raw)):
        return False
    return bool(raw.min() >= 0 and raw.max() < T_US_MODULUS and np.all(raw == np.round(raw)))


def spread_coarse_seconds(sec: np.ndarray) -> tuple[np.ndarray, float]:
    """Spread rows that share a whole-second timestamp evenly inside their second.

    The rows of a second are placed at ``sec + k / n`` (k-th of its n rows); the first and last, partial,
    seconds use the median rows per second instead, so that their rows sit at the end (first) or start
    (last) of their second.

    Parameters
    ----------
    sec : ndarray, shape (N,)
        Whole-second timestamps (s), non-decreasing.

    Returns
    -------
    t_s : ndarray, shape (N,)
        Spread times (s).
    rows_per_s : float
        Median rows per second (of the inner seconds).
    """
    sec = np.asarray(sec, dtype=np.float64)
    if sec.size == 0:
        return sec.copy(), float("nan")
    starts = np.flatnonzero(np.r_[True, sec[1:] != sec[:-1]])
    counts = np.diff(np.r_[starts, sec.size])
    inner = counts[1:-1] if counts.size > 2 else counts
    per_s = float(np.median(inner)) if inner.size else float(counts.max())
    k = (np.arange(sec.size) - np.repeat(starts, counts)).astype(np.float64)  # row index within its second
    n = np.repeat(counts, counts).astype(np.float64)
    frac = k / n
    if counts.size > 1:
        if counts[0] < per_s:  # partial first second: rows at its end
            m = slice(0, counts[0])
            frac[m] = 1.0 - (n[m] - k[m]) / per_s
        if counts[-1] < per_s:  # partial last second: rows at its start
            m = slice(starts[-1], sec.size)
            frac[m] = k[m] / per_s
    return sec + frac, per_s


# ------------------------------------------------------------------- streaming device clock (recorder)
@dataclass
class ClockEvent:
    """An irregularity found while unwrapping a stream."""

    kind: str  # "gap", "time_wrap", "nonmonotonic_time", "duplicate_time", "note"
    index: int  # index of the sample (in the whole stream) where it applies
    count: int = 0  # missing frames for gaps
    detail: str = ""


@dataclass
class StreamClock:
    """Streaming unwrapper for blocks of (seq, t_us) frames (protocol v1), with the counter gap rule.

    ``update(seq, t_us)`` returns the unwrapped device time in microseconds (int64, continuous, starting at
    the first raw value) and appends ``ClockEvent``s to ``events``. ``period_us`` (nominal sample period) is
    only used to resolve gaps longer than a seq wrap.
    """

    period_us: float = 1000.0
    n: int = 0  # samples seen
    dropped: int = 0  # frames missing according to seq
    events: list[ClockEvent] = field(default_factory=list)
    _seq: int | None = None
    _t_raw: int | None = None
    _t_cont: int = 0
    _reset_pending: bool = False
    _host_s: float | None = None

    def mark_discontinuity(self) -> None:
        """The link was interrupted (disconnect): the next gap is expected, not a transmission error."""
        self._reset_pending = True

    def update(self, seq, t_us, host_s: float | None = None) -> np.ndarray:
        """Unwrap a block; ``host_s`` (receive time, s) bridges a device clock that restarted."""
        seq = np.asarray(seq, dtype=np.int64)
        t_raw = np.asarray(t_us, dtype=np.int64)
        if seq.size == 0:
            return np.zeros(0, dtype=np.int64)
        dt = signed_delta(t_raw, self._t_raw, T_US_MODULUS)
        ds = signed_delta(seq, self._seq, SEQ_MODULUS)
        if self._t_raw is None:
            dt[0] = 0
            ds[0] = 1
            self._t_cont = int(t_raw[0])
        if host_s is not None and self._host_s is not None and dt[0] < 0:
            # The device restarted (clock went back) between blocks: keep time monotonic with the
            # host clock, which is what elapsed in reality.
            dt_host = np.int64(max(1.0, (host_s - self._host_s) * 1e6))
        else:
            dt_host = None
        dt_raw = dt.copy()
        first_call = self._t_raw is None
        dt[dt_raw < 0] = int(round(self.period_us))  # restart inside a block: assume one period
        if dt_host is not None:
            dt[0] = dt_host
        t_cont = self._t_cont + np.cumsum(dt)
        prev_raw = np.concatenate(([t_raw[0] if self._t_raw is None else self._t_raw], t_raw[:-1]))
        base = self.n
        for i in np.flatnonzero((t_raw < prev_raw) & (dt_raw > 0)).tolist():
            self.events.append(ClockEvent("time_wrap", base + i, 0, "device clock t_us wrapped (2**32 us)"))
        for i in np.flatnonzero(dt_raw < 0).tolist():
            self.events.append(ClockEvent(
                "nonmonotonic_time", base + i, 0, f"device clock went back {-int(dt_raw[i])} us (device reset?)"))
        zero = np.flatnonzero(dt_raw == 0)
        for i in (zero[zero > 0] if first_call else zero).tolist():
            self.events.append(ClockEvent("duplicate_time", base + i, 0, "same t_us as previous frame"))
        for i in np.flatnonzero(ds != 1).tolist():
            d = int(ds[i])
            if d <= 0:
                self.events.append(ClockEvent("note", base + i, 0, f"sequence went back by {1 - d} (device reset?)"))
                continue
            missing = d - 1
            if dt_raw[i] > 0:  # resolve whole seq wraps hidden in a long gap with the device clock
                frames_by_clock = dt_raw[i] / self.period_us
                missing += SEQ_MODULUS * int(round((frames_by_clock - d) / SEQ_MODULUS))
            if missing > 0:
                self.dropped += missing
                why = "across a disconnect" if self._reset_pending else "frames missing"
                self.events.append(ClockEvent("gap", base + i, missing, f"{missing} {why} (seq)"))
        self._reset_pending = False
        self._host_s = host_s
        self._seq = int(seq[-1])
        self._t_raw = int(t_raw[-1])
        self._t_cont = int(t_cont[-1])
        self.n += seq.size
        return t_cont
