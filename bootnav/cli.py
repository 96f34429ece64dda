"""The ``bootnav`` command: one entry point, one module per subcommand.

Each subcommand module exposes ``add_arguments(parser)`` and ``run(args) -> int``.
Subcommand modules must keep heavy imports (numba, matplotlib, scipy) inside ``run`` so that
building the parser stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from bootnav import __version__
from bootnav.errors import BootnavError

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
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="bootnav", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"bootnav {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module_name, help_text) in SUBCOMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
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
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    if getattr(args, "_missing", None):
        print(f"bootnav: {args._missing}", file=sys.stderr)
        return 2
    module = importlib.import_module(args._module)
    try:
        return int(module.run(args) or 0)
    except KeyboardInterrupt:
        return 130
    except BootnavError as exc:
        print(f"bootnav {args.command}: error: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
