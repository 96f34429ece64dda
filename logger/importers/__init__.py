"""Importers: text logs from our SD card and from other IMUs -> bootnav recordings (HDF5).

Public API::

    from bootnav.logger.importers import import_file, read_any, load_aux, builtin_names
    import_file("walk.csv", "walk.h5", profile=None, acc_unit=None, ...) -> Path
    read_any("walk.csv", profile=None, **overrides) -> ImportResult   # in memory, nothing written
    import_streaming("imu.csv", "walk.h5") -> ImportResult | None     # a canonical CSV block by block

Shipped profiles (``builtin_names()``) live in ``logger/importers/profiles/*.toml``; a user profile is any
TOML file with the same keys (``--profile my.toml``). See ``core`` for the stages and the recovery rules,
``checks`` for the unit and saturation checks, ``bootnav.core.timebase`` for time handling and the gap rule,
``bootnav.core.csvio`` for the canonical CSV, ``sdlog`` for our SD-card format.
"""

from .core import detect_profile, load_aux, read_any, write_result
from .profiles import Profile, builtin_names, load_profile
from .result import ImportResult
from .sdlog import format_sd_header, format_sd_line
from .stream import import_file, import_streaming

__all__ = ["ImportResult", "Profile", "builtin_names", "detect_profile", "format_sd_header", "format_sd_line",
           "import_file", "import_streaming", "load_aux", "load_profile", "read_any", "write_result"]
