"""Device clock and sequence counter: unwrapping and gap detection, streaming.

The firmware stamps each sample with ``t_us`` (u32 ``micros()``, wraps every 2**32 us = 71.58 min) and
``seq`` (u16, wraps every 65536 frames). Both are unwrapped with the *signed modular difference*

    d = ((x_k - x_{k-1} + M/2) mod M) - M/2            (M = 2**32 or 2**16)

which is exact as long as consecutive received samples are less than M/2 apart (35.8 min of device
time, 32768 frames). A wrap is a step where the raw value decreases but ``d > 0``; ``d <= 0`` is a
clock going backwards (device reset). For a gap longer than one seq wrap (65.5 s at 1 kHz) the
number of missing frames is ambiguous modulo 65536 and is resolved with the device clock:
``missing = d_seq - 1 + 65536 * round((dt / T - d_seq) / 65536)`` with nominal period ``T``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

T_US_MODULUS = 1 << 32
SEQ_MODULUS = 1 << 16
T_US_WRAP_S = T_US_MODULUS / 1e6  # 4294.967296 s = 71.58 min


def signed_delta(values: np.ndarray, previous: int | None, modulus: int) -> np.ndarray:
    """Signed modular differences of a block of counter values; the first against ``previous``."""
    v = np.asarray(values, dtype=np.int64)
    prev = np.concatenate(([v[0] if previous is None else previous], v[:-1]))
    half = modulus // 2
    return (v - prev + half) % modulus - half


@dataclass
class TimebaseEvent:
    kind: str  # "gap", "time_wrap", "nonmonotonic_time", "duplicate_time", "note"
    index: int  # index of the sample (in the whole stream) where it applies
    count: int = 0  # missing frames for gaps
    detail: str = ""


@dataclass
class Timebase:
    """Streaming unwrapper for (seq, t_us) blocks.

    ``update(seq, t_us)`` returns the unwrapped device time in microseconds (int64, continuous,
    starting at the first raw value) and appends events to ``events``. ``period_us`` (nominal sample
    period) is only used to resolve gaps longer than a seq wrap.
    """

    period_us: float = 1000.0
    n: int = 0  # samples seen
    dropped: int = 0  # frames missing according to seq
    events: list[TimebaseEvent] = field(default_factory=list)
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
            self.events.append(TimebaseEvent("time_wrap", base + i, 0, "device clock t_us wrapped (2**32 us)"))
        for i in np.flatnonzero(dt_raw < 0).tolist():
            self.events.append(TimebaseEvent(
                "nonmonotonic_time", base + i, 0, f"device clock went back {-int(dt_raw[i])} us (device reset?)"))
        zero = np.flatnonzero(dt_raw == 0)
        for i in (zero[zero > 0] if first_call else zero).tolist():
            self.events.append(TimebaseEvent("duplicate_time", base + i, 0, "same t_us as previous frame"))
        for i in np.flatnonzero(ds != 1).tolist():
            d = int(ds[i])
            if d <= 0:
                self.events.append(TimebaseEvent("note", base + i, 0, f"sequence went back by {1 - d} (device reset?)"))
                continue
            missing = d - 1
            if dt_raw[i] > 0:  # resolve whole seq wraps hidden in a long gap with the device clock
                frames_by_clock = dt_raw[i] / self.period_us
                missing += SEQ_MODULUS * int(round((frames_by_clock - d) / SEQ_MODULUS))
            if missing > 0:
                self.dropped += missing
                why = "across a disconnect" if self._reset_pending else "frames missing"
                self.events.append(TimebaseEvent("gap", base + i, missing, f"{missing} {why} (seq)"))
        self._reset_pending = False
        self._host_s = host_s
        self._seq = int(seq[-1])
        self._t_raw = int(t_raw[-1])
        self._t_cont = int(t_cont[-1])
        self.n += seq.size
        return t_cont
