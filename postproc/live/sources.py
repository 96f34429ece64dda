"""Where the live view's samples come from: a recording still being written, or a finished one replayed.

``GrowingRecording`` tails the SWMR file a running ``bootnav record`` flushes (``docs/recording-format.md``,
"Crash safety"): it opens the file read-only in SWMR mode once the recorder has created it, and each ``poll``
refreshes the datasets and returns the rows flushed since the last one, in SI units (raw · ``scale_to_si`` +
``offset_to_si``, exactly what ``recording.load`` computes). It runs in the view's own process and never
writes, so the recorder cannot lose a frame because of it.

``ReplayRecording`` serves a finished recording (``recording.load``; one boot of a multi-boot recording)
in the same chunks, paced by its own time stamps divided by ``speed``.

Both return ``Chunk`` objects: the new samples, the new ``/events`` rows, and the recording's ``/meta``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bootnav.logger.recording import EVENT_DTYPE, load

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
        self._f = None
        self._n = 0
        self._n_events = 0
        self.meta: dict = {}
        self._scale: dict[str, tuple[float, float]] = {}

    def _open(self) -> bool:
        import h5py

        if not self.path.exists():
            return False
        try:
            f = h5py.File(self.path, "r", libver="latest", swmr=True)
        except OSError:
            return False  # created but not yet switched to SWMR by the recorder: next poll
        if "imu" not in f or any(k not in f["imu"] for k in _IMU):
            f.close()
            return False
        self._f = f
        self.meta = {k: (v.decode() if isinstance(v, bytes) else v.item() if isinstance(v, np.generic) else v)
                     for k, v in f["meta"].attrs.items()} if "meta" in f else {}
        for k in ("acc", "gyro", "temp"):
            if k in f["imu"]:
                a = f["imu"][k].attrs
                self._scale[k] = (float(a.get("scale_to_si", 1.0)), float(a.get("offset_to_si", 0.0)))
        return True

    def poll(self) -> Chunk | None:
        """The rows flushed since the last call (None before the file is readable)."""
        if self._f is None and not self._open():
            return None
        imu = self._f["imu"]
        for k in _IMU:
            imu[k].refresh()
        n = min(imu[k].shape[0] for k in _IMU)  # the recorder flushes all at once; keep the common prefix
        chunk = _empty_chunk()
        if n > self._n:
            sl = slice(self._n, n)
            si = {k: imu[k][sl].astype(np.float64) * self._scale[k][0] + self._scale[k][1] for k in ("acc", "gyro")}
            temp = None
            if "temp" in self._scale and "temp" in imu:
                imu["temp"].refresh()
                if imu["temp"].shape[0] >= n:
                    temp = imu["temp"][sl].astype(np.float64) * self._scale["temp"][0] + self._scale["temp"][1]
            chunk = Chunk(imu["t_s"][sl], si["acc"], si["gyro"], imu["saturated"][sl], temp_degc=temp)
            self._n = n
        chunk.device_id = self.meta.get("device_id")
        if "events" in self._f:
            ev = self._f["events"]
            ev.refresh()
            if ev.shape[0] > self._n_events:
                chunk.events = ev[self._n_events:]
                self._n_events = ev.shape[0]
        return chunk

    def close(self) -> None:
        if self._f is not None:
            self._f.close()
            self._f = None


class ReplayRecording:
    """A finished recording served in chunks at ``speed`` times its own pace (``inf``: all at once).

    Parameters
    ----------
    path : recording to replay (anything ``recording.load`` reads)
    speed : float
        Recording seconds per wall-clock second.
    boot : str, optional
        The boot of a multi-boot recording (``recording.boot_labels``); its time stamps are on the session
        clock, so the boots of one file replay in step.
    """

    def __init__(self, path: str | Path, speed: float = 1.0, boot: str | None = None):
        self.path = Path(path)
        rec = load(self.path, with_truth=False, boot=boot, check_units=True)
        if rec.n < 2:
            from bootnav.errors import InputError

            raise InputError(f"{self.path}{f' boot {boot}' if boot else ''}: {rec.n} sample(s), nothing to replay "
                             "(the recording stopped before its first frames); `bootnav info` shows what it holds")
        self.meta = rec.meta
        self._rec = rec
        self.speed = float(speed)
        self._n = 0
        self._start: float | None = None
        ev = rec.events
        self._events = ev[np.argsort(ev["sample_index"], kind="stable")]
        self._n_events = 0

    @property
    def finished(self) -> bool:
        return self._n >= self._rec.n

    def poll(self) -> Chunk:
        """The samples whose time has come since the last call."""
        rec = self._rec
        now = time.monotonic()
        if self._start is None:
            self._start = now
        t_due = rec.t_s[0] + (now - self._start) * self.speed
        n = rec.n if not np.isfinite(t_due) else int(np.searchsorted(rec.t_s, t_due, side="right"))
        sl = slice(self._n, max(n, self._n))
        chunk = Chunk(rec.t_s[sl], rec.acc_mps2[sl], rec.gyro_radps[sl], rec.saturated[sl],
                      temp_degc=None if rec.temp_degc is None else rec.temp_degc[sl], device_id=rec.meta.get("device_id"))
        self._n = max(n, self._n)
        k = int(np.searchsorted(self._events["sample_index"], self._n, side="left"))
        if k > self._n_events:
            chunk.events = self._events[self._n_events:k]
            self._n_events = k
        return chunk

    def close(self) -> None:
        pass
