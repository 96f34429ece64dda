"""The bootnav recording: one self-describing HDF5 file per session.

The layout is documented in ``docs/recording-format.md`` (the single source of truth); this module is
its only reader and writer. Raw sensor values are kept exactly as delivered (int16 counts from our
firmware, or floats from another IMU's CSV) together with the factor that turns them into SI, so
nothing is lost and ``load`` always returns SI units.

Writing is incremental (``RecordingWriter``): chunked, compressed, extendible datasets in SWMR mode,
so a reader (or a crash) always sees a consistent file up to the last ``flush``.
"""

from __future__ import annotations

import datetime as _dt
import errno
import json
import os
import re
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

import h5py
import numpy as np

from bootnav.core.atomic import fsync_path
from bootnav.core.conventions import CONVENTIONS, __version__
from bootnav.core.timebase import timing_summary
from bootnav.errors import DiskFullError, InputError
from bootnav.logger.samplestats import SampleStats, read_summary

FORMAT_VERSION = 1
CHUNK_ROWS = 4096
_COMPRESSION = dict(compression="gzip", compression_opts=4, shuffle=True)
#: HDF5 file-format bounds of every file bootnav writes: the 1.10 format keeps SWMR and is read by the HDF5
#: 1.10 tools of Debian/Ubuntu (h5dump, h5ls) and by MATLAB; "latest" would pick HDF5 2.0 formats they reject.
LIBVER = ("v110", "v110")

#: Event kinds: every anomaly seen while recording or importing is kept as one row.
EVENT_KINDS = (
    "gap",  # samples missing (count = number missing), from sequence numbers or timestamps
    "crc_error",  # frame with a bad CRC (byte_offset = stream offset of its sync word)
    "resync",  # bytes skipped to find the next sync word (count = bytes skipped)
    "disconnect",  # serial port vanished
    "reconnect",  # serial port back
    "saturation",  # run of samples at full scale (axis 0-2 acc x/y/z, 3-5 gyro x/y/z; count = samples)
    "skipped_line",  # unparseable input line (line = 1-based line number)
    "duplicate_time",  # timestamp equal to the previous one
    "nonmonotonic_time",  # timestamp going backwards (not a wrap)
    "time_wrap",  # device counter wrapped (uint32 microseconds, every 71.6 min)
    "header",  # header/config frame received
    "note",  # anything else worth keeping
)

EVENT_DTYPE = np.dtype(
    [
        ("t_s", "<f8"),  # recording time of the event, NaN if unknown
        ("sample_index", "<i8"),  # index into /imu arrays where it applies, -1 if none
        ("kind", "S24"),
        ("count", "<i8"),  # samples missing / bytes skipped / samples saturated; 0 if n/a
        ("byte_offset", "<i8"),  # offset in the input byte stream or file, -1 if n/a
        ("line", "<i8"),  # 1-based input line number, -1 if n/a
        ("axis", "<i1"),  # 0-2 acc x/y/z, 3-5 gyro x/y/z, -1 if n/a
        ("detail", "S200"),  # short human-readable text
    ]
)

SATURATION_BITS = {"ax": 0, "ay": 1, "az": 2, "gx": 3, "gy": 4, "gz": 5}

#: Name of the dimension (and its index coordinate) of every per-sample array in /imu and /results/NAME.
SAMPLE_DIM = "sample"


def make_events(rows: Iterable[Mapping[str, Any]]) -> np.ndarray:
    """Build an event table from dicts; missing fields get their 'not applicable' value."""
    rows = list(rows)
    out = np.zeros(len(rows), dtype=EVENT_DTYPE)
    out["t_s"] = np.nan
    out["sample_index"] = -1
    out["byte_offset"] = -1
    out["line"] = -1
    out["axis"] = -1
    for i, row in enumerate(rows):
        for key, value in row.items():
            if key not in EVENT_DTYPE.names:
                raise KeyError(f"unknown event field {key!r}")
            if key == "kind" and value not in EVENT_KINDS:
                raise ValueError(f"unknown event kind {value!r}")
            if key in ("kind", "detail"):
                value = str(value).encode("utf-8")[:200]
            out[key][i] = value
    return out


@dataclass
class Channel:
    """How one sensor channel is stored: its raw unit and the factor to SI.

    ``si = raw * scale_to_si + offset_to_si``. ``full_scale`` is the saturation limit in *raw* units
    (e.g. 32767 counts), or NaN when unknown.
    """

    units: str  # raw unit: "count", "m/s^2", "rad/s", "degC"
    si_units: str
    scale_to_si: float = 1.0
    offset_to_si: float = 0.0
    full_scale: float = float("nan")
    dtype: str = "<f8"

    def attrs(self) -> dict:
        """The dataset's attributes: CF packing (``scale_factor``, ``add_offset``, ``units`` of the unpacked SI
        value: xarray, netCDF and MATLAB ``ncread`` return SI without bootnav) and, for readers of format 1,
        ``scale_to_si``/``offset_to_si`` (the same figures) with the stored unit as ``raw_units``."""
        return {
            "units": self.si_units,
            "raw_units": self.units,
            "si_units": self.si_units,
            **cf_scale(self.scale_to_si, self.offset_to_si),
            "full_scale": float(self.full_scale),
        }


def cf_scale(scale_to_si: float, offset_to_si: float = 0.0) -> dict:
    """The factor from stored to SI values under both names: ``scale_to_si``/``offset_to_si`` (bootnav's, format
    1) and ``scale_factor``/``add_offset`` (CF: ``si = stored * scale_factor + add_offset``). Every writer of a
    factor sets both through here, so they never disagree."""
    return {"scale_to_si": float(scale_to_si), "offset_to_si": float(offset_to_si),
            "scale_factor": float(scale_to_si), "add_offset": float(offset_to_si)}


def label_scale(group, name: str, labels) -> "h5py.Dataset":
    """A dimension scale of text labels (``axis``: x, y, z; ``q_component``: w, x, y, z) as UTF-8 strings, so
    that xarray gives ``str`` coordinates (``.sel(axis="x")``), not bytes."""
    ds = group.create_dataset(name, data=np.array([str(v) for v in labels], dtype=object),
                              dtype=h5py.string_dtype("utf-8"))
    ds.make_scale(name)
    return ds


def counts_channel(kind: str, scale_to_si: float) -> Channel:
    """An int16-count channel (our firmware): ``kind`` is 'acc', 'gyro' or 'temp'."""
    si = {"acc": "m/s^2", "gyro": "rad/s", "temp": "degC"}[kind]
    if kind == "temp":
        return Channel("count", si, scale_to_si, 36.53, float("nan"), "<i2")
    return Channel("count", si, scale_to_si, 0.0, 32767.0, "<i2")


def si_channel(kind: str, full_scale_si: float = float("nan")) -> Channel:
    si = {"acc": "m/s^2", "gyro": "rad/s", "temp": "degC"}[kind]
    return Channel(si, si, 1.0, 0.0, full_scale_si, "<f8")


def is_disk_full(exc: BaseException) -> bool:
    """True for a full disk, quota or file-size limit (``ENOSPC``, ``EDQUOT``, ``EFBIG``), also when h5py
    reports it only inside its message (``errno = 28``)."""
    codes = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
    if getattr(exc, "errno", None) in codes:
        return True
    return any(f"errno = {c}," in str(exc) for c in codes)


#: Space a new recording needs before its first block: the layout (superblock, groups, dataset headers, about
#: 15 KB measured) and the first chunks at the smallest chunk size, with room to spare.
MIN_FREE_BYTES = 64 << 10

#: Smallest chunk (rows) a recording on a nearly full disk uses: small chunks let a few hundred KB of free space
#: hold tens of seconds instead of nothing (HDF5 allocates a whole chunk per dataset at the first flush).
MIN_CHUNK_ROWS = 64

#: Bytes of one recorder row before compression: t_s 8, acc and gyro 2 x 6 (int16 counts), saturated 1, temp 2,
#: t_device 4, t_host 8, seq 2 (the worst case a compressed chunk can need).
RECORDER_ROW_BYTES = 37


def chunk_rows_for(path: str | os.PathLike, chunk_rows: int = CHUNK_ROWS, row_bytes: int = RECORDER_ROW_BYTES) -> int:
    """Rows per chunk for a new recording at ``path``: ``chunk_rows`` when space is plentiful, smaller (a power of
    two, at least ``MIN_CHUNK_ROWS``) so that one chunk of every dataset takes at most 1/64 of the free space."""
    fit = free_bytes(Path(path)) // (64 * row_bytes)
    rows = MIN_CHUNK_ROWS
    while rows * 2 <= min(fit, chunk_rows):
        rows *= 2
    return int(min(max(rows, MIN_CHUNK_ROWS), chunk_rows))


def minutes_that_fit(path: str | os.PathLike, rate_hz: float, row_bytes: int = RECORDER_ROW_BYTES) -> float:
    """Minutes of recording the free space at ``path`` holds at ``rate_hz`` (uncompressed rows: a lower bound)."""
    room = max(free_bytes(Path(path)) - MIN_FREE_BYTES, 0)
    return room / (row_bytes * rate_hz) / 60.0


def free_bytes(path: Path) -> int:
    """Bytes that can still be written to ``path``: free space of its file system for this user, capped by
    the process's file-size limit (``ulimit -f``) less the file's current size."""
    import resource

    path = Path(path)
    st = os.statvfs(path.parent if path.parent.exists() else ".")
    # a pseudo file system (/proc, /sys) reports no blocks at all: no space figure, let the write say why it fails
    free = st.f_bavail * st.f_frsize if st.f_blocks else 1 << 62
    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    if soft != resource.RLIM_INFINITY:
        free = min(free, soft - (path.stat().st_size if path.exists() else 0))
    return int(free)


def _utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def _root_attrs(f: h5py.File) -> None:
    """Format version, producer and the conventions: the root attributes of every file bootnav writes."""
    f.attrs["format_version"] = FORMAT_VERSION
    f.attrs["producer"] = f"bootnav {__version__}"
    f.attrs["created_utc"] = _utc_now()
    for key, value in CONVENTIONS.items():
        f.attrs[key] = value


def _clean_attr(value: Any) -> Any:
    if value is None:
        return ""
    if isinstance(value, (dict, list, tuple)) and not (
        isinstance(value, (list, tuple)) and all(isinstance(v, (int, float)) for v in value)
    ):
        return json.dumps(value)
    return value


def _creating_name(path: Path) -> Path:
    """Hidden name beside ``path`` under which a new recording is created (``_publish``)."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def _publish(file: h5py.File, tmp: Path, path: Path) -> None:
    """Show a newly created recording under its name only once its whole structure is on disk: a crash while
    creating leaves no header-only file at ``path``. HDF5 keeps writing through the open handle after the
    rename. Crash-safe as ``bootnav.core.atomic.commit``: the file is synced before the rename and the folder
    after it, so after a power cut the name shows the whole structure or nothing."""
    file.flush()
    fsync_path(tmp)
    os.replace(tmp, path)
    fsync_path(path.parent)


class RecordingWriter:
    """Incremental writer: create once, ``append`` blocks, ``add_events``, ``flush``, ``close``.

    Optional per-sample arrays are created only when enabled: ``temp`` (channel), ``t_device``
    (uint32 raw device clock, µs), ``t_host`` (host receive time, UNIX s), ``seq`` (uint16 frame
    sequence number). All datasets are created before SWMR mode is switched on, because SWMR
    forbids creating objects later; metadata given to ``close(final_meta=...)`` is written after
    leaving SWMR.
    """

    def __init__(
        self,
        path: str | os.PathLike,
        acc: Channel,
        gyro: Channel,
        *,
        temp: Channel | None = None,
        device_time: bool = False,
        host_time: bool = False,
        seq: bool = False,
        meta: Mapping[str, Any] | None = None,
        swmr: bool = True,
        chunk_rows: int | None = None,
        _shared: tuple[h5py.File, str] | None = None,
    ):
        self.path = Path(path)
        if chunk_rows is None:  # smaller chunks on a nearly full disk (``chunk_rows_for``)
            chunk_rows = chunk_rows_for(self.path)
        self._peers = [self]  # writers sharing the file (one per boot): a failed write rolls back all of them
        # what `bootnav info` reports, stored at close (a multi-boot recorder rewrites t_s after it: none there)
        self._stats = SampleStats() if _shared is None else None
        if _shared is not None:  # a boot group of a MultiBootWriter's file, which owns file attrs and SWMR
            self._file, group = _shared
            self._closed = False
            self._create_layout(self._file.create_group(group), acc, gyro, temp, device_time, host_time, seq,
                                meta, chunk_rows)
            return
        self._closed = True
        if free_bytes(self.path) < MIN_FREE_BYTES:  # HDF5 cannot recover from a failed create: do not start one
            raise DiskFullError(f"disk full at {self.path}: 0 frames written (no space for a new file)")
        tmp = _creating_name(self.path)
        try:
            self._file = h5py.File(tmp, "w", libver=LIBVER)
            self._closed = False
            self._create(acc, gyro, temp, device_time, host_time, seq, meta, swmr, chunk_rows)
            _publish(self._file, tmp, self.path)
        except (OSError, RuntimeError) as exc:
            self.abort()
            tmp.unlink(missing_ok=True)  # nothing of value in it: no 0-byte or header-only file
            if is_disk_full(exc):
                raise DiskFullError(f"disk full at {self.path}: 0 frames written (no space for a new file)") from exc
            raise

    def _create(self, acc, gyro, temp, device_time, host_time, seq, meta, swmr, chunk_rows) -> None:
        """Create every dataset (before SWMR mode, which forbids creating objects later)."""
        _root_attrs(self._file)
        self._create_layout(self._file, acc, gyro, temp, device_time, host_time, seq, meta, chunk_rows)
        if swmr:
            self._file.swmr_mode = True

    def _create_layout(self, f, acc, gyro, temp, device_time, host_time, seq, meta, chunk_rows) -> None:
        """``meta``, ``imu/*`` and ``events`` of one recording (or one boot) in the group ``f``."""
        meta_group = f.create_group("meta")
        for key, value in (meta or {}).items():
            meta_group.attrs[key] = _clean_attr(value)
        meta_group.attrs.setdefault("start_utc", _utc_now())

        imu = f.create_group("imu")
        # the dimension of every per-sample array is the sample index (monotonic by construction); t_s, whose
        # source clock may repeat a value, is a coordinate along it, named by CF's `coordinates` attribute
        self._sample = imu.create_dataset(
            SAMPLE_DIM, shape=(0,), maxshape=(None,), dtype="<i8", chunks=(chunk_rows,), **_COMPRESSION
        )
        self._sample.attrs["units"] = "1"
        self._sample.attrs["description"] = "sample index (row number): the dimension of every per-sample array"
        self._sample.make_scale(SAMPLE_DIM)
        self._t = imu.create_dataset(
            "t_s", shape=(0,), maxshape=(None,), dtype="<f8", chunks=(chunk_rows,), **_COMPRESSION
        )
        self._t.attrs["units"] = "s"
        self._t.attrs["description"] = "sample time since the first sample (device clock, unwrapped)"
        self._t.dims[0].attach_scale(self._sample)
        axis = label_scale(imu, "axis", "xyz")

        self._arrays: dict[str, h5py.Dataset] = {SAMPLE_DIM: self._sample, "t_s": self._t}
        for name, channel in (("acc", acc), ("gyro", gyro)):
            ds = imu.create_dataset(
                name,
                shape=(0, 3),
                maxshape=(None, 3),
                dtype=channel.dtype,
                chunks=(chunk_rows, 3),
                **_COMPRESSION,
            )
            ds.attrs.update(channel.attrs())
            ds.attrs["coordinates"] = "t_s"
            ds.dims[0].attach_scale(self._sample)
            ds.dims[1].attach_scale(axis)
            self._arrays[name] = ds
        optional = {
            "temp": (temp is not None, temp.dtype if temp else None, temp.attrs() if temp else None),
            "t_device": (device_time, "<u4", {"units": "us", "description": "raw device clock, wraps at 2**32"}),
            "t_host": (host_time, "<f8", {"units": "s", "description": "host receive time, UNIX epoch"}),
            "seq": (seq, "<u2", {"units": "1", "description": "frame sequence number, wraps at 2**16"}),
        }
        for name, (enabled, dtype, attrs) in optional.items():
            if not enabled:
                continue
            ds = imu.create_dataset(
                name, shape=(0,), maxshape=(None,), dtype=dtype, chunks=(chunk_rows,), **_COMPRESSION
            )
            ds.attrs.update(attrs)
            ds.attrs["coordinates"] = "t_s"
            ds.dims[0].attach_scale(self._sample)
            self._arrays[name] = ds
        sat = imu.create_dataset(
            "saturated", shape=(0,), maxshape=(None,), dtype="u1", chunks=(chunk_rows,), **_COMPRESSION
        )
        sat.attrs["units"] = "bitmask"
        sat.attrs["description"] = "bit 0-2 acc x/y/z, bit 3-5 gyro x/y/z at full scale"
        sat.attrs["coordinates"] = "t_s"
        sat.dims[0].attach_scale(self._sample)
        self._arrays["saturated"] = sat

        self._events = f.create_dataset(
            "events", shape=(0,), maxshape=(None,), dtype=EVENT_DTYPE, chunks=(256,), **_COMPRESSION
        )
        self._events.attrs["units"] = "t_s: s; count: samples or bytes; byte_offset: bytes; line: 1-based"
        self._events.attrs["kinds"] = ",".join(EVENT_KINDS)
        self.n = 0
        self.n_safe, self.t_safe = 0, float("nan")  # rows on disk at the last flush, and their last time

    @property
    def stats(self) -> SampleStats | None:
        """The figures of the rows appended so far (None for a boot of a multi-boot file)."""
        if self._stats is not None:
            self._stats.fold()
        return self._stats

    @property
    def enabled(self) -> tuple[str, ...]:
        return tuple(self._arrays)

    def times(self) -> np.ndarray:
        """The ``t_s`` of the rows appended so far (read back from the file)."""
        return self._arrays["t_s"][: self.n]

    def append(self, t_s, acc, gyro, *, saturated=None, **optional) -> None:
        """Append a block of samples. ``optional`` takes temp, t_device, t_host, seq.

        The whole block is checked before any dataset grows; if a write fails (disk full), every
        dataset is shrunk back to its rows at the last ``flush``, so no zero-filled row is left behind.
        """
        t_s = np.asarray(t_s, dtype=np.float64).reshape(-1)
        n_new = t_s.shape[0]
        if n_new == 0:
            return
        block = {"t_s": t_s, "acc": np.asarray(acc), "gyro": np.asarray(gyro)}
        if saturated is None:
            saturated = np.zeros(n_new, dtype=np.uint8)
        block["saturated"] = np.asarray(saturated, dtype=np.uint8)
        block[SAMPLE_DIM] = np.arange(self.n, self.n + n_new, dtype=np.int64)
        for name, value in optional.items():
            if value is None:
                continue
            if name not in self._arrays:
                raise KeyError(f"recording was created without {name!r}")
            block[name] = np.asarray(value)
        missing = set(self._arrays) - set(block)
        if missing:
            raise KeyError(f"append() is missing {sorted(missing)}")
        for name in self._arrays:
            if block[name].shape[0] != n_new:
                raise ValueError(f"{name}: {block[name].shape[0]} rows, expected {n_new}")
        try:
            for name, ds in self._arrays.items():
                ds.resize(self.n + n_new, axis=0)
                ds[self.n :] = block[name]
        except (OSError, RuntimeError) as exc:
            self._fail(exc)
        self.n += n_new
        if self._stats is not None:
            a, g = (block[k].astype(self._arrays[k].dtype, copy=False) for k in ("acc", "gyro"))
            self._stats.append(t_s, a, g, block["saturated"])

    def add_events(self, events: np.ndarray | Iterable[Mapping[str, Any]]) -> None:
        if not isinstance(events, np.ndarray):
            events = make_events(events)
        if len(events) == 0:
            return
        n0 = self._events.shape[0]
        try:
            self._events.resize(n0 + len(events), axis=0)
            self._events[n0:] = events
        except (OSError, RuntimeError) as exc:
            self._fail(exc, n_events=n0)

    def flush(self) -> None:
        """Write everything appended so far to disk (a reader or a crash sees it from now on)."""
        try:
            self._file.flush()
        except (OSError, RuntimeError) as exc:
            self._fail(exc)
        for w in self._peers:
            w.n_safe = w.n
            w.t_safe = float(w._t[w.n - 1]) if w.n else float("nan")

    def room_for(self, n_rows: int, n_events: int = 0) -> bool:
        """Whether the disk (and the process's file-size limit) has room for ``n_rows`` more samples and
        ``n_events`` events, with a margin for a rewritten partial chunk per dataset and the metadata.

        Checked before a write so a recording stops cleanly, readable, instead of failing half-way
        through a flush: HDF5 cannot undo a half-written flush and would leave a file it rejects.
        """
        row = sum(ds.dtype.itemsize * (ds.shape[1] if ds.ndim == 2 else 1) for ds in self._arrays.values())
        chunk = sum(ds.chunks[0] * ds.dtype.itemsize * (ds.shape[1] if ds.ndim == 2 else 1)
                    for w in self._peers for ds in w._arrays.values())
        need = n_rows * row + n_events * EVENT_DTYPE.itemsize + 2 * chunk + (64 << 10)
        return need <= free_bytes(self.path)

    def disk_full_error(self) -> DiskFullError:
        """The message of a full disk: how many frames are safe on disk, up to which time."""
        safe = f"up to t = {self.t_safe:.3f} s" if np.isfinite(self.t_safe) else "(no sample yet)"
        return DiskFullError(f"disk full at {self.path}: {self.n_safe} frames safely written {safe}")

    def _fail(self, exc: BaseException, n_events: int | None = None) -> None:
        """A write failed: shrink every dataset back to its rows at the last flush, close, raise.

        A full disk raises ``DiskFullError`` saying how much was safely written (up to the last
        ``flush``); any other I/O error is re-raised after the same clean-up.
        """
        for w in self._peers:
            for ds in w._arrays.values():
                try:
                    ds.resize(w.n_safe, axis=0)
                except (OSError, ValueError):
                    pass
        if n_events is not None:
            try:
                self._events.resize(n_events, axis=0)
            except (OSError, ValueError):
                pass
        self.abort()
        if is_disk_full(exc):
            raise self.disk_full_error() from exc
        raise exc

    def abort(self) -> None:
        """Close after a failed write without raising (the file keeps what the last flush wrote)."""
        if self._closed:
            return
        for w in self._peers:
            w._closed = True
        try:
            self._file.close()
        except (OSError, RuntimeError, ValueError):
            pass

    def close(self, final_meta: Mapping[str, Any] | None = None) -> None:
        if self._closed:
            return
        self.flush()
        try:
            self._file.close()
        except (OSError, RuntimeError) as exc:
            self._fail(exc)
        self._closed = True
        summary = self._stats.summary() if self._stats is not None and self.n else None
        if summary is not None and free_bytes(self.path) < MIN_FREE_BYTES + len(summary):
            summary = None  # optional (`info` scans without it): never what fills the disk
        if final_meta or summary:
            try:
                with h5py.File(self.path, "r+", libver=LIBVER) as f:
                    for key, value in (final_meta or {}).items():
                        f["meta"].attrs[key] = _clean_attr(value)
                    if summary:
                        f["imu"].attrs["summary"] = summary
            except (OSError, RuntimeError) as exc:
                if not final_meta:
                    return  # only the optional summary (a reader holds the file, e.g. a live view): info scans
                if is_disk_full(exc):
                    raise DiskFullError(f"{self.disk_full_error()} (final metadata not written)") from exc
                raise

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def write_recording(
    path,
    t_s,
    acc,
    gyro,
    *,
    acc_channel: Channel | None = None,
    gyro_channel: Channel | None = None,
    events=None,
    meta=None,
    measured_rate: bool = True,
    **optional,
) -> Path:
    """Write a whole recording at once (importers, simulator). Returns the path."""
    acc = np.asarray(acc)
    gyro = np.asarray(gyro)
    acc_channel = acc_channel or si_channel("acc")
    gyro_channel = gyro_channel or si_channel("gyro")
    temp_channel = optional.pop("temp_channel", None)
    writer = RecordingWriter(
        path,
        acc_channel,
        gyro_channel,
        temp=temp_channel,
        device_time=optional.get("t_device") is not None,
        host_time=optional.get("t_host") is not None,
        seq=optional.get("seq") is not None,
        meta=meta,
        swmr=False,
    )
    try:
        writer.append(t_s, acc, gyro, **optional)
        if events is not None:
            writer.add_events(events)
        final = {}
        if measured_rate:
            final = timing_summary(np.asarray(t_s, dtype=float))
        writer.close(final_meta=final)
    except BaseException:
        writer.abort()  # never leave an open HDF5 handle to be flushed again at exit
        raise
    return Path(path)


@dataclass
class BootLayout:
    """What one boot of a multi-boot recording stores (the arguments of a single ``RecordingWriter``)."""

    acc: Channel
    gyro: Channel
    temp: Channel | None = None
    device_time: bool = False
    host_time: bool = False
    seq: bool = False
    meta: Mapping[str, Any] | None = None


def check_boot_label(label: str) -> str:
    """A boot label is a group name: letters, digits, ``_`` and ``-``, starting with a letter."""
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_-]{0,31}", label or ""):
        raise InputError(f"boot label {label!r}: use letters, digits, '_' or '-', starting with a letter "
                         "(e.g. left, right)")
    return label


class MultiBootWriter:
    """One multi-boot recording (``docs/recording-format.md``): one ``RecordingWriter`` per boot group.

    ``boot(label)`` is that boot's writer (``append``, ``add_events``, ``n``, ``n_safe``); ``flush`` makes every
    boot's rows safe at once, and a failed write shrinks every boot back to the last flush. All groups are
    created before SWMR mode is switched on, as SWMR requires.
    """

    def __init__(self, path: str | os.PathLike, boots: Mapping[str, BootLayout], *,
                 attrs: Mapping[str, Any] | None = None, swmr: bool = True, chunk_rows: int | None = None):
        self.path = Path(path)
        if chunk_rows is None:  # every boot shares the free space
            chunk_rows = chunk_rows_for(self.path, row_bytes=RECORDER_ROW_BYTES * max(len(boots), 1))
        labels = [check_boot_label(label) for label in boots]
        if len(set(labels)) != len(labels) or not labels:
            raise InputError(f"boot labels {labels}: give one distinct label per boot")
        if free_bytes(self.path) < MIN_FREE_BYTES:
            raise DiskFullError(f"disk full at {self.path}: 0 frames written (no space for a new file)")
        tmp = _creating_name(self.path)
        self._file = h5py.File(tmp, "w", libver=LIBVER)
        try:
            _root_attrs(self._file)
            self._file.attrs["boots"] = json.dumps(labels)
            for key, value in (attrs or {}).items():
                self._file.attrs[key] = _clean_attr(value)
            self._boots = {
                label: RecordingWriter(self.path, b.acc, b.gyro, temp=b.temp, device_time=b.device_time,
                                       host_time=b.host_time, seq=b.seq, meta=b.meta, chunk_rows=chunk_rows,
                                       _shared=(self._file, f"boots/{label}"))
                for label, b in boots.items()}
            for w in self._boots.values():
                w._peers = list(self._boots.values())
            if swmr:
                self._file.swmr_mode = True
            _publish(self._file, tmp, self.path)
        except (OSError, RuntimeError) as exc:
            self.abort()
            tmp.unlink(missing_ok=True)
            if is_disk_full(exc):
                raise DiskFullError(f"disk full at {self.path}: 0 frames written (no space for a new file)") from exc
            raise

    @property
    def labels(self) -> list[str]:
        return list(self._boots)

    def boot(self, label: str) -> RecordingWriter:
        return self._boots[label]

    def flush(self) -> None:
        """Write every boot's rows to disk (a reader or a crash sees them from now on)."""
        next(iter(self._boots.values())).flush()

    def room_for(self, n_rows: int, n_events: int = 0) -> bool:
        """Room for ``n_rows`` more samples (all boots together) and ``n_events`` events (``RecordingWriter``)."""
        return next(iter(self._boots.values())).room_for(n_rows, n_events)

    def disk_full_error(self) -> DiskFullError:
        safe = ", ".join(f"{label} {w.n_safe} frames"
                         + (f" up to t = {w.t_safe:.3f} s" if np.isfinite(w.t_safe) else "")
                         for label, w in self._boots.items())
        return DiskFullError(f"disk full at {self.path}: safely written {safe}")

    def abort(self) -> None:
        """Close after a failed write without raising (the file keeps what the last flush wrote)."""
        try:
            self._file.close()
        except (OSError, RuntimeError, ValueError):
            pass
        for w in getattr(self, "_boots", {}).values():
            w._closed = True

    def close(self, final_meta: Mapping[str, Mapping[str, Any]] | None = None,
              final_attrs: Mapping[str, Any] | None = None) -> None:
        """Flush, close, then write per-boot ``final_meta`` (label -> attributes) and root ``final_attrs``."""
        first = next(iter(self._boots.values()))
        if first._closed:
            return
        self.flush()
        try:
            self._file.close()
        except (OSError, RuntimeError) as exc:
            first._fail(exc)
        for w in self._boots.values():
            w._closed = True
        if not final_meta and not final_attrs:
            return
        try:
            with h5py.File(self.path, "r+", libver=LIBVER) as f:
                for key, value in (final_attrs or {}).items():
                    f.attrs[key] = _clean_attr(value)
                for label, meta in (final_meta or {}).items():
                    for key, value in meta.items():
                        f[f"boots/{label}/meta"].attrs[key] = _clean_attr(value)
        except (OSError, RuntimeError) as exc:
            if is_disk_full(exc):
                raise DiskFullError(f"{self.disk_full_error()} (final metadata not written)") from exc
            raise


def set_scale_factors(path: str | os.PathLike, acc_scale_to_si: float, gyro_scale_to_si: float,
                      boot: str | None = None) -> None:
    """Replace the factors to SI of the stored ``acc`` and ``gyro`` counts of a closed recording (or of one boot
    of a multi-boot one): the recorder's correction when the header frame arrived after it assumed the
    default ranges. The counts are stored raw, so the correction is lossless (``cf_scale``)."""
    group = "" if boot is None else f"boots/{boot}/"
    with h5py.File(path, "r+", libver=LIBVER) as f:
        f[f"{group}imu/acc"].attrs.update(cf_scale(acc_scale_to_si))
        f[f"{group}imu/gyro"].attrs.update(cf_scale(gyro_scale_to_si))


def retime_boots(path: str | os.PathLike, retime: Mapping[str, Any], *,
                 attrs: Mapping[str, Any] | None = None, meta_of=None) -> dict[str, np.ndarray]:
    """Put the boots of a closed multi-boot recording on a new (session) clock, in one opening of the file.

    Parameters
    ----------
    retime
        ``{label: f}``: ``f(t_s, index)`` returns the new times of the stored times ``t_s`` of the rows
        ``index`` (float64 arrays, s). Applied to every sample (``index`` = its row) and to every event (its
        ``sample_index``, clipped at 0).
    attrs
        Root attributes written first (e.g. ``session_start_unix_s``).
    meta_of
        ``meta_of(label, t_new)`` -> the attributes written into that boot's ``/meta`` (values as they are).

    Returns
    -------
    dict
        ``{label: new t_s}``.
    """
    out = {}
    with h5py.File(path, "r+", libver=LIBVER) as f:
        for key, value in (attrs or {}).items():
            f.attrs[key] = value
        for label, fn in retime.items():
            g = f[f"boots/{label}"]
            t = g["imu/t_s"][()]
            t_new = fn(t, np.arange(t.size))
            g["imu/t_s"][...] = t_new
            ev = g["events"][()]
            if ev.size:
                ev["t_s"] = fn(ev["t_s"], np.clip(ev["sample_index"], 0, None))
                g["events"][...] = ev
            for key, value in (meta_of(label, t_new) if meta_of is not None else {}).items():
                g["meta"].attrs[key] = value
            out[label] = t_new
    return out


def write_multi_boot(path, boots: Mapping[str, Mapping[str, Any]], *, attrs: Mapping[str, Any] | None = None) -> Path:
    """Write a whole multi-boot recording at once (``bootnav import`` of two files).

    ``boots`` maps a label to the keyword arguments of ``write_recording`` for that boot (``t_s``, ``acc``,
    ``gyro``, ``acc_channel``, ``gyro_channel``, ``events``, ``meta``, ``saturated``, ``temp``, ``temp_channel``,
    ``t_device``, ``t_host``, ``seq``); every ``t_s`` must already be on the session clock.
    """
    layouts, blocks = {}, {}
    for label, b in boots.items():
        b = dict(b)
        opt = {k: b.pop(k) for k in ("temp", "t_device", "t_host", "seq") if b.get(k) is not None}
        layouts[label] = BootLayout(b.get("acc_channel") or si_channel("acc"),
                                    b.get("gyro_channel") or si_channel("gyro"), temp=b.get("temp_channel"),
                                    device_time="t_device" in opt, host_time="t_host" in opt, seq="seq" in opt,
                                    meta=b.get("meta"))
        blocks[label] = (b, opt)
    writer = MultiBootWriter(path, layouts, attrs=attrs, swmr=False)
    try:
        for label, (b, opt) in blocks.items():
            w = writer.boot(label)
            w.append(b["t_s"], np.asarray(b["acc"]), np.asarray(b["gyro"]), saturated=b.get("saturated"), **opt)
            if b.get("events") is not None:
                w.add_events(b["events"])
        writer.close(final_meta={label: timing_summary(np.asarray(b["t_s"], dtype=float))
                                 for label, (b, _) in blocks.items()})
    except BaseException:
        writer.abort()
        raise
    return Path(path)


@dataclass
class Recording:
    """A recording in SI units, as ``load`` returns it."""

    path: Path
    t_s: np.ndarray  # (N,) s
    acc_mps2: np.ndarray  # (N, 3) specific force in the body frame
    gyro_radps: np.ndarray  # (N, 3) angular rate in the body frame
    saturated: np.ndarray  # (N,) uint8 bitmask, see SATURATION_BITS
    events: np.ndarray  # EVENT_DTYPE
    meta: dict
    attrs: dict
    temp_degc: np.ndarray | None = None
    t_device: np.ndarray | None = None
    t_host: np.ndarray | None = None
    seq: np.ndarray | None = None
    raw: dict = field(default_factory=dict)  # raw acc/gyro arrays as stored (counts or SI)
    truth: dict | None = None  # /truth datasets and attrs, when present

    @property
    def n(self) -> int:
        return int(self.t_s.shape[0])

    @property
    def rate_hz(self) -> float:
        return timing_summary(self.t_s)["rate_measured_hz"]

    def events_of(self, kind: str) -> np.ndarray:
        return self.events[self.events["kind"] == kind.encode()]

    def __repr__(self) -> str:
        """One line (a notebook prints it): source, samples, duration, rate, what else it holds."""
        n = self.n
        dur = float(self.t_s[-1] - self.t_s[0]) if n > 1 else 0.0
        rate = f", {self.rate_hz:.1f} Hz" if n > 2 else ""
        extra = [name for name, v in (("temp", self.temp_degc), ("truth", self.truth)) if v is not None]
        n_sat = int(np.count_nonzero(self.saturated)) if self.saturated is not None else 0
        return (f"Recording({self.path.name if self.path else self.meta.get('source_file', 'arrays')!r}, {n} samples, "
                f"{dur:.1f} s{rate}, {len(self.events)} events, {n_sat} saturated"
                + (f", {'+'.join(extra)}" if extra else "") + ")")


def _open_for_read(path: Path) -> h5py.File:
    """Open read-only; a file left with SWMR/consistency flags (writer running or killed) in SWMR mode.

    The SWMR retry is attempted only for those flags: on a truncated or damaged file HDF5's SWMR
    metadata retries would spin for minutes, so such a file fails at once with its size.
    """
    try:
        return h5py.File(path, "r")
    except OSError as first:
        text = str(first)
        if "truncated file" in text:
            m = re.search(r"eof = (\d+).*stored_eof = (\d+)", text)
            have = (f"only {int(m[1])} of its {int(m[2])} bytes ({100 * int(m[1]) / int(m[2]):.1f} %) are present"
                    if m and int(m[2]) else text.split("(", 1)[-1].rstrip(")"))
            # salvage was tried and is not robust: HDF5 writes the chunk index and the group links where they
            # fit, often after the data, so a cut file rarely keeps a row of every dataset readable
            raise InputError(f"{path}: the file is cut short: {have}; it was not completely copied or written, "
                             "copy it again from its source") from first
        if not any(k in text for k in ("h5clear", "consistency flags", "already open", "lock")):
            raise InputError(f"{path}: cannot open as an HDF5 recording ({first})") from first
        try:
            return h5py.File(path, "r", libver="latest", swmr=True)
        except OSError:
            raise InputError(f"{path}: cannot open as an HDF5 recording ({first})") from first


def decode_attr(value):
    """An HDF5 attribute as a plain Python value (bytes -> str, numpy scalar -> Python scalar, array -> list)."""
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


#: the name before issue #25 made it public, for code of this module written against it (use ``decode_attr``)
_decode = decode_attr


def _finite_number(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_)) \
        and bool(np.isfinite(value))


def _check_layout(f: h5py.File, path: Path, g: h5py.Group | None = None) -> None:
    """Reject a file whose layout ``load`` cannot trust, naming the dataset path and what is wrong.

    ``g`` is the group holding ``imu`` and ``events`` (a boot group of a multi-boot file), default the root.
    """
    g = f if g is None else g
    at = g.name.rstrip("/")  # dataset paths in the messages: /imu/t_s or /boots/left/imu/t_s
    version = f.attrs.get("format_version")
    if version is None or "imu" not in g:
        raise InputError(f"{path}: not a bootnav recording (no format_version or {at}/imu)")
    if isinstance(version, np.ndarray) and version.size == 1:
        version = version.reshape(()).item()
    if isinstance(version, (bool, np.bool_)) or not isinstance(version, (int, np.integer)):
        raise InputError(f"{path}: attribute /format_version is {decode_attr(version)!r}, expected an integer "
                         "(not written by bootnav, or damaged)")
    if int(version) > FORMAT_VERSION:
        raise InputError(f"{path}: format_version {version} is newer than this bootnav reads ({FORMAT_VERSION})")
    if not isinstance(g["imu"], h5py.Group):
        raise InputError(f"{path}: {at}/imu is a dataset, expected a group holding t_s, acc and gyro")
    imu = g["imu"]
    for name, ndim in (("t_s", 1), ("acc", 2), ("gyro", 2)):
        if name not in imu:
            raise InputError(f"{path}: {at}/imu/{name} is missing; a recording needs imu/t_s, imu/acc and imu/gyro")
    for name in ("t_s", "acc", "gyro", "saturated", "temp", "t_device", "t_host", "seq"):
        if name not in imu:
            continue
        ds = imu[name]
        ndim = 2 if name in ("acc", "gyro") else 1
        if not isinstance(ds, h5py.Dataset) or ds.dtype.kind not in "iuf" or ds.ndim != ndim \
                or (ndim == 2 and ds.shape[1] != 3):
            want = "an (N, 3) numeric dataset" if ndim == 2 else "a 1-D numeric dataset"
            got = f"{ds.dtype} {ds.shape}" if isinstance(ds, h5py.Dataset) else "a group"
            raise InputError(f"{path}: {at}/imu/{name} is {got}, expected {want}")
        for key in ("scale_to_si", "offset_to_si"):
            value = ds.attrs.get(key, 0.0)
            if isinstance(value, np.ndarray) and value.size == 1:
                value = value.reshape(()).item()
            if not _finite_number(value):
                raise InputError(f"{path}: attribute {key} of {at}/imu/{name} is {decode_attr(value)!r}, expected a finite number")
    if "events" in g:
        ev = g["events"]
        if not isinstance(ev, h5py.Dataset) or ev.dtype.names is None \
                or not {"t_s", "sample_index", "kind"} <= set(ev.dtype.names):
            raise InputError(f"{path}: {at}/events is not an event table (a compound dataset with t_s, sample_index, "
                             "kind, ...); delete it with h5py to read the samples")


def _boots_attr(f: h5py.File, path: Path) -> list[str]:
    raw = f.attrs.get("boots")
    if raw is None:
        return []
    try:
        labels = json.loads(decode_attr(raw))
    except (TypeError, ValueError):
        labels = None
    if not isinstance(labels, list) or not all(isinstance(x, str) for x in labels):
        raise InputError(f"{path}: root attribute boots is {decode_attr(raw)!r}, expected a JSON list of boot labels")
    return labels


def load_aux(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """The ``/aux`` columns of an imported recording (magnetometer, heading, FSR, ...), {} if none."""
    with h5py.File(path, "r") as f:
        if "aux" not in f:
            return {}
        return {k: f["aux"][k][()] for k in f["aux"]}


def boot_labels(path: str | os.PathLike) -> list[str]:
    """Labels of the boots of a multi-boot recording in port order (e.g. ``["left", "right"]``); ``[]`` for a
    single-boot recording.

    Raises
    ------
    InputError
        The file is missing or not HDF5.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    with _open_for_read(path) as f:
        return _boots_attr(f, path)


def sample_count(path: str | os.PathLike) -> int:
    """Number of IMU samples of a single-boot recording, read from the layout without loading any data.

    Raises
    ------
    InputError
        The file is missing, not HDF5, or has no ``/imu/t_s``.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    with _open_for_read(path) as f:
        t = f.get("imu/t_s")
        if not isinstance(t, h5py.Dataset) or t.ndim != 1:
            raise InputError(f"{path}: dataset /imu/t_s is missing or not one-dimensional")
        return int(t.shape[0])


#: Rows of a recording the unit check reads (10 min at 200 Hz): enough still seconds and strides, bounded memory.
UNIT_CHECK_ROWS = 120_000


def unit_problems(acc_si, gyro_si, rate_hz: float) -> list[str]:
    """What is wrong with the units of samples that claim to be SI: ``import``'s checks (one definition,
    ``bootnav.logger.importers.checks``) applied to stored values times ``scale_to_si``. Gravity at rest must be
    9.81 m/s^2 +-25 % (a file in g, or in raw int16 counts without a scale, is not) and the gyro's 99.9th percentile
    at most 35 rad/s (a file in deg/s is not). Empty when the units are plausible."""
    from bootnav.logger.importers import checks

    out = []
    acc = np.asarray(acc_si, dtype=np.float64)
    if acc.ndim == 2 and acc.shape[0] >= 2:
        p = checks.acc_unit_problem(acc, 1.0, "m/s^2 (stored value x scale_to_si)", rate_hz)
        if p:
            out.append(p.replace("--acc-unit ", "acc unit "))
    if gyro_si is not None and np.asarray(gyro_si).shape[0] >= 2:
        p = checks.gyro_unit_problem(np.asarray(gyro_si, dtype=np.float64), "rad/s (stored value x scale_to_si)")
        if p:
            out.append(p.replace("--gyro-unit ", "gyro unit "))
    return out


def units_trusted(meta: Mapping[str, Any]) -> bool:
    """The recording was imported with ``--trust-units`` (its ``/meta unit_check`` says the check was
    overridden): the unit check is the user's decision, not repeated."""
    return "overridden" in str(meta.get("unit_check", ""))


def check_recording_units(rec: "Recording", path) -> None:
    """``InputError`` when a recording's samples are not in SI units (``unit_problems``), naming the file, the
    figures and the fix; nothing for a recording imported with ``--trust-units``."""
    if units_trusted(rec.meta) or rec.n < 2:
        return
    k = min(rec.n, UNIT_CHECK_ROWS)
    dt = np.diff(rec.t_s[:k])
    dt = dt[np.isfinite(dt) & (dt > 0)]
    rate = 1.0 / float(np.median(dt)) if dt.size else float("nan")
    problems = unit_problems(rec.acc_mps2[:k], rec.gyro_radps[:k], rate)
    if problems:
        raise InputError(f"{path}: the samples are not in SI units: {'; '.join(problems)}; set the scale_to_si "
                         "attributes of /imu/acc and /imu/gyro to the factors to m/s^2 and rad/s, or import the "
                         "source again with the right --acc-unit/--gyro-unit (--trust-units to keep them)")


def load(path: str | os.PathLike, *, with_truth: bool = True, boot: str | None = None,
         check_units: bool = False) -> Recording:
    """Open a recording and return it in SI units (the one function every consumer uses).

    Parameters
    ----------
    path
        A recording (single- or multi-boot).
    with_truth
        Also read ``/truth`` (simulator) when present.
    boot
        The boot to read from a multi-boot recording (``boot_labels``); required for one, refused for a
        single-boot recording. Its ``t_s`` is on the session clock shared by all boots.
    check_units
        Refuse samples whose units are not SI (``check_units``: acc in g or counts, gyro in deg/s, as ``import``
        refuses them). Every consumer that computes a path asks for it (``postproc.source.load_source``: process,
        eval and the API; ``live``; ``pdr``); tools that inspect or convert a file read it as it is (``info``
        reports the problem as a warning).

    Raises
    ------
    InputError
        The file is missing, cut short, unreadable, or its layout is not a recording's; the message
        names the file and the dataset path. A multi-boot file without ``boot`` (or an unknown label).
    """
    with recording_group(path, boot) as (f, g):
        rec = _read(f, Path(path), with_truth, g)
    if check_units:
        check_recording_units(rec, path)
    return rec


@contextmanager
def recording_group(path: str | os.PathLike, boot: str | None = None):
    """Open a recording and yield ``(file, group)``: the group holding ``imu``/``events``/``meta`` of the
    recording (the root) or of one boot (``/boots/<boot>``), its layout checked.

    The checks and messages of ``load``; a read error inside the ``with`` block (a damaged chunk or header)
    becomes the same one-line ``InputError``.
    """
    from bootnav.core.paths import regular_input

    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, expected a recording file")
    regular_input(path, "recording")  # a FIFO would block forever
    with _open_for_read(path) as f:
        _missing_recording(f, path)
        labels = _boots_attr(f, path)
        if labels and boot is None:
            raise InputError(f"{path}: a multi-boot recording (boots {', '.join(labels)}); read one boot with "
                             f"load(path, boot={labels[0]!r}), or use a command's two-boot mode")
        if boot is not None and boot not in labels:
            raise InputError(f"{path}: no boot {boot!r} in this recording"
                             + (f" (boots: {', '.join(labels)})" if labels else " (a single-boot recording)"))
        if boot is not None and f"boots/{boot}" not in f:
            raise InputError(f"{path}: group /boots/{boot} is missing although the root attribute boots lists it")
        g = f[f"boots/{boot}"] if boot is not None else f
        with read_errors(path):
            _check_layout(f, path, g)
            yield f, g


@contextmanager
def read_errors(path: str | os.PathLike):
    """A read error inside the block (a damaged chunk, "filter returned failure", or header) becomes the
    one-line ``InputError`` of ``load`` (``recording_group``; ``bootnav info`` around its reads)."""
    try:
        yield
    except (OSError, RuntimeError) as exc:
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{path}: part of the file cannot be read ({text}); the file is damaged or cut short") \
            from exc


def file_sha256(path: str | os.PathLike, block: int = 1 << 22) -> str:
    """SHA-256 of a file's bytes, read in 4 MB blocks (memory flat in the file's size)."""
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while chunk := fh.read(block):
            h.update(chunk)
    return h.hexdigest()


def start_results_file(path: str | os.PathLike, recording: str | os.PathLike, final_dir: str | os.PathLike) -> None:
    """Create a results file (``results.h5``) that refers to its recording instead of copying it.

    The new file holds the recording's root attributes, an HDF5 external link per top-level member of the
    recording (``/imu``, ``/events``, ``/meta``, ``/truth``, ``/boots``, ...; ``/results`` is left out: the caller
    adds its own) and the reference as root attributes: ``recording_file`` (path relative to ``final_dir``, the
    directory the file ends up in: HDF5 resolves an external link relative to the file holding it),
    ``recording_file_absolute`` and ``recording_sha256`` (the recording's bytes when the results were written).
    ``load`` reads such a file as it reads the recording while the recording is where the link says; when it is
    not, ``load`` names the recording to put back. Results files of earlier releases (a whole copy of the
    recording) stay readable.

    Parameters
    ----------
    path
        The file to create (normally a temporary name beside the final one).
    recording
        The HDF5 recording the results were computed from.
    final_dir
        The directory the results file is committed to.
    """
    recording = Path(recording).resolve()
    rel = os.path.relpath(recording, Path(final_dir).resolve())
    with h5py.File(recording, "r") as src, h5py.File(path, "w", libver=LIBVER) as f:
        for key, value in src.attrs.items():
            f.attrs[key] = value
        f.attrs["created_utc"] = _utc_now()
        f.attrs["recording_file"] = rel
        f.attrs["recording_file_absolute"] = str(recording)
        f.attrs["recording_sha256"] = file_sha256(recording)
        f.attrs["content"] = "results of the linked recording (HDF5 external links to its groups)"
        for name in src:
            if name != "results":
                f[name] = h5py.ExternalLink(rel, f"/{name}")


def _missing_recording(f: h5py.File, path: Path) -> None:
    """A results file whose linked recording is not found: say which file to put back (``start_results_file``)."""
    if "recording_file" not in f.attrs:
        return
    try:
        for name in f:
            f[name]  # noqa: B018 - an external link is only followed when opened
    except KeyError:
        raise InputError(f"{path}: the recording these results refer to is not found: {_decode(f.attrs['recording_file'])}"
                         f" (relative to {path.parent}; sha256 {_decode(f.attrs.get('recording_sha256', '?'))}); "
                         "put it back there, or read the results alone with h5py (/results)") from None


#: the per-sample datasets of /imu, in the order ``_read`` and ``RecordingReader`` look for them
IMU_DATASETS = ("t_s", "acc", "gyro", "saturated", "temp", "t_device", "t_host", "seq")


def si_factors(attrs) -> tuple[float, float]:
    """(scale, offset) of a stored channel: SI = stored × scale + offset (``Channel``; 1 and 0 when absent)."""
    return float(attrs.get("scale_to_si", 1.0)), float(attrs.get("offset_to_si", 0.0))


def si_values(ds, sl=slice(None)) -> np.ndarray:
    """Rows ``sl`` of a stored channel in SI units (``si_factors``), float64."""
    scale, offset = si_factors(ds.attrs)
    return ds[sl].astype(np.float64) * scale + offset


class RecordingReader:
    """Blocks of SI samples of one recording (or one boot of a multi-boot one): the only decoder of the
    ``/imu`` layout besides ``load`` (which reads every row through the same ``si_values``).

    Memory is bounded by the block: nothing is read before it is asked for. A recording still being written
    (``swmr=True``, ``bootnav live``) grows: ``refresh`` sees the rows flushed since.

    Parameters
    ----------
    path
        A recording.
    boot
        The boot of a multi-boot recording (as ``load``).
    swmr
        Open for reading while a writer appends (single-writer/multiple-reader mode); the layout is not
        checked (the writer may not have created every dataset yet: ``require`` names those that must be there,
        KeyError otherwise).

    Attributes
    ----------
    n : int
        Rows readable now: the common prefix of ``t_s``, ``acc``, ``gyro`` (and ``saturated``), since a
        killed or running writer may leave them of unequal length.
    meta : dict
        ``/meta`` attributes, decoded.
    """

    def __init__(self, path, boot: str | None = None, *, swmr: bool = False, require: tuple[str, ...] = ()):
        self.path = Path(path)
        self._swmr = swmr
        self._ctx = None
        self._file = None
        try:
            if swmr:
                self._file = h5py.File(self.path, "r", libver="latest", swmr=True)
                self._group = self._file if boot is None else self._file[f"boots/{boot}"]
            else:
                ctx = recording_group(self.path, boot)
                self._file, self._group = ctx.__enter__()
                self._ctx = ctx
            imu = self._group["imu"]  # KeyError (swmr: not created yet)
            missing = [k for k in require if k not in imu]
            if missing:
                raise KeyError(f"{self.path}: /imu has no {', '.join(missing)} yet")
            self._imu = imu
            self._names = [k for k in ("t_s", "acc", "gyro", "saturated") if k in imu]
            g = self._group
            self.meta = {k: decode_attr(v) for k, v in g["meta"].attrs.items()} if "meta" in g else {}
            self.n = self._common_rows()
        except BaseException:
            self.close()
            raise

    def _common_rows(self) -> int:
        return int(min(self._imu[k].shape[0] for k in self._names))

    def refresh(self) -> int:
        """See the rows a writer flushed since (``swmr``); returns ``n``."""
        for k in self._names:
            self._imu[k].refresh()
        self.n = self._common_rows()
        return self.n

    def block(self, i0: int, i1: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rows i0..i1-1 as ``(t_s, acc_mps2, gyro_radps, saturated)``: float64 SI, saturation bits uint8
        (zeros when the recording has no mask)."""
        imu, sl = self._imu, slice(i0, i1)
        t = imu["t_s"][sl].astype(np.float64)
        sat = imu["saturated"][sl] if "saturated" in imu else np.zeros(t.shape[0], np.uint8)
        return t, si_values(imu["acc"], sl), si_values(imu["gyro"], sl), np.asarray(sat, np.uint8)

    def temp_degc(self, i0: int, i1: int) -> np.ndarray | None:
        """Rows i0..i1-1 of the temperature channel in °C (float64), None when the recording has none (or,
        growing, not that many rows yet)."""
        if "temp" not in self._imu:
            return None
        ds = self._imu["temp"]
        if self._swmr:
            ds.refresh()
        if ds.shape[0] < i1:
            return None
        return si_values(ds, slice(i0, i1))

    def check_units(self) -> None:
        """``load(check_units=True)``'s check (``check_recording_units``) on the first ``UNIT_CHECK_ROWS`` rows:
        InputError when acc is in g or counts or gyro in deg/s."""
        k = min(self.n, UNIT_CHECK_ROWS)
        t, acc, gyro, sat = self.block(0, k)
        head = Recording(path=self.path, t_s=t, acc_mps2=acc, gyro_radps=gyro, saturated=sat,
                         events=make_events([]), meta=self.meta, attrs={})
        check_recording_units(head, self.path)

    def times(self, i0: int = 0, i1: int | None = None) -> np.ndarray:
        """``t_s`` of rows i0..i1-1 (float64), without reading the samples."""
        return self._imu["t_s"][i0:self.n if i1 is None else i1].astype(np.float64)

    @property
    def lengths(self) -> dict[str, int]:
        """Rows of every ``/imu`` dataset present (``IMU_DATASETS`` order): a killed writer may leave them
        unequal (``bootnav info`` reports it)."""
        return {k: int(self._imu[k].shape[0]) for k in IMU_DATASETS if k in self._imu}

    def stored_attrs(self, name: str) -> dict:
        """The attributes of the ``/imu`` dataset ``name`` (units, ``scale_to_si``, ``full_scale``, ...)."""
        return dict(self._imu[name].attrs)

    def stored_kind(self, name: str) -> str:
        """The numpy kind of the stored values of ``name``: "f" floats (SI), "i"/"u" counts."""
        return self._imu[name].dtype.kind

    def stored(self, name: str, i0: int, i1: int) -> np.ndarray:
        """Rows i0..i1-1 of the ``/imu`` dataset ``name`` as stored (counts or floats: ``si_factors`` of
        ``stored_attrs`` give SI)."""
        return self._imu[name][i0:i1]

    def stored_summary(self, n: int) -> dict | None:
        """The figures of the samples the writer stored at close (``samplestats.read_summary``) when they
        describe exactly the first ``n`` rows, else None."""
        return read_summary(self._imu, n)

    def events(self, start: int = 0) -> np.ndarray:
        """``/events`` rows from ``start`` (refreshed first when the file is growing)."""
        if "events" not in self._group:
            return np.zeros(0, EVENT_DTYPE)
        ev = self._group["events"]
        if self._swmr:
            ev.refresh()
        return ev[start:]

    def close(self) -> None:
        if self._ctx is not None:
            self._ctx.__exit__(None, None, None)
            self._ctx = None
        elif self._file is not None:
            self._file.close()
        self._file = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _read(f: h5py.File, path: Path, with_truth: bool, g: h5py.Group | None = None) -> Recording:
    g = f if g is None else g
    imu = g["imu"]
    # A killed writer may leave datasets of unequal length; keep the common prefix.
    names = [k for k in IMU_DATASETS if k in imu]
    n = min(imu[k].shape[0] for k in names)
    get = lambda k: imu[k][:n] if k in imu else None  # noqa: E731
    scale = lambda k: si_values(imu[k], slice(0, n))  # noqa: E731
    saturated = get("saturated")
    rec = Recording(
        path=path,
        t_s=get("t_s").astype(np.float64),
        acc_mps2=scale("acc"),
        gyro_radps=scale("gyro"),
        saturated=np.zeros(n, np.uint8) if saturated is None else saturated,
        events=g["events"][()] if "events" in g else np.zeros(0, EVENT_DTYPE),
        meta={k: decode_attr(v) for k, v in g["meta"].attrs.items()} if "meta" in g else {},
        attrs={k: decode_attr(v) for k, v in f.attrs.items()},
        temp_degc=scale("temp") if "temp" in imu else None,
        t_device=get("t_device"),
        t_host=get("t_host"),
        seq=get("seq"),
        raw={
            "acc": get("acc"),
            "gyro": get("gyro"),
            "acc_attrs": dict(imu["acc"].attrs),
            "gyro_attrs": dict(imu["gyro"].attrs),
        },
    )
    if with_truth and "truth" in g:
        tg = g["truth"]
        rec.truth = {k: tg[k][()] for k in tg if isinstance(tg[k], h5py.Dataset)}
        rec.truth["attrs"] = {k: decode_attr(v) for k, v in tg.attrs.items()}
    return rec


def write_group(path, group: str, arrays: Mapping[str, Any], attrs: Mapping[str, Any] | None = None,
                units: Mapping[str, str] | None = None, replace: bool = True) -> None:
    """Add (or replace) a group such as ``/truth`` or ``/results/<name>`` in an existing recording.

    Every array gets a ``units`` attribute (from ``units``, default "1").
    """
    units = units or {}
    with h5py.File(path, "r+", libver=LIBVER) as f:
        if group in f and replace:
            del f[group]
        g = f.require_group(group)
        for key, value in (attrs or {}).items():
            g.attrs[key] = _clean_attr(value)
        for key, value in arrays.items():
            value = np.asarray(value)
            kwargs = dict(_COMPRESSION, chunks=True) if value.ndim and value.size > 1024 else {}
            ds = g.create_dataset(key, data=value, **kwargs)
            ds.attrs["units"] = units.get(key, "1")


_AXIS_LABELS = {3: ("axis", "xyz"), 4: ("q_component", "wxyz")}


def attach_dimension_scales(path, group: str, time_key: str = "t_s", dim: str = SAMPLE_DIM) -> None:
    """Name the dimensions of a group's arrays with HDF5 dimension scales, as ``/imu`` does.

    A monotonic index ``group/dim`` (0, 1, ...: the row number) becomes the scale of the first dimension of every
    array with as many rows as ``group[time_key]``, which is named as their coordinate (CF ``coordinates``): a
    clock that repeats a value cannot be an index, a row number always can. A second dimension of 3 gets an
    ``axis`` (x, y, z) scale, of 4 a ``q_component`` (w, x, y, z) scale (UTF-8 strings), created in the group
    when needed. netCDF-4 readers (xarray with h5netcdf, MATLAB ``ncread``) then see named dimensions and
    coordinates instead of anonymous ones.

    Parameters
    ----------
    path
        An existing HDF5 file (written with ``LIBVER``).
    group
        The group holding ``time_key`` and the arrays, e.g. ``/results/default``.
    time_key
        The 1-D time array of the group.
    dim
        Name of the row dimension (``sample``; ``stride`` for a table of strides).
    """
    with h5py.File(path, "r+", libver=LIBVER) as f:
        g = f[group]
        n = g[time_key].shape[0]
        if dim in g:
            del g[dim]
        index = g.create_dataset(dim, shape=(n,), dtype=np.int64, **(_COMPRESSION if n > 1024 else {}))
        for i in range(0, n, 1 << 20):  # in pieces: the whole index is 8 B per row (138 MB at 24 h at 200 Hz)
            index[i:min(n, i + (1 << 20))] = np.arange(i, min(n, i + (1 << 20)), dtype=np.int64)
        index.attrs["units"] = "1"
        index.make_scale(dim)
        for name, ds in list(g.items()):
            if not isinstance(ds, h5py.Dataset) or ds.is_scale or ds.ndim == 0 or ds.shape[0] != n:
                continue
            ds.dims[0].attach_scale(index)
            if name != time_key:
                ds.attrs["coordinates"] = time_key
            if ds.ndim == 2 and ds.shape[1] in _AXIS_LABELS:
                scale_name, labels = _AXIS_LABELS[ds.shape[1]]
                if scale_name not in g:
                    label_scale(g, scale_name, labels)
                ds.dims[1].attach_scale(g[scale_name])
