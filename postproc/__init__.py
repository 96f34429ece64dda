"""bootnav post-processing: calibration, stance detection, ZUPT filtering, paths, metrics; PDR in bootnav.postproc.pdr."""

if __name__ != "bootnav.postproc":  # the folder postproc/ is importable only as bootnav.postproc (one module, one name)
    raise ImportError(f"import bootnav.postproc, not {__name__}: the postproc/ folder installs as bootnav.postproc")

