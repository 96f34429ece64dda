"""``bootnav info FILE [--json]``: what is in a recording and how healthy it is.

Everything is computed from the data and the events table (not only from ``/meta``), so it also
works for a file whose recorder was killed before writing its final metadata, and for imported or
simulated recordings. ``FILE`` is what ``bootnav process`` reads: a recording, or any file ``bootnav
import`` reads (e.g. a canonical ``imu.csv.gz``), summarised as the recording ``import`` would write.

The samples are read in blocks of ``BLOCK_ROWS`` rows and their figures accumulated, so memory does not
grow with the length of the recording (a 24 h shift at 200 Hz is 17 M rows). The median step, which
the rate and the gap rule need, is kept exact: the distinct step lengths are counted (a clock quantised
to µs has a few thousand), and gap candidates are kept per block against a bound checked at the end.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

AXES = ("ax", "ay", "az", "gx", "gy", "gz")
#: Rows read at a time: a multiple of the writer's chunk (``recording.CHUNK_ROWS`` = 4096 rows) so no chunk
#: is decompressed twice; about 60 MB of float64 working arrays.
BLOCK_ROWS = 1 << 20
#: Distinct step lengths counted for the exact median; timestamps with more (a float host clock) keep their
#: positive steps instead (8 bytes a sample).
MAX_DISTINCT_STEPS = 1 << 20
#: Gap candidates kept per block; a block with more is read again once the median is known.
MAX_GAP_CANDIDATES = 1 << 16
#: Below these the sensor did not move at all (a still boot still shows > 0.3 rad/s peaks when walking).
STILL_GYRO_RADPS = 0.05
STILL_ACC_STD_MPS2 = 0.05


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", metavar="FILE",
                        help="recording (.h5) or any file `bootnav import` reads (e.g. a canonical imu.csv.gz)")
    parser.add_argument("--json", action="store_true", help="print a machine-readable summary")


def summarize(path, boot=None, *, block_rows: int = BLOCK_ROWS) -> dict:
    """The summary ``bootnav info`` prints (also used by tests and other tools).

    Parameters
    ----------
    path
        A recording, or any other file through ``bootnav import``'s reader, summarised as the recording
        ``import`` would store (written to a temporary file and read back, so ``info FILE`` and ``info`` of
        the imported recording agree). A ``.h5``/``.hdf5`` name is always read as a recording, so a damaged
        recording is reported as such rather than as an unreadable CSV.
    boot
        The boot of a multi-boot recording (``bootnav.logger.recording.boot_labels``).
    block_rows
        Rows read at a time (bounds the memory).

    Returns
    -------
    dict
        Timing, gaps, link errors, saturation, ranges, events, device metadata and data warnings.

    Raises
    ------
    InputError
        As ``bootnav.logger.recording.load``: missing, unreadable or damaged file, unknown boot.
    """
    import tempfile
    from pathlib import Path

    import h5py

    p = Path(path)
    if p.is_file() and p.suffix.lower() not in (".h5", ".hdf5") and not h5py.is_hdf5(p):
        from bootnav.logger.importers import read_any, write_result

        with tempfile.TemporaryDirectory(prefix="bootnav-info-") as tmp:
            return _summarize_recording(write_result(read_any(p), Path(tmp) / "imported.h5"), path, None,
                                        block_rows)
    return _summarize_recording(p, path, boot, block_rows)


def _summarize_recording(path, shown, boot, block_rows: int) -> dict:
    """``summarize`` of a recording file ``path``, reported under the name ``shown``."""
    import numpy as np

    from bootnav.logger.recording import EVENT_DTYPE, _decode, recording_group

    with recording_group(path, boot) as (_, g):
        imu = g["imu"]
        names = [k for k in ("t_s", "acc", "gyro", "saturated", "temp", "t_device", "t_host", "seq") if k in imu]
        n = min(imu[k].shape[0] for k in names)  # a killed writer may leave unequal lengths: the common prefix
        events = g["events"][()] if "events" in g else np.zeros(0, EVENT_DTYPE)
        meta = {k: _decode(v) for k, v in g["meta"].attrs.items()} if "meta" in g else {}
        acc_attrs, gyro_attrs = dict(imu["acc"].attrs), dict(imu["gyro"].attrs)
        has_seq = "seq" in imu
        gyro_present = str(meta.get("gyro_present", 1)) not in ("0", "False")
        steps = _Steps()
        channels = {"acc": _Channel(imu["acc"])} | ({"gyro": _Channel(imu["gyro"])} if gyro_present else {})
        sat_hist = np.zeros(256, np.int64)
        for a in range(0, n, block_rows):
            b = min(a + block_rows, n)
            steps.add(imu["t_s"][a:b].astype(np.float64), a)
            for ch in channels.values():
                if ch.undecided(_moving(channels)):
                    ch.add(a, b)
            if "saturated" in imu:
                sat_hist += np.bincount(imu["saturated"][a:b].astype(np.uint8), minlength=256)
        med = steps.median()
        time_gaps = [{"t_s": float(t), "sample_index": int(i), "missing": int(m)}
                     for i, t, m in zip(*steps.gaps(imu["t_s"], med, n))]
    t_first, t_last = steps.t_first, steps.t_last
    kinds = [k.decode() if isinstance(k, bytes) else str(k) for k in events["kind"]]
    count_of = {k: kinds.count(k) for k in sorted(set(kinds))}
    gap_events = events[events["kind"] == b"gap"]
    if gap_events.size or has_seq:  # sequence numbers: the recorder's gap events are exact
        gaps = [{"t_s": float(e["t_s"]), "sample_index": int(e["sample_index"]), "missing": int(e["count"])}
                for e in gap_events]
        gap_source = "sequence numbers" if has_seq else "events"
        # a device that rebooted at a reconnect counts seq from 0 again: no seq gap, but a hole in time
        counted = {g["sample_index"] for g in gaps}
        restarts = [g for g in time_gaps if g["sample_index"] not in counted]
        if restarts:
            gaps = sorted(gaps + restarts, key=lambda g: g["sample_index"])
            gap_source += f" + timestamps ({len(restarts)} hole(s) across a device restart)"
    else:  # no seq numbers (imported data): gaps from the time stamps
        gaps, gap_source = time_gaps, "timestamps"
    sat_counts = {a: int(sat_hist[(np.arange(256) >> i) & 1 == 1].sum()) for i, a in enumerate(AXES)}

    def range_of(key, channel_attrs, scale_name):
        if meta.get(key) not in (None, ""):
            return float(meta[key])
        fs = float(channel_attrs.get("full_scale", float("nan")))
        if not math.isfinite(fs):
            return float("nan")
        si = fs * float(channel_attrs.get("scale_to_si", 1.0))
        return si / 9.80665 if scale_name == "g" else math.degrees(si)

    summary = {
        "file": str(shown),
        "frames": n,
        "duration_s": float(t_last - t_first) if n > 1 else 0.0,
        "rate_hz": 1.0 / med if steps.count else float("nan"),
        "rate_nominal_hz": _num(meta.get("rate_nominal_hz")),
        "jitter_s": steps.jitter(med),
        "dt_min_s": steps.min(),
        "dt_max_s": steps.max(),
        "gaps": len(gaps),
        "gap_source": gap_source,
        "dropped": int(sum(g["missing"] for g in gaps)),
        "crc_errors": count_of.get("crc_error", 0),
        "resyncs": count_of.get("resync", 0),
        "disconnects": count_of.get("disconnect", 0),
        "reconnects": count_of.get("reconnect", 0),
        "skipped_lines": count_of.get("skipped_line", 0),
        "saturated_samples": sat_counts,
        "saturated_any": int(sat_hist[1:].sum()),
        "accel_range_g": range_of("accel_range_g", acc_attrs, "g"),
        "gyro_range_dps": range_of("gyro_range_dps", gyro_attrs, "dps"),
        "raw_units": {"acc": _text(acc_attrs.get("units")), "gyro": _text(gyro_attrs.get("units"))},
        "events": count_of,
        "device": meta.get("device", ""),
        "device_id": meta.get("device_id", ""),
        "firmware_version": meta.get("firmware_version", ""),
        "mount": meta.get("mount", ""),
        "start_utc": meta.get("start_utc", ""),
        "complete": "stop_reason" in meta or "rate_measured_hz" in meta,
        "data_warnings": _data_warnings(channels, n),
        "gap_list": gaps[:100],
    }
    if boot is not None:  # the boot's place on the session clock (docs/recording-format.md)
        summary.update(boot=boot, start_s=float(t_first) if n else float("nan"),
                       **{k: meta.get(k) for k in ("clock_alignment", "clock_offset_s", "clock_scale",
                                                   "clock_residual_s")})
    return summary


class _Steps:
    """The time steps ``dt[i] = t[i+1] - t[i]``, fed block by block (``add``): the positive finite ones as
    distinct values with counts (exact median, extremes and jitter), and per block the steps above a bound,
    ``GAP_FACTOR`` times the block's own middle step, as gap candidates. Those hold every gap of the block
    when its bound does not exceed ``GAP_FACTOR`` times the recording's median; else ``gaps`` reads the
    block again (a block at a lower rate than the rest)."""

    def __init__(self):
        import numpy as np

        self.values, self.counts = np.zeros(0), np.zeros(0, np.int64)  # distinct positive finite steps, sorted
        self.raw: list | None = None  # the steps themselves, once there are more than MAX_DISTINCT_STEPS distinct
        self.blocks: list = []  # (first step, end step, bound, candidates or None)
        self.t_first = self.t_last = float("nan")

    def add(self, t, start: int) -> None:
        """Rows ``start .. start + len(t)`` of ``t_s`` (float64); blocks come in order."""
        import numpy as np

        from bootnav.core.timebase import GAP_FACTOR

        t_ext = np.concatenate(([self.t_last], t)) if start else t
        first = start - 1 if start else 0  # index of the first step of this block
        if not start and t.size:
            self.t_first = t[0]
        if t.size:
            self.t_last = t[-1]
        dt = np.diff(t_ext)
        pos = dt[np.isfinite(dt) & (dt > 0)]
        v, c = np.unique(pos.view(np.int64), return_counts=True)  # positive floats sort as their bits, faster
        v = v.view(np.float64)
        bound = GAP_FACTOR * _kth(v, np.cumsum(c), (pos.size - 1) // 2) if pos.size else float("nan")
        idx = np.flatnonzero(dt > bound)
        cand = (first + idx, t_ext[idx + 1], dt[idx]) if idx.size <= MAX_GAP_CANDIDATES else None
        self.blocks.append((first, first + dt.size, bound, cand))
        if self.raw is not None:
            self.raw.append(pos)
            return
        u, inv = np.unique(np.concatenate((self.values, v)), return_inverse=True)
        self.values, self.counts = u, np.bincount(inv, weights=np.concatenate((self.counts, c))).astype(np.int64)
        if u.size > MAX_DISTINCT_STEPS:
            self.raw, self.values, self.counts = [np.repeat(u, self.counts)], np.zeros(0), np.zeros(0, np.int64)

    @property
    def count(self) -> int:
        return sum(x.size for x in self.raw) if self.raw is not None else int(self.counts.sum())

    def median(self) -> float:
        """``timebase.nominal_period`` of all steps: NaN without a positive step."""
        import numpy as np

        from bootnav.core.timebase import nominal_period

        if self.raw is not None:
            return nominal_period(np.concatenate(self.raw))
        p, cum = int(self.counts.sum()), np.cumsum(self.counts)
        if p == 0:
            return float("nan")
        if p % 2:
            return float(_kth(self.values, cum, (p - 1) // 2))
        return float((_kth(self.values, cum, p // 2 - 1) + _kth(self.values, cum, p // 2)) / 2)

    def jitter(self, med: float) -> float:
        """``timebase.timing_summary``'s jitter: std of the positive steps below ``GAP_FACTOR * med``."""
        import numpy as np

        from bootnav.core.timebase import GAP_FACTOR

        if self.count == 0:
            return float("nan")
        if self.raw is not None:
            x = np.concatenate(self.raw)
            return float(np.std(x[x < GAP_FACTOR * med]))
        keep = self.values < GAP_FACTOR * med
        v, c = self.values[keep], self.counts[keep]
        mean = float((v * c).sum() / c.sum())
        return float(np.sqrt((c * (v - mean) ** 2).sum() / c.sum()))

    def min(self) -> float:
        if self.count == 0:
            return float("nan")
        return float(min(x.min() for x in self.raw if x.size)) if self.raw is not None else float(self.values[0])

    def max(self) -> float:
        if self.count == 0:
            return float("nan")
        return float(max(x.max() for x in self.raw if x.size)) if self.raw is not None else float(self.values[-1])

    def gaps(self, t_ds, med: float, n: int):
        """Sample index, time and missing samples of every gap (``timebase.gap_mask``) given the median."""
        import numpy as np

        from bootnav.core.timebase import GAP_FACTOR, gap_mask, missing_samples

        parts = []
        for first, end, bound, cand in self.blocks if math.isfinite(med) else []:
            if cand is None or not bound <= GAP_FACTOR * med:  # candidates may miss a gap: read the block again
                t = t_ds[first:min(end + 1, n)].astype(np.float64)
                cand = (first + np.arange(t.size - 1), t[1:], np.diff(t))
            keep = gap_mask(cand[2], med)
            parts.append((cand[0][keep] + 1, cand[1][keep], missing_samples(cand[2][keep], med)))
        if not parts:
            return (), (), ()
        return tuple(np.concatenate(x) for x in zip(*parts))


def _kth(values, cum_counts, k: int):
    """The ``k``-th smallest (0-based) of values repeated by counts, given their cumulative counts."""
    return values[cum_counts.searchsorted(k, side="right")]


class _Channel:
    """An (N, 3) sensor dataset read block by block in SI units (as ``recording.load`` scales it): non-finite
    rows, whether any finite value is non-zero, per-axis std (Chan's parallel update) and largest |value|.

    Only blocks that can still change a warning are read (``undecided``): integer counts cannot be non-finite,
    so a walking recording stored as counts is settled by its first block."""

    def __init__(self, ds):
        import numpy as np

        self.ds = ds
        self.scale = float(ds.attrs.get("scale_to_si", 1.0))
        self.offset = float(ds.attrs.get("offset_to_si", 0.0))
        self.nonfinite, self.first_bad = 0, -1
        self.any_finite = self.any_nonzero = False
        self.n, self.mean, self.m2, self.absmax = 0, np.zeros(3), np.zeros(3), 0.0

    def undecided(self, moving: bool) -> bool:
        """Whether the next block can still change a figure ``_data_warnings`` uses (``moving``: the gyro has
        shown motion, so the no-motion check is decided)."""
        return self.ds.dtype.kind == "f" or not self.any_nonzero or not moving

    def add(self, a: int, b: int) -> None:
        import numpy as np

        x = self.ds[a:b].astype(np.float64) * self.scale + self.offset
        finite = x
        if self.ds.dtype.kind == "f":  # integer counts times a finite scale cannot be non-finite
            ok = np.isfinite(x)
            bad = ~np.all(ok, axis=1)
            if bad.any():
                self.first_bad = a + int(np.argmax(bad)) if self.first_bad < 0 else self.first_bad
                self.nonfinite += int(bad.sum())
                finite = x[ok]
        self.any_finite |= bool(finite.size)
        self.any_nonzero |= bool(np.any(finite != 0))
        if self.nonfinite or not x.size:
            return
        nb, mean_b = x.shape[0], x.mean(axis=0)
        delta, tot = mean_b - self.mean, self.n + nb
        self.m2 += ((x - mean_b) ** 2).sum(axis=0) + delta ** 2 * self.n * nb / tot
        self.mean += delta * nb / tot
        self.n = tot
        self.absmax = max(self.absmax, float(np.abs(x).max()))

    def std(self):
        return (self.m2 / self.n) ** 0.5


def _moving(channels: dict) -> bool:
    """The gyro (when present) has exceeded the no-motion bound in the blocks read so far."""
    return "gyro" in channels and channels["gyro"].absmax >= STILL_GYRO_RADPS


def _data_warnings(channels: dict, n: int) -> list[str]:
    """What makes a recording useless or suspicious though it opens: non-finite samples, all-zero
    channels, no motion at all. Empty when nothing is wrong."""
    out = []
    for name, ch in channels.items():
        if ch.nonfinite:
            out.append(f"{name}: {ch.nonfinite} non-finite samples (first at sample {ch.first_bad})")
        if ch.any_finite and not ch.any_nonzero:
            out.append(f"{name}: all zero (sensor not delivering data?)")
    if n > 1 and not out and not _moving(channels) and channels["acc"].std().max() < STILL_ACC_STD_MPS2:
        out.append("no motion: the sensor stayed still for the whole recording")
    return out


def _fmt(value) -> str:
    return f"{value:g}" if isinstance(value, float) and math.isfinite(value) else "?"


def _num(value):
    try:
        return float(value)
    except (TypeError, ValueError):
        return float("nan")


def _text(value):
    return value.decode() if isinstance(value, bytes) else ("" if value is None else str(value))


def run(args) -> int:
    labels = _boot_labels(args.file)
    s = {"file": str(args.file), "boots": {b: summarize(args.file, b) for b in labels}} if labels \
        else summarize(args.file)
    if args.json:
        from bootnav.core.jsonio import to_jsonable

        print(json.dumps(to_jsonable(s), indent=1, allow_nan=False))
        return 0
    if labels:
        print(f"{args.file}: multi-boot recording, boots {', '.join(labels)} on one session clock")
        for b, sb in s["boots"].items():
            lines = _lines(sb)
            lines[0] = f"boot {b}"
            fitted = str(sb["clock_alignment"]) == "host-receive"  # recorder: rate and residual of the fit
            lines.insert(1, f"  clock       {sb['clock_alignment'] or '?'}: starts at {_fmt(sb['start_s'])} s"
                            + (f", device clock {(1 / _num(sb['clock_scale']) - 1) * 1e6:+.1f} ppm, residual "
                               f"{_fmt(round(_num(sb['clock_residual_s']) * 1e3, 2))} ms" if fitted else ""))
            print("\n".join(lines))
        return 0
    print("\n".join(_lines(s)), file=sys.stdout)
    return 0


def _boot_labels(path) -> list[str]:
    """Labels of a multi-boot recording, [] for anything else (which ``summarize`` reports on)."""
    import h5py

    from bootnav.logger.recording import boot_labels

    try:
        return boot_labels(path) if h5py.is_hdf5(path) else []
    except (OSError, TypeError):
        return []


def _lines(s: dict) -> list[str]:
    """The text ``bootnav info`` prints for one recording (or one boot)."""
    sat = ", ".join(f"{a} {c}" for a, c in s["saturated_samples"].items() if c) or "none"
    lines = [
        f"{s['file']}",
        f"  device      {s['device'] or '?'} id {s['device_id'] or '?'} fw {s['firmware_version'] or '?'}"
        f"  mount {s['mount'] or '?'}  start {s['start_utc'] or '?'}",
        f"  samples     {s['frames']} over {s['duration_s']:.3f} s",
        f"  rate        {s['rate_hz']:.3f} Hz (nominal {_fmt(s['rate_nominal_hz'])}), jitter {s['jitter_s'] * 1e6:.1f} µs,"
        f" dt {s['dt_min_s'] * 1e3:.3f}..{s['dt_max_s'] * 1e3:.3f} ms",
        f"  ranges      ±{_fmt(s['accel_range_g'])} g, ±{_fmt(s['gyro_range_dps'])} °/s (raw units"
        f" {s['raw_units']['acc']}, {s['raw_units']['gyro']})",
        f"  gaps        {s['gaps']} ({s['dropped']} samples missing, from {s['gap_source']})",
        f"  link        {s['crc_errors']} CRC errors, {s['resyncs']} resyncs, {s['disconnects']} disconnects,"
        f" {s['reconnects']} reconnects, {s['skipped_lines']} skipped lines",
        f"  saturation  {sat}",
        f"  events      {', '.join(f'{k} {v}' for k, v in s['events'].items()) or 'none'}",
    ]
    for w in s["data_warnings"]:
        lines.append(f"  WARNING     {w}")
    if not s["complete"]:
        lines.append("  note        no final metadata: the writer did not close (crash or still recording)")
    return lines
