"""``bootnav emulate``: a fake boot sensor on a pseudo-terminal (see ``bootnav.logger.emulator``)."""

from __future__ import annotations

import argparse
import math
import signal
import sys


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out-link", required=True, metavar="PATH",
                        help="symlink to create for the pty (open this path with `bootnav record --port`)")
    parser.add_argument("--source", default="synthetic", metavar="FILE|synthetic",
                        help="HDF5 recording to stream (int16 counts, or SI quantised with its ranges), "
                             "or 'synthetic' (default)")
    parser.add_argument("--duration", type=float, default=None, metavar="S",
                        help="seconds of device time to stream (default: the source once; synthetic 10 s)")
    parser.add_argument("--rate", type=float, default=None, metavar="HZ",
                        help="frame rate (default: the source's rate; synthetic 200 Hz)")
    parser.add_argument("--corrupt", type=float, default=0.0, metavar="RATE",
                        help="probability per frame of one fault: bit flip, garbage bytes or dropped frame")
    parser.add_argument("--corrupt-kinds", default="bitflip,garbage,drop",
                        help="comma-separated subset of bitflip,garbage,drop (default: all)")
    parser.add_argument("--disconnect-at", type=float, default=None, metavar="S",
                        help="close the port S seconds into the stream and recreate it after --disconnect-pause")
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
                        help="keep the port open S seconds after the last frame")
    parser.add_argument("--seq0", type=int, default=0, help="first sequence number (0..65535)")
    parser.add_argument("--t0-us", type=int, default=0, help="first device time in µs (0..2**32-1)")
    parser.add_argument("--accel-fs", type=int, choices=range(4), default=3,
                        help="AFS_SEL code of the synthetic signal (default 3 = ±16 g; a --source file declares its own)")
    parser.add_argument("--gyro-fs", type=int, choices=range(4), default=3,
                        help="FS_SEL code of the synthetic signal (default 3 = ±2000 °/s; a --source file declares its own)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the synthetic signal and the fault plan")
    parser.add_argument("--report", default=None, metavar="FILE.json",
                        help="write what was sent (frames_sent, frames_corrupted, valid_seqs, ...)")
    parser.add_argument("--quiet", action="store_true")


def run(args) -> int:
    from bootnav.errors import BootnavError
    from bootnav.logger.emulator import FAULT_KINDS, Emulator, EmulatorSettings

    kinds = tuple(k for k in args.corrupt_kinds.split(",") if k)
    bad = [k for k in kinds if k not in FAULT_KINDS]
    if bad:
        raise BootnavError(f"--corrupt-kinds: unknown {bad}; choose from {','.join(FAULT_KINDS)}")
    if not 0.0 <= args.corrupt <= 1.0:
        raise BootnavError(f"--corrupt must be a probability in [0, 1], got {args.corrupt}")
    for flag, value, zero_ok in (("--rate", args.rate, False), ("--duration", args.duration, False),
                                 ("--disconnect-at", args.disconnect_at, True),
                                 ("--disconnect-pause", args.disconnect_pause, True),
                                 ("--host-timeout", args.host_timeout, False),
                                 ("--write-timeout", args.write_timeout, False), ("--linger", args.linger, True)):
        if value is not None and not (math.isfinite(value) and (value >= 0 if zero_ok else value > 0)):
            raise BootnavError(f"{flag} {value}: must be a {'non-negative' if zero_ok else 'positive'} number")
    settings = EmulatorSettings(
        out_link=args.out_link, source=args.source, duration_s=args.duration, rate_hz=args.rate,
        corrupt_rate=args.corrupt, corrupt_kinds=kinds, disconnect_at_s=args.disconnect_at,
        disconnect_pause_s=args.disconnect_pause, restart_on_reconnect=args.restart_on_reconnect,
        replay_timing=args.replay_timing,
        wait_for_host=not args.no_wait,
        host_timeout_s=args.host_timeout, write_timeout_s=args.write_timeout, linger_s=args.linger, seq0=args.seq0 % 65536,
        t0_us=args.t0_us % 2**32, accel_fs=args.accel_fs, gyro_fs=args.gyro_fs, seed=args.seed,
    )
    progress = None if args.quiet else _progress()
    try:
        emulator = Emulator(settings, progress=progress)
    except (OSError, ValueError) as exc:
        raise BootnavError(f"--source {args.source}: {exc}") from exc
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: emulator.stop())
    if not args.quiet:
        print(f"emulating on {args.out_link} at {emulator.rate_hz:g} Hz, {emulator.n_frames} frames"
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


def _progress():
    from bootnav.cli import Progress

    shown = Progress()

    def show(k, n, rep):
        shown.update(f"{k}/{n} frames, {rep.frames_corrupted} corrupted, {rep.frames_dropped} dropped")

    show.done = shown.done
    return show
