"""``bootnav info FILE [--json]``: what is in a recording and how healthy it is.

Everything is computed from the data and the events table (not only from ``/meta``), so it also
works for a file whose recorder was killed before writing its final metadata, and for imported or
simulated recordings. ``FILE`` is what ``bootnav process`` reads: a recording, or any file ``bootnav
import`` reads (e.g. a canonical ``imu.csv.gz``), summarised as the recording ``import`` would write.

A recording closed by its writer carries the figures of its samples (``imu`` attribute ``summary``,
``bootnav.logger.samplestats``), used when they describe exactly the rows in the file. Otherwise (a writer
that died, an older file) the samples are read in blocks of ``BLOCK_ROWS`` rows and the same figures
accumulated, so memory does not grow with the length of the recording (a 24 h shift at 200 Hz is 17 M
rows). The median step, which the rate and the gap rule need, is kept exact: the distinct step lengths are
counted (a clock quantised to µs has a few thousand), and gap candidates are kept per block against a
bound checked at the end.
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
        from bootnav.logger.importers import import_file

        with tempfile.TemporaryDirectory(prefix="bootnav-info-") as tmp:  # a canonical CSV streams (bounded memory)
            return _summarize_recording(import_file(p, Path(tmp) / "imported.h5"), path, None, block_rows)
    return _summarize_recording(p, path, boot, block_rows)


def _summarize_recording(path, shown, boot, block_rows: int) -> dict:
    """``summarize`` of a recording file ``path``, reported under the name ``shown``."""
    import numpy as np

    from bootnav.logger.recording import RecordingReader, read_errors, si_factors
    from bootnav.logger.mpu6050 import STANDARD_GRAVITY

    with RecordingReader(path, boot) as r, read_errors(path):
        lengths = r.lengths
        n = min(lengths.values())  # a killed writer may leave unequal lengths: the common prefix
        file_warnings = []
        if len(set(lengths.values())) > 1:
            file_warnings.append("the datasets of /imu have different lengths (" + ", ".join(
                f"{k} {v}" for k, v in lengths.items()) + f"): only the first {n} rows, common to all, are used; "
                "a writer was killed or the file was edited")
        unit_warnings = _unit_warnings(r, n)
        events = r.events()
        meta = r.meta
        acc_attrs, gyro_attrs = r.stored_attrs("acc"), r.stored_attrs("gyro")
        has_seq = "seq" in lengths
        gyro_present = str(meta.get("gyro_present", 1)) not in ("0", "False")
        si = {"acc": si_factors(acc_attrs), "gyro": si_factors(gyro_attrs)}
        stored = r.stored_summary(n) if all(o == 0.0 for _, o in si.values()) else None
        fig = _Figures.of_summary(stored, si, gyro_present) if stored else _scan(r, n, si, gyro_present, block_rows)
    med = fig.median
    time_gaps = [{"t_s": float(t), "sample_index": int(i), "missing": int(m)} for i, t, m in fig.time_gaps]
    channels, sat_hist = fig.channels, fig.sat_hist
    t_first, t_last = fig.t_first, fig.t_last
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
        si = fs * si_factors(channel_attrs)[0]
        return si / STANDARD_GRAVITY if scale_name == "g" else math.degrees(si)

    summary = {
        "file": str(shown),
        "frames": n,
        "duration_s": float(t_last - t_first) if n > 1 else 0.0,
        "rate_hz": 1.0 / med if fig.count else float("nan"),
        "rate_nominal_hz": _num(meta.get("rate_nominal_hz")),
        "jitter_s": fig.jitter,
        "dt_min_s": fig.dt_min,
        "dt_max_s": fig.dt_max,
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
        "raw_units": {"acc": _text(acc_attrs.get("raw_units", acc_attrs.get("units"))),  # format 1: `units` was raw
                      "gyro": _text(gyro_attrs.get("raw_units", gyro_attrs.get("units")))},
        "events": count_of,
        "device": meta.get("device", ""),
        "device_id": meta.get("device_id", ""),
        "calibration": calibration_line(meta.get("device_id")),
        "firmware_version": meta.get("firmware_version", ""),
        "mount": meta.get("mount", ""),
        "start_utc": meta.get("start_utc", ""),
        "complete": "stop_reason" in meta or "rate_measured_hz" in meta,
        "data_warnings": file_warnings + _data_warnings(channels, n) + _cut_warnings(events),
        "unit_warnings": unit_warnings,
        "gap_list": gaps[:100],
    }
    if boot is not None:  # the boot's place on the session clock (docs/recording-format.md)
        summary.update(boot=boot, start_s=float(t_first) if n else float("nan"),
                       **{k: meta.get(k) for k in ("clock_alignment", "clock_offset_s", "clock_scale",
                                                   "clock_residual_s")})
    return summary


class _Figures:
    """What ``info`` reports of the samples: timing, gaps from the time stamps, saturation histogram and the
    acc/gyro ``ChannelStats``, from a writer's summary or a scan."""

    def __init__(self, t_first, t_last, count, median, jitter, dt_min, dt_max, time_gaps, sat_hist, channels):
        self.t_first, self.t_last, self.count, self.median = t_first, t_last, count, median
        self.jitter, self.dt_min, self.dt_max = jitter, dt_min, dt_max
        self.time_gaps, self.sat_hist, self.channels = time_gaps, sat_hist, channels

    @classmethod
    def of_summary(cls, s: dict, si: dict, gyro_present: bool) -> "_Figures":
        """From the ``summary`` a writer stored (``samplestats.SampleStats.summary``)."""
        import numpy as np

        from bootnav.logger.samplestats import ChannelStats

        channels = {k: ChannelStats.from_state(s["channels"][k], si[k][0])
                    for k in (("acc", "gyro") if gyro_present else ("acc",))}
        return cls(s["t_first"], s["t_last"], s["step_count"], s["dt_median_s"], s["jitter_s"], s["dt_min_s"],
                   s["dt_max_s"], [tuple(x) for x in s["time_gaps"]], np.asarray(s["saturated_hist"], np.int64),
                   channels)


def _scan(r, n: int, si: dict, gyro_present: bool, block_rows: int) -> _Figures:
    """``_Figures`` of the first ``n`` rows of the recording read by ``r`` (a ``RecordingReader``), in blocks
    of ``block_rows``.

    A channel's block is read only while it can still change a warning: integer counts cannot be non-finite,
    so a walking recording stored as counts is settled by its first block."""
    import numpy as np

    from bootnav.logger.samplestats import ChannelStats, StepStats

    steps = StepStats()
    channels = {"acc": ChannelStats()} | ({"gyro": ChannelStats()} if gyro_present else {})
    sat_hist = np.zeros(256, np.int64)
    has_sat = "saturated" in r.lengths
    for a in range(0, n, block_rows):
        b = min(a + block_rows, n)
        steps.add(r.times(a, b))
        moving = _moving(channels)
        for name, ch in channels.items():
            if r.stored_kind(name) == "f" or not ch.any_nonzero or not moving:
                ch.add(r.stored(name, a, b), a, *si[name])
        if has_sat:
            sat_hist += np.bincount(r.stored("saturated", a, b).astype(np.uint8), minlength=256)
    med = steps.median()
    gaps = list(zip(*steps.gaps(_TimeRows(r), med, n)))
    return _Figures(steps.t_first, steps.t_last, steps.count, med, steps.jitter(med), steps.min(), steps.max(),
                    gaps, sat_hist, channels)


class _TimeRows:
    """``t_s`` of a ``RecordingReader`` indexed by a slice, as ``StepStats.gaps`` reads it."""

    def __init__(self, reader):
        self.reader = reader

    def __getitem__(self, sl: slice):
        return self.reader.times(sl.start, sl.stop)


def _unit_warnings(r, n: int) -> list[str]:
    """The recording loader's unit check (``recording.unit_problems``) on the first rows, as warnings: info
    shows such a file, ``process`` refuses it."""
    import numpy as np

    from bootnav.logger.recording import UNIT_CHECK_ROWS, unit_problems

    k = min(n, UNIT_CHECK_ROWS)
    if k < 2:
        return []
    t, acc, gyro, _ = r.block(0, k)
    dt = np.diff(t)
    dt = dt[np.isfinite(dt) & (dt > 0)]
    rate = 1.0 / float(np.median(dt)) if dt.size else float("nan")
    return [f"units: {p}; `bootnav process` refuses this file until scale_to_si is fixed"
            for p in unit_problems(acc, gyro, rate)]


def _cut_warnings(events) -> list[str]:
    """A source cut short (a gzip stream or a file that ends mid-line): only the lines before the cut were read."""
    out = []
    for e in events:
        detail = e["detail"].decode("utf-8", "replace") if isinstance(e["detail"], bytes) else str(e["detail"])
        if any(w in detail for w in ("cut off", "truncated", "damaged gzip")):
            line = int(e["line"]) if int(e["line"]) >= 0 else None
            out.append(f"the source file is cut short or damaged ({detail}): only what precedes the damage"
                       + (f" (line {line})" if line else "") + " was read; copy the file again from its source")
            break
    return out


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
    for w in s["data_warnings"] + s.get("unit_warnings", []):
        print(f"bootnav info: warning: {w}", file=sys.stderr)
    return 0


def _boot_labels(path) -> list[str]:
    """Labels of a multi-boot recording, [] for anything else (which ``summarize`` reports on)."""
    import h5py

    from bootnav.logger.recording import boot_labels

    try:
        return boot_labels(path) if h5py.is_hdf5(path) else []
    except (OSError, TypeError):
        return []


def calibration_line(device_id) -> str:
    """Whether a stored sensor calibration applies to this device when it is processed (what `bootnav process`
    resolves by default; ``bootnav.core.sensorcal.find_calibration``)."""
    from bootnav.core.sensorcal import find_calibration, normalize_device_id, store_dir
    from bootnav.errors import InputError

    try:
        dev = normalize_device_id(device_id)
    except (ValueError, TypeError):
        dev = None
    if dev is None:
        return "none applies: the recording has no device id (process --calibration FILE to give one)"
    try:
        cal = find_calibration(dev)
    except InputError as exc:
        return f"none applies: the stored calibration of {dev} is unreadable ({exc})"
    if cal is None:
        return f"none stored for device {dev} in {store_dir()} (run `bootnav calibrate`)"
    return f"{cal.source} applies (device {dev}, created {cal.created_utc or '?'})"


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
    if s.get("calibration"):
        lines.append(f"  calibration {s['calibration']}")
    for w in s["data_warnings"] + s.get("unit_warnings", []):
        lines.append(f"  WARNING     {w}")
    if not s["complete"]:
        lines.append("  note        no final metadata: the writer did not close (crash or still recording)")
    return lines
