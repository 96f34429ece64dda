"""``bootnav process`` with two boots: ``process BOTH.h5`` (a multi-boot recording) or
``process LEFT RIGHT --two-boots``. Options are added to ``process``'s parser by ``add_arguments``."""

from __future__ import annotations

import json
from pathlib import Path


def add_arguments(p) -> None:
    """The two-boot options of ``bootnav process`` (fields of ``TwoBootSettings``)."""
    g = p.add_argument_group("two boots (one walker, both feet fused with a maximum-separation bound)")
    g.add_argument("--two-boots", action="store_true",
                   help="fuse the inputs as the two feet of one walker: LEFT RIGHT (two recordings), or one "
                        "multi-boot recording (automatic for a multi-boot file)")
    g.add_argument("--boots", metavar="LEFT,RIGHT",
                   help="labels of the left and right boot in a multi-boot recording (default: 'left,right', "
                        "else the first two)")
    g.add_argument("--two-boot-settings", metavar="FILE.json", help="TwoBootSettings as JSON (full or partial)")
    g.add_argument("--max-separation", type=float, metavar="M",
                   help="largest distance between the two foot sensors, m (default 1.0: about a tall adult's leg)")
    g.add_argument("--clock", choices=("recording", "gait"),
                   help="recording: the t_s of both feet are one clock (default); gait: shift the right foot "
                        "by the gait-symmetry estimate (two files without a common clock)")
    g.add_argument("--right-offset-s", type=float, metavar="S", help="add S seconds to the right foot's t_s (default 0: a common clock)")


#: The options of a two-boot run only (``add_arguments``): (flag, attribute).
TWO_BOOT_FLAGS = (("--boots", "boots"), ("--two-boot-settings", "two_boot_settings"),
                  ("--max-separation", "max_separation"), ("--clock", "clock"), ("--right-offset-s", "right_offset_s"))


def refuse_two_boot_flags(args) -> None:
    """A two-boot option on a run of single feet is an error (it would be ignored)."""
    from bootnav.errors import InputError

    for flag, attr in TWO_BOOT_FLAGS:
        if getattr(args, attr, None) is not None:
            raise InputError(f"{flag} applies to two boots of one walker only: add --two-boots (LEFT RIGHT) or give "
                             "one multi-boot recording, or drop the option")


def is_multi_boot(path: str) -> bool:
    """True for an existing multi-boot HDF5 recording."""
    from bootnav.logger.recording import boot_labels
    from bootnav.postproc.source import is_hdf5 as _is_hdf5

    p = Path(path)
    return p.is_file() and _is_hdf5(p) and bool(boot_labels(p))


def wanted(args) -> bool:
    """Whether ``process`` runs the two-boot fusion for these arguments."""
    return bool(getattr(args, "two_boots", False)) or (len(args.input) == 1 and is_multi_boot(args.input[0]))


def two_boot_settings(args):
    from bootnav.errors import InputError

    from .settings import TwoBootSettings

    data = {}
    if getattr(args, "two_boot_settings", None):
        try:
            data = json.loads(Path(args.two_boot_settings).read_text())
        except (OSError, ValueError) as exc:
            raise InputError(f"{args.two_boot_settings}: not a readable JSON settings file ({exc})") from None
        if not isinstance(data, dict):
            raise InputError(f"{args.two_boot_settings}: expected a JSON object of TwoBootSettings fields")
    for opt, key in (("max_separation", "max_separation_m"), ("clock", "clock"), ("right_offset_s", "right_offset_s")):
        v = getattr(args, opt, None)
        if v is not None:
            data[key] = v
    return TwoBootSettings.from_dict(data)


def sources(args) -> tuple[object, object, list[str]]:
    """(left, right, input paths) from the command line (a multi-boot file is split into its boots)."""
    from bootnav.errors import InputError

    if len(args.input) == 2:
        if any(is_multi_boot(i) for i in args.input):
            raise InputError("give either one multi-boot recording or two single-boot recordings (LEFT RIGHT)")
        if getattr(args, "boots", None):
            raise InputError(f"--boots {args.boots}: chooses two boots of one multi-boot recording; with two files "
                             "LEFT RIGHT the order of the files says which foot is which: drop the option")
        return args.input[0], args.input[1], list(args.input)
    if len(args.input) != 1 or not is_multi_boot(args.input[0]):
        raise InputError(f"--two-boots needs LEFT RIGHT (two recordings) or one multi-boot recording; got "
                         f"{len(args.input)} input(s)" + ("" if len(args.input) != 1 else
                                                          f" ({args.input[0]} has one boot)"))
    left, right = boot_pair(args.input[0], None if not args.boots else [s.strip() for s in args.boots.split(",")])
    return left, right, [args.input[0]]


def boot_pair(path, boots=None) -> tuple[object, object]:
    """The left and right boots' ``Recording`` s of a multi-boot recording: the labels ``boots`` (two), else
    ``left`` and ``right``, else the first two (``InputError`` naming the labels there are)."""
    from bootnav.errors import InputError
    from bootnav.logger.recording import boot_labels, load

    labels = boot_labels(path)
    if boots:
        want = list(boots)
        if len(want) == 2 and want[0] == want[1]:
            raise InputError(f"--boots {want[0]},{want[1]}: the same boot twice; give two different labels of {path}: "
                             f"{', '.join(labels)}")
        if len(want) != 2 or any(w not in labels for w in want):
            raise InputError(f"boots {','.join(map(str, want))}: give two of the labels in {path}: {', '.join(labels)}")
    elif {"left", "right"} <= set(labels):
        want = ["left", "right"]
    elif len(labels) >= 2:
        want = labels[:2]
    else:
        raise InputError(f"{path}: a multi-boot recording with one boot ({labels[0]}); process it with --boots or as "
                         "a single foot")
    return load(path, boot=want[0], with_truth=False), load(path, boot=want[1], with_truth=False)


def run(args, settings, progress) -> int:
    """``bootnav process`` in two-boot mode: fuse, write ``outputs.write_two_boot_outputs``, print a summary.
    ``progress``: ``process``'s stage progress (called with (stage, fraction), closed with ``done()``)."""
    from .outputs import check_outputs, write_two_boot_outputs
    from .run import process_two_boots

    tb = two_boot_settings(args)
    left, right, inputs = sources(args)
    others = [args.settings, args.accel_calibration, getattr(args, "two_boot_settings", None)]
    check_outputs(settings, args.out, [*inputs, *others], args.force)
    if args.save_settings:
        from bootnav.errors import InputError
        from bootnav.postproc.outputs import same_file

        dest = Path(args.save_settings)
        if any(i and same_file(dest, Path(i)) for i in [*inputs, *others]):
            raise InputError(f"--save-settings {dest} is an input file; choose another name")
        if dest.exists() and not args.force:
            raise InputError(f"{dest} exists; use --force to overwrite it")
        settings.save(dest)
    try:
        result = process_two_boots(left, right, settings, tb, progress)
        files = write_two_boot_outputs(result, args.out, args.force)
    finally:
        progress.done()
    print(format_summary(result.summary, files))
    return 0


def format_summary(summary: dict, files: dict) -> str:
    """The few lines ``process --two-boots`` prints."""
    lines = []
    for label, f in summary["feet"].items():
        s, u = f["single"], f["fused"]
        lines.append(f"{label:5s} ({f['input']}): {u.get('distance_m', 0):.2f} m fused ({s.get('distance_m', 0):.2f} m "
                     f"alone), {u.get('strides', 0)} strides, mean stride {f['mean_stride_length_m']:.3f} m, "
                     f"mean step width {f['mean_step_width_m']:.3f} m")
    c, k, h = summary["constraint"], summary["clock"], summary["heading_alignment"]
    lines.append(f"walker: {summary['walker']['distance_m']:.2f} m; bound {c['bound_m']:.2f} m active at "
                 f"{c['active_updates']} of {c['checks']} checks (largest separation before it "
                 f"{c['max_separation_before_m']:.2f} m)")
    lines.append(f"clock: {k['mode']}, gait-symmetry offset of the right foot {k['offset_s'] * 1e3:+.0f} ms "
                 f"(residual {k['residual_s'] * 1e3:.0f} ms, {k['n_strides']} strides), applied "
                 f"{k['applied_offset_s'] * 1e3:+.0f} ms; right frame turned {h['yaw_rad'] * 57.29578:+.1f} deg")
    lines.append(f"files: {Path(files['summary']).parent}/ (two_boots.json, walker.csv, strides.csv, left/, right/)")
    return "\n".join(lines)


__all__ = ["add_arguments", "wanted", "run", "format_summary", "two_boot_settings", "sources", "refuse_two_boot_flags",
           "TWO_BOOT_FLAGS"]
