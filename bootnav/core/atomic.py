"""Crash-safe file writes: write beside the target under a hidden temporary name, flush it to disk, rename it
over the target (atomic on one file system), sync the directory.

A kill -9, a crash or a full disk during the write leaves either the old file (or none) or the complete new
one, never a half-written file; the temporary file is removed when the write fails in this process (after a
kill -9 a hidden ``.<name>.<pid>.tmp`` may remain beside the target, never under the target's name).

A symbolic link is written through: the new file replaces the link's target and the link stays.

``output_set`` makes the outputs of one run appear together or not at all: inside it every ``commit`` is
deferred to the end of the block, and an error (or a signal, a full disk) removes every temporary file, so a
clean error never leaves ``results.h5`` without the CSVs and the summary.
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterable, Iterator


def through_links(target: str | Path) -> Path:
    """``target``, or the file a symbolic link ``target`` points to (a rename replaces the target, not the link)."""
    target = Path(target)
    return target.resolve() if target.is_symlink() else target


#: Folders where this process made temporary files (``remove_temporaries`` cleans them on a forced exit).
_TMP_DIRS: set[Path] = set()


def temporary_beside(target: str | Path) -> Path:
    """The hidden temporary name used for ``target`` by this process: ``.<name>.<pid>.tmp`` beside it."""
    target = through_links(target)
    _TMP_DIRS.add(target.parent)
    return target.with_name(f".{target.name}.{os.getpid()}.tmp")


def remove_temporaries() -> list[Path]:
    """Remove every hidden temporary of this process (``.<name>.<pid>.tmp``, ``.<name>.<pid>.set.tmp``) in the
    folders it wrote to: the clean-up of an exit that cannot unwind (a stop signal that deadlocked a library).
    Returns the files removed."""
    removed = []
    pid = os.getpid()
    for folder in list(_TMP_DIRS):
        for pattern in (f".*.{pid}.tmp", f".*.{pid}.set.tmp"):
            for p in folder.glob(pattern):
                try:
                    p.unlink()
                    removed.append(p)
                except OSError:
                    pass
    return removed


def fsync_path(path: str | Path) -> None:
    """Flush a file's (or a directory's) data to disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


#: The open ``output_set`` blocks of this process, innermost last: their deferred (tmp, target) renames.
_SETS: list[list[tuple[Path, Path]]] = []
_SET_PID = [0]  # the process that opened them (a forked chart worker inherits the list, not the set)


def commit(tmp: str | Path, target: str | Path) -> None:
    """fsync ``tmp``, rename it over ``target``, fsync the directory (at the end of an open ``output_set``)."""
    fsync_path(tmp)
    target = through_links(target)
    if _SETS and _SET_PID[0] == os.getpid():  # (a forked helper commits at once: the set is its parent's)
        # staged under a name of the set's own: a caller's ``tmp.unlink`` cannot lose it
        staged = target.with_name(f".{target.name}.{os.getpid()}.set.tmp")
        os.replace(tmp, staged)
        pending = _SETS[-1]
        if all(t != staged for t, _ in pending):
            pending.append((staged, target))
        return
    os.replace(tmp, target)
    fsync_path(target.parent)


@contextmanager
def output_set(planned: Iterable[str | Path] = ()) -> Iterator[None]:
    """Every file committed inside the block appears when the block ends without an error, none otherwise.

    Parameters
    ----------
    planned
        The run's output files: on an error, those of them that did not exist before the block and exist now
        (written by a helper process, e.g. a chart worker, outside this process's deferral) are removed too.
    """
    planned = [Path(p) for p in planned]
    existed = {p for p in planned if p.exists()}
    pending: list[tuple[Path, Path]] = []
    _SETS.append(pending)
    _SET_PID[0] = os.getpid()
    try:
        yield
    except BaseException:
        _SETS.remove(pending)
        for tmp, _ in pending:
            tmp.unlink(missing_ok=True)
        for p in planned:
            if p not in existed and p.is_file() and not p.is_symlink():
                p.unlink(missing_ok=True)
        raise
    _SETS.remove(pending)
    if _SETS:  # nested: the outer set commits
        _SETS[-1].extend(pending)
        return
    folders = []
    for tmp, target in pending:
        os.replace(tmp, target)
        if target.parent not in folders:
            folders.append(target.parent)
    for folder in folders:
        fsync_path(folder)


def replace_with(target: str | Path, write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp)`` on the temporary beside ``target``, then ``commit`` it; returns ``target``."""
    target = through_links(target)
    tmp = temporary_beside(target)
    try:
        write(tmp)
        commit(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return target


@contextmanager
def replacing(target: str | Path, mode: str = "wb") -> Iterator:
    """``with replacing(path) as f: f.write(...)``: the file appears under ``path`` only when the block ends
    without an error (``replace_with`` with an open file)."""
    target = through_links(target)
    tmp = temporary_beside(target)
    try:
        with open(tmp, mode) as f:
            yield f
        commit(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_text(target: str | Path, text: str) -> Path:
    """``target.write_text(text)``, crash-safe."""
    return replace_with(target, lambda tmp: Path(tmp).write_text(text))
