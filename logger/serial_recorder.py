"""Serial recorder: protocol-v1 frames from a port -> incremental, crash-safe HDF5 recording.

One loop, no threads: read what the port has (pyserial ``serial_for_url``, so ``/dev/ttyUSB0``,
a pty path or ``loop://`` work), parse it with the vectorised ``FrameParser``, unwrap ``seq``/``t_us``
(``bootnav.core.timebase.StreamClock``), and every ``flush_interval_s`` append the block to a
``RecordingWriter`` (SWMR) and flush, so a ``kill -9`` loses at most that interval and the file still opens.

The sensor configuration comes from the header frame: the recorder asks for it (``H``) when it
connects and waits up to ``header_wait_s`` before creating the file with its scale factors; with no
header by then it assumes the recommended ±16 g / ±2000 °/s and records a ``note`` event saying so.

A port that disappears (cable pulled, emulator restarted) is reopened every ``reconnect_interval_s``;
the ``disconnect``/``reconnect`` events and the ``gap`` (frames missing by seq, resolved with the
device clock) go into the same file. Byte offsets in events are absolute over the whole session.

Two boots (``MultiBootRecorder``, ``bootnav record --port A --port B``): each port runs this same loop in a
thread of its own without writing; one writer thread owns the multi-boot HDF5 file (one group per boot) and
puts every boot on one session clock by fitting each device clock to the host receive times
(``fit_host_clock``; ``docs/recording-format.md``).
"""

from __future__ import annotations

import json
import os
import threading
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from bootnav.core.runs import runs
from bootnav.core.timebase import StreamClock, timing_summary
from bootnav.errors import BootnavError, DiskFullError
from bootnav.logger import mpu6050
from bootnav.logger.protocol import CMD_RESEND_HEADER, FrameParser, HeaderFrame, ParseResult
from bootnav.logger.recording import (RecordingWriter, counts_channel, make_events, retime_boots,
                                      set_scale_factors)

AXES = ("ax", "ay", "az", "gx", "gy", "gz")
DEFAULT_ACCEL_FS, DEFAULT_GYRO_FS = 3, 3  # ±16 g, ±2000 °/s: what a boot needs (see PROTOCOL.md)


@dataclass
class RecorderSettings:
    """Every knob of the recorder (saved as JSON in /meta/recorder_settings)."""

    port: str
    out: str
    baud: int = 500_000
    duration_s: float | None = None  # wall-clock seconds; None = until stopped
    flush_interval_s: float = 0.5  # crash loses at most this much
    header_wait_s: float = 1.5  # wait this long for a header frame before assuming defaults
    connect_timeout_s: float = 10.0  # the port must open within this at start
    reconnect_interval_s: float = 0.2
    read_timeout_s: float = 0.02  # latency of one read; the loop never busy-waits
    read_size: int = 65536
    status_interval_s: float = 0.5
    silence_s: float = 2.0  # note an open port that delivers nothing for this long
    mount: str = ""
    subject: str = ""
    session_notes: str = ""


@dataclass
class RecorderStats:
    frames: int = 0
    dropped: int = 0
    crc_errors: int = 0
    resyncs: int = 0
    skipped_bytes: int = 0
    unknown_frames: int = 0
    headers: int = 0
    status_frames: int = 0
    disconnects: int = 0
    bytes_in: int = 0
    saturated_samples: list[int] = field(default_factory=lambda: [0] * 6)
    stop_reason: str = ""


class SerialRecorder:
    """One port: read, parse, unwrap and (unless ``writes`` is False) write its own recording.

    With ``writes=False`` (one port of a ``MultiBootRecorder``) the loop runs in its own thread and only
    collects blocks; the writer thread takes them with ``take_pending`` (every mutation of the pending
    blocks and events holds ``lock``).
    """

    def __init__(self, settings: RecorderSettings, status_stream=None, writes: bool = True):
        self.s = settings
        self.writes = writes
        self.lock = threading.RLock()
        self.file_created = False  # set by a MultiBootRecorder once the shared file exists
        # per read block: (device s of its last sample, host receive s, index of that sample), and the sample
        # indices where the device clock restarted (its time across a restart is bridged, not measured)
        self.clock_points: list[tuple[float, float, int]] = []
        self.clock_breaks: list[int] = []
        self.stats = RecorderStats()
        self.status_stream = status_stream
        self._stop = False
        self._writer: RecordingWriter | None = None
        self.disk_full: DiskFullError | None = None  # set when a write hit a full disk; the recording stops
        self._header: HeaderFrame | None = None
        self._config_source = ""
        self._parser = FrameParser()
        self._clock: StreamClock | None = None
        self._t0_us: int | None = None
        self._pending: list[dict] = []  # blocks of per-sample arrays not yet written
        self._pending_events: list[dict] = []
        self._n = 0  # samples accepted (written + pending)
        self._last_t_s = float("nan")
        self._open_runs: list[int | None] = [None] * 6  # start index of a saturation run per axis
        self._first_sample_mono: float | None = None
        self._late_header: HeaderFrame | None = None
        self._connected = False
        self._rate_window: list[tuple[float, int]] = []

    @property
    def wrote_file(self) -> bool:
        return self._writer is not None

    def stop(self, reason: str = "stopped") -> None:
        self._stop = True
        self.stats.stop_reason = self.stats.stop_reason or reason

    # ------------------------------------------------------------------ main loop
    def run(self) -> RecorderStats:
        import serial

        s = self.s
        start = time.monotonic()
        ser, ever_connected, down_since = None, False, None
        last_flush = last_status = start
        last_data, silence_noted = start, False
        last_h = start
        try:
            while not self._stop:
                now = time.monotonic()
                if s.duration_s is not None and now - start >= s.duration_s:
                    self.stats.stop_reason = "duration reached"
                    break
                if self.writes and now - last_flush >= s.flush_interval_s:
                    self._flush()
                    last_flush = now
                if self.writes and now - last_status >= s.status_interval_s:
                    self._status(now)
                    last_status = now
                if ser is None:
                    try:
                        ser = serial.serial_for_url(s.port, baudrate=s.baud, timeout=s.read_timeout_s)
                        ser.write(CMD_RESEND_HEADER)
                        last_h = time.monotonic()
                    except (serial.SerialException, OSError, ValueError) as exc:
                        ser = None
                        if not ever_connected and now - start > s.connect_timeout_s:
                            raise BootnavError(f"cannot open serial port {s.port}: {exc}") from exc
                        time.sleep(s.reconnect_interval_s)
                        continue
                    if ever_connected:
                        self._event("reconnect", detail=f"{s.port} back after {now - down_since:.2f} s")
                        self._parser = FrameParser(base_offset=self.stats.bytes_in)
                    ever_connected, down_since = True, None
                    self._connected = True
                    last_data, silence_noted = time.monotonic(), False
                if self._header is None and now - last_h >= 0.5:
                    try:  # the start-up header may have been lost or corrupted: ask again
                        ser.write(CMD_RESEND_HEADER)
                    except (serial.SerialException, OSError):
                        pass  # a dead port shows up in the read below
                    last_h = now
                t_read = time.monotonic()
                data, error = self._read(ser)
                if data:
                    if silence_noted:
                        self._event("note", detail=f"data resumed after {t_read - last_data:.1f} s of silence")
                    last_data, silence_noted = t_read, False
                    host_time = time.time()
                    with self.lock:
                        self.stats.bytes_in += len(data)
                        self._handle(self._parser.feed(data), host_time)
                elif not silence_noted and t_read - last_data >= s.silence_s:
                    # Port open but nothing arrives: device hung, wrong baud, or streaming off.
                    silence_noted = True
                    self._event("note", detail=f"port open but no data for {s.silence_s:g} s")
                if error is not None:
                    with self.lock:
                        self._on_disconnect(str(error))
                    try:
                        ser.close()
                    except (serial.SerialException, OSError):
                        pass
                    ser, down_since = None, time.monotonic()
                    self._connected = False
                    continue
                if len(data) < 1024 and getattr(ser, "fd", None) is not None:
                    # little traffic: batch reads instead of waking up for every frame
                    time.sleep(max(0.0, t_read + s.read_timeout_s - time.monotonic()))
        except KeyboardInterrupt:
            self.stats.stop_reason = "interrupted (Ctrl-C)"
        finally:
            if ser is not None:
                try:
                    ser.close()
                except Exception:  # noqa: BLE001 - closing a dead port must not hide the data
                    pass
            self._finish()
        return self.stats

    def _read(self, ser):
        """What the port has, waiting up to the read timeout; returns (data, exception or None).

        A real device or pty (pyserial's posix ``Serial``, which has an ``fd``) is read with one
        ``select`` + ``os.read``: pyserial's own ``read(n)`` discards what it has already collected
        when the port dies half-way through, and those frames would be lost at a disconnect. URL
        handlers without a file descriptor (``socket://``, ``loop://``, ``rfc2217://``) use
        ``read(n)`` with the timeout.
        """
        import select

        import serial

        fd = getattr(ser, "fd", None)
        try:
            if fd is None:
                return ser.read(self.s.read_size), None
            ready, _, _ = select.select([fd], [], [], self.s.read_timeout_s)
            if not ready:
                return b"", None
            data = os.read(fd, self.s.read_size)
            if not data:
                return b"", serial.SerialException("device reports readiness to read but returned no data "
                                                   "(device disconnected?)")
            return data, None
        except BlockingIOError:
            return b"", None
        except (serial.SerialException, OSError) as exc:
            return b"", exc

    # ------------------------------------------------------------------ frame handling
    def _handle(self, result: ParseResult, host_time: float) -> None:
        samples = result.samples
        offsets = samples["offset"]
        for header in result.headers:
            self._on_header(header, int(np.searchsorted(offsets, header.offset)))
        for status in result.statuses:
            self.stats.status_frames += 1
            self._event("note", index_in_block=int(np.searchsorted(offsets, status.offset)),
                        byte_offset=status.offset, count=status.value,
                        detail=f"device status {status.code}: {status.meaning} (detail {status.detail}, "
                               f"value {status.value})")
        for ev in result.events:
            i = int(np.searchsorted(offsets, ev.byte_offset))
            if ev.kind == "crc_error":
                self.stats.crc_errors += 1
                self._event("crc_error", index_in_block=i, byte_offset=ev.byte_offset, count=ev.count,
                            detail=f"bad CRC in a {ev.count}-byte frame of type {ev.frame_type:#04x}")
            elif ev.kind in ("resync", "truncated"):
                self.stats.resyncs += 1
                self.stats.skipped_bytes += ev.count
                why = f" ({ev.detail})" if ev.detail else ""
                self._event("resync", index_in_block=i, byte_offset=ev.byte_offset, count=ev.count,
                            detail=f"{ev.count} bytes skipped to the next sync word{why}")
            elif ev.kind == "unknown":
                self.stats.unknown_frames += 1
                self._event("note", index_in_block=i, byte_offset=ev.byte_offset,
                            detail=f"unknown frame skipped: {ev.detail}")
        if samples.size:
            self._on_samples(samples, host_time)

    def _on_header(self, header: HeaderFrame, index_in_block: int) -> None:
        self.stats.headers += 1
        if self._header is None:
            self._header = header
            detail = json.dumps(header.config())
            if self._writer is not None or self.file_created:  # defaults were assumed before this header came
                self._late_header = header
                detail += "; arrived after the default scale factors were assumed: corrected when the file closes"
            else:
                self._config_source = "header frame"
            self._event("header", index_in_block=index_in_block, byte_offset=header.offset, detail=detail)
        elif header.config() != self._header.config():
            old, new = self._header.config(), header.config()
            changed = {k: [old[k], new[k]] for k in old if old[k] != new[k]}
            self._event("header", index_in_block=index_in_block, byte_offset=header.offset,
                        detail=f"configuration changed {json.dumps(changed)}; scale factors stay those of the start")
            self._header = header
            if self.status_stream is not None:
                print(f"\nwarning: sensor configuration changed mid-recording: {changed}", file=self.status_stream)

    def _on_samples(self, samples: np.ndarray, host_time: float) -> None:
        if self._first_sample_mono is None:
            self._first_sample_mono = time.monotonic()
        if self._clock is None:
            rate = self._header.rate_hz if self._header else 1000.0
            self._clock = StreamClock(period_us=1e6 / rate)
        n_ev = len(self._clock.events)
        t_cont = self._clock.update(samples["seq"], samples["t_us"], host_s=host_time)
        if self._t0_us is None:
            self._t0_us = int(t_cont[0])
        for ev in self._clock.events[n_ev:]:
            self._event(ev.kind, sample_index=ev.index, count=ev.count, detail=ev.detail,
                        t_s=float(t_cont[ev.index - self._n] - self._t0_us) / 1e6)
            if ev.kind == "nonmonotonic_time":
                self.clock_breaks.append(ev.index)
        self.stats.dropped = self._clock.dropped
        t_s = (t_cont - self._t0_us) / 1e6
        acc, gyro = samples["acc"], samples["gyro"]
        raw = np.concatenate([acc, gyro], axis=1)
        sat = (raw == mpu6050.INT16_MAX) | (raw == mpu6050.INT16_MIN)
        bits = (sat.astype(np.uint8) << np.arange(6, dtype=np.uint8)).sum(axis=1).astype(np.uint8)
        self._update_saturation_runs(sat, t_s)
        self._pending.append({"t_s": t_s, "acc": acc.copy(), "gyro": gyro.copy(), "temp": samples["temp"].copy(),
                              "t_device": samples["t_us"].copy(), "seq": samples["seq"].copy(),
                              "t_host": np.full(samples.size, host_time), "saturated": bits})
        self._n += samples.size
        self.stats.frames = self._n
        self._last_t_s = float(t_s[-1])
        self.clock_points.append((self._last_t_s, host_time, self._n - 1))
        self._rate_window.append((time.monotonic(), self._n))

    def _update_saturation_runs(self, sat: np.ndarray, t_s: np.ndarray) -> None:
        """One ``saturation`` event per run of full-scale samples per axis (count = run length)."""
        n = sat.shape[0]
        for axis in range(6):
            m = sat[:, axis]
            self.stats.saturated_samples[axis] += int(m.sum())
            if not m.any() and self._open_runs[axis] is None:
                continue
            starts, ends = runs(m)
            if self._open_runs[axis] is not None and (starts.size == 0 or starts[0] != 0):
                self._close_run(axis, self._n)  # the open run ended just before this block
            for a, b in zip(starts.tolist(), ends.tolist()):
                begin = self._open_runs[axis] if (a == 0 and self._open_runs[axis] is not None) else self._n + a
                if b == n:
                    self._open_runs[axis] = begin  # still at full scale at the end of the block
                else:
                    self._open_runs[axis] = begin
                    self._close_run(axis, self._n + b)

    def _close_run(self, axis: int, end_index: int) -> None:
        begin = self._open_runs[axis]
        self._open_runs[axis] = None
        self._event("saturation", sample_index=begin, count=end_index - begin, axis=axis,
                    detail=f"{AXES[axis]} at full scale for {end_index - begin} samples")

    def _on_disconnect(self, why: str) -> None:
        self.stats.disconnects += 1
        self._event("disconnect", sample_index=self._n, detail=f"{self.s.port}: {why}"[:200])
        for ev in self._parser.finish():
            self.stats.resyncs += 1
            self.stats.skipped_bytes += ev.count
            self._event("resync", sample_index=self._n, byte_offset=ev.byte_offset, count=ev.count,
                        detail=f"{ev.count} bytes lost at disconnect ({ev.detail})")
        if self._clock is not None:
            self._clock.mark_discontinuity()

    def _event(self, kind: str, *, index_in_block: int | None = None, sample_index: int | None = None,
               t_s: float | None = None, **fields) -> None:
        with self.lock:
            if sample_index is None:
                sample_index = self._n + (index_in_block or 0)
            self._pending_events.append({"kind": kind, "sample_index": sample_index,
                                         "t_s": self._last_t_s if t_s is None else t_s, **fields})

    def take_pending(self) -> tuple[list[dict], list[dict]]:
        """Hand the blocks and events collected so far to the writer (``writes=False``)."""
        with self.lock:
            blocks, events = self._pending, self._pending_events
            self._pending, self._pending_events = [], []
        return blocks, events

    # ------------------------------------------------------------------ writing
    def _create_writer(self) -> None:
        acc, gyro, temp, meta = self.layout()
        self._writer = RecordingWriter(self.s.out, acc, gyro, temp=temp, device_time=True, host_time=True, seq=True,
                                       meta=meta)

    def layout(self):
        """(acc, gyro, temp channels, meta) of this port's recording, from its header frame or the defaults."""
        if self._header is None:
            self._config_source = (f"default ±{mpu6050.ACCEL_RANGE_G[DEFAULT_ACCEL_FS]} g / "
                                   f"±{mpu6050.GYRO_RANGE_DPS[DEFAULT_GYRO_FS]} °/s: no header frame within "
                                   f"{self.s.header_wait_s} s")
            self._pending_events.insert(0, {"kind": "note", "sample_index": 0, "t_s": 0.0,
                                            "detail": f"scale factors assumed: {self._config_source}"})
            a_fs, g_fs = DEFAULT_ACCEL_FS, DEFAULT_GYRO_FS
        else:
            a_fs, g_fs = self._header.accel_fs, self._header.gyro_fs
        h = self._header
        meta = {
            "device": "MPU6050",
            "protocol_version": 1,
            "accel_fs": a_fs, "gyro_fs": g_fs,
            "accel_range_g": mpu6050.ACCEL_RANGE_G[a_fs],
            "gyro_range_dps": mpu6050.GYRO_RANGE_DPS[g_fs],
            "config_source": self._config_source,
            "port": self.s.port, "baud": self.s.baud,
            "mount": self.s.mount, "subject": self.s.subject, "session_notes": self.s.session_notes,
            "recorder_settings": json.dumps(asdict(self.s)),
        }
        if h is not None:
            meta.update(self._header_meta(h))
        return (counts_channel("acc", mpu6050.accel_scale_mps2(a_fs)),
                counts_channel("gyro", mpu6050.gyro_scale_radps(g_fs)),
                counts_channel("temp", 1.0 / mpu6050.TEMP_LSB_PER_DEGC), meta)

    def _flush(self, final: bool = False) -> None:
        """Write the pending block; a full disk stops the recording (``disk_full`` says what is safe)."""
        if self.disk_full is not None:
            return
        try:
            self._write_pending(final)
        except DiskFullError as exc:
            self.disk_full = exc
            self._writer = self._writer if self._writer is not None and self._writer.n_safe else None
            self.stop("disk full")

    def _write_pending(self, final: bool) -> None:
        if self._writer is None:
            waited = (time.monotonic() - self._first_sample_mono) if self._first_sample_mono else 0.0
            if self._header is None and not final and waited < self.s.header_wait_s:
                return
            if not self._pending and not self._pending_events and not final:
                return
            self._create_writer()
        n_rows = sum(len(p["t_s"]) for p in self._pending)
        if not self._writer.room_for(n_rows, len(self._pending_events)):
            # stop before the disk fills: the file stays whole and readable up to the last flush
            exc = self._writer.disk_full_error()
            self._writer.close()
            raise exc
        if self._pending:
            block = {k: np.concatenate([p[k] for p in self._pending]) for k in self._pending[0]}
            self._writer.append(block.pop("t_s"), block.pop("acc"), block.pop("gyro"), **block)
            self._pending.clear()
        if self._pending_events:
            self._pending_events.sort(key=lambda e: e["sample_index"])  # stable: stream order within a sample
            self._writer.add_events(make_events(self._pending_events))
            self._pending_events.clear()
        self._writer.flush()

    def _finish(self) -> None:
        with self.lock:
            for axis in range(6):
                if self._open_runs[axis] is not None:
                    self._close_run(axis, self._n)
            for ev in self._parser.finish():
                self.stats.skipped_bytes += ev.count
                self._event("resync", byte_offset=ev.byte_offset, count=ev.count,
                            detail=f"{ev.count} bytes left at the end ({ev.detail})")
        if not self.writes:
            return
        if self.disk_full is not None:
            return  # the writer is closed with everything up to its last flush; nothing more can be written
        if self._writer is None and self.stats.frames == 0:
            # nothing usable came in: no file rather than an empty one
            self.stats.stop_reason = self.stats.stop_reason or "no data received"
            return
        self._flush(final=True)
        if self._status_line_shown:
            print(file=self.status_stream)
        self._writer.close(final_meta=self.final_meta(self._writer_t_s()))
        if self._late_header is not None:
            self._correct_scale_factors(self._late_header)

    def final_meta(self, t) -> dict:
        """The metadata written when the recording closes: timing of the written ``t`` and the counters."""
        final = timing_summary(t) if t is not None and t.size > 1 else {}
        st = self.stats
        final.update(frames=st.frames, dropped=st.dropped, crc_errors=st.crc_errors, resyncs=st.resyncs,
                     skipped_bytes=st.skipped_bytes, disconnects=st.disconnects, bytes_received=st.bytes_in,
                     saturated_samples=list(st.saturated_samples), stop_reason=st.stop_reason or "stopped",
                     duration_s=float(t[-1] - t[0]) if t is not None and t.size else 0.0)
        if self._late_header is not None:
            final.update(self._header_meta(self._late_header))
            final["config_source"] = "header frame (arrived after defaults were assumed; scale factors corrected)"
        return final

    def _correct_scale_factors(self, h: HeaderFrame, boot: str | None = None) -> None:
        """Counts are stored raw, so a late header only changes the factor to SI (lossless)."""
        set_scale_factors(self.s.out, mpu6050.accel_scale_mps2(h.accel_fs), mpu6050.gyro_scale_radps(h.gyro_fs),
                          boot)

    @staticmethod
    def _header_meta(h: HeaderFrame) -> dict:
        return {"accel_fs": h.accel_fs, "gyro_fs": h.gyro_fs, "accel_range_g": mpu6050.ACCEL_RANGE_G[h.accel_fs],
                "gyro_range_dps": mpu6050.GYRO_RANGE_DPS[h.gyro_fs], "device_id": f"0x{h.device_id:08X}",
                "firmware_version": h.fw_string, "dlpf_cfg": h.dlpf, "smplrt_div": h.smplrt_div,
                "rate_nominal_hz": h.rate_hz, "header_flags": h.flags}

    _status_line_shown = False

    def _writer_t_s(self):
        w = self._writer
        if w is None or w.n == 0:
            return None
        return w.times()

    def _status(self, now: float) -> None:
        if self.status_stream is None:
            return
        self._print_status(self.status_text(now))

    def status_text(self, now: float) -> str:
        """One status line: rate over the last 2 s and the counters."""
        win = [(t, n) for t, n in self._rate_window if now - t <= 2.0]
        self._rate_window = win[-200:]
        rate = (win[-1][1] - win[0][1]) / (win[-1][0] - win[0][0]) if len(win) > 1 and win[-1][0] > win[0][0] else 0.0
        st = self.stats
        sat = " ".join(f"{a}:{c}" for a, c in zip(AXES, st.saturated_samples) if c) or "none"
        return (f"{rate:7.1f} Hz | frames {st.frames} | dropped {st.dropped} | crc {st.crc_errors} | "
                f"resync {st.resyncs} | disc {st.disconnects} | sat {sat}"
                + ("" if self._connected else f" | waiting for {self.s.port}"))

    def _print_status(self, line: str) -> None:
        tty = getattr(self.status_stream, "isatty", lambda: False)()
        if not tty:  # a log file gets one line every 10 intervals, not a flood
            self._status_count = getattr(self, "_status_count", 0) + 1
            if self._status_count % 10 != 1:
                return
        print(("\r" + line + "  ") if tty else line, end="" if tty else "\n", file=self.status_stream, flush=True)
        self._status_line_shown = tty


# ====================================================================== two (or more) boots, one file
def fit_host_clock(dev_s: np.ndarray, host_s: np.ndarray, outlier_sigma: float,
                   segment: np.ndarray | None = None) -> tuple[np.ndarray, float, float, int]:
    """Lines ``host_s = offset[segment] + scale * dev_s`` through the host receive times of the read blocks.

    One rate (``scale``) for the whole recording and one offset per segment of continuous device clock (a
    device restart starts a new segment: its clock is bridged with host time there, not measured). Least
    squares, then refitted without the blocks more than ``outlier_sigma`` standard deviations away (a read
    delayed by a scheduling stall), until that set no longer changes (at most 3 fits); with fewer than 3 blocks
    the scale is 1 (no rate to fit).

    Parameters
    ----------
    dev_s : ndarray
        Device time (s, unwrapped, since the boot's first sample) of the last sample of each read block.
    host_s : ndarray
        Host receive time of each block (s, any origin).
    outlier_sigma : float
        Rejection bound of the refit, in standard deviations of the residuals.
    segment : ndarray of int, optional
        Segment (0, 1, ...) of each block; default all 0.

    Returns
    -------
    offsets_s : ndarray
        Offset of each segment up to the largest in ``segment`` (a segment without blocks takes the previous
        one's).
    scale : float
    residual_s : float
        Std of host − mapped device time over the blocks kept (NaN with fewer than 2).
    n_used : int
        Blocks kept.
    """
    dev_s, host_s = np.asarray(dev_s, float), np.asarray(host_s, float)
    seg = np.zeros(dev_s.size, int) if segment is None else np.asarray(segment, int)
    n_seg = int(seg.max()) + 1 if seg.size else 1
    if dev_s.size == 0:
        return np.full(n_seg, np.nan), 1.0, float("nan"), 0
    fit_scale = dev_s.size >= 3 and np.ptp(dev_s) > 0
    present = np.unique(seg)
    cols = (present[None, :] == seg[:, None]).astype(float)
    design = np.column_stack([dev_s, cols]) if fit_scale else cols
    target = host_s if fit_scale else host_s - dev_s
    keep = np.ones(dev_s.size, bool)
    for _ in range(3):
        coef = np.linalg.lstsq(design[keep], target[keep], rcond=None)[0]
        r = target - design @ coef
        sigma = float(r[keep].std())
        new_keep = np.abs(r) <= outlier_sigma * sigma if sigma > 0 else keep
        if new_keep.sum() < design.shape[1] + 1 or np.array_equal(new_keep, keep):
            break
        keep = new_keep
    scale = float(coef[0]) if fit_scale else 1.0
    offsets = np.full(n_seg, np.nan)
    offsets[present] = coef[1:] if fit_scale else coef
    for k in range(1, n_seg):  # a segment without blocks: continuous with the previous one
        if not np.isfinite(offsets[k]):
            offsets[k] = offsets[k - 1]
    return offsets, scale, float(r[keep].std()) if keep.sum() > 1 else float("nan"), int(keep.sum())


@dataclass
class MultiRecorderSettings:
    """Every knob of a multi-boot recording (saved as JSON in each boot's /meta/recorder_settings)."""

    ports: list[str]
    labels: list[str]
    out: str
    # the knobs shared with one boot's recorder: its defaults (one place for each)
    baud: int = RecorderSettings.baud
    duration_s: float | None = None
    flush_interval_s: float = RecorderSettings.flush_interval_s
    header_wait_s: float = RecorderSettings.header_wait_s
    connect_timeout_s: float = RecorderSettings.connect_timeout_s
    mounts: list[str] = field(default_factory=list)  # per boot; default <label>_boot
    subject: str = ""
    session_notes: str = ""
    status_interval_s: float = RecorderSettings.status_interval_s
    clock_outlier_sigma: float = 3.0  # refit of the host-clock line without blocks this far off (fit_host_clock)

    def port_settings(self, i: int) -> RecorderSettings:
        return RecorderSettings(port=self.ports[i], out=self.out, baud=self.baud, duration_s=None,
                                flush_interval_s=self.flush_interval_s, header_wait_s=self.header_wait_s,
                                connect_timeout_s=self.connect_timeout_s, status_interval_s=self.status_interval_s,
                                mount=self.mounts[i] if i < len(self.mounts) else f"{self.labels[i]}_boot",
                                subject=self.subject, session_notes=self.session_notes)


class MultiBootRecorder:
    """Several boots into one multi-boot recording (``docs/recording-format.md``), one reader thread per port.

    Each port is a ``SerialRecorder(writes=False)`` in its own thread (parsing, CRC, resync, reconnect and
    clock unwrapping exactly as for one port); this thread owns the HDF5 file: every ``flush_interval_s`` it
    takes what every port collected, shifts it to the session clock and flushes all boots at once, so a
    ``kill -9`` leaves every boot readable up to the last flush. The file is created when every boot has its
    header frame, or ``header_wait_s`` after the first sample of any boot (a boot without a header then
    records the default ranges, corrected at close if its header comes later).

    Session clock: while recording, a boot's ``t_s`` is its device time plus the offset of its first block
    (preliminary); at close each boot's device clock is fitted to the host receive times (``fit_host_clock``)
    and ``t_s`` and the event times are rewritten on that line, with session time 0 at the first sample of
    any boot.
    """

    def __init__(self, settings: MultiRecorderSettings, status_stream=None):
        self.s = settings
        self.status_stream = status_stream
        self.ports = [SerialRecorder(settings.port_settings(i), writes=False) for i in range(len(settings.ports))]
        self._threads: list[threading.Thread] = []
        self._errors: list[BaseException | None] = [None] * len(self.ports)
        self._writer = None
        self._offset0: list[float | None] = [None] * len(self.ports)  # preliminary device -> session offset
        self._host0: float | None = None  # host time (UNIX s) of preliminary session time 0
        self._backlog: list[tuple[list, list]] = [([], []) for _ in self.ports]
        self._stop = False
        self._last_flush = 0.0
        self.disk_full: DiskFullError | None = None
        self.stop_reason = ""
        self.clock: dict[str, dict] = {}  # per boot: the fitted clock attributes written at close

    @property
    def wrote_file(self) -> bool:
        return self._writer is not None

    def stop(self, reason: str = "stopped") -> None:
        self._stop = True
        self.stop_reason = self.stop_reason or reason
        for p in self.ports:
            p.stop(reason)

    def _run_port(self, i: int) -> None:
        try:
            self.ports[i].run()
        except BaseException as exc:  # noqa: BLE001 - re-raised by the writer thread
            self._errors[i] = exc

    def run(self) -> list[RecorderStats]:
        s = self.s
        self._threads = [threading.Thread(target=self._run_port, args=(i,), name=f"bootnav-port-{lab}", daemon=True)
                         for i, lab in enumerate(s.labels)]
        for t in self._threads:
            t.start()
        start = time.monotonic()
        last_status = start
        try:
            while not self._stop:
                time.sleep(min(s.flush_interval_s, 0.05))
                now = time.monotonic()
                if s.duration_s is not None and now - start >= s.duration_s:
                    self.stop("duration reached")
                    break
                if any(e is not None for e in self._errors):
                    self.stop("a port failed")
                    break
                if not any(t.is_alive() for t in self._threads):
                    break
                if now - self._last_flush >= s.flush_interval_s:
                    self._flush()
                if self.status_stream is not None and now - last_status >= s.status_interval_s:
                    self._status(now)
                    last_status = now
        except KeyboardInterrupt:
            self.stop("interrupted (Ctrl-C)")
        finally:
            self.stop(self.stop_reason or "stopped")
            for t in self._threads:
                t.join()
            self._finish()
        for e in self._errors:
            if e is not None:
                if self._writer is not None and isinstance(e, BootnavError):
                    raise BootnavError(f"{e}; {self.s.out} holds what the other ports sent") from e
                raise e
        return [p.stats for p in self.ports]

    # ------------------------------------------------------------------ writing
    def _ready(self, final: bool) -> bool:
        """Whether the file can be created: every boot has its header, or the header wait is over."""
        firsts = [p._first_sample_mono for p in self.ports if p._first_sample_mono is not None]
        if not firsts:
            return False
        if final or all(p._header is not None for p in self.ports):
            return True
        return time.monotonic() - min(firsts) >= self.s.header_wait_s

    def _create(self) -> None:
        from bootnav.logger.recording import BootLayout, MultiBootWriter

        layouts = {}
        for i, (label, p) in enumerate(zip(self.s.labels, self.ports)):
            with p.lock:  # a header arriving from now on is a late one (scale factors corrected at close)
                acc, gyro, temp, meta = p.layout()
                p.file_created = True
            off0 = self._offset0[i]
            meta.update(clock_alignment="host-receive-preliminary",
                        clock_offset_s=float("nan") if off0 is None else off0, clock_scale=1.0,
                        clock_residual_s=float("nan"), clock_blocks=0, boot_label=label,
                        session_recorder_settings=json.dumps(asdict(self.s)))
            layouts[label] = BootLayout(acc, gyro, temp, device_time=True, host_time=True, seq=True, meta=meta)
        self._writer = MultiBootWriter(self.s.out, layouts, attrs={
            "session_start_unix_s": float("nan") if self._host0 is None else self._host0,
            "session_clock": "seconds since the first sample of any boot"})

    def _take(self) -> None:
        """Collect every port's new blocks; fix each boot's preliminary offset at its first block."""
        firsts = []
        for i, p in enumerate(self.ports):
            blocks, events = p.take_pending()
            self._backlog[i][0].extend(blocks)
            self._backlog[i][1].extend(events)
            if self._offset0[i] is None and self._backlog[i][0]:
                b = self._backlog[i][0][0]
                firsts.append((i, float(b["t_host"][-1] - b["t_s"][-1])))  # host time of the boot's first sample
        if firsts and self._host0 is None:
            self._host0 = min(h for _, h in firsts)
        for i, h in firsts:
            self._offset0[i] = h - self._host0

    def _flush(self, final: bool = False) -> None:
        self._last_flush = time.monotonic()
        if self.disk_full is not None:
            return
        self._take()
        if self._writer is None:
            if not self._ready(final):
                return
            self._create()
        w = self._writer
        n_rows = sum(len(b["t_s"]) for blocks, _ in self._backlog for b in blocks)
        n_events = sum(len(ev) for _, ev in self._backlog)
        try:
            if not w.room_for(n_rows, n_events):
                exc = w.disk_full_error()
                w.close()
                raise exc
            for i, label in enumerate(self.s.labels):
                blocks, events = self._backlog[i]
                off = self._offset0[i] or 0.0  # None: no sample yet, its events have no time (NaN)
                bw = w.boot(label)
                if blocks:
                    block = {k: np.concatenate([b[k] for b in blocks]) for k in blocks[0]}
                    bw.append(block.pop("t_s") + off, block.pop("acc"), block.pop("gyro"), **block)
                if events:
                    events.sort(key=lambda e: e["sample_index"])
                    rows = make_events(events)
                    rows["t_s"] += off
                    bw.add_events(rows)
                self._backlog[i] = ([], [])
            w.flush()
        except DiskFullError as exc:
            self.disk_full = exc
            self.stop("disk full")

    def _finish(self) -> None:
        self._flush(final=True)
        if self.ports[0]._status_line_shown:
            print(file=self.status_stream)
        if self._writer is None:
            return
        if self.disk_full is not None:
            return  # closed with everything up to the last flush; the preliminary clock stays
        final = {label: p.final_meta(None) for label, p in zip(self.s.labels, self.ports)}
        self._writer.close(final_meta=final)
        self._realign()
        for label, p in zip(self.s.labels, self.ports):
            if p._late_header is not None:
                p._correct_scale_factors(p._late_header, boot=label)

    def _realign(self) -> None:
        """Fit every boot's device clock to the host receive times and rewrite ``t_s`` on the session clock
        (``recording.retime_boots``)."""
        fits = {}
        for i, (label, p) in enumerate(zip(self.s.labels, self.ports)):
            if self._offset0[i] is None:
                continue
            pts = np.asarray(p.clock_points, float).reshape(-1, 3)
            breaks = np.asarray(p.clock_breaks, np.int64)
            seg = np.searchsorted(breaks, pts[:, 2].astype(np.int64), "right")
            offsets, scale, resid, n_used = fit_host_clock(pts[:, 0], pts[:, 1] - self._host0,
                                                           self.s.clock_outlier_sigma, seg)
            offsets = np.concatenate([offsets, np.full(breaks.size + 1 - offsets.size, offsets[-1])])
            fits[label] = (i, offsets, scale, resid, n_used, breaks)
        if not fits:
            return
        s0 = min(f[1][0] for f in fits.values())  # session time 0: the first sample of any boot

        def on_session_clock(i, offsets, scale, breaks):
            off0 = self._offset0[i]
            return lambda t, index: (offsets[np.searchsorted(breaks, index, "right")] - s0) + scale * (t - off0)

        def meta_of(label, t_new):
            i, offsets, scale, resid, n_used, breaks = fits[label]
            meta = dict(clock_alignment="host-receive", clock_offset_s=float(offsets[0] - s0), clock_scale=scale,
                        clock_residual_s=resid, clock_blocks=n_used, clock_segments=int(breaks.size + 1))
            meta.update(timing_summary(t_new) if t_new.size > 1 else {})
            if t_new.size:
                meta["duration_s"] = float(t_new[-1] - t_new[0])
            self.clock[label] = meta
            return meta

        retime_boots(self.s.out, {label: on_session_clock(i, offsets, scale, breaks)
                                  for label, (i, offsets, scale, _, _, breaks) in fits.items()},
                     attrs={"session_start_unix_s": self._host0 + s0}, meta_of=meta_of)

    def _status(self, now: float) -> None:
        """One line for all boots, printed through the first port's status printer (tty-aware)."""
        line = " || ".join(f"{label}: {p.status_text(now)}" for label, p in zip(self.s.labels, self.ports))
        self.ports[0].status_stream = self.status_stream  # the port threads never print (writes=False)
        self.ports[0]._print_status(line)
