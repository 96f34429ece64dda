"""logger: MPU6050 frames -> HDF5 recordings (serial recorder, emulator, importers).

Never imports ``postproc``: data flows one way, firmware -> frames -> logger -> recording -> postproc.
"""
