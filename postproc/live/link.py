"""Link status of one boot from what the recorder writes: rate, drops, CRC errors, saturation, connection.

Counted from the ``/events`` rows (``gap`` counts missing frames, one ``crc_error`` row per bad frame,
``disconnect``/``reconnect``) and the per-sample ``/imu/saturated`` bitmask (``docs/recording-format.md``);
the rate is the number of samples over the device-time span of the last ``rate_window_s``.
"""

from __future__ import annotations

from collections import deque

import numpy as np


class LinkStatus:
    """Running link figures of one boot.

    Parameters
    ----------
    rate_window_s : float, s
        Device-time window of the rate estimate; 2 s holds several hundred samples at 200 Hz, so the figure
        is steady to about 1 %.
    stale_s : float, s
        Wall-clock time without a new sample after which a live link is shown as stale; the recorder flushes
        every 0.2 s, so 2 s means ten missed flushes.
    """

    def __init__(self, rate_window_s: float = 2.0, stale_s: float = 2.0):
        self.rate_window_s = rate_window_s
        self.stale_s = stale_s
        self.dropped = 0
        self.crc_errors = 0
        self.saturated = 0
        self.samples = 0
        self.connected = True
        self._blocks: deque[tuple[float, float, int]] = deque()  # (t first, t last, n) per chunk
        self._last_wall: float | None = None

    def update(self, t_s: np.ndarray, saturated: np.ndarray, events: np.ndarray, wall_s: float) -> None:
        """Account for one chunk of samples and events received at ``wall_s`` (monotonic s)."""
        if len(events):
            kind = events["kind"]
            self.dropped += int(events["count"][kind == b"gap"].sum())
            self.crc_errors += int((kind == b"crc_error").sum())
            for k in kind[np.isin(kind, (b"disconnect", b"reconnect"))]:
                self.connected = k == b"reconnect"
        n = len(t_s)
        if n == 0:
            return
        self.samples += n
        self.saturated += int(np.count_nonzero(saturated))
        self._blocks.append((float(t_s[0]), float(t_s[-1]), n))
        while self._blocks and self._blocks[-1][1] - self._blocks[0][0] > self.rate_window_s and len(self._blocks) > 1:
            self._blocks.popleft()
        self._last_wall = wall_s

    def as_dict(self, wall_s: float, ended: bool) -> dict:
        """``state`` (waiting, ok, stale, disconnected, ended), ``rate_hz``, ``dropped``, ``crc_errors``,
        ``saturated`` (samples with an axis at full scale), ``age_s`` (wall s since the last sample)."""
        span = self._blocks[-1][1] - self._blocks[0][0] if self._blocks else 0.0
        n = sum(b[2] for b in self._blocks) - 1
        age = float("inf") if self._last_wall is None else wall_s - self._last_wall
        if ended:
            state = "ended"
        elif self._last_wall is None:
            state = "waiting"
        elif not self.connected:
            state = "disconnected"
        else:
            state = "ok" if age <= self.stale_s else "stale"
        return {"state": state, "rate_hz": n / span if span > 0 else 0.0, "dropped": self.dropped,
                "crc_errors": self.crc_errors, "saturated": self.saturated,
                "age_s": age if np.isfinite(age) else None}
