"""Errors shown to the user as ``bootnav CMD: error: MESSAGE`` (exit code 1); imported as ``bootnav.errors``."""


class BootnavError(Exception):
    """An error whose message says what is wrong and where (file, line, byte offset)."""


class InputError(BootnavError):
    """Bad input data: unreadable, wrong units, non-monotonic time, no stance, ..."""


class DiskFullError(BootnavError):
    """The disk (or the file-size limit) is full: the message says what was safely written and where."""
