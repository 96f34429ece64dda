"""The ground floor: primitives shared by acquisition (``bootnav.logger``) and processing (``bootnav.postproc``).

One definition of each idea: the user-facing errors (``errors``, imported as ``bootnav.errors``), time base and
gap rule (``timebase``), run-length phases (``runs``), array helpers of the processing stages (``arrays``: row
norms and dots, moving means, clipping and saturation masks), the canonical IMU CSV reader (``csvio``), JSON
cleaning (``jsonio``), rotation conversions (``rotations``), peak finding (``peaks``), crash-safe writes
(``atomic``), the check of a settings value (``validate``), the registry of named algorithms (``registry``),
the progress display (``progress``), the conventions and software version written into every output
(``conventions``). Nothing here imports anything of the package outside ``bootnav.core``.
"""
