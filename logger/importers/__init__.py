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

#: each public name and the module that defines it, imported on first use (PEP 562): a recording's unit check
#: (``checks``, run by every ``bootnav process`` and ``info``) then does not load the importers' readers
_WHERE = {"detect_profile": "core", "load_aux": "core", "read_any": "core", "write_result": "core",
          "Profile": "profiles", "builtin_names": "profiles", "load_profile": "profiles", "ImportResult": "result",
          "format_sd_header": "sdlog", "format_sd_line": "sdlog", "import_file": "stream", "import_streaming": "stream"}

__all__ = ["ImportResult", "Profile", "builtin_names", "detect_profile", "format_sd_header", "format_sd_line",
           "import_file", "import_streaming", "load_aux", "load_profile", "read_any", "write_result"]


def __getattr__(name: str):
    import importlib

    if name in _WHERE:
        return getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
    try:  # a submodule read as an attribute (``importers.core``), as when this package imported them all
        return importlib.import_module(f"{__name__}.{name}")
    except ModuleNotFoundError as exc:
        if exc.name != f"{__name__}.{name}":
            raise
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
