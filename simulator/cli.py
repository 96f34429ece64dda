"""``bootnav simulate``: write a simulated recording (HDF5 with /truth, or SD-card text)."""

from __future__ import annotations

import sys
import time


def add_arguments(parser) -> None:
    parser.add_argument("--list", action="store_true", help="list scenarios and sensor profiles, then exit")
    parser.add_argument("--scenario", help="scenario name (see --list)")
    # --seed, --sensor-profile, --rate: None = simulate()'s own defaults (``simulate_defaults``)
    parser.add_argument("--seed", type=int, default=None, help="seed of the one random generator (default 0)")
    parser.add_argument("--sensor-profile", default=None,
                        help="sensor model (see --list; default mpu6050-16g-2000dps)")
    parser.add_argument("--rate", type=float, default=None, help="output sample rate, Hz (default 200)")
    parser.add_argument("--duration", type=float, default=None,
                        help="length in s (mixed-30min, running, long, fast-corridor, shuffle only; default: the "
                             "scenario's own)")
    parser.add_argument("--mount", default=None, help="sensor mount on the boot (see --list; default right_boot)")
    parser.add_argument("--format", choices=("h5", "sd-txt"), default=None,
                        help="output format (default: from the file extension, .txt -> sd-txt, else h5)")
    parser.add_argument("--out", help="output file")
    parser.add_argument("--plot", metavar="PNG", help="also save a figure of the truth and the signals")
    parser.add_argument("--two-boots", action="store_true",
                        help="both feet of one walker (right foot half a stride behind, independent sensor errors) "
                             "into one multi-boot recording (simulator/twoboots.py)")
    parser.add_argument("--two-files", action="store_true",
                        help="with --two-boots: two single-boot files OUT_left.h5 and OUT_right.h5 instead")
    parser.add_argument("--force", action="store_true",
                        help="replace existing output files (never an input; an HDF5 output never replaces a file "
                             "that is not HDF5)")
    dev = parser.add_argument_group("one unit and its temperature (simulator/device.py, docs/simulator.md)")
    dev.add_argument("--device", metavar="D",
                     help="device id 0..2^32-1 (decimal or 0x-hex): draws one unit's stable constants (scale, "
                          "cross-axis, mean turn-on bias, temperature coefficients, clock error) from D alone; "
                          "--seed then draws this power-on and walk. Written into the header as device_id")
    dev.add_argument("--ambient-degc", type=float, metavar="C",
                     help="ambient temperature at power-on, C (default 25; needs --device)")
    dev.add_argument("--ambient-ramp-degc-per-min", type=float, metavar="R",
                     help="ambient ramp, C per minute (e.g. a boot carried into a hot building; default 0: none; "
                          "needs --device)")
    dev.add_argument("--ambient-ramp-start-s", type=float, metavar="S", help="start of the ramp, s (default 0)")
    dev.add_argument("--ambient-ramp-duration-s", type=float, metavar="S",
                     help="length of the ramp, s (default: to the end)")
    dev.add_argument("--self-heating-degc", type=float, metavar="C",
                     help="die warm-up above ambient after power-on, C (default 3, time constant 300 s)")


_TEMPERATURE_FLAGS = {"ambient_degc": "ambient_degc", "ambient_ramp_degc_per_min": "ramp_degc_per_min",
                      "ambient_ramp_start_s": "ramp_start_s", "ambient_ramp_duration_s": "ramp_duration_s",
                      "self_heating_degc": "self_heating_degc"}


def device_options(args) -> dict:
    """``simulate`` keywords from the device and temperature flags (InputError when they do not fit)."""
    from bootnav.errors import InputError
    from bootnav.simulator.device import TemperatureProfile, parse_device_id

    given = {field: getattr(args, flag) for flag, field in _TEMPERATURE_FLAGS.items()
             if getattr(args, flag, None) is not None}
    device = getattr(args, "device", None)
    if device is None:
        if given:
            flags = ", ".join("--" + f.replace("_", "-") for f in _TEMPERATURE_FLAGS
                              if getattr(args, f, None) is not None)
            raise InputError(f"{flags}: give --device D too (the temperature coefficients belong to one unit)")
        return {}
    try:
        out = {"device": parse_device_id(device)}
        if given:
            out["temperature"] = TemperatureProfile(**given)
    except ValueError as exc:
        raise InputError(f"--device/--ambient: {exc}") from exc
    return out


def _list() -> int:
    from bootnav.simulator.imu_model import PROFILE_HELP
    from bootnav.simulator.imu_synth import MOUNTS
    from bootnav.simulator.scenarios import SCENARIOS

    print("scenarios:")
    for name, sc in SCENARIOS.items():
        print(f"  {name:16s} {sc.description}")
    print("sensor profiles:")
    for name, text in PROFILE_HELP.items():
        print(f"  {name:22s} {text}")
    print("mounts: " + ", ".join(MOUNTS))
    return 0


def simulate_defaults(args) -> None:
    """Fill ``--seed``, ``--sensor-profile`` and ``--rate`` not given with ``simulate()``'s defaults, their one
    home (``simulate.DEFAULT_*``; ``simulate_two_boots`` takes the same)."""
    from bootnav.simulator.simulate import DEFAULT_PROFILE, DEFAULT_RATE_HZ, DEFAULT_SEED

    for flag, default in (("seed", DEFAULT_SEED), ("sensor_profile", DEFAULT_PROFILE), ("rate", DEFAULT_RATE_HZ)):
        if getattr(args, flag, None) is None:
            setattr(args, flag, default)


def run(args) -> int:
    from bootnav.errors import InputError, UsageError

    if args.list:
        return _list()
    if not args.scenario or not args.out:
        raise UsageError("give --scenario NAME and --out FILE (or --list)")
    from bootnav.simulator.imu_synth import MOUNTS
    from bootnav.simulator.simulate import simulate

    simulate_defaults(args)
    from bootnav.simulator.writers import write_h5, write_sd_txt

    from pathlib import Path

    from bootnav.core.limits import check_duration, check_range
    from bootnav.core.paths import output_file

    check_duration("--duration", args.duration)
    check_range("--rate", args.rate, 1.0, 10000.0, "Hz", why="an IMU's output rate")
    fmt = args.format or ("sd-txt" if str(args.out).lower().endswith(".txt") else "h5")
    outs = [args.out]
    if args.two_boots and args.two_files:
        stem = Path(args.out).name[:-3] if Path(args.out).name.lower().endswith(".h5") else Path(args.out).name
        outs = [Path(args.out).with_name(f"{stem}_{label}.h5") for label in ("left", "right")]
    for target in outs:  # every refusal before the simulation (bootnav.core.paths)
        output_file(target, force=args.force, hdf5=args.two_boots or fmt == "h5")
    if args.plot:
        output_file(args.plot, force=args.force, inputs=outs, flag="--plot")
    dev_kw = device_options(args)
    if args.two_files and not args.two_boots:
        raise UsageError("--two-files splits a --two-boots simulation into two files: add --two-boots, or drop it")
    if args.two_boots:
        for flag, given in (("--mount", args.mount), ("--plot", args.plot)):
            if given:  # two boots are mounted left and right, and --plot draws one boot: never silently ignored
                raise UsageError(f"{flag} is not available with --two-boots (the feet are left_boot and right_boot, "
                                 "one figure shows one boot); simulate one boot for it")
        from bootnav.simulator.twoboots import run_cli

        if dev_kw:
            raise UsageError("--device is not available with --two-boots (two boots are two units); simulate "
                             "each boot with its own --device instead")
        return run_cli(args)
    if args.mount is not None and args.mount not in MOUNTS:
        raise UsageError(f"--mount: unknown mount {args.mount!r}; choose one of {', '.join(MOUNTS)}")
    t0 = time.perf_counter()
    from bootnav.core import atomic
    from bootnav.core.progress import Progress

    shown = Progress(quiet=getattr(args, "quiet", False))

    def progress(frac: float) -> None:
        shown.update(f"simulating {args.scenario}: {100 * frac:5.1f} %")

    try:
        res = simulate(args.scenario, seed=args.seed, profile=args.sensor_profile, rate_hz=args.rate,
                       duration_s=args.duration, progress=progress, **dev_kw,
                       **({"mount": args.mount} if args.mount is not None else {}))  # else simulate's default
    except ValueError as exc:  # an option's value: unknown scenario or profile, rate, duration, device
        raise UsageError(str(exc)) from exc
    shown.done()
    path = Path(args.out)
    if fmt == "sd-txt":
        write_sd_txt(res, path)
    else:  # crash-safe (core.atomic): written beside the target, then renamed over it: no half-written HDF5 file
        atomic.replace_with(path, lambda tmp: write_h5(res, tmp))
    if args.plot:
        from bootnav.simulator.plot import plot_result

        plot_result(res, args.plot)
    tr = res.truth
    import numpy as np

    from bootnav.simulator.gait import GAIT_CODES

    dist = float(np.sum(res.steps["length_m"]))
    # the foot origin rises when the boot tips onto its toe to crawl: a posture change, not a climb
    moves = ~np.isin(res.steps["kind"], [GAIT_CODES["kneel"], GAIT_CODES["stand_up"]])
    climb = float(np.sum(np.clip(res.steps["dz_m"][moves], 0, None)))
    sat = sum(res.saturation_counts().values())
    print(f"{path}: {args.scenario}, {res.n} samples at {res.rate_hz:g} Hz ({tr['t_s'][-1]:.1f} s), "
          f"{len(res.steps['length_m'])} strides, {dist:.1f} m, climb {climb:.2f} m, profile {res.profile.name}, "
          f"seed {res.seed}{device_text(res)}, {res.attrs['n_dropped']} dropped, {sat} saturated axis-samples "
          f"[{time.perf_counter() - t0:.1f} s]")
    return 0


def device_text(res) -> str:
    """', device 0x0000002A, chip 25.0-27.9 C' for a recording of one unit, else ''."""
    if "device_id" not in res.attrs:
        return ""
    t = res.truth["temp_degc"]
    return f", device 0x{int(res.attrs['device_id']):08X}, chip {t.min():.1f}-{t.max():.1f} C"
