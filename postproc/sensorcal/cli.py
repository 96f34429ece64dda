"""``bootnav calibrate``: fit a per-device calibration from hand-held sessions, or guide one live on a port.

``bootnav calibrate A.h5 [B.h5 ...] [--out FILE.json] [--force] [--no-store] [--device-id ID]``
``bootnav calibrate --port P [--record FILE.h5] ...`` (guided live mode, ``live``)

The result goes into the calibration store under the recording's device id (``bootnav.core.sensorcal``),
where ``process``/``live``/``pdr``/``eval`` find it, and/or into ``--out``. The procedure and the math:
docs/calibration.md.
"""

from __future__ import annotations

import argparse
import math


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("sessions", nargs="*", metavar="SESSION.h5",
                        help="calibration sessions (recordings of the hand-held procedure, docs/calibration.md); "
                             "several sessions of one boot, e.g. cold and warm, fit the bias against temperature")
    parser.add_argument("--out", metavar="FILE.json", help="also write the calibration to this file")
    parser.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    parser.add_argument("--no-store", action="store_true",
                        help="do not put the calibration into the store (by device id; see --store-dir)")
    parser.add_argument("--device-id", metavar="ID",
                        help="device id (e.g. 0x0000BEEF) for a recording without one in its metadata")
    parser.add_argument("--store-dir", action="store_true",
                        help="print the calibration store directory ($BOOTNAV_CALIBRATION_DIR, else "
                             "$XDG_DATA_HOME/bootnav/calibrations, default ~/.local/share/bootnav/calibrations) "
                             "and exit")
    parser.add_argument("--gravity", type=float, default=None, metavar="M/S2",
                        help="local gravity in m/s^2 (default: WGS-84 normal gravity at --latitude, --height)")
    parser.add_argument("--latitude", type=float, default=None, metavar="DEG",
                        help="latitude for normal gravity, degrees (default 45)")
    parser.add_argument("--height", type=float, default=None, metavar="M",
                        help="ellipsoidal height for normal gravity, m (default 0)")
    parser.add_argument("--json", action="store_true", help="print the calibration as JSON instead of a table")
    live = parser.add_argument_group("guided live mode")
    live.add_argument("--port", help="record and guide a session live from this serial port (or pty from "
                                     "`bootnav emulate`); stops when every parameter reaches the goals or on Ctrl-C")
    live.add_argument("--record", metavar="FILE.h5",
                      help="live mode: the session file to record (default calibration-<UTC time>.h5 in the "
                           "current directory; never overwritten)")
    live.add_argument("--baud", type=int, default=None, help="live mode: baud rate (default 500000)")
    live.add_argument("--hold", type=float, default=3.0, metavar="S",
                      help="live mode: how long to hold each pose, s (default 3)")
    live.add_argument("--duration", type=float, default=None, metavar="S",
                      help="live mode: give up after S seconds (default: until the goals or Ctrl-C)")
    live.add_argument("--goal-scale", type=float, default=None, metavar="PERCENT",
                      help="live mode: stop when every scale factor is known to this 1σ, %% (default 0.05)")
    live.add_argument("--goal-misalignment", type=float, default=None, metavar="DEG",
                      help="live mode: stop when every misalignment is known to this 1σ, degrees (default 0.05)")


def settings_from_args(args):
    from .settings import SensorCalSettings

    from bootnav.errors import InputError

    for flag, v in (("--gravity", args.gravity), ("--latitude", args.latitude), ("--height", args.height)):
        if v is not None and not math.isfinite(v):
            raise InputError(f"{flag} {v}: must be a finite number")
    if args.gravity is not None and not 9.7 <= args.gravity <= 9.9:
        raise InputError(f"--gravity {args.gravity}: gravity on Earth is 9.76-9.84 m/s^2")
    if args.latitude is not None and not -90 <= args.latitude <= 90:
        raise InputError(f"--latitude {args.latitude}: must be within -90..90 degrees")
    given = {"gravity_mps2": args.gravity, "latitude_deg": args.latitude, "height_m": args.height}
    s = SensorCalSettings(**{k: v for k, v in given.items() if v is not None})  # its defaults: the only ones
    if getattr(args, "goal_scale", None) is not None:
        if not (math.isfinite(args.goal_scale) and args.goal_scale > 0):
            raise InputError(f"--goal-scale {args.goal_scale}: must be a positive percentage")
        s.goal_scale_sigma = args.goal_scale / 100.0
    if getattr(args, "goal_misalignment", None) is not None:
        if not (math.isfinite(args.goal_misalignment) and args.goal_misalignment > 0):
            raise InputError(f"--goal-misalignment {args.goal_misalignment}: must be a positive angle in degrees")
        s.goal_misalignment_sigma_rad = math.radians(args.goal_misalignment)
    return s


def check_outputs(args, device_id) -> None:
    """Refuse before any work: an existing --out without --force, nowhere to put the result."""
    from pathlib import Path

    from bootnav.errors import InputError

    if args.out:
        from bootnav.core.paths import output_file

        out = Path(args.out)
        if out.is_dir():
            raise InputError(f"--out {out}: is a directory; give a file name such as {out / 'calibration.json'}")
        # the one output rule of every writer: never an input, an existing file only with --force
        output_file(out, force=args.force, inputs=list(getattr(args, "sessions", None) or []), flag="--out")
    if args.no_store and not args.out:
        raise InputError("--no-store without --out would throw the calibration away; give --out FILE.json")


def run(args) -> int:
    from bootnav.core import sensorcal
    from bootnav.errors import InputError

    if args.store_dir:
        print(sensorcal.store_dir())
        return 0
    if args.device_id is not None:
        try:
            args.device_id = sensorcal.normalize_device_id(args.device_id)
        except (ValueError, TypeError):
            raise InputError(f"--device-id {args.device_id!r}: not a 32-bit id such as 0x0000BEEF") from None
    settings = settings_from_args(args)
    check_outputs(args, args.device_id)
    if args.port:
        if args.sessions:
            raise InputError("give either SESSION files or --port (live mode), not both")
        from .live import run_live

        return run_live(args, settings)
    if not args.sessions:
        raise InputError("give one or more SESSION.h5 recordings of the calibration procedure, or --port P for "
                         "the guided live mode (see docs/calibration.md)")
    from .fit import calibrate, load_session

    sessions = [load_session(p) for p in args.sessions]
    dev = args.device_id or next((s.device_id for s in sessions if s.device_id), None)
    if dev is None and not args.out:
        raise InputError(f"{args.sessions[0]}: the recording has no device_id; give --device-id ID to store the "
                         "calibration for that boot, or --out FILE.json")
    res = calibrate(sessions, settings, device_id=args.device_id)
    from .report import finish

    finish(args, res)
    return 0
