"""Where the live view's samples come from: a recording still being written, or a finished one replayed.

``GrowingRecording`` tails the SWMR file a running ``bootnav record`` flushes (``docs/recording-format.md``,
"Crash safety"): it opens the file read-only in SWMR mode once the recorder has created it, and each ``poll``
refreshes the datasets and returns the rows flushed since the last one, in SI units (read through
``recording.RecordingReader``, the one decoder of the layout: exactly what ``recording.load`` computes). It
runs in the view's own process and never writes, so the recorder cannot lose a frame because of it.

``ReplayRecording`` serves a finished recording (``recording.RecordingReader``, block by block as they are
due; one boot of a multi-boot recording) in the same chunks, paced by its own time stamps divided by ``speed``.

Both return ``Chunk`` objects: the new samples, the new ``/events`` rows, and the recording's ``/meta``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bootnav.logger.recording import EVENT_DTYPE, RecordingReader

#: per-sample datasets read by the view (every recorder-written file has them)
_IMU = ("t_s", "acc", "gyro", "saturated")


@dataclass
class Chunk:
    """Samples new since the last poll (SI, body frame) and the events new since then."""

    t_s: np.ndarray
    acc_mps2: np.ndarray
    gyro_radps: np.ndarray
    saturated: np.ndarray  # uint8 bitmask (recording.SATURATION_BITS)
    events: np.ndarray = field(default_factory=lambda: np.zeros(0, EVENT_DTYPE))
    temp_degc: np.ndarray | None = None  # sensor temperature per sample, when the recording has it
    device_id: str | None = None  # the recording's /meta device_id (which calibration applies)


def _empty_chunk() -> Chunk:
    return Chunk(np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.uint8))


class GrowingRecording:
    """Rows of a recording another process is writing in SWMR mode, as they are flushed.

    Parameters
    ----------
    path : path of the recording (it may not exist yet: ``poll`` returns None until it does)
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._reader: RecordingReader | None = None
        self._n = 0
        self._n_events = 0
        self.meta: dict = {}

    def _open(self) -> bool:
        if not self.path.exists():
            return False
        try:
            reader = RecordingReader(self.path, swmr=True, require=_IMU)
        except (OSError, KeyError):
            return False  # created but not yet switched to SWMR (or its /imu not complete) by the recorder
        self._reader, self.meta = reader, reader.meta
        return True

    def poll(self) -> Chunk | None:
        """The rows flushed since the last call (None before the file is readable)."""
        if self._reader is None and not self._open():
            return None
        n = self._reader.refresh()  # the recorder flushes all at once; the common prefix
        chunk = _empty_chunk()
        if n > self._n:
            chunk = Chunk(*self._reader.block(self._n, n), temp_degc=self._reader.temp_degc(self._n, n))
            self._n = n
        chunk.device_id = self.meta.get("device_id")
        events = self._reader.events(self._n_events)
        if len(events):
            chunk.events = events
            self._n_events += len(events)
        return chunk

    def close(self) -> None:
        if self._reader is not None:
            self._reader.close()
            self._reader = None


class ReplayRecording:
    """A finished recording served in chunks at ``speed`` times its own pace (``inf``: all at once).

    Parameters
    ----------
    path : recording to replay (a bootnav HDF5 recording)
    speed : float
        Recording seconds per wall-clock second.
    boot : str, optional
        The boot of a multi-boot recording (``recording.boot_labels``); its time stamps are on the session
        clock, so the boots of one file replay in step.
    """

    def __init__(self, path: str | Path, speed: float = 1.0, boot: str | None = None):
        self.path = Path(path)
        self._reader = RecordingReader(self.path, boot)  # blocks read as they are due: memory bounded by them
        if self._reader.n < 2:
            from bootnav.errors import InputError

            n = self._reader.n
            self._reader.close()
            raise InputError(f"{self.path}{f' boot {boot}' if boot else ''}: {n} sample(s), nothing to replay "
                             "(the recording stopped before its first frames); `bootnav info` shows what it holds")
        self._reader.check_units()
        self.meta = self._reader.meta
        self._t = self._reader.times()
        self.speed = float(speed)
        self._n = 0
        self._start: float | None = None
        ev = self._reader.events()
        self._events = ev[np.argsort(ev["sample_index"], kind="stable")]
        self._n_events = 0

    @property
    def finished(self) -> bool:
        return self._n >= self._reader.n

    def poll(self) -> Chunk:
        """The samples whose time has come since the last call."""
        now = time.monotonic()
        if self._start is None:
            self._start = now
        t_due = self._t[0] + (now - self._start) * self.speed
        n = self._reader.n if not np.isfinite(t_due) else int(np.searchsorted(self._t, t_due, side="right"))
        chunk = (Chunk(*self._reader.block(self._n, n), temp_degc=self._reader.temp_degc(self._n, n),
                       device_id=self.meta.get("device_id")) if n > self._n else _empty_chunk())
        self._n = max(n, self._n)
        k = int(np.searchsorted(self._events["sample_index"], self._n, side="left"))
        if k > self._n_events:
            chunk.events = self._events[self._n_events:k]
            self._n_events = k
        return chunk

    def close(self) -> None:
        self._reader.close()
