"""A fake boot sensor (Arduino Nano + MPU6050) on a pseudo-terminal, speaking protocol v1.

The emulator opens a pty pair (``os.openpty``), puts the slave side in raw mode (no echo, no CR/LF
translation, exactly like a USB-serial adapter) and publishes it as a symlink at ``out_link``, so the
recorder opens ``out_link`` as if it were ``/dev/ttyUSB0``. Frames go out at the real rate, paced by
the monotonic clock, in small batches per tick.

Like a Nano (whose DTR line resets it when the host opens the port), streaming starts when the host
connects, which the emulator sees as the first byte the host sends (the recorder sends ``H``).
After that the device clock (``t_us``) and ``seq`` run on regardless of the host; frames due while
the link is down are never sent, exactly as with a yanked cable.

Fault injection (seeded, reproducible): per frame with probability ``corrupt_rate`` one of
``bitflip`` (one random bit of the frame inverted), ``garbage`` (1..16 random bytes before the
frame), ``drop`` (frame not sent: a seq gap) is applied; ``disconnect_at`` closes the pty (the port
vanishes), waits ``disconnect_pause`` seconds and recreates it at the same path. ``EmulatorReport``
lists every intact frame sent so a test can prove that none was lost.
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import select
import struct
import termios
import time
import tty
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from bootnav.core import atomic
from bootnav.core.jsonio import to_jsonable
from bootnav.core.timebase import T_US_MODULUS, unwrap_counter
from bootnav.logger import mpu6050
from bootnav.logger.protocol import (
    CMD_RESEND_HEADER,
    SAMPLE_DTYPE,
    HeaderFrame,
    StatusFrame,
    pack_samples,
)

FAULT_KINDS = ("bitflip", "garbage", "drop")


@dataclass
class EmulatorSettings:
    """Every knob of the emulator (saved in the report)."""

    out_link: str
    source: str = "synthetic"  # path of an HDF5 recording, or "synthetic"
    duration_s: float | None = None  # None: the source once (synthetic: 10 s)
    rate_hz: float | None = None  # None: the source's rate (synthetic: 200 Hz)
    corrupt_rate: float = 0.0  # probability per frame of one injected fault
    corrupt_kinds: tuple[str, ...] = FAULT_KINDS
    disconnect_at_s: float | None = None  # stream time of the disconnect
    disconnect_pause_s: float = 1.0
    restart_on_reconnect: bool = False  # device reboots at reconnect: seq and t_us start again
    replay_timing: bool = False  # send the source's own seq/t_device (its gaps and jitter), paced by them
    wait_for_host: bool = True  # start streaming on the host's first byte
    host_timeout_s: float = 30.0  # give up if no host connects
    write_timeout_s: float = 5.0  # give up if the host reads nothing for this long (it is gone)
    linger_s: float = 1.0  # keep the port open after the last frame
    seq0: int = 0  # first seq (set near 65535 to exercise the u16 wrap)
    t0_us: int = 0  # first device time (set near 2**32 to exercise the t_us wrap)
    clock_ppm: float = 0.0  # device clock rate error: t_us advances (1 + ppm 1e-6) periods per real period
    start_delay_s: float = 0.0  # the device starts streaming this long after the host connects
    accel_fs: int = 3
    gyro_fs: int = 3
    dlpf: int = 3
    header_every: int = 1000  # periodic header frame, as the firmware does
    device_id: int = 0x0000BEEF
    fw_version: tuple[int, int, int] = (0, 1, 0)
    seed: int = 0
    tick_s: float = 0.005  # pacing granularity
    boot: str | None = None  # the boot of a multi-boot --source to stream


@dataclass
class EmulatorReport:
    frames_sent: int = 0  # sample frames written (intact or corrupted)
    frames_corrupted: int = 0  # sample frames written with a flipped bit
    frames_dropped: int = 0  # sample frames skipped on purpose (seq gap)
    frames_unsent_disconnected: int = 0  # frames due while the port was down or no host was connected
    garbage_bytes: int = 0
    garbage_bursts: int = 0
    headers_sent: int = 0
    status_sent: int = 0
    disconnects: int = 0
    host_commands: int = 0
    bytes_sent: int = 0
    duration_s: float = 0.0
    rate_hz: float = 0.0
    stream_start_unix: float = 0.0  # wall time of the first frame
    bytes_unread_at_close: int = 0  # bytes the host had not read when the port was closed (lost)
    valid_seqs: list[int] = field(default_factory=list)  # seq of every intact sample frame, in order
    valid_index: list[int] = field(default_factory=list)  # index into the source of each intact frame
    settings: dict = field(default_factory=dict)

    def write(self, path) -> None:
        atomic.write_text(path, json.dumps(asdict(self)))


@dataclass
class SourceSignal:
    """int16 counts to stream and the rate they were sampled at."""

    acc: np.ndarray  # (N, 3) int16
    gyro: np.ndarray  # (N, 3) int16
    temp: np.ndarray  # (N,) int16
    rate_hz: float
    accel_fs: int
    gyro_fs: int
    seq: np.ndarray | None = None  # (N,) u16 as recorded, for --replay-timing
    t_device: np.ndarray | None = None  # (N,) u32 µs as recorded, for --replay-timing
    device_id: int | None = None  # the recording's board id (meta ``device_id``), sent in the header frames


def synthetic_signal(duration_s: float, rate_hz: float, accel_fs: int = 3, gyro_fs: int = 3,
                     seed: int = 0) -> SourceSignal:
    """A deterministic walking-like signal: 1 Hz strides, 40 % stance at rest, swing with a pitch
    rotation up to ~400 deg/s and a heel-strike spike of ~6 g, plus white noise.

    Only meant to exercise the link (plausible magnitudes, every code path), not to be navigated on;
    realistic walks come from ``bootnav simulate``.
    """
    rng = np.random.default_rng(seed)
    n = max(1, int(round(duration_s * rate_hz)))
    t = np.arange(n) / rate_hz
    phase = t % 1.0
    swing = (phase >= 0.4) & (phase < 0.9)
    s = np.where(swing, np.sin(np.pi * (phase - 0.4) / 0.5), 0.0)
    gyro_dps = np.zeros((n, 3))
    gyro_dps[:, 1] = 400.0 * np.sin(2 * np.pi * (phase - 0.4) / 0.5) * swing
    acc_g = np.zeros((n, 3))
    acc_g[:, 2] = 1.0 + 1.5 * s
    acc_g[:, 0] = 2.0 * np.sin(2 * np.pi * (phase - 0.4) / 0.5) * swing
    strike = np.abs(phase - 0.9) < 0.5 / rate_hz + 1e-12
    acc_g[strike, 2] += 5.0
    acc_g += rng.normal(0, 0.004, acc_g.shape)
    gyro_dps += rng.normal(0, 0.05, gyro_dps.shape) + np.array([0.5, -0.3, 0.2])
    acc = np.clip(np.round(acc_g * mpu6050.ACCEL_LSB_PER_G[accel_fs]), -32768, 32767).astype(np.int16)
    gyro = np.clip(np.round(gyro_dps * mpu6050.GYRO_LSB_PER_DPS[gyro_fs]), -32768, 32767).astype(np.int16)
    temp = np.full(n, int(round((25.0 - mpu6050.TEMP_OFFSET_DEGC) * mpu6050.TEMP_LSB_PER_DEGC)), np.int16)
    return SourceSignal(acc, gyro, temp, rate_hz, accel_fs, gyro_fs)


def load_source(path, accel_fs: int | None = None, gyro_fs: int | None = None, boot: str | None = None) -> SourceSignal:
    """Counts from a recording (``boot``: one boot of a multi-boot recording): int16 counts as stored, or SI
    floats quantised with the declared ranges."""
    from bootnav.logger.recording import load

    rec = load(path, with_truth=False, boot=boot)
    meta = rec.meta
    nominal = meta.get("rate_nominal_hz")
    finite = isinstance(nominal, (int, float)) and math.isfinite(nominal) and nominal > 0
    rate = float(nominal) if finite else rec.rate_hz
    a_fs = accel_fs if accel_fs is not None else _code(meta.get("accel_range_g"), mpu6050.accel_code, 3)
    g_fs = gyro_fs if gyro_fs is not None else _code(meta.get("gyro_range_dps"), mpu6050.gyro_code, 3)
    if rec.raw["acc_attrs"].get("units") == "count" and rec.raw["gyro_attrs"].get("units") == "count":
        acc = np.asarray(rec.raw["acc"], dtype=np.int16)
        gyro = np.asarray(rec.raw["gyro"], dtype=np.int16)
    else:
        acc = _quantise(rec.acc_mps2, mpu6050.accel_scale_mps2(a_fs))
        gyro = _quantise(rec.gyro_radps, mpu6050.gyro_scale_radps(g_fs))
    if rec.temp_degc is not None:
        temp = _quantise(rec.temp_degc - mpu6050.TEMP_OFFSET_DEGC, 1 / mpu6050.TEMP_LSB_PER_DEGC)
    else:
        temp = np.full(rec.n, int(round((25.0 - mpu6050.TEMP_OFFSET_DEGC) * mpu6050.TEMP_LSB_PER_DEGC)), np.int16)
    return SourceSignal(acc, gyro, temp, rate, a_fs, g_fs, rec.seq, rec.t_device, _device_id(meta.get("device_id")))


def _device_id(value) -> int | None:
    """The recorded board id (``"0x%08X"`` as the recorder stores it, or an int) as an int, None if absent."""
    try:
        v = int(value, 0) if isinstance(value, str) else int(value)
    except (TypeError, ValueError):
        return None
    return v if 0 <= v < 2**32 else None


def _code(value, to_code, default):
    try:
        return to_code(float(value)) if value not in (None, "") else default
    except (TypeError, ValueError):
        return default


def _quantise(si: np.ndarray, scale: float) -> np.ndarray:
    return np.clip(np.round(np.asarray(si) / scale), -32768, 32767).astype(np.int16)


class PtyPort:
    """The device end of a pseudo-terminal published at a symlink."""

    def __init__(self, link: str):
        self.link = Path(link)
        self.master, slave = os.openpty()
        tty.setraw(slave)  # raw: no echo, no newline translation, 8 data bits
        self._slave = slave  # keep our slave end open so the pty exists before the host opens it
        self.slave_name = os.ttyname(slave)
        os.set_blocking(self.master, False)
        tmp = self.link.with_name(self.link.name + ".tmp")
        tmp.unlink(missing_ok=True)
        os.symlink(self.slave_name, tmp)
        os.replace(tmp, self.link)  # atomic: the path never points at a dead pty

    def write_all(self, data: bytes, stopped=lambda: False, timeout_s: float = float("inf")) -> int:
        """Write everything: a slow host makes us wait (like USB flow control), never lose bytes.

        Raises ``TimeoutError`` when not one byte could be written for ``timeout_s``: the host has
        stopped reading (closed the port or died), and waiting longer would hang the emulator.
        """
        view = memoryview(data)
        sent = 0
        last_progress = time.monotonic()
        while sent < len(data) and not stopped():
            try:
                sent += os.write(self.master, view[sent:])
                last_progress = time.monotonic()
            except BlockingIOError:
                if time.monotonic() - last_progress > timeout_s:
                    raise TimeoutError(f"the host stopped reading {self.link} for {timeout_s:g} s "
                                       f"({len(data) - sent} bytes unsent); is the recorder still running?") from None
                select.select([], [self.master], [], 0.01)
        return sent

    def pending(self) -> int:
        """Bytes written but not yet read by the host (FIONREAD on our slave end)."""
        try:
            return struct.unpack("i", fcntl.ioctl(self._slave, termios.FIONREAD, b"\0\0\0\0"))[0]
        except OSError:
            return 0

    def drain(self, timeout_s: float) -> int:
        """Wait until the host has read everything (or timeout); return the bytes still unread."""
        end = time.monotonic() + timeout_s
        while self.pending() and time.monotonic() < end:
            time.sleep(0.005)
        return self.pending()

    def read_commands(self) -> bytes:
        try:
            return os.read(self.master, 256)
        except (BlockingIOError, OSError):
            return b""

    def close(self) -> None:
        if self.link.is_symlink() and os.readlink(self.link) == self.slave_name:
            self.link.unlink()
        for fd in (self.master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass


class Emulator:
    """Streams a ``SourceSignal`` as protocol-v1 frames on a pty (see module docstring)."""

    def __init__(self, settings: EmulatorSettings, signal: SourceSignal | None = None, progress=None):
        self.settings = s = settings
        if signal is None:
            if s.source == "synthetic":
                rate = s.rate_hz or 200.0
                signal = synthetic_signal(s.duration_s or 10.0, rate, s.accel_fs, s.gyro_fs, s.seed)
            else:
                signal = load_source(s.source, boot=s.boot)
        self.signal = signal
        if signal.acc.shape[0] == 0:
            raise ValueError("the source has no samples")
        self.rate_hz = float(s.rate_hz or signal.rate_hz)
        if not np.isfinite(self.rate_hz) or self.rate_hz <= 0:
            raise ValueError("cannot tell the source's sample rate; give --rate")
        self.accel_fs, self.gyro_fs = signal.accel_fs, signal.gyro_fs
        n_src = signal.acc.shape[0]
        self.n_frames = n_src if s.duration_s is None else int(round(s.duration_s * self.rate_hz))
        self._t_rel_s = None
        if s.replay_timing:
            if signal.seq is None or signal.t_device is None:
                raise ValueError("--replay-timing needs a source with seq and t_device (a serial or simulated recording)")
            if s.restart_on_reconnect:
                raise ValueError("--replay-timing and --restart-on-reconnect exclude each other")
            t = signal.t_device.astype(np.int64)
            t_us = unwrap_counter(t, T_US_MODULUS)[0]
            self._t_rel_s = (t_us - t_us[0]) / 1e6
            self.n_frames = n_src if s.duration_s is None else int(np.searchsorted(self._t_rel_s, s.duration_s, "left"))
        # The fault plan is drawn once per frame index, so what gets corrupted does not depend on
        # how the real-time loop happens to batch frames (runs are reproducible from the seed).
        rng = np.random.default_rng(s.seed)
        kinds = np.array([FAULT_KINDS.index(k) for k in s.corrupt_kinds] or [0], dtype=np.int8)
        hit = rng.random(self.n_frames) < s.corrupt_rate
        self._fault = np.where(hit, kinds[rng.integers(0, kinds.size, self.n_frames)], -1).astype(np.int8)
        self._fault_bit = rng.integers(0, SAMPLE_DTYPE.itemsize * 8, self.n_frames).astype(np.uint8)
        self.report = EmulatorReport(rate_hz=self.rate_hz, settings=to_jsonable(s))
        self.progress = progress
        self._stop = False
        self._restart_k = 0  # frame index of the last device (re)start: seq and t_us count from there

    def stop(self) -> None:
        self._stop = True

    def header(self, next_seq: int, t_us: int) -> HeaderFrame:
        # SMPLRT_DIV for the nominal rate with DLPF on (1 kHz gyro output rate).
        div = int(np.clip(round(1000.0 / self.rate_hz - 1), 0, 255))
        return HeaderFrame(next_seq & 0xFFFF, t_us & 0xFFFFFFFF, self.accel_fs, self.gyro_fs,
                           self.settings.dlpf, div, self.settings.fw_version, 0b10,
                           self.signal.device_id if self.signal.device_id is not None else self.settings.device_id)

    def _counters(self, idx: np.ndarray, period_us: float) -> tuple[np.ndarray, np.ndarray]:
        """(seq, t_us) of frames ``idx``: the source's own, or counted since the last device start."""
        s = self.settings
        if self._t_rel_s is not None:
            k = np.minimum(idx, self.signal.seq.shape[0] - 1)
            return self.signal.seq[k].astype(np.int64), self.signal.t_device[k].astype(np.int64)
        j = idx - self._restart_k
        tick_us = period_us * (1.0 + s.clock_ppm * 1e-6)  # frames leave at the true rate, stamped by a skewed clock
        return (s.seq0 + j) & 0xFFFF, (s.t0_us + np.round(j * tick_us).astype(np.int64)) & 0xFFFFFFFF

    def _due(self, now_s: float) -> int:
        """How many frames the device has produced ``now_s`` seconds into the stream."""
        if self._t_rel_s is not None:
            return min(self.n_frames, int(np.searchsorted(self._t_rel_s, now_s, "right")))
        return min(self.n_frames, int(now_s * self.rate_hz) + 1)

    def _header_at(self, k: int, period_us: float) -> bytes:
        """Header frame sent just before sample frame ``k`` (it carries the next frame's seq)."""
        seq, t_us = self._counters(np.array([k]), period_us)
        return self.header(int(seq[0]), int(t_us[0])).pack()

    def _wait_for_host(self, port: PtyPort) -> bool:
        """Block until the host sends a byte (it opened the port). False on timeout/stop."""
        deadline = time.monotonic() + self.settings.host_timeout_s
        while not self._stop and time.monotonic() < deadline:
            ready, _, _ = select.select([port.master], [], [], 0.05)
            if ready and port.read_commands():
                self.report.host_commands += 1
                return True
        return False

    def run(self) -> EmulatorReport:
        s, rep, sig = self.settings, self.report, self.signal
        n_src = sig.acc.shape[0]
        period_us = 1e6 / self.rate_hz
        port = PtyPort(s.out_link)
        port_up = True
        try:
            if s.wait_for_host and not self._wait_for_host(port):
                raise TimeoutError(f"no host opened {s.out_link} within {s.host_timeout_s} s")
            delay_end = time.monotonic() + s.start_delay_s
            while not self._stop and time.monotonic() < delay_end:
                port.read_commands()  # a header request before the device runs is not answered
                time.sleep(min(s.tick_s, max(0.0, delay_end - time.monotonic())))
            t_start = time.monotonic()
            rep.stream_start_unix = time.time()
            sent_header_at = None
            reconnect_at = None
            disconnect_at = s.disconnect_at_s
            host_ready = True
            k = 0  # frames emitted so far (index of the next frame in device time)
            self._send(port, self._header_at(0, period_us), rep, header=True)
            sent_header_at = 0
            while k < self.n_frames and not self._stop:
                now = time.monotonic() - t_start
                due = self._due(now)
                if disconnect_at is not None and port_up and now >= disconnect_at:
                    # Let the host read what is in flight, so the report's valid frames are exactly
                    # those it could receive (bytes still unread are counted, not hidden).
                    rep.bytes_unread_at_close += port.drain(1.0)
                    port.close()
                    port_up, disconnect_at = False, None
                    rep.disconnects += 1
                    reconnect_at = now + s.disconnect_pause_s
                if not port_up:
                    rep.frames_unsent_disconnected += due - k
                    k = due
                    if now >= reconnect_at:
                        port = PtyPort(s.out_link)
                        port_up, host_ready = True, not s.wait_for_host
                        if s.restart_on_reconnect:  # a Nano reboots when its USB comes back (DTR)
                            self._restart_k = k
                    time.sleep(s.tick_s)
                    continue
                cmds = port.read_commands()
                if cmds:
                    rep.host_commands += len(cmds)
                    host_ready = True
                    if CMD_RESEND_HEADER in cmds:
                        self._send(port, self._header_at(k, period_us), rep, header=True)
                if not host_ready:  # port back, host not yet reopened it: the device streams into the void
                    rep.frames_unsent_disconnected += due - k
                    k = due
                    time.sleep(s.tick_s)
                    continue
                if due > k:
                    if sent_header_at is not None and s.header_every and k - sent_header_at >= s.header_every:
                        self._send(port, self._header_at(k, period_us), rep, header=True)
                        sent_header_at = k
                    self._send_block(port, k, due, n_src, period_us)
                    k = due
                if self.progress:
                    self.progress(k, self.n_frames, rep)
                time.sleep(s.tick_s)
            rep.duration_s = time.monotonic() - t_start
            linger_end = time.monotonic() + s.linger_s
            while port_up and not self._stop and time.monotonic() < linger_end:
                if CMD_RESEND_HEADER in port.read_commands():
                    self._send(port, self._header_at(k, period_us), rep, header=True)
                time.sleep(0.02)
        finally:
            if port_up:
                rep.bytes_unread_at_close += port.drain(1.0)
            port.close()
        return rep

    def _send(self, port: PtyPort, data: bytes, rep: EmulatorReport, header=False) -> None:
        rep.bytes_sent += port.write_all(data, lambda: self._stop, self.settings.write_timeout_s)
        if header:
            rep.headers_sent += 1

    def _send_block(self, port: PtyPort, k0: int, k1: int, n_src: int, period_us: float):
        """Pack frames k0..k1-1, inject faults, write them."""
        s, rep, sig = self.settings, self.report, self.signal
        idx = np.arange(k0, k1)
        src = idx % n_src  # a source shorter than the duration is looped
        seq, t_us = self._counters(idx, period_us)
        data = np.frombuffer(pack_samples(seq, t_us, sig.acc[src], sig.gyro[src], sig.temp[src]), np.uint8)
        frames = data.reshape(-1, SAMPLE_DTYPE.itemsize).copy()
        fault = self._fault[k0:k1]
        if not np.any(fault >= 0):  # fast path: the packed block as is
            rep.valid_seqs.extend(seq.tolist())
            rep.valid_index.extend(idx.tolist())
            rep.frames_sent += idx.size
            rep.bytes_sent += port.write_all(data.tobytes(), lambda: self._stop, s.write_timeout_s)
            return
        out = bytearray()
        dropped_run = 0
        for i in range(idx.size):
            kind = fault[i]
            if kind == 2:  # drop
                rep.frames_dropped += 1
                dropped_run += 1
                continue
            if dropped_run:  # the firmware reports missed samples (code 4) with the next frame
                out += StatusFrame(int(seq[i]), int(t_us[i]), 4, 0, dropped_run).pack()
                rep.status_sent += 1
                dropped_run = 0
            if kind == 1:  # garbage before the frame
                g = np.random.default_rng([s.seed, int(idx[i])])
                junk = g.integers(0, 256, int(g.integers(1, 17)), dtype=np.uint8).tobytes()
                out += junk
                rep.garbage_bytes += len(junk)
                rep.garbage_bursts += 1
            frame = frames[i]
            if kind == 0:  # one bit flipped anywhere in the frame
                bit = int(self._fault_bit[idx[i]])
                frame[bit // 8] ^= np.uint8(1 << (bit % 8))
                rep.frames_corrupted += 1
            else:
                rep.valid_seqs.append(int(seq[i]))
                rep.valid_index.append(int(idx[i]))
            out += frame.tobytes()
            rep.frames_sent += 1
        rep.bytes_sent += port.write_all(bytes(out), lambda: self._stop, s.write_timeout_s)
