"""The user-facing errors, ``bootnav.errors`` as every module imports them; defined in ``bootnav.core.errors``
(the ground floor, which imports nothing else of the package). ``BootnavWarning`` is the warning category of the
Python API (``warnings.simplefilter("error", bootnav.errors.BootnavWarning)`` turns them into exceptions)."""

from bootnav.core.errors import BootnavError, BootnavWarning, DiskFullError, InputError, UsageError

__all__ = ["BootnavError", "BootnavWarning", "DiskFullError", "InputError", "UsageError"]
