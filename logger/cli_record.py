"""``bootnav record``: serial port -> HDF5 recording (see ``bootnav.logger.serial_recorder``)."""

from __future__ import annotations

import argparse
import math
import signal
import sys

#: Serial rates a UART/USB adapter can plausibly run (the CH340/FT232 of a Nano tops out at 3-4 Mbaud).
MIN_BAUD, MAX_BAUD = 300, 4_000_000


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--port", required=True, action="append",
                        help="serial port or pyserial URL: /dev/ttyUSB0, a pty path from `bootnav emulate`, loop://; "
                             "twice (--port A --port B) records two boots into one multi-boot recording")
    parser.add_argument("--label", action="append", default=None,
                        help="boot label of each --port, in order (default with two ports: left, right); "
                             "the mount becomes LABEL_boot")
    parser.add_argument("--baud", type=int, default=None,
                        help="baud rate (default 500000: carries 1 kHz; see firmware-protocol/PROTOCOL.md)")
    parser.add_argument("--out", required=True, metavar="FILE.h5", help="recording to create")
    parser.add_argument("--force", action="store_true",
                        help="replace --out if it is an existing recording (never a file that is not HDF5)")
    parser.add_argument("--duration", type=float, default=None, metavar="S",
                        help="stop after S seconds (default: until Ctrl-C / SIGTERM)")
    parser.add_argument("--flush-interval", type=float, default=None, metavar="S",
                        help="write to disk at least every S s; a crash loses at most this much (default 0.5 s)")
    parser.add_argument("--header-wait", type=float, default=None, metavar="S",
                        help="wait S s for the sensor's header frame before assuming ±16 g / ±2000 °/s (default 1.5 s)")
    parser.add_argument("--connect-timeout", type=float, default=None, metavar="S",
                        help="give up if the port cannot be opened at start within S seconds (default 10 s)")
    parser.add_argument("--mount", default="", help="where the sensor sits, e.g. left_boot, right_boot (one port)")
    parser.add_argument("--subject", default="", help="who wears the boot (a name or code), stored in /meta")
    parser.add_argument("--notes", default="", help="free-text session notes stored in /meta")


#: The firmware's output rate (firmware-protocol/PROTOCOL.md: 1 kHz / (1 + SMPLRT_DIV 4)), for the space estimate.
NOMINAL_RATE_HZ = 200.0
#: Below this many minutes of free space ``record`` warns at start (a walk-through drill lasts 10-30 min).
WARN_MINUTES = 10.0


def check_free_space(out, n_boots: int = 1, quiet: bool = False) -> float:
    """Say at start how many minutes of recording the free space holds; refuse when not even a new file fits.

    Returns the minutes (uncompressed rows at ``NOMINAL_RATE_HZ`` per boot: a lower bound, gzip typically
    doubles it). The recorder itself stops cleanly at the last flush that fits (``RecordingWriter.room_for``).
    """
    from pathlib import Path

    from bootnav.errors import DiskFullError
    from bootnav.logger.recording import MIN_FREE_BYTES, free_bytes, minutes_that_fit

    out = Path(out)
    free = free_bytes(out)
    if free < MIN_FREE_BYTES:
        raise DiskFullError(f"--out {out}: only {free / 1024:.0f} KB free there (the file-size limit or the disk), "
                            f"less than a new recording needs ({MIN_FREE_BYTES >> 10} KB); free some space or "
                            "record elsewhere")
    minutes = minutes_that_fit(out, NOMINAL_RATE_HZ * n_boots)
    if minutes < WARN_MINUTES:
        print(f"bootnav record: warning: only {free / 1e6:.2f} MB free at {out.parent.resolve()}: about "
              f"{minutes:.1f} min of recording at {NOMINAL_RATE_HZ:g} Hz x {n_boots} boot(s) fit; the recording stops "
              "cleanly (readable, everything up to the last flush kept) when the disk is full", file=sys.stderr)
    elif not quiet:
        print(f"bootnav record: {free / 1e9:.1f} GB free: about {minutes / 60:.0f} h of recording fit",
              file=sys.stderr)
    return minutes


def given_knobs(args) -> dict:
    """The recorder knobs given on the command line; the others keep ``RecorderSettings``' defaults (the one
    place of each default: the numbers in the help texts are checked against it, ``tests/test_one_default.py``)."""
    knobs = (("baud", "baud"), ("flush_interval_s", "flush_interval"), ("header_wait_s", "header_wait"),
             ("connect_timeout_s", "connect_timeout"))
    return {field: getattr(args, attr) for field, attr in knobs if getattr(args, attr, None) is not None}


def run(args) -> int:
    import os
    from pathlib import Path

    from bootnav.core.paths import output_file
    from bootnav.errors import BootnavError
    from bootnav.logger.serial_recorder import RecorderSettings, SerialRecorder

    out = Path(args.out)
    if args.baud is not None and not MIN_BAUD <= args.baud <= MAX_BAUD:
        raise BootnavError(f"--baud {args.baud}: outside {MIN_BAUD}..{MAX_BAUD}; the sensor's rate is 500000 "
                           "(see firmware-protocol/PROTOCOL.md)")
    for flag, value in (("--flush-interval", args.flush_interval), ("--header-wait", args.header_wait),
                        ("--connect-timeout", args.connect_timeout), ("--duration", args.duration)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise BootnavError(f"{flag} {value}: must be a positive number of seconds")
    from bootnav.core.limits import check_duration

    check_duration("--duration", args.duration)
    # never lose a session by re-running a command, never turn a user's other file into a recording
    output_file(out, force=args.force, hdf5=True)
    check_free_space(out, len(args.port), quiet=args.quiet)

    if len(args.port) > 1 or args.label:
        return _run_multi(args)
    settings = RecorderSettings(port=args.port[0], out=args.out, duration_s=args.duration, mount=args.mount,
                                subject=args.subject, session_notes=args.notes, **given_knobs(args))
    recorder = SerialRecorder(settings, status_stream=None if args.quiet else sys.stderr)
    stats = _run_until_stopped(recorder)
    if not recorder.wrote_file:
        if stats.bytes_in:
            raise BootnavError(f"no valid frame in {stats.bytes_in} bytes from {args.port} (wrong --baud, or not "
                               f"a bootnav sensor?); {args.out} not written")
        raise BootnavError(f"no data received from {args.port} ({stats.stop_reason}); {args.out} not written")
    print(f"{args.out}: {stats.frames} frames, {stats.dropped} dropped, {stats.crc_errors} CRC errors, "
          f"{stats.resyncs} resyncs, {stats.disconnects} disconnects ({stats.stop_reason})", file=sys.stderr)
    return 0


def _run_until_stopped(recorder):
    """Run a recorder until its end; SIGTERM and Ctrl-C end the loop cleanly (the pending block is written
    and the file closed); a full disk is raised after the file is closed. Returns the recorder's stats."""
    signal.signal(signal.SIGTERM, lambda *_: recorder.stop("SIGTERM"))
    signal.signal(signal.SIGINT, lambda *_: recorder.stop("interrupted (Ctrl-C)"))
    stats = recorder.run()
    if recorder.disk_full is not None:
        raise recorder.disk_full
    return stats


def _run_multi(args) -> int:
    """Two (or more) ports into one multi-boot recording (``MultiBootRecorder``)."""
    from bootnav.errors import BootnavError
    from bootnav.logger.recording import check_boot_label
    from bootnav.logger.serial_recorder import MultiBootRecorder, MultiRecorderSettings

    ports = args.port
    if len(ports) < 2:
        raise BootnavError("--label names the boots of a multi-boot recording: give two --port (one sensor: "
                           "--mount left_boot)")
    labels = args.label or (["left", "right"] if len(ports) == 2 else [])
    if len(labels) != len(ports):
        raise BootnavError(f"{len(ports)} --port but {len(labels)} --label: give one --label per --port "
                           "(default only for two ports: left, right)")
    if len(set(labels)) != len(labels) or len(set(ports)) != len(ports):
        raise BootnavError(f"--label {labels} / --port {ports}: each boot needs its own label and port")
    for label in labels:
        check_boot_label(label)
    if args.mount:
        raise BootnavError("--mount names one sensor; with several ports the mount of each is LABEL_boot "
                           "(choose the labels with --label)")
    settings = MultiRecorderSettings(
        ports=ports, labels=labels, out=args.out, duration_s=args.duration, **given_knobs(args),
        mounts=[f"{label}_boot" for label in labels], subject=args.subject, session_notes=args.notes)
    recorder = MultiBootRecorder(settings, status_stream=None if args.quiet else sys.stderr)
    all_stats = _run_until_stopped(recorder)
    if not recorder.wrote_file:
        got = sum(st.bytes_in for st in all_stats)
        raise BootnavError((f"no valid frame in {got} bytes from {', '.join(ports)} (wrong --baud?)" if got else
                            f"no data received from {', '.join(ports)} ({recorder.stop_reason})")
                           + f"; {args.out} not written")
    for label, port, st in zip(labels, ports, all_stats):
        clock = recorder.clock.get(label, {})
        align = (f", clock residual {clock['clock_residual_s'] * 1e3:.2f} ms, device clock rate "
                 f"error {(1 / clock['clock_scale'] - 1) * 1e6:+.0f} ppm" if clock else ", no sample")
        print(f"{args.out} [{label} {port}]: {st.frames} frames, {st.dropped} dropped, {st.crc_errors} CRC errors, "
              f"{st.resyncs} resyncs, {st.disconnects} disconnects{align}", file=sys.stderr)
    print(f"{args.out}: {recorder.stop_reason}", file=sys.stderr)
    return 0
