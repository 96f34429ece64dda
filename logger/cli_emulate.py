"""``bootnav emulate``: a fake boot sensor on a pseudo-terminal (see ``bootnav.logger.emulator``)."""

from __future__ import annotations

import argparse
import math
import signal
import sys


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out-link", required=True, metavar="PATH", action="append",
                        help="symlink to create for the pty (open this path with `bootnav record --port`); "
                             "twice for two boots, each on its own pty with its own device clock")
    parser.add_argument("--source", default="synthetic", metavar="FILE|synthetic",
                        help="HDF5 recording to stream (int16 counts, or SI quantised with its ranges), "
                             "or 'synthetic' (default)")
    parser.add_argument("--duration", type=float, default=None, metavar="S",
                        help="seconds of device time to stream (default: the source once; synthetic 10 s)")
    parser.add_argument("--rate", type=float, default=None, metavar="HZ",
                        help="frame rate (default: the source's rate; synthetic 200 Hz)")
    parser.add_argument("--corrupt", default="0", metavar="RATE[,RATE]",
                        help="probability per frame of one fault: bit flip, garbage bytes or dropped frame "
                             "(one per --out-link, or one for all)")
    parser.add_argument("--corrupt-kinds", default="bitflip,garbage,drop",
                        help="comma-separated subset of bitflip,garbage,drop (default: all)")
    parser.add_argument("--disconnect-at", type=float, default=None, metavar="S",
                        help="close the port S seconds into the stream and recreate it after --disconnect-pause "
                             "(default: none)")
    parser.add_argument("--disconnect-pause", type=float, default=1.0, metavar="S",
                        help="how long the port stays away (default 1 s)")
    parser.add_argument("--restart-on-reconnect", action="store_true",
                        help="the device reboots when the port comes back (as a Nano does on DTR): "
                             "seq and t_us start again from --seq0/--t0-us")
    parser.add_argument("--replay-timing", action="store_true",
                        help="send the source's own seq and device timestamps (its gaps and jitter), paced by them")
    parser.add_argument("--no-wait", action="store_true",
                        help="stream at once instead of waiting for the host's first byte")
    parser.add_argument("--host-timeout", type=float, default=30.0, metavar="S",
                        help="give up if no host opens the port within S seconds (default 30)")
    parser.add_argument("--write-timeout", type=float, default=5.0, metavar="S",
                        help="give up if the host reads nothing for S seconds (default 5)")
    parser.add_argument("--linger", type=float, default=1.0, metavar="S",
                        help="keep the port open S seconds after the last frame (default 1 s)")
    parser.add_argument("--clock-ppm", default=None, metavar="PPM[,PPM]",
                        help="rate error of each device clock in ppm (default 0; two boots: -40,60)")
    parser.add_argument("--start-delay", default=None, metavar="S[,S]",
                        help="each device starts streaming S s after its host connects (default 0; two boots: 0,0.25)")
    parser.add_argument("--seq0", type=int, default=0, help="first sequence number, a count 0..65535 (default 0)")
    parser.add_argument("--t0-us", type=int, default=0, help="first device time in µs (0..2**32-1; default 0); a second "
                        "boot's clock starts 123456789 µs later")
    parser.add_argument("--accel-fs", type=int, choices=range(4), default=3,
                        help="AFS_SEL code of the synthetic signal (default 3 = ±16 g; a --source file declares its own)")
    parser.add_argument("--gyro-fs", type=int, choices=range(4), default=3,
                        help="FS_SEL code of the synthetic signal (default 3 = ±2000 °/s; a --source file declares its own)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the synthetic signal and the fault plan (default 0)")
    parser.add_argument("--report", default=None, metavar="FILE.json",
                        help="write what was sent (frames_sent, frames_corrupted, valid_seqs, ...)")


def check_link_free(link: str, source: str | None = None) -> None:
    """Refuse an ``--out-link`` that names an existing file or folder: the link would replace it and be removed on
    exit (a recording given there by mistake would be lost). Only a stale link of an earlier emulator (a symlink to a
    pseudo-terminal) may be replaced."""
    import os
    from pathlib import Path

    from bootnav.core.paths import same_path, writable_folder
    from bootnav.errors import InputError

    p = Path(link)
    if source and source != "synthetic" and same_path(p, source):
        raise InputError(f"--out-link {p} is the --source file; give a new name for the link, e.g. /tmp/bootnav-boot")
    if p.is_symlink() and os.readlink(p).startswith("/dev/pts/") and not p.exists():
        return  # a dead pty's link left by an emulator killed with kill -9
    if p.exists() or p.is_symlink():
        raise InputError(f"--out-link {p} exists; the emulator never replaces a file: give a new name for the link, "
                         "e.g. /tmp/bootnav-boot")
    writable_folder(p.parent, "--out-link")


def run(args) -> int:
    from pathlib import Path

    from bootnav.errors import BootnavError
    from bootnav.logger.emulator import FAULT_KINDS, Emulator, EmulatorSettings

    kinds = tuple(k for k in args.corrupt_kinds.split(",") if k)
    bad = [k for k in kinds if k not in FAULT_KINDS]
    if bad:
        raise BootnavError(f"--corrupt-kinds: unknown {bad}; choose from {','.join(FAULT_KINDS)}")
    corrupt = _per_boot(args.corrupt, "--corrupt", len(args.out_link), [0.0], non_negative=True)
    if not all(c <= 1.0 for c in corrupt):
        raise BootnavError(f"--corrupt must be a probability in [0, 1], got {args.corrupt}")
    for flag, value, zero_ok in (("--rate", args.rate, False), ("--duration", args.duration, False),
                                 ("--disconnect-at", args.disconnect_at, True),
                                 ("--disconnect-pause", args.disconnect_pause, True),
                                 ("--host-timeout", args.host_timeout, False),
                                 ("--write-timeout", args.write_timeout, False), ("--linger", args.linger, True)):
        if value is not None and not (math.isfinite(value) and (value >= 0 if zero_ok else value > 0)):
            raise BootnavError(f"{flag} {value}: must be a {'non-negative' if zero_ok else 'positive'} number")
    links = args.out_link
    for link in links:
        check_link_free(link, args.source)
    if len(links) > 1:
        return _run_multi(args, kinds, corrupt)
    if args.source != "synthetic":
        from bootnav.logger.recording import boot_labels

        labels = boot_labels(args.source) if Path(args.source).is_file() else []
        if labels:
            raise BootnavError(f"--source {args.source} is a multi-boot recording ({', '.join(labels)}): give one "
                               "--out-link per boot")
    settings = EmulatorSettings(
        out_link=links[0], source=args.source, duration_s=args.duration, rate_hz=args.rate,
        corrupt_rate=corrupt[0], corrupt_kinds=kinds, disconnect_at_s=args.disconnect_at,
        disconnect_pause_s=args.disconnect_pause, restart_on_reconnect=args.restart_on_reconnect,
        replay_timing=args.replay_timing,
        wait_for_host=not args.no_wait,
        host_timeout_s=args.host_timeout, write_timeout_s=args.write_timeout, linger_s=args.linger, seq0=args.seq0 % 65536,
        t0_us=args.t0_us % 2**32, accel_fs=args.accel_fs, gyro_fs=args.gyro_fs, seed=args.seed,
        clock_ppm=_per_boot(args.clock_ppm, "--clock-ppm", 1, [0.0])[0],
        start_delay_s=_per_boot(args.start_delay, "--start-delay", 1, [0.0], non_negative=True)[0],
    )
    progress = None if args.quiet else _progress()
    try:
        emulator = Emulator(settings, progress=progress)
    except (OSError, ValueError) as exc:
        raise BootnavError(f"--source {args.source}: {exc}") from exc
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: emulator.stop())
    if not args.quiet:
        print(f"emulating on {links[0]} at {emulator.rate_hz:g} Hz, {emulator.n_frames} frames"
              + ("" if args.no_wait else " (waiting for the host to open the port)"), file=sys.stderr)
    try:
        report = emulator.run()
    except TimeoutError as exc:
        raise BootnavError(str(exc)) from exc
    finally:
        if args.report:
            emulator.report.write(args.report)
    if progress is not None:
        progress.done()
        print(f"sent {report.frames_sent} frames ({report.frames_corrupted} corrupted, {report.frames_dropped} "
              f"dropped, {report.garbage_bytes} garbage bytes, {report.disconnects} disconnects)", file=sys.stderr)
    return 0


def _per_boot(text, flag: str, n: int, default: list[float], non_negative: bool = False) -> list[float]:
    """One number per boot from ``A[,B]`` (a single number applies to every boot)."""
    from bootnav.errors import BootnavError

    if text is None:
        return default
    try:
        values = [float(v) for v in str(text).split(",")]
    except ValueError:
        raise BootnavError(f"{flag} {text!r}: expected numbers separated by commas, one per --out-link") from None
    if len(values) == 1:
        values *= n
    if len(values) != n or not all(math.isfinite(v) and (v >= 0 or not non_negative) for v in values):
        raise BootnavError(f"{flag} {text!r}: give one {'non-negative ' if non_negative else ''}number per "
                           f"--out-link ({n})")
    return values


def _run_multi(args, kinds, corrupt: list[float]) -> int:
    """Two (or more) boots, one pty and one thread each, with independent device clocks."""
    import json
    import threading
    from dataclasses import asdict
    from pathlib import Path

    from bootnav.errors import BootnavError
    from bootnav.logger.emulator import Emulator, EmulatorSettings

    links = args.out_link
    n = len(links)
    if len(set(links)) != n:
        raise BootnavError(f"--out-link {links}: each boot needs its own path")
    ppm = _per_boot(args.clock_ppm, "--clock-ppm", n, [-40.0, 60.0] + [0.0] * (n - 2))
    delay = _per_boot(args.start_delay, "--start-delay", n, [0.0, 0.25] + [0.0] * (n - 2), non_negative=True)
    boots: list[str | None] = [None] * n
    if args.source != "synthetic":
        from bootnav.logger.recording import boot_labels

        labels = boot_labels(args.source)
        if labels and len(labels) != n:
            raise BootnavError(f"--source {args.source} has {len(labels)} boots ({', '.join(labels)}); "
                               f"give one --out-link per boot")
        boots = labels or boots
    emulators = []
    for i, link in enumerate(links):
        settings = EmulatorSettings(
            out_link=link, source=args.source, boot=boots[i], duration_s=args.duration, rate_hz=args.rate,
            corrupt_rate=corrupt[i], corrupt_kinds=kinds, disconnect_at_s=args.disconnect_at,
            disconnect_pause_s=args.disconnect_pause, restart_on_reconnect=args.restart_on_reconnect,
            replay_timing=args.replay_timing, wait_for_host=not args.no_wait, host_timeout_s=args.host_timeout,
            write_timeout_s=args.write_timeout, linger_s=args.linger, seq0=(args.seq0 + 1000 * i) % 65536,
            t0_us=(args.t0_us + 123_456_789 * i) % 2**32, accel_fs=args.accel_fs, gyro_fs=args.gyro_fs,
            seed=args.seed + i, clock_ppm=ppm[i], start_delay_s=delay[i])
        try:
            emulators.append(Emulator(settings))
        except (OSError, ValueError) as exc:
            raise BootnavError(f"--source {args.source}: {exc}") from exc
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: [e.stop() for e in emulators])
    errors: list[BaseException | None] = [None] * n

    def serve(i):
        try:
            emulators[i].run()
        except BaseException as exc:  # noqa: BLE001 - reported below
            errors[i] = exc
            for e in emulators:
                e.stop()

    if not args.quiet:
        for link, e, p, d in zip(links, emulators, ppm, delay):
            print(f"emulating on {link} at {e.rate_hz:g} Hz, {e.n_frames} frames, clock {p:+g} ppm, "
                  f"start {d:g} s after the host", file=sys.stderr)
    threads = [threading.Thread(target=serve, args=(i,), daemon=True) for i in range(n)]
    for t in threads:
        t.start()
    while any(t.is_alive() for t in threads):
        for t in threads:
            t.join(0.1)
    if args.report:
        from bootnav.core import atomic

        atomic.write_text(args.report, json.dumps({"boots": [asdict(e.report) for e in emulators]}))
    for e in errors:
        if isinstance(e, TimeoutError):
            raise BootnavError(str(e)) from e
        if e is not None:
            raise e
    if not args.quiet:
        for link, e in zip(links, emulators):
            r = e.report
            print(f"{link}: sent {r.frames_sent} frames ({r.frames_corrupted} corrupted, {r.frames_dropped} dropped, "
                  f"{r.garbage_bytes} garbage bytes, {r.disconnects} disconnects)", file=sys.stderr)
    return 0


def _progress():
    from bootnav.core.progress import Progress

    shown = Progress()

    def show(k, n, rep):
        shown.update(f"{k}/{n} frames, {rep.frames_corrupted} corrupted, {rep.frames_dropped} dropped")

    show.done = shown.done
    return show
