"""bootnav post-processing: calibration, stance detection, ZUPT filtering, paths, metrics; PDR in postproc.pdr."""
