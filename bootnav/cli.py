"""The ``bootnav`` command: one entry point, one module per subcommand.

Each subcommand module exposes ``add_arguments(parser)`` and ``run(args) -> int``.
Subcommand modules must keep heavy imports (numba, matplotlib, scipy) inside ``run`` so that
building the parser stays fast.
"""

from __future__ import annotations

import argparse
import codecs
import errno
import importlib
import os
import re
import signal
import sys
import time
import traceback

from bootnav.core.conventions import __version__
from bootnav.core.progress import Progress  # noqa: F401  (bootnav.cli.Progress, as before)
from bootnav.errors import BootnavError, InputError, UsageError

#: Signals that stop a command like Ctrl-C: one clean line, temporary files removed, exit code 128 + signal number
#: (Ctrl-C = SIGINT = 2 -> 130, SIGHUP = 1 -> 129, SIGTERM = 15 -> 143), as a shell reports a killed command.
STOP_SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")

#: Characters of our messages that an ASCII or cp1252 console cannot show, and their ASCII spelling.
ASCII_SPELLING = {"°": "deg", "±": "+-", "²": "^2", "³": "^3", "µ": "u", "σ": "sigma", "ω": "omega", "τ": "tau",
                  "Δ": "delta", "→": "->", "←": "<-", "≈": "~", "≤": "<=", "≥": ">=", "×": "x", "·": ".",
                  "–": "-", "—": "-", "…": "...", "‰": "permil", "ψ": "psi", "θ": "theta", "φ": "phi"}


class Stopped(KeyboardInterrupt):
    """A stop signal (SIGTERM, SIGHUP) raised where the program is, like Ctrl-C's KeyboardInterrupt: every
    ``finally`` and every crash-safe writer cleans up on the way out."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


#: Seconds a stopped command may take to unwind before it is ended from a watchdog thread: an exception raised
#: by a signal inside a library's lock (llvmlite, seen under SIGHUP) can deadlock the unwinding.
STOP_GRACE_S = 10.0
_STOPPING: list[int] = []
_UNWOUND = __import__("threading").Event()  # set when main() has returned: the watchdog stands down


def _raise_stopped(signum, frame):
    """Stop like Ctrl-C: raise ``Stopped`` here; a watchdog ends the process if unwinding hangs; a second stop
    signal ends it at once. Either way this process's temporary files are removed and the exit code is 128 + sig."""
    if _STOPPING:
        _hard_exit(signum)
    _STOPPING.append(signum)
    import threading

    threading.Thread(target=_watchdog, args=(signum,), daemon=True).start()
    raise Stopped(signum)


def _watchdog(signum: int) -> None:
    if not _UNWOUND.wait(STOP_GRACE_S):
        _hard_exit(signum)


def _hard_exit(signum: int) -> None:
    from bootnav.core.atomic import remove_temporaries

    remove_temporaries()
    name = signal.Signals(signum).name
    command = next((a for a in sys.argv[1:] if a in SUBCOMMANDS), "")
    try:
        os.write(2, f"bootnav {command}: stopped by {name}; unfinished output files were removed\n".replace(
            "bootnav : ", "bootnav: ").encode("ascii", "replace"))
    except OSError:
        pass
    os._exit(128 + int(signum))


def _ascii_fallback(exc: UnicodeEncodeError):
    """Codec error handler ``bootnav-ascii``: our symbols spelled in ASCII, anything else as ``?``."""
    text = exc.object[exc.start:exc.end]
    return "".join(ASCII_SPELLING.get(ch, "?") for ch in text), exc.end


codecs.register_error("bootnav-ascii", _ascii_fallback)


def prepare_process() -> dict:
    """Make the process safe to run whatever its environment (called once by ``main``).

    - fds 0-2 closed by the caller (``bootnav info X >&-``) are reopened on /dev/null, so no file bootnav opens
      gets fd 1 and no print fails;
    - a console that cannot encode our symbols (ASCII, cp1252) gets them spelled in ASCII, never an error;
    - SIGINT (Ctrl-C), SIGTERM and SIGHUP stop the command (``Stopped``, a KeyboardInterrupt), with a watchdog
      that ends the process if the unwinding hangs;
    - SIGXFSZ (the file-size limit, ``ulimit -f``) is ignored so a write past the limit fails with EFBIG, which
      every writer turns into a clean error, instead of killing the process with a half-written file set.

    Returns the previous signal handlers ({signal: handler}) for ``restore_signals``.
    """
    previous = {}
    for fd in (0, 1, 2):
        try:
            os.fstat(fd)
        except OSError:
            try:
                null = os.open(os.devnull, os.O_RDWR)
                if null != fd:
                    os.dup2(null, fd)
                    os.close(null)
            except OSError:
                pass
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if stream is None:
            try:
                setattr(sys, name, open(os.devnull, "w"))
            except OSError:
                continue
            continue
        try:
            stream.reconfigure(errors="bootnav-ascii")
        except (AttributeError, ValueError, OSError):
            pass
    sys.unraisablehook = _quiet_hdf5_dealloc
    sys.excepthook = _quiet_hdf5_excepthook
    wanted = [(n, _raise_stopped) for n in STOP_SIGNALS] + [("SIGXFSZ", signal.SIG_IGN)]
    for name, handler in wanted:
        if hasattr(signal, name):
            if handler is _raise_stopped and signal.getsignal(getattr(signal, name)) == signal.SIG_IGN:
                continue  # ignored by the caller (nohup, a background job): stays ignored
            try:
                previous[getattr(signal, name)] = signal.signal(getattr(signal, name), handler)
            except (ValueError, OSError):  # not the main thread (embedded use): leave the defaults
                pass
    return previous


_DEFAULT_UNRAISABLEHOOK = sys.unraisablehook


def _quiet_hdf5_dealloc(unraisable) -> None:
    """h5py reports a failed close of a file whose write failed (full disk, ``ulimit -f``) as an ignored exception
    with a traceback; the write's own error is reported as one line, so these are not shown (``--verbose`` does)."""
    obj = repr(getattr(unraisable, "object", ""))
    if "h5py" in obj or "ObjectID" in obj:
        if "--verbose" in sys.argv:
            _DEFAULT_UNRAISABLEHOOK(unraisable)
        return
    _DEFAULT_UNRAISABLEHOOK(unraisable)


_DEFAULT_EXCEPTHOOK = sys.excepthook


def _quiet_hdf5_excepthook(kind, value, tb) -> None:
    """Cython prints an h5py close failure through ``sys.excepthook`` before the unraisable hook: hidden as above."""
    if isinstance(value, RuntimeError) and "decrement id ref count" in str(value) and "--verbose" not in sys.argv:
        return
    _DEFAULT_EXCEPTHOOK(kind, value, tb)


def restore_signals(previous: dict) -> None:
    """Put back the handlers ``prepare_process`` replaced (``main`` called from Python, e.g. by a test)."""
    for signum, handler in previous.items():
        try:
            signal.signal(signum, handler if handler is not None else signal.SIG_DFL)
        except (ValueError, OSError, TypeError):
            pass

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


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The ``bootnav`` parser: every subcommand's options, or, given the command line ``argv``, only those of the
    subcommand it names (the others listed with their help line: importing every subcommand's module costs the
    start of each command about 50 ms)."""
    only = None if argv is None else next((a for a in argv if not a.startswith("-")), "")
    parser = argparse.ArgumentParser(
        prog="bootnav", parents=[_common_options(top=True)],
        description="Indoor path of a pedestrian from an inertial sensor on the boot: record or import the "
                    "sensor data, check it, and reconstruct the 3-D path. `bootnav COMMAND --help` for each command.",
        epilog="Exit status: 0 ok, 1 error (one line on stderr; --verbose adds the traceback of an unexpected "
               "one), 2 usage, 128+N stopped by signal N (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP), 141 output pipe closed.")
    parser.add_argument("--version", action="version", version=f"bootnav {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module_name, help_text) in SUBCOMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text, parents=[_common_options(top=False)])
        p.set_defaults(_module=module_name)
        if only is not None and name != only:
            continue
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

    Exit codes: 0 ok, 1 error (bad input, I/O), 2 usage, 128+N stopped by signal N (130 Ctrl-C, 143 SIGTERM,
    129 SIGHUP), 141 output pipe closed
    (``bootnav info X | head``). An unexpected exception prints one line and a pointer to
    ``--verbose``, which adds the traceback.
    """
    raw = sys.argv[1:] if argv is None else list(argv)
    previous = prepare_process()
    _UNWOUND.clear()
    try:
        code = _main(raw)
    finally:
        restore_signals(previous)
        _UNWOUND.set()
        _STOPPING.clear()
    if argv is None and (code > 128 or code != 0 and "h5py" in sys.modules):
        # a stopped run may leave worker threads blocked (a stop signal inside a library's lock), and after a failed
        # write HDF5 may crash in its exit handler (seen under ulimit -f, after the clean message): leave now,
        # without the interpreter's teardown (the program's own exit only, never when main() is called from Python)
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError, AttributeError):
                pass
        os._exit(code)
    if argv is None:
        # the program's own exit (never main() called from Python): the interpreter's teardown would run the cyclic
        # garbage collector over every object left (numba's and scipy's modules: ~0.3-0.8 s after `bootnav process`);
        # frozen, they are skipped, and the memory goes back to the system with the process. atexit handlers still run.
        import gc

        gc.freeze()
    return code


def hdf5_left_open() -> bool:
    """True when an HDF5 file is still open (after ``release_hdf5``: one that could not be closed)."""
    h5py = sys.modules.get("h5py")
    if h5py is None:
        return False
    try:
        return bool(h5py.h5f.get_obj_count(types=h5py.h5f.OBJ_FILE))
    except Exception:  # noqa: BLE001
        return False


def _main(raw: list[str]) -> int:
    parser = build_parser(raw)
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
        refuse_special_paths(args)
        module = importlib.import_module(args._module)
        code = int(module.run(args) or 0)
        sys.stdout.flush()
        return code
    except KeyboardInterrupt as exc:
        signum = exc.signum if isinstance(exc, Stopped) else signal.SIGINT
        name = signal.Signals(signum).name
        _say(f"{prefix}: stopped by {name}{' (Ctrl-C)' if signum == signal.SIGINT else ''}; "
             "unfinished output files were removed")
        _silence_stdout()
        return 128 + int(signum)
    except BrokenPipeError:
        _silence_stdout()
        return 141
    except UsageError as exc:
        _fail(prefix, str(exc), args.verbose)
        return 2
    except BootnavError as exc:
        return _fail(prefix, str(exc), args.verbose)
    except OSError as exc:
        release_hdf5()
        return _fail(prefix, _os_message(exc), args.verbose)
    except MemoryError:
        return _fail(prefix, "out of memory (try a shorter recording or fewer --jobs)", args.verbose)
    except RecursionError:
        return _fail(prefix, "an input is nested too deeply to read (a JSON file with thousands of nested [ or {?);"
                             " check the files given", args.verbose)
    except Exception as exc:  # noqa: BLE001 - the one place that turns any bug into a clean message
        text = str(exc).splitlines()[0] if str(exc) else ""
        return _fail(prefix, f"internal error, a bug in bootnav ({type(exc).__name__}: {text}); please report it "
                             "with the output of --verbose", args.verbose)


#: Options whose value is a device by design (a serial port).
DEVICE_OPTIONS = {"port"}


def refuse_special_paths(args: argparse.Namespace) -> None:
    """Refuse a FIFO, a device or a socket given as any path on the command line (except a serial ``--port``),
    before a reader opens it and blocks or never ends (``bootnav.core.paths``)."""
    from bootnav.core.paths import special_kind

    for key, value in vars(args).items():
        if key.startswith("_") or key in DEVICE_OPTIONS:
            continue
        for v in value if isinstance(value, (list, tuple)) else [value]:
            if not isinstance(v, (str, os.PathLike)) or not str(v) or "\0" in str(v):
                continue
            kind = special_kind(v)
            if kind is not None:
                raise InputError(f"{v}: is a {kind}, not a regular file; bootnav reads and writes only regular "
                                 "files (a pipe or a device would block or never end): save the data to a file")


def _say(text: str) -> None:
    try:
        print(text, file=sys.stderr)
    except (OSError, ValueError):
        pass


def release_hdf5() -> None:
    """Close every HDF5 object a failed write left open, now, while h5py is whole: a file whose write failed
    (full disk, ``ulimit -f``) would otherwise be flushed again by h5py at interpreter exit, which can crash the
    process (segfault) after the clean message. Their close errors are expected and not shown."""
    h5py = sys.modules.get("h5py")
    if h5py is None:
        return
    import gc

    hook, sys.unraisablehook = sys.unraisablehook, lambda unraisable: None
    try:
        gc.collect()
        for oid in h5py.h5f.get_obj_ids(types=h5py.h5f.OBJ_ALL):
            try:
                while oid.valid:
                    oid._close() if hasattr(oid, "_close") else h5py.h5i.dec_ref(oid)
            except Exception:  # noqa: BLE001 - best effort; the error was reported already
                pass
        gc.collect()
    except Exception:  # noqa: BLE001
        pass
    finally:
        sys.unraisablehook = hook


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
    code = exc.errno
    if where == "" and "errno = " in reason:  # HDF5's multi-line text: its errno and file name in words
        m = re.search(r"errno = (\d+)", reason)
        code = int(m.group(1)) if m else code
        f = re.search(r"filename = '([^']*)'", reason)
        where = f.group(1) if f else ""
        reason = os.strerror(code) if code else reason.splitlines()[0]
    reason = reason.splitlines()[0] if reason else reason
    hidden = re.fullmatch(r"\.(.+)\.\d+(\.set)?\.tmp", os.path.basename(str(where)))
    if hidden:  # the crash-safe writer's temporary file: name the file the user asked for
        where = os.path.join(os.path.dirname(str(where)), hidden.group(1))
        folder = os.path.dirname(str(where)) or "."
        if code == errno.ENOENT and not os.path.isdir(folder):
            return f"{where}: the folder {folder} does not exist; create it first or choose another place"
    hint = {
        errno.ENOSPC: "free some space or write elsewhere",
        errno.EDQUOT: "free some space or write elsewhere",
        errno.EFBIG: "the file-size limit was reached (ulimit -f)",
        errno.EACCES: "check the permissions",
        errno.EROFS: "choose a writable place",
        errno.EISDIR: "give a file, not a directory",
        errno.ENOENT: "check the path",
    }.get(code or 0)
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
