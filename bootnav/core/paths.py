"""Where a bootnav command may read and write: one policy for every reader and every writer.

**Outputs** (``output_file``, ``output_folder``). A user's file is never destroyed by a re-run or a typo:

- an output is never one of the run's inputs, not even with ``--force``;
- an existing file is replaced only with ``--force``;
- a file bootnav would write as HDF5 never replaces an existing file that is not HDF5, not even with ``--force``
  (``record --out notes.txt --force`` must not turn notes into a recording);
- an existing directory, FIFO, device or socket is never an output file;
- the folder the output goes into must exist and be writable; the message names that folder (not the hidden
  temporary file the crash-safe writer of ``bootnav.core.atomic`` would have created in it);
- a symbolic link is written through: the result replaces the link's target and the link stays (renaming a
  temporary file over the link itself would replace the link by a file).

**Inputs** (``regular_input``). Only regular files are read: opening a FIFO without a writer blocks forever and a
device (``/dev/zero``) never ends, so both are refused before anything opens them, with a one-line message.

Every command calls these functions before any work; ``bootnav.cli`` also refuses a non-regular file given
as any command-line path (the net under readers that open a file themselves).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Iterable

from bootnav.core.errors import InputError

#: The HDF5 format signature, found at byte 0 or at 512, 1024, 2048, ... after a user block.
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def file_kind(mode: int) -> str:
    """``"file"``, ``"directory"``, ``"FIFO (named pipe)"``, ``"character device"``, ... of an ``st_mode``."""
    for test, name in ((stat.S_ISREG, "file"), (stat.S_ISDIR, "directory"), (stat.S_ISFIFO, "FIFO (named pipe)"),
                       (stat.S_ISCHR, "character device"), (stat.S_ISBLK, "block device"),
                       (stat.S_ISSOCK, "socket")):
        if test(mode):
            return name
    return "special file"


def special_kind(path: str | os.PathLike) -> str | None:
    """The kind of an existing path that is neither a regular file nor a directory (a FIFO, a device, a socket),
    else None (also for a missing path). Links are followed."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    kind = file_kind(mode)
    return None if kind in ("file", "directory") else kind


def regular_input(path: str | os.PathLike, what: str = "input") -> Path:
    """``path`` if it is an existing regular file (links followed); else ``InputError`` saying what it is.

    Parameters
    ----------
    path
        The file a command is about to read.
    what
        How the message names the file the user should give ("recording", "settings JSON", ...).
    """
    p = Path(path)
    try:
        mode = os.stat(p).st_mode
    except FileNotFoundError:
        raise InputError(f"{p}: no such file") from None
    except OSError as exc:
        raise InputError(f"{p}: cannot be read ({exc.strerror or exc}); check the path and its permissions") from None
    kind = file_kind(mode)
    if kind == "directory":
        raise InputError(f"{p}: is a directory; give a {what} file")
    if kind != "file":
        raise InputError(f"{p}: is a {kind}, not a regular file; bootnav reads only regular files (a pipe or a "
                         f"device would block or never end): save the data to a file and give that {what}")
    return p


def looks_like_hdf5(path: str | os.PathLike) -> bool:
    """True when a regular file starts with the HDF5 signature (at 0 or after a 512·2^k user block).
    Never opens a FIFO or a device."""
    p = Path(path)
    if special_kind(p) is not None or not p.is_file():
        return False
    try:
        size = p.stat().st_size
        with open(p, "rb") as f:
            offset = 0
            while offset + len(HDF5_SIGNATURE) <= size:
                f.seek(offset)
                if f.read(len(HDF5_SIGNATURE)) == HDF5_SIGNATURE:
                    return True
                offset = 512 if offset == 0 else offset * 2
    except OSError:
        return False
    return False


def same_path(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """True when two paths name the same file (links resolved), whether or not they exist yet."""
    try:
        a, b = Path(a), Path(b)
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and os.path.samefile(a, b))
    except (OSError, RuntimeError):
        return False


def writable_folder(folder: str | os.PathLike, flag: str = "--out") -> Path:
    """``folder`` if it is an existing writable directory; else ``InputError`` naming it and the option."""
    d = Path(folder) if str(folder) else Path(".")
    if not d.exists():
        raise InputError(f"{flag}: the folder {d} does not exist; create it first (mkdir -p {d}) or choose another")
    if not d.is_dir():
        raise InputError(f"{flag}: {d} is not a folder")
    if not os.access(d, os.W_OK | os.X_OK):
        raise InputError(f"{flag}: the folder {d} is not writable; check its permissions or choose another")
    return d


def output_file(path: str | os.PathLike, *, force: bool = False, inputs: Iterable = (), flag: str = "--out",
                hdf5: bool = False) -> Path:
    """Check a file a command is about to create or replace (module docstring); return the path to write to.

    Parameters
    ----------
    path
        The output file.
    force
        The user's ``--force``: an existing file may be replaced (never an input, never a non-HDF5 file by HDF5).
    inputs
        Files the run reads (None entries are ignored).
    flag
        The option that named ``path``, for the messages.
    hdf5
        The output is an HDF5 file.

    Returns
    -------
    Path
        ``path``, or the target of a symbolic link ``path`` (written through, the link stays).

    Raises
    ------
    InputError
        Naming the path, why it is refused and the fix.
    """
    p = Path(path)
    if any(same_path(p, i) for i in inputs if i is not None):
        raise InputError(f"{flag} {p} is the input file (it is an input of this run): the output would replace an "
                         "input; choose another name (an input is never overwritten, not even with --force)")
    target = p.resolve() if p.is_symlink() else p
    if target.is_dir():
        raise InputError(f"{flag} {p} is a directory; give a file name inside it, e.g. {p / 'out.h5'}"
                         if hdf5 else f"{flag} {p} is a directory; give a file name inside it")
    kind = special_kind(target)
    if kind is not None:
        raise InputError(f"{flag} {p} is a {kind}, not a regular file; bootnav writes only regular files")
    writable_folder(target.parent, flag)
    if target.exists():
        if hdf5 and not looks_like_hdf5(target):
            raise InputError(f"{flag} {p} exists and is not an HDF5 file; bootnav never replaces it (not even with "
                             "--force): choose another name")
        if not force:
            raise InputError(f"{p} exists; use --force to replace it, or choose another {flag}")
    return target


def output_folder(out_dir: str | os.PathLike, names: Iterable[str], *, force: bool = False, inputs: Iterable = (),
                  flag: str = "--out") -> list[Path]:
    """Check an output folder and the files a command will write into it; return those files' paths.

    The folder may not exist yet (its parent must then be writable); it must not be an input nor an existing
    file. Each file goes through ``output_file`` (``.h5`` names as HDF5).
    """
    out = Path(out_dir)
    inputs = [i for i in inputs if i is not None]
    if any(same_path(out, i) for i in inputs):
        raise InputError(f"{flag} {out} is an input of this run; give a new folder for the outputs")
    if out.exists() and not out.is_dir():
        kind = special_kind(out) or "file"
        raise InputError(f"{flag} {out} is an existing {kind}, not a folder; give a folder for the outputs")
    if not out.exists():
        parent = out.parent
        while not parent.exists() and parent != parent.parent:
            parent = parent.parent
        writable_folder(parent, flag)
        return [out / n for n in names]
    return [output_file(out / n, force=force, inputs=inputs, flag=flag, hdf5=str(n).endswith(".h5"))
            for n in names]
