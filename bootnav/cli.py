"""The ``bootnav`` command: one entry point, one module per subcommand.

Each subcommand module exposes ``add_arguments(parser)`` and ``run(args) -> int``.
Subcommand modules must keep heavy imports (numba, matplotlib, scipy) inside ``run`` so that
building the parser stays fast.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import sys
import time
import traceback

from bootnav.core.conventions import __version__
from bootnav.core.progress import Progress  # noqa: F401  (bootnav.cli.Progress, as before)
from bootnav.errors import BootnavError, UsageError

# name -> (module, one-line help)
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "record": ("bootnav.logger.cli_record", "record binary frames from a serial port into an HDF5 recording"),
    "import": ("bootnav.logger.cli_import", "import an SD-card log or a CSV from another IMU into HDF5"),
    "info": ("bootnav.logger.cli_info", "summarise a recording (rate, gaps, drops, CRC errors, saturation)"),
    "emulate": ("bootnav.logger.cli_emulate", "fake boot sensor on a pseudo-terminal streaming protocol frames"),
    "simulate": ("bootnav.simulator.cli", "simulate a boot walk with exact truth and an MPU6050 error model"),
    "process": ("bootnav.postproc.cli_process", "reconstruct the 3-D path from a recording (ZUPT Kalman filter)"),
    "pdr": ("bootnav.postproc.pdr.cli", "step-and-heading dead reckoning for waist/phone sensors"),
    "eval": ("bootnav.postproc.evaluate.cli", "accuracy and speed on the public datasets, with a report"),
    "live": ("bootnav.postproc.live.cli", "record boots and watch their paths live in the browser, or replay recordings"),
    "calibrate": ("bootnav.postproc.sensorcal.cli", "per-boot sensor calibration from hand-held poses (file or guided live)"),
}


def _common_options(top: bool) -> argparse.ArgumentParser:
    """The parent parser of the top parser and of every subcommand: ``-q/--quiet`` and ``--verbose``.

    Subcommand copies default to SUPPRESS so they never overwrite a flag given before the subcommand
    (``bootnav -q info X`` and ``bootnav info -q X`` are the same).
    """
    parent = argparse.ArgumentParser(add_help=False)
    default = False if top else argparse.SUPPRESS
    parent.add_argument("--verbose", action="store_true", default=default,
                        help="show the Python traceback of an unexpected error")
    parent.add_argument("-q", "--quiet", action="store_true", default=default,
                        help="print only results and errors (no progress or status lines)")
    return parent


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="bootnav", parents=[_common_options(top=True)],
        description="Indoor path of a pedestrian from an inertial sensor on the boot: record or import the "
                    "sensor data, check it, and reconstruct the 3-D path. `bootnav COMMAND --help` for each command.",
        epilog="Exit status: 0 ok, 1 error (one line on stderr; --verbose adds the traceback of an unexpected "
               "one), 2 usage, 130 interrupted, 141 output pipe closed.")
    parser.add_argument("--version", action="version", version=f"bootnav {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module_name, help_text) in SUBCOMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text, parents=[_common_options(top=False)])
        p.set_defaults(_module=module_name)
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name and module_name.startswith(exc.name):
                p.set_defaults(_missing=f"'bootnav {name}' is not available in this build ({exc})")
                continue
            raise
        module.add_arguments(p)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run one subcommand; every failure becomes one line on stderr and a non-zero exit code.

    Exit codes: 0 ok, 1 error (bad input, I/O), 2 usage, 130 Ctrl-C, 141 output pipe closed
    (``bootnav info X | head``). An unexpected exception prints one line and a pointer to
    ``--verbose``, which adds the traceback.
    """
    raw = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser()
    args = parser.parse_args(raw)
    # a global flag given before the subcommand is seen by subcommands defining their own copy too
    args.verbose = bool(getattr(args, "verbose", False) or "--verbose" in raw)
    args.quiet = bool(getattr(args, "quiet", False) or "--quiet" in raw or "-q" in raw)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    if getattr(args, "_missing", None):
        print(f"bootnav: {args._missing}", file=sys.stderr)
        return 2
    prefix = f"bootnav {args.command}"
    try:
        module = importlib.import_module(args._module)
        code = int(module.run(args) or 0)
        sys.stdout.flush()
        return code
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        _silence_stdout()
        return 141
    except UsageError as exc:
        _fail(prefix, str(exc), args.verbose)
        return 2
    except BootnavError as exc:
        return _fail(prefix, str(exc), args.verbose)
    except OSError as exc:
        return _fail(prefix, _os_message(exc), args.verbose)
    except MemoryError:
        return _fail(prefix, "out of memory (try a shorter recording or fewer --jobs)", args.verbose)
    except Exception as exc:  # noqa: BLE001 - the one place that turns any bug into a clean message
        text = str(exc).splitlines()[0] if str(exc) else ""
        return _fail(prefix, f"unexpected {type(exc).__name__}: {text} (run with --verbose for the traceback)",
                     args.verbose)


def _fail(prefix: str, message: str, verbose: bool) -> int:
    if verbose:
        traceback.print_exc(file=sys.stderr)
    try:
        print(f"{prefix}: error: {message}", file=sys.stderr)
    except (BrokenPipeError, OSError):
        pass
    _silence_stdout()  # stdout may be a closed pipe; do not let the interpreter's final flush raise
    return 1


def _os_message(exc: OSError) -> str:
    """``PATH: reason`` for an OS error, with the fix for the common ones."""
    where = exc.filename if exc.filename is not None else ""
    reason = exc.strerror or str(exc)
    hint = {
        errno.ENOSPC: "free some space or write elsewhere",
        errno.EDQUOT: "free some space or write elsewhere",
        errno.EFBIG: "the file-size limit was reached (ulimit -f)",
        errno.EACCES: "check the permissions",
        errno.EROFS: "choose a writable place",
        errno.EISDIR: "give a file, not a directory",
        errno.ENOENT: "check the path",
    }.get(exc.errno or 0)
    text = f"{where}: {reason}" if where else reason
    return f"{text}; {hint}" if hint else text


def _silence_stdout() -> None:
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass


if __name__ == "__main__":
    sys.exit(main())
