"""Stage 1 of ``process``: read the input and cut out the window to process.

The input is a bootnav HDF5 recording (``bootnav.logger.recording.load``; a simulator's ``/truth`` is not
read: it is for evaluation only) or any file ``bootnav import`` reads (``bootnav.logger.importers.read_any``,
e.g. the canonical ``imu.csv.gz``, which needs no options), or an in-memory ``Recording``. The crop keeps the
recording's clock, so times in every output match the input file.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bootnav.core.conventions import CONVENTIONS
from bootnav.errors import InputError
from bootnav.logger.recording import Recording, load, make_events


@dataclass
class Source:
    """One input as read: the full (uncropped) recording and where it came from."""

    recording: Recording  # SI units, every sample of the input
    path: Path | None  # None for an in-memory Recording without a file
    is_hdf5: bool  # True: a bootnav recording (results can go into it); False: an imported file

    @property
    def name(self) -> str:
        """How messages name the input: its path, else ``"recording"``."""
        return str(self.path) if self.path else "recording"


@dataclass
class Samples:
    """The window of the input that is processed (contiguous float64 arrays, body frame, SI)."""

    t_s: np.ndarray  # (N,) s, recording time
    acc_b: np.ndarray  # (N, 3) m/s^2, specific force as recorded (uncalibrated)
    gyro_b: np.ndarray  # (N, 3) rad/s
    saturated: np.ndarray  # (N,) uint8 saturation bitmask as recorded (bits ``SATURATION_BITS``), zeros if none
    index: slice  # the window's samples within the recording


def is_hdf5(path: Path) -> bool:
    """True when ``path`` is an HDF5 file (an unreadable file is not)."""
    import h5py

    try:
        return bool(h5py.is_hdf5(path))
    except OSError:
        return False


def load_source(source: str | Path | Recording, import_overrides: dict | None = None) -> Source:
    """Read a recording, an HDF5 file or any importable file.

    Parameters
    ----------
    source
        An in-memory ``Recording``, the path of a bootnav HDF5 recording, or the path of any file
        ``bootnav import`` reads.
    import_overrides
        For a text file: ``read_any``'s overrides (``acc_unit``, ``gyro_unit``, ``time_unit``, ``check_units``).
        Refused for an HDF5 recording or a ``Recording``, whose units are declared.

    Returns
    -------
    Source
        The full recording (an imported file keeps its ``ImportResult`` on ``recording.raw["import_result"]``,
        so the outputs can write the imported recording next to the results).

    Raises
    ------
    InputError
        Missing file, a directory, an unreadable file, or fewer than 3 samples.
    """
    def declared(name):  # unit keywords are for text files; a recording says its units
        if import_overrides:
            raise InputError(f"{name}: a bootnav recording declares its own units; "
                             f"{', '.join(sorted(import_overrides))} apply to a text file (CSV, SD-card log)")

    if isinstance(source, Recording):
        declared(source.path or "the recording")
        path = Path(source.path) if source.path else None
        src = Source(source, path, bool(source.path) and is_hdf5(path))
        if src.is_hdf5:  # a recording read from a file (bootnav.load): its units checked like a path's
            from bootnav.logger.recording import check_recording_units

            check_recording_units(source, path)
    else:
        path = Path(source)
        if not path.exists():
            raise InputError(f"{path}: no such file")
        if path.is_dir():
            raise InputError(f"{path}: is a directory; give a recording (.h5) or an IMU file (e.g. imu.csv.gz)")
        from bootnav.core.paths import regular_input

        regular_input(path, "recording (.h5) or IMU")  # a FIFO would block forever, a device never end
        if is_hdf5(path):  # units checked as `import` checks them (acc in g, gyro in deg/s, raw counts)
            declared(path)
            src = Source(load(path, with_truth=False, check_units=True), path, True)
        else:
            src = Source(_import(path, import_overrides or {}), path, False)
    if src.recording.n < 3:
        raise InputError(f"{src.name}: only {src.recording.n} samples; nothing to process")
    return src


def _import(path: Path, overrides: dict) -> Recording:
    """A non-HDF5 input through ``bootnav import``'s reader, as an in-memory Recording."""
    from bootnav.logger.importers import read_any

    imp = read_any(path, **overrides)
    events = sorted(imp.events, key=lambda e: (e.get("sample_index", -1), e.get("line", -1)))
    return Recording(path=path, t_s=np.asarray(imp.t_s, np.float64), acc_mps2=imp.acc_mps2,
                     gyro_radps=imp.gyro_radps, saturated=np.asarray(imp.saturated, np.uint8),
                     events=make_events(events), meta=dict(imp.meta), attrs=dict(CONVENTIONS),
                     raw={"import_result": imp})


def crop_index(t_s: np.ndarray, crop_s: tuple[float, float] | None, name: str = "recording") -> slice:
    """Samples with ``crop_s[0] <= t_s <= crop_s[1]`` (all samples for ``None``).

    Parameters
    ----------
    t_s
        (N,) recording time, s, non-decreasing.
    crop_s
        (t0, t1) window in recording seconds, or None.
    name
        How error messages name the input.

    Returns
    -------
    slice
        The window's sample indices.

    Raises
    ------
    InputError
        ``t1 <= t0``, or fewer than 2 samples in the window.
    """
    if crop_s is None:
        return slice(0, len(t_s))
    t0, t1 = float(crop_s[0]), float(crop_s[1])
    if not t1 > t0:
        raise InputError(f"{name}: --crop: end {t1} s must be after start {t0} s")
    i0 = int(np.searchsorted(t_s, t0, side="left"))
    i1 = int(np.searchsorted(t_s, t1, side="right"))
    if i1 - i0 < 2:
        raise InputError(f"{name}: --crop {t0:g} {t1:g}: no samples in that window (recording spans "
                         f"{t_s[0]:.3f}-{t_s[-1]:.3f} s)")
    return slice(i0, i1)


def crop(recording: Recording, crop_s: tuple[float, float] | None, name: str = "recording") -> Samples:
    """The samples of ``recording`` inside ``crop_s`` (see ``crop_index``) as contiguous float64 arrays.

    Parameters
    ----------
    recording
        The full input (SI).
    crop_s
        (t0, t1) window in recording seconds, or None for every sample.
    name
        How error messages name the input.

    Returns
    -------
    Samples
        Copies (or contiguous views) of the window; ``saturated`` is all zeros when the input has no mask.
    """
    idx = crop_index(recording.t_s, crop_s, name)
    t_s = np.ascontiguousarray(recording.t_s[idx], dtype=np.float64)
    sat = (np.asarray(recording.saturated[idx]) if recording.saturated is not None
           else np.zeros(len(t_s), np.uint8))
    return Samples(t_s=t_s, acc_b=np.ascontiguousarray(recording.acc_mps2[idx], dtype=np.float64),
                   gyro_b=np.ascontiguousarray(recording.gyro_radps[idx], dtype=np.float64), saturated=sat,
                   index=idx)


# ---------------------------------------------------------------------------------------------------------------
# Readers of blocks: what the block passes of ``pipeline`` read (``RecordingReader``'s interface)


class MemoryReader:
    """``logger.recording.RecordingReader``'s interface over an in-memory ``Recording`` (an imported file, a
    ``Recording`` given to the API): the same block passes read it, whatever the input (its memory is the
    recording's, already loaded)."""

    def __init__(self, recording: Recording):
        self.recording = recording
        self.path = Path(recording.path) if recording.path else None
        self.meta = dict(recording.meta)
        self.n = int(recording.n)

    def block(self, i0: int, i1: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rows i0..i1-1 as ``(t_s, acc_mps2, gyro_radps, saturated)`` (float64 SI, uint8 bits)."""
        rec, sl = self.recording, slice(i0, i1)
        t = np.ascontiguousarray(rec.t_s[sl], dtype=np.float64)
        sat = (np.asarray(rec.saturated[sl], np.uint8) if rec.saturated is not None
               else np.zeros(len(t), np.uint8))
        return (t, np.ascontiguousarray(rec.acc_mps2[sl], dtype=np.float64),
                np.ascontiguousarray(rec.gyro_radps[sl], dtype=np.float64), sat)

    def temp_degc(self, i0: int, i1: int) -> np.ndarray | None:
        temp = self.recording.temp_degc
        return None if temp is None else np.asarray(temp[i0:i1], np.float64)

    def times(self, i0: int = 0, i1: int | None = None) -> np.ndarray:
        return np.asarray(self.recording.t_s[i0:self.n if i1 is None else i1], np.float64)

    def check_units(self) -> None:
        """The units were checked when the input was read (``load_source``)."""

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class ReaderWindow:
    """Rows ``start``..``stop``-1 of a reader (a crop) with the reader's interface, row 0 = row ``start``:
    the passes count samples in the window, messages and ``sample_index_start`` add ``start``."""

    def __init__(self, reader, start: int = 0, stop: int | None = None):
        self.reader = reader
        self.start = int(start)
        self.stop = int(reader.n if stop is None else stop)
        self.n = self.stop - self.start
        self.meta = reader.meta

    def block(self, i0: int, i1: int):
        return self.reader.block(self.start + i0, self.start + i1)

    def temp_degc(self, i0: int, i1: int):
        return self.reader.temp_degc(self.start + i0, self.start + i1)

    def times(self, i0: int = 0, i1: int | None = None) -> np.ndarray:
        return self.reader.times(self.start + i0, self.stop if i1 is None else self.start + i1)

    def check_units(self) -> None:
        self.reader.check_units()  # on the recording's first rows, as ``load_source`` checks them


def crop_window(reader, crop_s: tuple[float, float] | None, name: str, rows: int = 1 << 16) -> ReaderWindow:
    """``crop_index`` on a reader, reading its times ``rows`` at a time (bounded memory): the same window
    (``np.searchsorted`` of non-decreasing times, block by block), as a ``ReaderWindow``.

    Raises
    ------
    InputError
        As ``crop_index``.
    """
    n = reader.n
    if crop_s is None:
        return ReaderWindow(reader, 0, n)
    t0, t1 = float(crop_s[0]), float(crop_s[1])
    if not t1 > t0:
        raise InputError(f"{name}: --crop: end {t1} s must be after start {t0} s")
    i0 = i1 = None
    for b0 in range(0, n, rows):
        t = reader.times(b0, min(n, b0 + rows))
        if i0 is None and t[-1] >= t0:
            i0 = b0 + int(np.searchsorted(t, t0, side="left"))
        if t[-1] > t1:
            i1 = b0 + int(np.searchsorted(t, t1, side="right"))
            break
    i0 = n if i0 is None else i0
    i1 = n if i1 is None else i1
    if i1 - i0 < 2:
        first, last = reader.times(0, 1)[0], reader.times(n - 1, n)[0]
        raise InputError(f"{name}: --crop {t0:g} {t1:g}: no samples in that window (recording spans "
                         f"{first:.3f}-{last:.3f} s)")
    return ReaderWindow(reader, i0, i1)
