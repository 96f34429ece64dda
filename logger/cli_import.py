"""``bootnav import FILE --out FILE.h5``: an SD-card log or another IMU's CSV/TXT -> HDF5 recording.

Prints what it detected (profile, delimiter, header, columns, units, ranges) and every skipped line.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", type=Path, nargs="?",
                        help="input log: bootnav SD-card .txt, CSV/TXT (optionally .gz); "
                             "not needed with --profile list")
    parser.add_argument("--out", type=Path, help="output recording (default: FILE's name with .h5, in the cwd)")
    parser.add_argument("--profile", help="shipped profile NAME or a FILE.toml (default: auto-detect); "
                        "'--profile list' shows the shipped ones")
    parser.add_argument("--columns", help="column roles in file order, e.g. t,gx,gy,gz,ax,ay,az ('-' skips), "
                        "or role=NAME|INDEX pairs, e.g. 't=Time (s),ax=1'")
    parser.add_argument("--acc-unit", choices=("g", "mps2", "counts"))
    parser.add_argument("--gyro-unit", choices=("dps", "radps", "counts"))
    parser.add_argument("--time-unit", choices=("s", "ms", "us"))
    parser.add_argument("--acc-range", type=float, metavar="G", help="accelerometer full scale, +-G")
    parser.add_argument("--gyro-range", type=float, metavar="DPS", help="gyro full scale, +-deg/s")
    parser.add_argument("--rate", type=float, metavar="HZ", help="nominal sample rate (required without a time column)")
    parser.add_argument("--mount", help="where the sensor was worn: left_boot, right_boot, lower_back, phone_hand, ...")
    parser.add_argument("--sensor", type=int, help="which IMU of a multi-IMU file (e.g. IEZ: 1 or 2)")
    parser.add_argument("--delimiter", help="force the delimiter: ',' ';' 'tab' 'whitespace'")
    parser.add_argument("--no-unit-check", action="store_true",
                        help="record a failed gravity/gyro unit check as a note instead of an error")
    parser.add_argument("--force", action="store_true", help="replace --out if it is an existing HDF5 file")
    parser.add_argument("--quiet", action="store_true", help="print only errors")


def check_out(src: Path, out: Path, force: bool) -> None:
    """Refuse an ``--out`` that would destroy something: the input, a directory, a non-HDF5 file, or
    (without ``force``) an existing recording.

    Raises
    ------
    BootnavError
        Naming the path and the fix.
    """
    import h5py

    from bootnav.errors import BootnavError

    if src.is_dir():
        raise BootnavError(f"{src}: is a directory; give the log file to import")
    if out.is_dir():
        raise BootnavError(f"--out {out}: is a directory; give a file name such as {out / (src.stem + '.h5')}")
    parent = out.parent if str(out.parent) else Path(".")
    if parent.is_dir() and not os.access(parent, os.W_OK):
        raise BootnavError(f"--out {out}: {parent} is not writable; choose a writable place")
    if not out.exists():
        return
    if src.exists() and os.path.samefile(src, out):
        raise BootnavError(f"--out {out} is the input file; choose another name (the input is never overwritten)")
    if not h5py.is_hdf5(out):
        raise BootnavError(f"--out {out} exists and is not an HDF5 file; bootnav does not overwrite it, "
                           "choose another name")
    if not force:
        raise BootnavError(f"--out {out} exists; choose another name or add --force to replace it")


def run(args: argparse.Namespace) -> int:
    from bootnav.logger.importers import builtin_names, load_profile, read_any, write_result

    if args.profile == "list" or str(args.file) == "list":
        for name in builtin_names():
            print(f"{name:32s} {load_profile(name).get('description', '')}")
        return 0
    if args.file is None:  # a usage error, like a missing required argument
        print("bootnav import: error: the input file is required (except with --profile list)", file=sys.stderr)
        return 2
    name = args.file.name[:-3] if args.file.name.endswith(".gz") else args.file.name
    out = args.out or Path.cwd() / (Path(name).stem + ".h5")
    check_out(args.file, out, args.force)
    delimiter = {"tab": "\t", "comma": ",", "semicolon": ";"}.get(args.delimiter, args.delimiter)
    result = read_any(args.file, args.profile, columns=args.columns, acc_unit=args.acc_unit,
                      gyro_unit=args.gyro_unit, time_unit=args.time_unit, acc_range_g=args.acc_range,
                      gyro_range_dps=args.gyro_range, rate_hz=args.rate, mount=args.mount, sensor=args.sensor,
                      delimiter=delimiter, check_units=not args.no_unit_check)
    write_result(result, out)
    if not args.quiet:
        for line in result.messages:
            print(f"{args.file.name}: {line}")
        kinds: dict[str, int] = {}
        for e in result.events:
            kinds[e["kind"]] = kinds.get(e["kind"], 0) + 1
        if kinds:
            print(f"{args.file.name}: events: " + ", ".join(f"{k} {v}" for k, v in sorted(kinds.items())))
        sat = int((result.saturated != 0).sum())
        if sat:
            print(f"{args.file.name}: saturated samples: {sat}")
        print(f"wrote {out} ({result.n} samples)")
    sys.stdout.flush()
    return 0
