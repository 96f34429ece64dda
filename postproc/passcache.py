"""What the passes over the blocks of a long recording compute once and read back (``passes.BlockPasses``).

A run in many blocks makes several passes over its samples (``pipeline``'s module docstring). Without these
spills each pass decoded the HDF5 blocks again, applied the sensor calibration and searched the clipping
rails' samples again, ran the stance detector again, and the final pass ran again the filter + smoother the
pass before it had run (over one block it replays those rows from memory). Here each of them is done once,
its rows written to a temporary file (binary, as computed: float64 stays float64) and read back chunk by
chunk by the passes after it, so the outputs are the same bit for bit and memory stays bounded by the block:

- ``DecodedBlocks``: a block's samples ``(t, acc, gyro, saturation bits)``, decoded and calibrated, and its
  saturation bits with the clipping rails' (``checks.ClipRails.bits``), keyed by the block's rows;
- ``StanceSpill``: the ``StanceChunk``\\ s of a stance detector's stream over the blocks, keyed by the
  detector's settings and noise floor (every pass pushes the same blocks to a detector built the same way, so
  its chunks, boundaries included, are the same);
- ``NavRowSpill``: the ``NavRows`` of each push of a filter pass, which the final pass replays when it runs
  the same filter with the same gate (the condition of the one-block replay, which it keeps in memory).

Each spill takes its bytes from the run's ``SpillBudget``; what would go over it (or what the disk refuses)
is not kept, and the passes that would have read it compute as without spills. At 200 Hz a run spills about
222 MB per hour of recording (``docs/long-recordings.md``).
"""

from __future__ import annotations

import json
import shutil
import tempfile
import weakref

import numpy as np

#: bytes the spills of one run may write to the temporary folder. A run spills ~230 MB per hour at 200 Hz
#: (decoded samples 57 B, stance chunks 75 B, one filter pass's rows 172 B per sample), so 8 GiB holds a
#: 24-hour shift (5.5 GB) with room for the stance fallback's candidates; a longer recording (or a higher
#: rate) recomputes in the passes past the budget, as without spills. Never more than ``FREE_SHARE`` of the
#: temporary folder's free space either.
SPILL_BUDGET_BYTES = 8 << 30

#: the share of the temporary folder's free space (at the start of the run) the spills may take: the rest is
#: left to the outputs being written and to other programs.
FREE_SHARE = 0.5

#: file systems kept in memory: a spill there is memory (222 MB per hour at 200 Hz), against memory flat in the
#: recording's length, so none is spilled there (``TMPDIR`` on a disk brings the spills back)
RAM_FILE_SYSTEMS = ("tmpfs", "ramfs")


def ram_backed(folder) -> bool:
    """Whether ``folder`` is on a file system kept in memory (``RAM_FILE_SYSTEMS``), from the mount table of
    Linux (``/proc/self/mounts``: the mount point that is the longest prefix of its real path); False when
    that cannot be read (another system)."""
    import os

    path = os.path.realpath(folder)
    best, kind = "", ""
    try:
        with open("/proc/self/mounts", encoding="utf-8", errors="replace") as f:
            for line in f:
                parts = line.split()
                if len(parts) < 3:
                    continue
                point = parts[1].encode().decode("unicode_escape")  # \040 for a space
                inside = path == point or path.startswith(point.rstrip("/") + "/")
                if inside and len(point) >= len(best):
                    best, kind = point, parts[2]
    except OSError:
        return False
    return kind in RAM_FILE_SYSTEMS


class SpillBudget:
    """The bytes the spills of one run may write to the temporary folder.

    Parameters
    ----------
    limit_bytes : int, optional
        The budget (default ``SPILL_BUDGET_BYTES``; 0: no spill, every pass computes).
    folder : str, optional
        Where the spills go (default ``tempfile.gettempdir()``); the budget is at most ``FREE_SHARE`` of its
        free space, and 0 when it is kept in memory (``ram_backed``).

    Attributes
    ----------
    limit : int
        The budget in bytes.
    """

    def __init__(self, limit_bytes: int | None = None, folder: str | None = None):
        self.folder = tempfile.gettempdir() if folder is None else str(folder)
        limit = SPILL_BUDGET_BYTES if limit_bytes is None else int(limit_bytes)
        try:
            free = 0 if ram_backed(self.folder) else shutil.disk_usage(self.folder).free
        except OSError:  # no such folder, or not readable: no spill
            free = 0
        self.limit = max(0, min(limit, int(free * FREE_SHARE)))
        self._files: weakref.WeakSet = weakref.WeakSet()

    @property
    def used(self) -> int:
        """Bytes held by the spill files still open."""
        return sum(f.size for f in self._files)

    def open(self, prefix: str) -> "ArrayFile":
        """A new spill file charged to this budget."""
        f = ArrayFile(self, prefix)
        self._files.add(f)
        return f

    def allows(self, nbytes: int) -> bool:
        """Whether ``nbytes`` more fit in the budget."""
        return self.used + nbytes <= self.limit


class ArrayFile:
    """Arrays appended to one temporary file (their bytes as they are in memory) and read back by place.

    Made by ``SpillBudget.open``. Once a write is refused (the budget, or the disk) the file is ``full``: every
    later write is refused too (its user recomputes what it did not keep), while what it holds stays readable
    (a pass may be replaying it).
    """

    def __init__(self, budget: SpillBudget, prefix: str):
        self._budget = budget
        self._prefix = prefix
        self._f = None
        self.size = 0
        self.full = False

    def write(self, arrays) -> list | None:
        """Append ``arrays`` (a sequence of arrays or None); their places for ``read``, or None when refused."""
        if self.full:
            return None
        arrays = [None if a is None else np.ascontiguousarray(a) for a in arrays]
        nbytes = sum(a.nbytes for a in arrays if a is not None)
        if not self._budget.allows(nbytes):
            self.full = True
            return None
        places, pos = [], self.size
        try:
            if self._f is None:
                self._f = tempfile.TemporaryFile(prefix=self._prefix, dir=self._budget.folder)
            self._f.seek(pos)
            for a in arrays:
                places.append(None if a is None else (pos, a.dtype, a.shape))
                if a is not None and a.nbytes:
                    self._f.write(memoryview(a).cast("B"))
                    pos += a.nbytes
            self._f.flush()  # a full disk says so here, not at a later read
        except OSError:  # the disk is full (or gone): what was written before stays readable
            self.full = True
            return None
        self.size = pos
        return places

    def read(self, places) -> list:
        """The arrays written at ``places`` (``write``'s), each a new C-contiguous array."""
        out = []
        for p in places:
            if p is None:
                out.append(None)
                continue
            offset, dtype, shape = p
            a = np.empty(shape, dtype)
            if a.nbytes:
                self._f.seek(offset)
                if self._f.readinto(memoryview(a).cast("B")) != a.nbytes:
                    raise OSError(f"a spill file ended early at byte {offset}")
            out.append(a)
        return out

    def close(self) -> None:
        """Close and delete the file (its places are no longer readable); its bytes go back to the budget."""
        self.full = True
        if self._f is not None:
            self._f.close()
            self._f = None
        self.size = 0


class DecodedBlocks:
    """The samples of a run's blocks, decoded and calibrated once, and their saturation bits with the
    clipping rails' computed once (``passes.BlockPasses.read``).

    Parameters
    ----------
    budget : SpillBudget
    blocks : list of (i0, i1)
        The run's blocks (rows i0..i1-1); other windows are neither kept nor looked up. Over one block the
        samples are not spilled (the passes keep that block in memory), only the rails' bits.
    """

    def __init__(self, budget: SpillBudget, blocks: list[tuple[int, int]]):
        self._blocks = set(blocks)
        self._spill_samples = len(blocks) > 1
        self._file = budget.open("bootnav-blocks-")
        self._samples: dict = {}
        self._railed: dict = {}

    def get(self, i0: int, i1: int) -> tuple | None:
        """The block's ``(t, acc, gyro, saturated)`` as ``put`` was given them, or None when not kept."""
        places = self._samples.get((i0, i1))
        return None if places is None else tuple(self._file.read(places))

    def put(self, i0: int, i1: int, samples: tuple) -> None:
        """Keep a block's decoded, calibrated ``(t, acc, gyro, saturated)`` (a window that is not a block, or
        one block alone: nothing)."""
        if self._spill_samples and (i0, i1) in self._blocks and (i0, i1) not in self._samples:
            places = self._file.write(samples)
            if places is not None:
                self._samples[(i0, i1)] = places

    def railed(self, i0: int, i1: int, compute) -> np.ndarray:
        """The saturation bits of rows i0..i1-1 with the rails' (``compute()``), computed once per block."""
        places = self._railed.get((i0, i1))
        if places is not None:
            return self._file.read(places)[0]
        sat = compute()
        if (i0, i1) in self._blocks:
            places = self._file.write([sat])
            if places is not None:
                self._railed[(i0, i1)] = places
        return sat


class StanceSpill:
    """The ``StanceChunk``\\ s of each stance detector stream of a run, spilled as the first pass makes them and
    replayed by the passes after it (``passes.BlockPasses.detector_stream``).

    A stream is replayed only when it was recorded to its end (a pass that stopped early leaves nothing), and
    only for the same key: the detector's settings and fixed noise floor (the rate, gravity, rest bias and the
    blocks pushed are the run's). Every replayed chunk is made of new arrays, so a pass that changes a chunk
    (the fallback's stance) changes nothing in the passes after it.

    Parameters
    ----------
    budget : SpillBudget
    """

    FIELDS = ("t_s", "acc_b", "gyro_b", "stance", "saturated", "statistic", "threshold_log10")

    def __init__(self, budget: SpillBudget):
        self._file = budget.open("bootnav-stance-")
        self._streams: dict = {}  # key: [(start, places)] of a stream recorded to its end

    @staticmethod
    def key(det_settings, noise_floor_log10) -> tuple:
        """A stream's key: the detector settings' values and the fixed noise floor."""
        return json.dumps(det_settings.to_dict(), sort_keys=True, default=repr), noise_floor_log10

    def replay(self, det_settings, noise_floor_log10):
        """The recorded stream's chunks (a generator), or None when there is none."""
        rows = self._streams.get(self.key(det_settings, noise_floor_log10))
        if rows is None:
            return None
        return self._chunks(rows)

    def _chunks(self, rows):
        from .detectors.stream import StanceChunk

        for start, places in rows:
            yield StanceChunk(start, *self._file.read(places))

    def recorder(self, det_settings, noise_floor_log10) -> "StanceRecorder":
        """A recorder of a stream being computed: its ``keep`` spills each chunk before the pass sees it."""
        return StanceRecorder(self, self.key(det_settings, noise_floor_log10))


class StanceRecorder:
    """One detector stream being spilled (``StanceSpill.recorder``)."""

    def __init__(self, spill: StanceSpill, key: tuple):
        self._spill = spill
        self._key = key
        self._rows: list | None = []

    def keep(self, chunks, last: bool = False) -> list:
        """Spill ``chunks`` (a list of StanceChunks, as ``StreamStance.push`` returns) and return them;
        ``last``: the stream's final chunks (``StreamStance.finish``'s), after which it can be replayed."""
        if self._rows is not None:
            for ch in chunks:
                places = self._spill._file.write([getattr(ch, f) for f in StanceSpill.FIELDS])
                if places is None:
                    self._rows = None
                    break
                self._rows.append((ch.start, places))
        if last and self._rows is not None:
            self._spill._streams.setdefault(self._key, self._rows)
        return chunks


class NavRowSpill:
    """The ``NavRows`` of each push of a filter pass, in order, for the final pass to replay
    (``passes.BlockPasses.path_footprints``).

    Parameters
    ----------
    budget : SpillBudget
    in_memory : bool
        Keep the rows in memory (one block: as many rows as the block) instead of a temporary file.

    Attributes
    ----------
    kept : bool
        Every row appended is kept (False once the budget or the disk refused one: recompute).
    """

    def __init__(self, budget: SpillBudget, in_memory: bool):
        self._memory: list | None = [] if in_memory else None
        self._file = None if in_memory else budget.open("bootnav-navrows-")
        self._places: list = []
        self.kept = True

    def append(self, rows) -> None:
        """Keep the rows of one push (``StreamNavigator.push`` or ``finish``)."""
        from dataclasses import fields

        if self._memory is not None:
            self._memory.append(rows)
            return
        if not self.kept:
            return
        names = [f.name for f in fields(rows) if f.name != "start"]
        places = self._file.write([getattr(rows, nm) for nm in names])
        if places is None:  # not replayed: its disk space back at once
            self.kept = False
            self._places = []
            self._file.close()
            return
        self._places.append((rows.start, names, places))

    def __iter__(self):
        """The rows appended, in order (each a new ``NavRows`` read back from the file); the file is closed
        after the last."""
        if self._memory is not None:
            yield from self._memory
            return
        from .ins.stream import NavRows

        for start, names, places in self._places:
            yield NavRows(start, **dict(zip(names, self._file.read(places))))
        self._file.close()


class PassSpills:
    """The spills of one run in passes (``passes.BlockPasses``): its budget, ``samples``
    (``DecodedBlocks``), ``stance`` (``StanceSpill``) and a ``NavRowSpill`` per filter pass (``nav_rows``).

    Parameters
    ----------
    blocks : list of (i0, i1)
        The run's blocks.
    budget : SpillBudget, optional
        Default ``SpillBudget()`` (``SPILL_BUDGET_BYTES``, at most ``FREE_SHARE`` of the free space).
    """

    def __init__(self, blocks: list[tuple[int, int]], budget: SpillBudget | None = None):
        self.budget = SpillBudget() if budget is None else budget
        self._one_block = len(blocks) == 1
        self.samples = DecodedBlocks(self.budget, blocks)
        self.stance = StanceSpill(self.budget)

    def nav_rows(self) -> NavRowSpill:
        """A new spill for the rows of one filter pass (in memory over one block)."""
        return NavRowSpill(self.budget, self._one_block)
