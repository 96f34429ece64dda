"""The user-facing errors, ``bootnav.errors`` as every module imports them; defined in ``bootnav.core.errors``
(the ground floor, which imports nothing else of the package)."""

from bootnav.core.errors import BootnavError, DiskFullError, InputError

__all__ = ["BootnavError", "DiskFullError", "InputError"]
