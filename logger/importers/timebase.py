"""Sample times: unit conversion, counter wrap-around, coarse clocks, and the time events.

Nothing is resampled or reordered: times are converted and unwrapped, and every irregularity is
recorded as an event (kept samples, never dropped):

* ``time_wrap``: an unsigned 32-bit counter (``micros()`` every 2**32 µs = 71.6 min, ``millis()`` every
  49.7 days) went from near its top to near zero. Unwrapping adds 2**32 counts from there on. A jump is a
  wrap when the raw value falls by more than half the counter range (so small backward steps stay
  ``nonmonotonic_time``).
* ``duplicate_time``: dt == 0 (kept; e.g. 205 in the x-io NGIMU file).
* ``nonmonotonic_time``: dt < 0 after unwrapping.
* ``gap``: dt > 1.5 nominal intervals; ``count`` = round(dt / interval) - 1 missing samples.

Coarse clocks (an RTC logging whole seconds, several rows per second, ttruty): the rows of each second
are spread evenly inside it, t = sec + k / n_k (k = row index within the second, n_k rows in it); the
first and last, partial, seconds use the median rows-per-second instead so that their rows sit at the end
(first) or start (last) of their second. A ``note`` event says so.
"""

from __future__ import annotations

import numpy as np

TIME_SCALE = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
U32 = 2**32


def unwrap_u32(raw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unwrap an unsigned 32-bit counter. Returns (unwrapped int64/float, indices where a wrap occurs)."""
    raw = np.asarray(raw)
    d = np.diff(raw.astype(np.float64))
    wraps = np.flatnonzero(d < -(U32 / 2)) + 1
    offset = np.zeros(raw.shape[0], dtype=np.float64)
    for i in wraps:
        offset[i:] += U32
    return raw.astype(np.float64) + offset, wraps


def is_u32_counter(raw: np.ndarray) -> bool:
    """Integer-valued, within [0, 2**32): a device tick counter that may wrap."""
    if raw.size == 0 or not np.all(np.isfinite(raw)):
        return False
    return bool(raw.min() >= 0 and raw.max() < U32 and np.all(raw == np.round(raw)))


def spread_coarse_seconds(sec: np.ndarray) -> tuple[np.ndarray, float]:
    """Spread rows that share a whole-second timestamp evenly inside their second.

    Returns (t in s, median rows per second).
    """
    sec = np.asarray(sec, dtype=np.float64)
    starts = np.flatnonzero(np.r_[True, sec[1:] != sec[:-1]])
    counts = np.diff(np.r_[starts, sec.size])
    inner = counts[1:-1] if counts.size > 2 else counts
    per_s = float(np.median(inner)) if inner.size else float(counts.max())
    t = np.empty_like(sec)
    for j, (s0, n) in enumerate(zip(starts, counts)):
        k = np.arange(n, dtype=np.float64)
        if j == 0 and counts.size > 1 and n < per_s:
            frac = 1.0 - (n - k) / per_s  # partial first second: rows at its end
        elif j == counts.size - 1 and counts.size > 1 and n < per_s:
            frac = k / per_s  # partial last second: rows at its start
        else:
            frac = k / n
        t[s0 : s0 + n] = sec[s0] + frac
    return t, per_s


def time_events(t_s: np.ndarray, line_numbers: np.ndarray | None, *, nominal_dt: float | None = None,
                with_gaps: bool = True) -> list[dict]:
    """Duplicate, backward and gap events for a time vector (already in seconds, unwrapped)."""
    events: list[dict] = []
    if t_s.size < 2:
        return events
    d = np.diff(t_s)
    pos = d[d > 0]
    dt0 = nominal_dt or (float(np.median(pos)) if pos.size else 0.0)

    def line(i):
        return int(line_numbers[i]) if line_numbers is not None else -1

    for i in np.flatnonzero(d == 0) + 1:
        events.append(dict(kind="duplicate_time", t_s=float(t_s[i]), sample_index=int(i), line=line(i), count=1,
                           detail=f"same time as the previous sample ({t_s[i]:.6f} s)"))
    for i in np.flatnonzero(d < 0) + 1:
        events.append(dict(kind="nonmonotonic_time", t_s=float(t_s[i]), sample_index=int(i), line=line(i), count=1,
                           detail=f"time goes back by {-d[i - 1]:.6g} s (kept, not reordered)"))
    if with_gaps and dt0 > 0:
        for i in np.flatnonzero(d > 1.5 * dt0) + 1:
            missing = int(round(d[i - 1] / dt0)) - 1
            if missing >= 1:
                events.append(dict(kind="gap", t_s=float(t_s[i - 1]), sample_index=int(i), line=line(i),
                                   count=missing, detail=f"dt {d[i - 1]:.6g} s = {missing} missing sample(s) "
                                   f"at {1 / dt0:.4g} Hz"))
    return events
