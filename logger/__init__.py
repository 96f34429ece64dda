"""logger: MPU6050 frames -> HDF5 recordings (serial recorder, emulator, importers).

Never imports ``postproc``: data flows one way, firmware -> frames -> logger -> recording -> postproc.
"""

if __name__ != "bootnav.logger":  # the folder logger/ is importable only as bootnav.logger (one module, one name)
    raise ImportError(f"import bootnav.logger, not {__name__}: the logger/ folder installs as bootnav.logger")

