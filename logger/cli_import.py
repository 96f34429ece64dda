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
    parser.add_argument("second", type=Path, nargs="?", metavar="FILE2",
                        help="a second boot's log: both go into one multi-boot recording (--labels, --align)")
    parser.add_argument("--labels", default="left,right", help="boot labels of FILE and FILE2 (default left,right)")
    parser.add_argument("--align", choices=("timestamps", "start"), default=None,
                        help="two files: 'timestamps' = their own time columns share one clock (default when both "
                             "have one), 'start' = both first samples at session time 0")
    parser.add_argument("--offset-s", type=float, default=None, metavar="S",
                        help="two files: FILE2's first sample at S seconds of FILE's clock (may be negative; default: "
                             "aligned by the files' own timestamps)")
    parser.add_argument("--out", type=Path, help="output recording (default: FILE's name with .h5, in the cwd)")
    parser.add_argument("--profile", help="shipped profile NAME or a FILE.toml (default: auto-detect); "
                        "'--profile list' shows the shipped ones")
    parser.add_argument("--columns", help="column roles in file order, e.g. t,gx,gy,gz,ax,ay,az ('-' skips), "
                        "or role=NAME|INDEX pairs, e.g. 't=Time (s),ax=1'")
    parser.add_argument("--acc-unit", choices=("g", "mps2", "counts"),
                        help="accelerometer unit of the file: %(choices)s (default: from the header or profile, else "
                             "from the gravity magnitude at rest)")
    parser.add_argument("--gyro-unit", choices=("dps", "radps", "counts"),
                        help="gyroscope unit of the file: %(choices)s (default: from the header or profile)")
    parser.add_argument("--time-unit", choices=("s", "ms", "us"),
                        help="unit of the time column: %(choices)s (default: from the header or profile, else "
                             "guessed from the median time step)")
    parser.add_argument("--acc-range", type=float, metavar="G", help="accelerometer full scale, ±G in g (default: from the file name or profile; "
                                                              "none: no saturation flags)")
    parser.add_argument("--gyro-range", type=float, metavar="DPS", help="gyro full scale, ±DPS in deg/s (default: from the file name or profile; none: "
                                                              "no saturation flags)")
    parser.add_argument("--rate", type=float, metavar="HZ", help="nominal sample rate, Hz (required without a time column; "
                                                             "default: measured from the time column)")
    parser.add_argument("--mount", help="where the sensor was worn: left_boot, right_boot, lower_back, phone_hand, ...")
    parser.add_argument("--sensor", type=int, help="which IMU of a multi-IMU file, a number (e.g. IEZ: 1 or 2; default: "
                                                             "the profile's first)")
    parser.add_argument("--delimiter", help="force the delimiter: ',' ';' 'tab' 'whitespace'")
    parser.add_argument("--no-unit-check", "--trust-units", action="store_true", dest="no_unit_check",
                        help="trust the declared units: record a failed gravity/gyro unit check as a note (and in "
                             "/meta unit_check) instead of an error")
    parser.add_argument("--force", action="store_true", help="replace --out if it is an existing HDF5 file")


def check_out(src: Path, out: Path, force: bool) -> None:
    """Refuse an ``--out`` that would destroy something: the input, a directory, a non-HDF5 file, or
    (without ``force``) an existing recording.

    Raises
    ------
    BootnavError
        Naming the path and the fix.
    """
    from bootnav.core.paths import output_file, regular_input

    if src.exists():
        regular_input(src, "log")
    output_file(out, force=force, inputs=[src], hdf5=True)  # the one output rule (bootnav.core.paths)


def run(args: argparse.Namespace) -> int:
    from bootnav.logger.importers import builtin_names, import_streaming, load_profile, read_any, write_result

    if args.profile == "list" or str(args.file) == "list":
        for name in builtin_names():
            print(f"{name:32s} {load_profile(name).get('description', '')}")
        return 0
    if args.file is None:  # a usage error, like a missing required argument
        print("bootnav import: error: the input file is required (except with --profile list)", file=sys.stderr)
        return 2
    if args.second is not None:
        return _run_two(args)
    name = args.file.name[:-3] if args.file.name.endswith(".gz") else args.file.name
    out = args.out or Path.cwd() / (Path(name).stem + ".h5")
    check_out(args.file, out, args.force)
    delimiter = {"tab": "\t", "comma": ",", "semicolon": ";"}.get(args.delimiter, args.delimiter)
    overrides = dict(columns=args.columns, acc_unit=args.acc_unit, gyro_unit=args.gyro_unit,
                     time_unit=args.time_unit, acc_range_g=args.acc_range, gyro_range_dps=args.gyro_range,
                     rate_hz=args.rate, mount=args.mount, sensor=args.sensor, delimiter=delimiter,
                     check_units=not args.no_unit_check)
    result = import_streaming(args.file, out, args.profile, **overrides)  # a canonical CSV: block by block
    if result is None:
        result = read_any(args.file, args.profile, **overrides)
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


def _run_two(args: argparse.Namespace) -> int:
    """Two boots' files -> one multi-boot recording, on one session clock by the rule of ``--align`` /
    ``--offset-s`` (docs/recording-format.md, "Multi-boot recordings")."""
    import math

    import numpy as np

    from bootnav.errors import BootnavError
    from bootnav.logger.importers import read_any
    from bootnav.logger.importers.core import write_atomically, write_aux
    from bootnav.logger.recording import check_boot_label, make_events, write_multi_boot

    files = [args.file, args.second]
    labels = [x.strip() for x in args.labels.split(",")]
    if len(labels) != 2 or labels[0] == labels[1]:
        raise BootnavError(f"--labels {args.labels!r}: give two distinct labels, e.g. left,right")
    for label in labels:
        check_boot_label(label)
    if args.out is None:
        raise BootnavError("two input files: give the multi-boot recording to write with --out FILE.h5")
    if args.offset_s is not None and (args.align is not None or not math.isfinite(args.offset_s)):
        raise BootnavError("--offset-s S (a finite number) and --align exclude each other: give one rule")
    for f in files:
        check_out(f, args.out, args.force)
    delimiter = {"tab": "\t", "comma": ",", "semicolon": ";"}.get(args.delimiter, args.delimiter)
    results = [read_any(f, args.profile, columns=args.columns, acc_unit=args.acc_unit, gyro_unit=args.gyro_unit,
                        time_unit=args.time_unit, acc_range_g=args.acc_range, gyro_range_dps=args.gyro_range,
                        rate_hz=args.rate, mount=args.mount or f"{label}_boot", sensor=args.sensor,
                        delimiter=delimiter, check_units=not args.no_unit_check)
               for f, label in zip(files, labels)]
    t0 = [r.meta.get("t0_source_s") for r in results]
    have_t0 = all(isinstance(x, (int, float)) and math.isfinite(x) for x in t0)
    rule = "offset" if args.offset_s is not None else (args.align or ("timestamps" if have_t0 else "start"))
    if rule == "timestamps" and not have_t0:
        raise BootnavError(f"--align timestamps: {files[t0.index(None) if None in t0 else 0]} has no time column; "
                           "use --align start or --offset-s S")
    if rule == "timestamps":
        first = [float(x) for x in t0]
    elif rule == "offset":
        first = [0.0, float(args.offset_s)]
    else:
        first = [0.0, 0.0]
    s0 = min(first)
    boots = {}
    for label, r, f0 in zip(labels, results, first):
        meta = dict(r.meta, boot_label=label, clock_alignment={"timestamps": "file-timestamps", "start":
                    "start-together", "offset": "offset"}[rule], clock_offset_s=f0 - s0, clock_scale=1.0,
                    clock_residual_s=float("nan"), clock_blocks=0)
        events = make_events(sorted(r.events, key=lambda e: (e.get("sample_index", -1), e.get("line", -1))))
        events["t_s"] += f0 - s0
        boots[label] = dict(r.optional, t_s=r.t_s + (f0 - s0), acc=r.acc, gyro=r.gyro, acc_channel=r.acc_channel,
                            gyro_channel=r.gyro_channel, events=events, meta=meta, saturated=r.saturated)
    epoch = rule == "timestamps" and s0 > 1e9  # both files on a UNIX clock: the session start is absolute
    attrs = {"session_start_unix_s": s0 if epoch else float("nan"),
             "session_clock": "seconds since the first sample of any boot", "clock_alignment": rule}
    out = args.out

    def write(tmp):
        write_multi_boot(tmp, boots, attrs=attrs)
        for label, r in zip(labels, results):
            write_aux(tmp, f"boots/{label}/aux", r)

    write_atomically(out, write)
    if not args.quiet:
        for f, label, r in zip(files, labels, results):
            for line in r.messages:
                print(f"{f.name}: {line}")
        print(f"alignment: {rule} ({labels[1]} starts {first[1] - first[0]:+.6f} s after {labels[0]})")
        print(f"wrote {out} ({', '.join(f'{label} {r.n} samples' for label, r in zip(labels, results))})")
    sys.stdout.flush()
    return 0
