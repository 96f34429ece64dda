"""Errors shown to the user as ``bootnav CMD: error: MESSAGE`` (exit code 1); imported as ``bootnav.errors``."""


class BootnavError(Exception):
    """An error whose message says what is wrong and where (file, line, byte offset)."""


class InputError(BootnavError):
    """Bad input data: unreadable, wrong units, non-monotonic time, no stance, ..."""


class UsageError(BootnavError):
    """Options missing, contradictory or out of range, found after parsing: exit status 2, as argparse's own
    usage errors."""


class DiskFullError(BootnavError):
    """The disk (or the file-size limit) is full: the message says what was safely written and where."""


class BootnavWarning(UserWarning):
    """A problem the Python API found and worked around (also in the result's ``warnings``): a failed check, a
    fallback, a borderline unit."""
