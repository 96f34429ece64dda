"""Crash-safe file writes: write beside the target under a hidden temporary name, flush it to disk, rename it
over the target (atomic on one file system), sync the directory.

A kill -9, a crash or a full disk during the write leaves either the old file (or none) or the complete new
one, never a half-written file; the temporary file is removed when the write fails in this process (after a
kill -9 a hidden ``.<name>.<pid>.tmp`` may remain beside the target, never under the target's name).
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator


def temporary_beside(target: str | Path) -> Path:
    """The hidden temporary name used for ``target`` by this process: ``.<name>.<pid>.tmp`` beside it."""
    target = Path(target)
    return target.with_name(f".{target.name}.{os.getpid()}.tmp")


def fsync_path(path: str | Path) -> None:
    """Flush a file's (or a directory's) data to disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def commit(tmp: str | Path, target: str | Path) -> None:
    """fsync ``tmp``, rename it over ``target``, fsync the directory."""
    fsync_path(tmp)
    os.replace(tmp, target)
    fsync_path(Path(target).parent)


def replace_with(target: str | Path, write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp)`` on the temporary beside ``target``, then ``commit`` it; returns ``target``."""
    target = Path(target)
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
    target = Path(target)
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
